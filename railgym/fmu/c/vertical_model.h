/*
 * railgym's one-bogie vertical reference model (railgym.vehicles.vertical, variant "dynamic"):
 * bogie m1 on the primary suspension k1, c1; carbody share m2 on the air spring with surge
 * reservoir and orifice, the bump stops and the damper in series with its bush stiffness.
 * The laws are those of railgym/vehicles/vertical/elements.py, statement for statement.
 *
 * States x = [x1, v1, x2, v2, dp_bag, dp_res, y_damper]; inputs u = [z, zdot, F_a].
 * Parameters P (a struct of doubles) come from model_data.h.
 */
#define MD_NX 7
#define MD_NU 3

static double md_ramp(double x, double eps) { return 0.5 * (x + sqrt(x * x + eps * eps)); }

static double md_branch_inv(double f, double c, double vk, double r, double eps) {
    double alpha = 0.5 * (1.0 + r), beta = 0.5 * (1.0 - r), re2 = r * eps * eps;
    double phi0 = -vk - (1.0 - r) * md_ramp(-vk, eps);
    double phi = f / c + phi0;
    double w = alpha * phi + beta * sqrt(phi * phi + re2);
    double w0 = alpha * phi0 + beta * sqrt(phi0 * phi0 + re2);
    return (w - w0) / r;
}

static double md_damper_velocity(double f) {
    if (f >= 0.0) return md_branch_inv(f, P.c_c, P.vk_c, P.blowoff, P.knee);
    return -md_branch_inv(-f, P.c_r, P.vk_r, P.blowoff, P.knee);
}

static double md_contact_ramp(double e, double s) {
    double ep = e > 0.0 ? e : 0.0;
    double quad = 0.5 * ep * ep / s;
    double lin = ep - 0.5 * s;
    return ep < s ? quad : lin;
}

static double md_bump_stop(double d) {
    double ec = d - P.free_c > 0.0 ? d - P.free_c : 0.0;
    double er = -d - P.free_r > 0.0 ? -d - P.free_r : 0.0;
    double fc = P.k_bs * md_contact_ramp(ec, P.bs_smooth) + P.k_bs3 * ec * ec * ec;
    double fr = P.k_bs * md_contact_ramp(er, P.bs_smooth) + P.k_bs3 * er * er * er;
    return 0.0 + fc - fr;
}

/* derivative dx of the state x at the inputs u; returns the secondary-suspension force F_s */
static double md_rhs(const double *x, const double *u, double *dx) {
    double d = x[0] - x[2], dd = x[1] - x[3];
    double n = P.n_poly, p0 = P.p0, a0 = P.area, da = P.d_area;
    double ae = a0 + da * d;
    double vb = P.v_bag - a0 * d - 0.5 * da * d * d;
    double vr = P.v_res;
    double pb = p0 + x[4], pr = p0 + x[5];
    double rho_b = P.rho0 * pow(pb / p0, 1.0 / n);
    double rho_r = P.rho0 * pow(pr / p0, 1.0 / n);
    double dp = x[4] - x[5], dl = P.dp_lam;
    double q = P.cd_area * sqrt(rho_b + rho_r) * dp / sqrt(sqrt(dp * dp + dl * dl));
    double f_d = P.k_series * (d - x[6]);
    double f_air = P.n_springs * ((p0 - P.p_atm) * da * d + x[4] * ae);
    double fs;
    dx[4] = n * pb * (ae * dd - q / rho_b) / vb;
    dx[5] = n * pr * q / (rho_r * vr);
    dx[6] = md_damper_velocity(f_d);
    fs = f_air + f_d + md_bump_stop(d);
    dx[0] = x[1];
    dx[1] = (P.k1 * (u[0] - x[0]) + P.c1 * (u[1] - x[1]) - fs - u[2]) / P.m1;
    dx[2] = x[3];
    dx[3] = (fs + u[2]) / P.m2;
    return fs;
}

#define MD_NY 7
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
