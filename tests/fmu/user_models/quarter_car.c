/*
 * quarter_car.c - a quarter car as a user would bring it: an FMI 2.0 co-simulation FMU,
 * written by hand without any railgym code (only the FMI 2.0 standard headers and the
 * user's own glue, user_fmi2_glue.h, and user_quarter_car.h).
 *
 * Bodies (displacements from the loaded static equilibrium, m, positive upwards; gravity
 * is balanced by the static preload of the secondary spring and does not appear):
 *   x1, v1  bogie,   m1 = 1 800 kg
 *   x2, v2  carbody, m2 = 8 000 kg
 * Primary (track to bogie), linear:   F1 = k1 (zr - x1) + c1 (zr_dot - v1),
 *   k1 = 2.4e6 N/m, c1 = 3.0e4 N s/m.
 * Secondary (bogie to carbody), nonlinear, no bump stops, delta = x1 - x2 > 0 in compression:
 *   Fs = k2 delta (1 + 30 delta^2) + c(delta_dot) delta_dot,
 *   c  = c_reb + (c_comp - c_reb) (1 + tanh(delta_dot / 0.01)) / 2,
 *   k2 = 4.3e5 N/m, c_comp = 2.0e4 N s/m (compression), c_reb = 1.4e4 N s/m (rebound).
 * Actuator force Fact (N): upwards on the carbody, downwards on the bogie.
 *   m1 a1 = F1 - Fs - Fact,   m2 a2 = Fs + Fact.
 *
 * Inputs zr (m), zr_dot (m/s), Fact (N); outputs x1, v1, x2, v2 and a2 (m/s2, from the
 * current state and the current Fact). fmi2DoStep integrates with classic RK4 in 4 equal
 * substeps per communication step; the inputs are held (zero-order hold) at the values set
 * before the step (canInterpolateInputs is false).
 *
 * Build: cc -shared -fPIC -O2 -std=c99 -ffp-contract=off -I<fmi2 headers>
 *        -DQUARTER_CAR_GUID="\"{...}\"" -o quarter_car.so quarter_car.c -lm
 */
#include <math.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef QUARTER_CAR_GUID
#define QUARTER_CAR_GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"
#endif

/* parameters, SI */
#define M1 1800.0
#define M2 8000.0
#define K1 2.4e6
#define C1 3.0e4
#define K2 4.3e5
#define PROGRESSION 30.0   /* 1/m^2 */
#define C_COMP 2.0e4
#define C_REB 1.4e4
#define V_BLEND 0.01       /* m/s */
#define N_SUBSTEPS 4
#define NX 4

/* value references */
enum { VR_ZR, VR_ZR_DOT, VR_FACT, VR_X1, VR_V1, VR_X2, VR_V2, VR_A2, N_VR };

typedef struct {
    fmi2CallbackFunctions cb;
    char *name;
    fmi2Boolean logging;
    double time;
    double x[NX]; /* x1, v1, x2, v2 */
    double u[3]; /* zr, zr_dot, Fact */
} QuarterCar;

static double secondary_force(double delta, double delta_dot) {
    double w = 0.5 * (1.0 + tanh(delta_dot / V_BLEND));
    double c = C_REB + (C_COMP - C_REB) * w;
    return K2 * delta * (1.0 + PROGRESSION * delta * delta) + c * delta_dot;
}

static void rates(const double *x, const double *u, double *dx) {
    double fs = secondary_force(x[0] - x[2], x[1] - x[3]);
    double f1 = K1 * (u[0] - x[0]) + C1 * (u[1] - x[1]);
    dx[0] = x[1];
    dx[1] = (f1 - fs - u[2]) / M1;
    dx[2] = x[3];
    dx[3] = (fs + u[2]) / M2;
}

static void start_values(QuarterCar *q) {
    memset(q->x, 0, sizeof q->x);
    memset(q->u, 0, sizeof q->u);
    q->time = 0.0;
}

#define MODEL_ID "quarter_car"
#define MODEL_GUID QUARTER_CAR_GUID
#define MODEL_T QuarterCar
#define MODEL_LABEL "the quarter car"
#include "user_fmi2_glue.h"
#include "user_quarter_car.h"
