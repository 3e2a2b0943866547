/*
 * railgym's whole-vehicle vertical reference model (railgym.vehicles.vehicle, variant
 * "dynamic"): carbody bounce, pitch and first bending on two bogies (bounce and pitch), four
 * wheelsets, the dynamic secondary suspension of suspension.h at each bogie. The equations are
 * those of railgym/vehicles/vehicle.py (_rhs, _outputs), statement for statement.
 *
 * States x = [z_c, th_c, q, z_b0, th_b0, z_b1, th_b1, their 7 rates, dp_bag0, dp_res0, y0,
 * dp_bag1, dp_res1, y1]; inputs u = [z_1, zdot_1, ..., z_4, zdot_4 (wheelsets front to rear),
 * F_a0, F_a1 (front, rear bogie)]. Parameters V (railgym.vehicles.vehicle.model.Params) and E
 * (SuspensionParams of the suspension) come from model_data.h.
 */
#include "suspension.h"

#define MD_NX 20
#define MD_NU 10
#define MD_NY 13

/* derivative dx of x at the inputs u; the secondary forces into fs[2] */
static void md_rhs_fs(const double *x, const double *u, double *dx, double *fs) {
    double f0 = 0.0, f1 = 0.0;
    int i, j;
    for (i = 0; i < 2; i++) {
        double xi = i == 0 ? V.a : -V.a;
        double zb = x[3 + 2 * i], vb = x[10 + 2 * i];
        double d = zb - (x[0] + xi * x[1] + V.phi_a * x[2]);
        double dd = vb - (x[7] + xi * x[8] + V.phi_a * x[9]);
        double f_d, f, ftot, tb, wb, lead, trail;
        int k = 14 + 3 * i;
        double f_air = md_dynamic_element(d, dd, x[k], x[k + 1], x[k + 2], dx + k, &f_d);
        f = f_air + f_d + md_bump_stop(d);
        fs[i] = f;
        ftot = f + u[8 + i];
        if (i == 0) f0 = ftot;
        else f1 = ftot;
        tb = x[4 + 2 * i];
        wb = x[11 + 2 * i];
        lead = V.k1w * (u[4 * i] - zb - V.b * tb) + V.c1w * (u[4 * i + 1] - vb - V.b * wb);
        trail = V.k1w * (u[4 * i + 2] - zb + V.b * tb) + V.c1w * (u[4 * i + 3] - vb + V.b * wb);
        dx[3 + 2 * i] = vb;
        dx[4 + 2 * i] = wb;
        dx[10 + 2 * i] = (lead + trail - ftot) * V.inv_m_b;
        dx[11 + 2 * i] = V.b * (lead - trail) * V.inv_j_b;
    }
    for (j = 0; j < 3; j++) dx[j] = x[7 + j];
    dx[7] = (f0 + f1) * V.inv_m_c;
    dx[8] = V.a * (f0 - f1) * V.inv_j_c;
    dx[9] = (V.phi_a * (f0 + f1) - V.k_q * x[2] - V.c_q * x[9]) * V.inv_m_q;
}

static double md_rhs(const double *x, const double *u, double *dx) {
    double fs[2];
    md_rhs_fs(x, u, dx, fs);
    return fs[0];
}

/* outputs: acc_front, _centre, _rear (floor points), bogie_acc_front, _rear, deflection_front, _rear,
 * deflection_rate_front, _rear, carbody_vel_front, _rear (at the bogies), secondary_force_front,
 * _rear (SI) */
static void md_outputs(const double *x, const double *u, double *y) {
    double dx[MD_NX], fs[2];
    int b;
    md_rhs_fs(x, u, dx, fs);
    y[0] = dx[7] + V.a * dx[8] + V.phi_a * dx[9];
    y[1] = dx[7] + V.phi_c * dx[9];
    y[2] = dx[7] - V.a * dx[8] + V.phi_a * dx[9];
    y[3] = dx[10];
    y[4] = dx[12];
    for (b = 0; b < 2; b++) {
        double xb = b == 0 ? V.a : -V.a;
        double vel = x[7] + xb * x[8] + V.phi_a * x[9];
        y[5 + b] = x[3 + 2 * b] - x[0] - xb * x[1] - V.phi_a * x[2];
        y[7 + b] = x[10 + 2 * b] - vel;
        y[9 + b] = vel;
        y[11 + b] = fs[b];
    }
}
