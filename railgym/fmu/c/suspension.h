/*
 * Secondary-suspension laws of railgym's reference models (railgym/vehicles/vertical/elements.py,
 * statement for statement): damper curve and its inverse, bump stops, the air spring with
 * reservoir and orifice in series with the Maxwell damper. Parameters E (the fields of
 * railgym.vehicles.vertical.params.SuspensionParams) come from model_data.h.
 */
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
    if (f >= 0.0) return md_branch_inv(f, E.c_c, E.vk_c, E.blowoff, E.knee);
    return -md_branch_inv(-f, E.c_r, E.vk_r, E.blowoff, E.knee);
}

static double md_contact_ramp(double e, double s) {
    double ep = e > 0.0 ? e : 0.0;
    double quad = 0.5 * ep * ep / s;
    double lin = ep - 0.5 * s;
    return ep < s ? quad : lin;
}

static double md_bump_stop(double d) {
    double ec = d - E.free_c > 0.0 ? d - E.free_c : 0.0;
    double er = -d - E.free_r > 0.0 ? -d - E.free_r : 0.0;
    double fc = E.k_bs * md_contact_ramp(ec, E.bs_smooth) + E.k_bs3 * ec * ec * ec;
    double fr = E.k_bs * md_contact_ramp(er, E.bs_smooth) + E.k_bs3 * er * er * er;
    return 0.0 + fc - fr;
}

/* air spring and Maxwell damper: rates (d dp_bag/dt, d dp_res/dt, dy/dt) of the element states
 * (dpb, dpr, y) at deflection d and rate dd; returns the air-spring force, the damper force in
 * *f_d */
static double md_dynamic_element(double d, double dd, double dpb, double dpr, double y,
                                 double *rates, double *f_d) {
    double n = E.n_poly, p0 = E.p0, a0 = E.area, da = E.d_area;
    double ae = a0 + da * d;
    double vb = E.v_bag - a0 * d - 0.5 * da * d * d;
    double vr = E.v_res;
    double pb = p0 + dpb, pr = p0 + dpr;
    double rho_b = E.rho0 * pow(pb / p0, 1.0 / n);
    double rho_r = E.rho0 * pow(pr / p0, 1.0 / n);
    double dp = dpb - dpr, dl = E.dp_lam;
    double q = E.cd_area * sqrt(rho_b + rho_r) * dp / sqrt(sqrt(dp * dp + dl * dl));
    rates[0] = n * pb * (ae * dd - q / rho_b) / vb;
    rates[1] = n * pr * q / (rho_r * vr);
    *f_d = E.k_series * (d - y);
    rates[2] = md_damper_velocity(*f_d);
    return E.n_springs * ((p0 - E.p_atm) * da * d + dpb * ae);
}
