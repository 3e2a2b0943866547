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
 * Constants from policy_data.h: PL_NIN, PL_NOUT, PL_NL, PL_MAXW, pl_sizes[PL_NL + 1],
 * pl_act[PL_NL] (0 identity, 1 tanh, 2 relu), pl_offset[PL_NL] (start of layer l's weights,
 * row-major (out, in), then its biases, in pl_param), pl_param, pl_inv_scale, pl_low, pl_high,
 * PL_SQUASH, PL_FMAX.
 */
#define EL_NIN PL_NIN
#define EL_NOUT PL_NOUT
#define EL_NSTATE 1 /* none used; C arrays cannot be empty */

static void el_init(double *state) { state[0] = 0.0; }

static int el_outputs(const double *u, const double *state, double *y, char *msg, size_t n) {
    double x[PL_MAXW], h[PL_MAXW];
    int l, i, o, j;
    (void)state;
    (void)msg;
    (void)n;
    for (j = 0; j < PL_NIN; j++) x[j] = (double)(float)(u[j] * pl_inv_scale[j]);
    for (l = 0; l < PL_NL; l++) {
        int nin = pl_sizes[l], nout = pl_sizes[l + 1];
        const float *w = pl_param + pl_offset[l];
        const float *b = w + nin * nout;
        for (o = 0; o < nout; o++) {
            double s = (double)b[o];
            for (i = 0; i < nin; i++) s += (double)w[o * nin + i] * x[i];
            if (pl_act[l] == 1) s = tanh(s);
            else if (pl_act[l] == 2) s = s > 0.0 ? s : 0.0;
            h[o] = s;
        }
        for (o = 0; o < nout; o++) x[o] = h[o];
    }
    for (j = 0; j < PL_NOUT; j++) {
        double a = x[j];
        if (PL_SQUASH) a = pl_low[j] + 0.5 * (tanh(a) + 1.0) * (pl_high[j] - pl_low[j]);
        if (a < pl_low[j]) a = pl_low[j];
        if (a > pl_high[j]) a = pl_high[j];
        if (a < -1.0) a = -1.0;
        if (a > 1.0) a = 1.0;
        y[j] = a * PL_FMAX;
    }
    return 0;
}

static void el_commit(const double *u, double *state) {
    (void)u;
    (void)state;
}
