/*
 * railgym's one-bogie vertical reference model (railgym.vehicles.vertical, variant "dynamic"):
 * bogie m1 on the primary suspension k1, c1; carbody share m2 on the air spring with surge
 * reservoir and orifice, the bump stops and the damper in series with its bush stiffness
 * (suspension.h). States x = [x1, v1, x2, v2, dp_bag, dp_res, y_damper]; inputs
 * u = [z, zdot, F_a]. Parameters E (SuspensionParams) come from model_data.h.
 */
#include "suspension.h"

#define MD_NX 7
#define MD_NU 3
#define MD_NY 7

/* derivative dx of the state x at the inputs u; returns the secondary-suspension force F_s */
static double md_rhs(const double *x, const double *u, double *dx) {
    double d = x[0] - x[2], dd = x[1] - x[3], f_d, fs;
    double f_air = md_dynamic_element(d, dd, x[4], x[5], x[6], dx + 4, &f_d);
    fs = f_air + f_d + md_bump_stop(d);
    dx[0] = x[1];
    dx[1] = (E.k1 * (u[0] - x[0]) + E.c1 * (u[1] - x[1]) - fs - u[2]) / E.m1;
    dx[2] = x[3];
    dx[3] = (fs + u[2]) / E.m2;
    return fs;
}

/* outputs: carbody_acc, bogie_acc, deflection, deflection_rate, carbody_vel, carbody_disp,
 * secondary_force (SI) */
static void md_outputs(const double *x, const double *u, double *y) {
    double dx[MD_NX];
    double fs = md_rhs(x, u, dx);
    y[0] = dx[3];
    y[1] = dx[1];
    y[2] = x[0] - x[2];
    y[3] = x[1] - x[3];
    y[4] = x[3];
    y[5] = x[2];
    y[6] = fs;
}
