/*
 * A trained policy's deterministic action as an FMU element (surrogates/fmi/c/element.c):
 * inputs = the env's observation channels in SI, outputs = the actuator forces in N.
 *
 *   o_j   = (float)(u_j * inv_scale_j)            the env's float32 observation
 *   h     = act_l(W_l h + b_l), l = 0 .. L-1      the MLP (float32 weights, double sums)
 *   a     = tanh(h) if PL_SQUASH, then low + (a + 1)(high - low)/2 (SAC), else h (PPO)
 *   a     = min(max(a, low), high)                the policy's and the env's clipping
 *   F_k   = a_k * f_max                           N
 *
 * A residual policy (PL_RESIDUAL 1, agents/controllers/residual.py) adds the network's action to its
 * classical base's (linear_base.h, on the same o): a_k = (float)clip(b_k + PL_RSCALE * a_k,
 * -1, 1) with b the base's float32 action, then F_k = a_k * f_max; the base's state is
 * updated at fmi2DoStep from the inputs of the communication point.
 *
 * Constants from policy_data.h: PL_NIN, PL_NOUT, PL_NL, PL_MAXW, pl_sizes[PL_NL + 1],
 * pl_act[PL_NL] (0 identity, 1 tanh, 2 relu), pl_offset[PL_NL] (start of layer l's weights,
 * row-major (out, in), then its biases, in pl_param), pl_param, pl_inv_scale, pl_low, pl_high,
 * PL_SQUASH, PL_FMAX; PL_RESIDUAL, PL_RSCALE and those of linear_base.h for a residual.
 */
#define EL_NIN PL_NIN
#define EL_NOUT PL_NOUT
#ifndef PL_RESIDUAL
#define PL_RESIDUAL 0
#endif

#if PL_RESIDUAL
#include "linear_base.h"
#define EL_NSTATE CT_NSTATE
static void el_init(double *state) { ct_init(state); }
#else
#define EL_NSTATE 1 /* none used; C arrays cannot be empty */
static void el_init(double *state) { state[0] = 0.0; }
#endif

/* the env's float32 observation o[PL_NIN] from the SI inputs u */
static void pl_observation(const double *u, double *o) {
    int j;
    for (j = 0; j < PL_NIN; j++) o[j] = (double)(float)(u[j] * pl_inv_scale[j]);
}

/* the network's action a[PL_NOUT], clipped to its space and [-1, 1], at the observation o */
static void pl_network(const double *o, double *a) {
    double x[PL_MAXW], h[PL_MAXW];
    int l, i, k, j;
    for (j = 0; j < PL_NIN; j++) x[j] = o[j];
    for (l = 0; l < PL_NL; l++) {
        int nin = pl_sizes[l], nout = pl_sizes[l + 1];
        const float *w = pl_param + pl_offset[l];
        const float *b = w + nin * nout;
        for (k = 0; k < nout; k++) {
            double s = (double)b[k];
            for (i = 0; i < nin; i++) s += (double)w[k * nin + i] * x[i];
            if (pl_act[l] == 1) s = tanh(s);
            else if (pl_act[l] == 2) s = s > 0.0 ? s : 0.0;
            h[k] = s;
        }
        for (k = 0; k < nout; k++) x[k] = h[k];
    }
    for (j = 0; j < PL_NOUT; j++) {
        double v = x[j];
        if (PL_SQUASH) v = pl_low[j] + 0.5 * (tanh(v) + 1.0) * (pl_high[j] - pl_low[j]);
        if (v < pl_low[j]) v = pl_low[j];
        if (v > pl_high[j]) v = pl_high[j];
        if (v < -1.0) v = -1.0;
        if (v > 1.0) v = 1.0;
        a[j] = v;
    }
}

static int el_outputs(const double *u, const double *state, double *y, char *msg, size_t n) {
    double o[PL_NIN], a[PL_NOUT];
    int j;
    (void)msg;
    (void)n;
    pl_observation(u, o);
    pl_network(o, a);
#if PL_RESIDUAL
    {
        double xe[CT_NXA], f[PL_NOUT];
        ct_force(o, state, xe, f);
        for (j = 0; j < PL_NOUT; j++) {
            double t = ct_action(f[j]) + PL_RSCALE * a[j];
            if (t < -1.0) t = -1.0;
            if (t > 1.0) t = 1.0;
            y[j] = (double)(float)t * PL_FMAX;
        }
    }
#else
    (void)state;
    for (j = 0; j < PL_NOUT; j++) y[j] = a[j] * PL_FMAX;
#endif
    return 0;
}

static void el_commit(const double *u, double *state) {
#if PL_RESIDUAL
    double o[PL_NIN];
    pl_observation(u, o);
    ct_commit(o, state);
#else
    (void)u;
    (void)state;
#endif
}
