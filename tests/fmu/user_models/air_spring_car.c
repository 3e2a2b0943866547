/*
 * air_spring_car.c - a quarter car with an air spring, surge pipe and reservoir, as a user
 * would bring it: an FMI 2.0 co-simulation FMU written by hand without any railgym code
 * (its FMI glue shared with the user's other models: user_fmi2_glue.h, and with the
 * other quarter car: user_quarter_car.h).
 *
 * Bodies (displacements from the loaded static equilibrium, m, positive upwards):
 *   x1, v1  bogie share,   m1 = 2 100 kg
 *   x2, v2  carbody share, m2 = 8 150 kg (its weight is carried by the static gauge
 *           pressure P0 - p_atm on the effective area, not in the equations)
 * Primary (track to bogie), linear:   F1 = k1 (zr - x1) + c1 (zr_dot - v1),
 *   k1 = 2.9e6 N/m, c1 = 2.6e4 N s/m.
 * Secondary: an air spring (bellows, effective area A = 0.2 m2, volume Vb = Vb0 - A delta,
 * delta = x1 - x2 > 0 in compression) joined by a surge pipe to a reservoir of volume Vr.
 * The gas masses mb, mr (kg) are states; each volume is polytropic, p = P0 (rho/rho0)^n,
 * n = 1.4; the pipe's volume flow Q (bellows to reservoir) obeys
 *   pb - pr = Rl Q + Rt Q |Q|   (laminar and turbulent losses),   dmb/dt = -rho_m Q,
 * rho_m the mean gas density of the two volumes. The secondary force is
 *   Fs = (pb - P0) A;   m1 a1 = F1 - Fs - Fact,   m2 a2 = Fs + Fact.
 * Linearised: k0 = A^2 n P0/(Vb0 + Vr) = 364 kN/m (static), k_inf = A^2 n P0/Vb0 = 830 kN/m,
 * relaxation time Rl/(n P0 (1/Vb0 + 1/Vr)) = 45.7 ms, loss-angle peak 23 deg at 2.3 Hz.
 *
 * Inputs zr (m), zr_dot (m/s), Fact (N); outputs x1, v1, x2, v2 and a2 (m/s2). fmi2DoStep
 * integrates with classic RK4 in 4 equal substeps per communication step, the inputs held.
 */
#include <math.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef AIR_SPRING_CAR_GUID
#define AIR_SPRING_CAR_GUID "{5d0e6a52-9a3e-4f1c-8e44-2b7d1c0a5e11}"
#endif

/* parameters, SI */
#define M1 2100.0
#define M2 8150.0
#define K1 2.9e6
#define C1 2.6e4
#define AREA 0.2          /* m^2, effective area of the bellows */
#define P0 5.0e5          /* Pa, absolute pressure at the static equilibrium */
#define RHO0 5.95         /* kg/m^3, gas density at P0 */
#define N_POLY 1.4
#define VB0 0.03373       /* m^3, bellows volume at the static equilibrium */
#define VR 0.04320        /* m^3, reservoir */
#define R_LAM 1.69e6      /* Pa s/m^3, laminar loss of the surge pipe */
#define R_TURB 2.0e7      /* Pa s^2/m^6, turbulent loss of the surge pipe */
#define N_SUBSTEPS 4
#define NX 6

/* value references */
enum { VR_ZR, VR_ZR_DOT, VR_FACT, VR_X1, VR_V1, VR_X2, VR_V2, VR_A2, N_VR };

typedef struct {
    fmi2CallbackFunctions cb;
    char *name;
    fmi2Boolean logging;
    double time;
    double x[NX]; /* x1, v1, x2, v2, mb, mr */
    double u[3]; /* zr, zr_dot, Fact */
} QuarterCar;

static double pressure(double mass, double volume) {
    return P0 * pow(mass / (volume * RHO0), N_POLY);
}

static void rates(const double *x, const double *u, double *dx) {
    double vb = VB0 - AREA * (x[0] - x[2]);
    double pb = pressure(x[4], vb), pr = pressure(x[5], VR);
    double dp = pb - pr;
    double q = 2.0 * dp / (R_LAM + sqrt(R_LAM * R_LAM + 4.0 * R_TURB * fabs(dp)));
    double mdot = 0.5 * (x[4] / vb + x[5] / VR) * q;
    double fs = (pb - P0) * AREA;
    double f1 = K1 * (u[0] - x[0]) + C1 * (u[1] - x[1]);
    dx[0] = x[1];
    dx[1] = (f1 - fs - u[2]) / M1;
    dx[2] = x[3];
    dx[3] = (fs + u[2]) / M2;
    dx[4] = -mdot;
    dx[5] = mdot;
}

static void start_values(QuarterCar *q) {
    memset(q->x, 0, sizeof q->x);
    q->x[4] = RHO0 * VB0;
    q->x[5] = RHO0 * VR;
    memset(q->u, 0, sizeof q->u);
    q->time = 0.0;
}

#define MODEL_ID "air_spring_car"
#define MODEL_GUID AIR_SPRING_CAR_GUID
#define MODEL_T QuarterCar
#define MODEL_LABEL "the air-spring car"
#include "user_fmi2_glue.h"
#include "user_quarter_car.h"
