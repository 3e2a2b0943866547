/*
 * Crash element with memory (railgym's CrashElement law), for co-simulation.
 *
 * Inputs: u, the element's crush (m, compression positive), and its rate (m/s; read by the
 * "paper" variant only). Outputs: the force f (N, compression positive) and the permanent set
 * (m) after this evaluation. State: the permanent set u_p, committed at each fmi2DoStep from
 * the inputs of the communication point.
 *
 *   unilateral and u <= 0:  f = 0
 *   "paper" (HY_VARIANT 0): LPR of the loading branch if rate >= 0, else of the unloading
 *                           branch, clipped to that branch's force range; f >= 0 if unilateral
 *   "hysteretic" (1):       trial = k_u (u - u_p); if trial > 0: the envelope
 *                           env = min(LPR(u), f_max); f = 0 if env <= 0, else f = env and
 *                           u_p = u - env / k_u if trial >= env, else f = trial (elastic);
 *                           if trial <= 0: tension k_t (u - u_p + slack) for u < u_p - slack
 *
 * Constants HY_* and the per-degree Legendre coefficients hy_c0 (loading / envelope) and hy_c1
 * (unloading, when HY_HAS_UNLOADING) come from element_data.h.
 */
#include <stddef.h>

#define EL_NIN 2
#define EL_NOUT 2
#define EL_NSTATE 1

static void el_init(double *state) { state[0] = 0.0; }

/* sum_{k<=n} c_k P_k(t), t = 2 (u - lo) / (up - lo) - 1, by Clenshaw's recurrence (the
 * arithmetic of railgym's crash kernels); outside [lo, up] the end value, extended with the
 * end slope unless mode is 1 (clip): P_k(+-1) = (+-1)^k, P'_k(+-1) = (+-1)^(k+1) k (k+1) / 2. */
static double hy_series(double u, const double *c, int n, double lo, double up, int mode) {
    double b0, b1 = 0.0, b2 = 0.0, t, s, value = 0.0, slope = 0.0, sign = 1.0, end;
    int k;
    if (lo <= u && u <= up) {
        t = (u - lo) * (2.0 / (up - lo)) - 1.0;
        for (k = n; k > 0; k--) {
            b0 = c[k] + (2.0 * k + 1.0) / (k + 1.0) * t * b1 - (k + 1.0) / (k + 2.0) * b2;
            b2 = b1;
            b1 = b0;
        }
        return c[0] + t * b1 - 0.5 * b2;
    }
    s = u > up ? 1.0 : -1.0;
    for (k = 0; k <= n; k++) {
        value += c[k] * sign;
        slope += c[k] * sign * s * 0.5 * k * (k + 1);
        sign *= s;
    }
    if (mode == 1) return value;
    end = u > up ? up : lo;
    return value + slope * (2.0 / (up - lo)) * (u - end);
}

/* Force at the inputs u with permanent set up; *up_new receives the new permanent set. */
static double hy_law(const double *u, double up, double *up_new) {
    double x = u[0];
    double f_lpr = 0.0, f_min = 0.0, f_max = 0.0, f, trial, env;
    int model;
    *up_new = up;
    if (HY_UNILATERAL && x <= 0.0) return 0.0;
    if (HY_VARIANT == 0) {
        model = u[1] >= 0.0 ? 0 : 1;
    } else {
        model = HY_KU * (x - up) > 0.0 ? 0 : -1;
    }
    if (model == 0) {
        f_lpr = hy_series(x, hy_c0, HY_N0, HY_LO0, HY_UP0, HY_MODE0);
        f_min = HY_FMIN0;
        f_max = HY_FMAX0;
    }
#if HY_HAS_UNLOADING
    if (model == 1) {
        f_lpr = hy_series(x, hy_c1, HY_N1, HY_LO1, HY_UP1, HY_MODE1);
        f_min = HY_FMIN1;
        f_max = HY_FMAX1;
    }
#endif
    if (HY_VARIANT == 0) {
        f = f_lpr < f_min ? f_min : (f_lpr > f_max ? f_max : f_lpr);
        return HY_UNILATERAL && f < 0.0 ? 0.0 : f;
    }
    trial = HY_KU * (x - up);
    if (trial > 0.0) {
        env = f_lpr < f_max ? f_lpr : f_max;
        if (env <= 0.0) return 0.0;
        if (trial >= env) {
            *up_new = x - env / HY_KU;
            return env;
        }
        return trial;
    }
    if (HY_KT > 0.0 && x < up - HY_SLACK) return HY_KT * (x - up + HY_SLACK);
    return 0.0;
}

static int el_outputs(const double *u, const double *state, double *y, char *msg, size_t n) {
    (void)msg;
    (void)n;
    y[0] = hy_law(u, state[0], &y[1]);
    return 0;
}

static void el_commit(const double *u, double *state) {
    double up_new;
    hy_law(u, state[0], &up_new);
    state[0] = up_new;
}
