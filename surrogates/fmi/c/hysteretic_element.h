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
 * Constants HY_* and the LPR arrays hy_*0 (loading / envelope) and hy_*1 (unloading, when
 * HY_HAS_UNLOADING) come from element_data.h.
 */
#include "lpr.h"

#define EL_NIN 2
#define EL_NOUT 2
#define EL_NSTATE 1

static void el_init(double *state) { state[0] = 0.0; }

/* Force at the inputs u with permanent set up; *up_new receives the new permanent set. */
static double hy_law(const double *u, double up, double *up_new) {
    double x = u[0];
    double f_lpr = 0.0, f_min = 0.0, f_max = 0.0, f, trial, env;
    int model, column = 0;
    *up_new = up;
    if (HY_UNILATERAL && x <= 0.0) return 0.0;
    if (HY_VARIANT == 0) {
        model = u[1] >= 0.0 ? 0 : 1;
    } else {
        model = HY_KU * (x - up) > 0.0 ? 0 : -1;
    }
    if (model == 0) {
        lpr_value(&x, 1, HY_T0, HY_NMAX0, hy_e0, hy_c0, hy_lo0, hy_up0, HY_MODE0, &f_lpr,
                  &column);
        f_min = HY_FMIN0;
        f_max = HY_FMAX0;
    }
#if HY_HAS_UNLOADING
    if (model == 1) {
        lpr_value(&x, 1, HY_T1, HY_NMAX1, hy_e1, hy_c1, hy_lo1, hy_up1, HY_MODE1, &f_lpr,
                  &column);
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
