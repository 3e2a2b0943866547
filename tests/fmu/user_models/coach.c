/*
 * coach.c - a whole coach as a user would bring it: an FMI 2.0 co-simulation FMU, written by
 * hand without any railgym code (only the FMI 2.0 standard headers and the user's own glue,
 * user_fmi2_glue.h).
 *
 * Conventions (the user's own): x along the coach, positive forward, origin at the carbody
 * centre; vertical displacements from the loaded static equilibrium, positive upwards,
 * reported in mm; the carbody pitch phiK is positive NOSE DOWN (a point at x moves by
 * zK - x phiK); the first vertical bending mode is the free-free uniform beam mode
 * normalised to 1 at the carbody ENDS (modal coordinate eta = end deflection): its value
 * over the bogies (x = +-A) is PHI_BOGIE, at the centre PHI_CENTRE, modal mass M_ETA = M_C/4.
 * Bogie 1 is the front bogie (x = +A), bogie 2 the rear (x = -A); wheelsets 1..4 front to
 * rear at x = A + B, A - B, -A + B, -A - B.
 *
 * Bodies: carbody 38 000 kg, pitch inertia 2.3e6 kg m2, 24.5 m long, bending 9.2 Hz with
 * 2.5 % damping; bogies 3 100 kg, pitch inertia 1 900 kg m2, centres 17.2 m apart,
 * wheelbase 2.5 m. Primary per wheelset: 1.4e6 N/m, 2.0e4 N s/m.
 * Secondary per bogie (no bump stops), delta = bogie - carbody over the bogie, > 0 in
 * compression:
 *   Fs = K2 delta (1 + P2 delta^2) + c(delta_dot) delta_dot + KS (delta - u),
 *   c  = C_REB + (C_COMP - C_REB) (1 + tanh(delta_dot / V_BLEND)) / 2,
 *   du/dt = KS / CS (delta - u)      (a damper with a stiff mount: a Maxwell element)
 * Actuator force Fa1, Fa2 (kN) of each bogie: upwards on the carbody, downwards on the bogie.
 *
 * Inputs: zr1..zr4 (m), zr1_dot..zr4_dot (m/s) track under the wheelsets, Fa1, Fa2 (kN).
 * Outputs (bodies only): zK, eta, zB1, zB2 (mm), their rates (m/s) and accelerations
 * (m/s2), phiK (rad), phiK_d (rad/s), phiK_dd (rad/s2, no declared unit).
 * fmi2DoStep integrates with classic RK4 in N_SUBSTEPS substeps per communication step;
 * the track inputs follow the Taylor polynomials of fmi2SetRealInputDerivatives (orders
 * 1-3, canInterpolateInputs), zero derivatives when not set; the forces are held.
 */
#include <math.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef COACH_GUID
#define COACH_GUID "{5b2e7d4c-1a90-4c1e-9d2f-c0ac4c0ac400}"
#endif

#define PI 3.14159265358979323846
#define M_C 38000.0
#define J_C 2.3e6
#define F_BEND 9.2
#define Z_BEND 0.025
#define M_ETA 9500.0
#define PHI_BOGIE 0.316503867672641
#define PHI_CENTRE (-0.6078222294162603)
#define M_B 3100.0
#define J_B 1900.0
#define A 8.6
#define B 1.25
#define K1W 1.4e6
#define C1W 2.0e4
#define K2 5.0e5
#define P2 40.0
#define C_COMP 1.6e4
#define C_REB 1.1e4
#define V_BLEND 0.02
#define KS 1.5e6
#define CS 1.2e4
#define N_SUBSTEPS 4
#define NX 16
#define NU 10
#define N_TRACK 8

/* value references: inputs, then outputs */
enum {
    VR_ZR1, VR_ZR1_DOT, VR_ZR2, VR_ZR2_DOT, VR_ZR3, VR_ZR3_DOT, VR_ZR4, VR_ZR4_DOT,
    VR_FA1, VR_FA2,
    VR_ZK, VR_ZK_D, VR_ZK_DD, VR_PHIK, VR_PHIK_D, VR_PHIK_DD, VR_ETA, VR_ETA_D, VR_ETA_DD,
    VR_ZB1, VR_ZB1_D, VR_ZB1_DD, VR_ZB2, VR_ZB2_D, VR_ZB2_DD, N_VR
};

typedef struct {
    fmi2CallbackFunctions cb;
    char *name;
    fmi2Boolean logging;
    double time;
    /* zK, phiK, eta, zB1, thB1, zB2, thB2, their rates, u1, u2 (SI) */
    double x[NX];
    double u[NU];           /* inputs at the start of the step (SI: m, m/s, N) */
    double der[N_TRACK][3]; /* track inputs' derivatives of orders 1-3 */
} Coach;

static double secondary_force(double delta, double delta_dot, double u) {
    double w = 0.5 * (1.0 + tanh(delta_dot / V_BLEND));
    double c = C_REB + (C_COMP - C_REB) * w;
    return K2 * delta * (1.0 + P2 * delta * delta) + c * delta_dot + KS * (delta - u);
}

