/*
 * The classical base of a residual policy (agents/policies/residual_export.py) as a linear discrete
 * state-space controller, included by policy_element.h when PL_RESIDUAL is 1. Per control
 * step, on the env's float32 observation o (the network's input):
 *
 *   y   = o * ct_scale                      physical observation, SI
 *   e   = y - C x- - D u-                   innovation          (CT_NX > 0 only)
 *   xe  = x- + M e                          measurement update  (CT_NX > 0 only)
 *   F   = clip(G y - K xe, -f_max, f_max)   force, N
 *   a   = (float)clip(F / f_max, -1, 1)     the controller's action
 *
 * and at fmi2DoStep (ct_commit): x- = Phi xe + Gamma F, u- = F. State: state[0 .. CT_NX-1]
 * = x-, state[CT_NX .. CT_NX+PL_NOUT-1] = u- (N); zero at fmi2Instantiate and fmi2Reset, as
 * the Python estimate at an episode start.
 *
 * Constants from element_data.h: CT_NX, ct_scale[PL_NIN], ct_g (PL_NOUT x PL_NIN) and, when
 * CT_NX > 0, ct_c (PL_NIN x CT_NX), ct_d (PL_NIN x PL_NOUT), ct_m (CT_NX x PL_NIN),
 * ct_k (PL_NOUT x CT_NX), ct_phi (CT_NX x CT_NX), ct_gamma (CT_NX x PL_NOUT), row-major;
 * PL_NIN, PL_NOUT, PL_FMAX.
 */
#define CT_NSTATE (CT_NX + PL_NOUT)
#define CT_NXA (CT_NX > 0 ? CT_NX : 1) /* C arrays cannot be empty */

static void ct_init(double *state) {
    int i;
    for (i = 0; i < CT_NSTATE; i++) state[i] = 0.0;
}

/* the estimate xe[CT_NXA] and the force f[PL_NOUT] (N) at the observation o */
static void ct_force(const double *o, const double *state, double *xe, double *f) {
    double y[PL_NIN];
    int j, a;
    for (j = 0; j < PL_NIN; j++) y[j] = o[j] * ct_scale[j];
#if CT_NX > 0
    {
        const double *xp = state, *up = state + CT_NX;
        double e[PL_NIN];
        int i;
        for (j = 0; j < PL_NIN; j++) {
            double cx = 0.0, du = 0.0;
            for (i = 0; i < CT_NX; i++) cx += ct_c[j * CT_NX + i] * xp[i];
            for (a = 0; a < PL_NOUT; a++) du += ct_d[j * PL_NOUT + a] * up[a];
            e[j] = y[j] - cx - du;
        }
        for (i = 0; i < CT_NX; i++) {
            double me = 0.0;
            for (j = 0; j < PL_NIN; j++) me += ct_m[i * PL_NIN + j] * e[j];
            xe[i] = xp[i] + me;
        }
    }
#else
    (void)state;
    xe[0] = 0.0;
#endif
    for (a = 0; a < PL_NOUT; a++) {
        double gy = 0.0, kx = 0.0, s;
        for (j = 0; j < PL_NIN; j++) gy += ct_g[a * PL_NIN + j] * y[j];
#if CT_NX > 0
        {
            int i;
            for (i = 0; i < CT_NX; i++) kx += ct_k[a * CT_NX + i] * xe[i];
        }
#endif
        s = gy - kx;
        if (s < -PL_FMAX) s = -PL_FMAX;
        if (s > PL_FMAX) s = PL_FMAX;
        f[a] = s;
    }
}

/* the controller's action, float32 in [-1, 1], from its force f (N) */
static double ct_action(double f) {
    double a = f / PL_FMAX;
    if (a < -1.0) a = -1.0;
    if (a > 1.0) a = 1.0;
    return (double)(float)a;
}

/* the state update of one control step at the observation o */
static void ct_commit(const double *o, double *state) {
#if CT_NX > 0
    double xe[CT_NXA], f[PL_NOUT], xn[CT_NXA];
    int i, l, a;
    ct_force(o, state, xe, f);
    for (i = 0; i < CT_NX; i++) {
        double px = 0.0, gf = 0.0;
        for (l = 0; l < CT_NX; l++) px += ct_phi[i * CT_NX + l] * xe[l];
        for (a = 0; a < PL_NOUT; a++) gf += ct_gamma[i * PL_NOUT + a] * f[a];
        xn[i] = px + gf;
    }
    for (i = 0; i < CT_NX; i++) state[i] = xn[i];
    for (a = 0; a < PL_NOUT; a++) state[CT_NX + a] = f[a];
#else
    (void)o;
    (void)state;
#endif
}