/* state rates dx of state x with inputs u (SI) */
static void rates(const double *x, const double *u, double *dx) {
    const double xb[2] = {A, -A};
    const double wb = 2.0 * PI * F_BEND;
    double f[2], ftot;
    int i, j;
    for (i = 0; i < 7; i++) dx[i] = x[7 + i];
    for (i = 0; i < 2; i++) {
        double body = x[0] - xb[i] * x[1] + PHI_BOGIE * x[2];
        double body_d = x[7] - xb[i] * x[8] + PHI_BOGIE * x[9];
        double delta = x[3 + 2 * i] - body, delta_dot = x[10 + 2 * i] - body_d;
        double p[2];
        f[i] = secondary_force(delta, delta_dot, x[14 + i]) + u[8 + i];
        dx[14 + i] = KS / CS * (delta - x[14 + i]);
        for (j = 0; j < 2; j++) { /* leading (+B), trailing (-B) wheelset of bogie i */
            double s = j == 0 ? B : -B;
            int w = 2 * i + j;
            p[j] = K1W * (u[2 * w] - x[3 + 2 * i] - s * x[4 + 2 * i]) +
                   C1W * (u[2 * w + 1] - x[10 + 2 * i] - s * x[11 + 2 * i]);
        }
        dx[10 + 2 * i] = (p[0] + p[1] - f[i]) / M_B;
        dx[11 + 2 * i] = B * (p[0] - p[1]) / J_B;
    }
    ftot = f[0] + f[1];
    dx[7] = ftot / M_C;
    dx[8] = -A * (f[0] - f[1]) / J_C;
    dx[9] = PHI_BOGIE * ftot / M_ETA - 2.0 * Z_BEND * wb * x[9] - wb * wb * x[2];
}

/* inputs at time s after the start of the step */
static void inputs_at(const Coach *q, double s, double *u) {
    int i;
    for (i = 0; i < NU; i++) u[i] = q->u[i];
    for (i = 0; i < N_TRACK; i++)
        u[i] += s * (q->der[i][0] + s * (q->der[i][1] / 2.0 + s * q->der[i][2] / 6.0));
}

static void rk4(Coach *q, double s, double h) {
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX], u[NU];
    int i;
    inputs_at(q, s, u);
    rates(q->x, u, k1);
    inputs_at(q, s + 0.5 * h, u);
    for (i = 0; i < NX; i++) y[i] = q->x[i] + 0.5 * h * k1[i];
    rates(y, u, k2);
    for (i = 0; i < NX; i++) y[i] = q->x[i] + 0.5 * h * k2[i];
    rates(y, u, k3);
    inputs_at(q, s + h, u);
    for (i = 0; i < NX; i++) y[i] = q->x[i] + h * k3[i];
    rates(y, u, k4);
    for (i = 0; i < NX; i++) q->x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

static void start_values(Coach *q) {
    memset(q->x, 0, sizeof q->x);
    memset(q->u, 0, sizeof q->u);
    memset(q->der, 0, sizeof q->der);
    q->time = 0.0;
}

#define MODEL_ID "coach"
#define MODEL_GUID COACH_GUID
#define MODEL_T Coach
#define MODEL_LABEL "the coach"
#include "user_fmi2_glue.h"

/* ------------------------------------------------------------------ FMI 2.0 functions
 * (the rest, the same in every model of the user's: user_fmi2_glue.h) */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Coach *q = (Coach *)c;
    double dx[NX];
    size_t i;
    rates(q->x, q->u, dx);
    for (i = 0; i < nvr; i++) {
        unsigned r = (unsigned)vr[i];
        if (r < VR_FA1) {
            value[i] = q->u[r];
        } else if (r <= VR_FA2) {
            value[i] = q->u[r] / 1000.0; /* kN */
        } else if (r < N_VR) {
            /* (position state, its scale) of each output triple: value, rate, acceleration */
            static const int pos[5] = {0, 1, 2, 3, 5};
            static const double scale[5] = {1000.0, 1.0, 1000.0, 1000.0, 1000.0};
            int body = (int)(r - VR_ZK) / 3, kind = (int)(r - VR_ZK) % 3;
            int k = pos[body];
            value[i] = kind == 0 ? scale[body] * q->x[k] : kind == 1 ? q->x[7 + k] : dx[7 + k];
        } else {
            model_log(q, fmi2Error, "fmi2GetReal: no Real variable with value reference %u", r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Coach *q = (Coach *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        unsigned r = (unsigned)vr[i];
        if (r > VR_FA2) {
            model_log(q, fmi2Error, "fmi2SetReal: value reference %u is not an input", r);
            return fmi2Error;
        }
        q->u[r] = r >= VR_FA1 ? 1000.0 * value[i] : value[i];
        if (r < N_TRACK) memset(q->der[r], 0, sizeof q->der[r]);
    }
    return fmi2OK;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    Coach *q = (Coach *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= N_TRACK || order[i] < 1 || order[i] > 3) {
            model_log(q, fmi2Error,
                      "fmi2SetRealInputDerivatives: value reference %u, order %d: only the "
                      "track inputs, orders 1-3", (unsigned)vr[i], (int)order[i]);
            return fmi2Error;
        }
        q->der[vr[i]][order[i] - 1] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Coach *q = (Coach *)c;
    double h = communicationStepSize / N_SUBSTEPS, u[NU];
    int k;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!step_size_ok(q, communicationStepSize)) return fmi2Error;
    for (k = 0; k < N_SUBSTEPS; k++) rk4(q, k * h, h);
    inputs_at(q, communicationStepSize, u); /* the inputs at the end of the step */
    memcpy(q->u, u, sizeof u);
    memset(q->der, 0, sizeof q->der);
    q->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}
