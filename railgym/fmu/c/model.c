/*
 * FMI 2.0 model exchange and co-simulation implementation of a railgym reference model with
 * continuous states, written by railgym.fmu.reference. The generated model_data.h defines the
 * GUID, the parameters P, the integration step MD_DT and includes the model header, which
 * defines
 *
 *   MD_NX, MD_NU, MD_NY       numbers of continuous states, inputs and outputs
 *   md_rhs(x, u, dx)          state derivative at the state x and the inputs u
 *   md_outputs(x, u, y)       outputs
 *
 * Value references: inputs 0 .. NU-1, outputs NU .. NU+NY-1, states NU+NY .. NU+NY+NX-1,
 * their derivatives NU+NY+NX .. NU+NY+2NX-1.
 *
 * Co-simulation: fmi2DoStep integrates the communication step H with classic RK4 in
 * n = round(H / MD_DT) (at least 1) equal substeps. The inputs over the step are the Taylor
 * polynomials u(t_c + s) = u + u' s + u'' s^2/2 + u''' s^3/6 from fmi2SetRealInputDerivatives
 * (orders 1 to 3; all zero after an fmi2SetReal of that input, i.e. a held input).
 *
 * The FMI functions shared with the surrogate elements' FMUs are in fmi2_common.h (shipped by
 * surrogates.fmi).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_data.h"

#define VR_Y (MD_NU)
#define VR_X (MD_NU + MD_NY)
#define VR_DX (MD_NU + MD_NY + MD_NX)
#define VR_END (MD_NU + MD_NY + 2 * MD_NX)
#define MAX_ORDER 3

#define FMU_GUID MD_GUID
#define FMU_NOUN "model"
#include "fmi2_common.h"

typedef struct {
    FmuBase base;
    double x[MD_NX];
    double u[MD_NU];
    double du[MD_NU][MAX_ORDER];
} Model;

static fmi2Component fmu_new(void) { return calloc(1, sizeof(Model)); }

static void fmu_reset(fmi2Component c) {
    Model *m = (Model *)c;
    memset(m->x, 0, sizeof m->x);
    memset(m->du, 0, sizeof m->du);
    memset(m->u, 0, sizeof m->u);
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Model *m = (Model *)c;
    double y[MD_NY], dx[MD_NX];
    size_t i;
    md_outputs(m->x, m->u, y);
    md_rhs(m->x, m->u, dx);
    for (i = 0; i < nvr; i++) {
        fmi2ValueReference r = vr[i];
        if (r < VR_Y) {
            value[i] = m->u[r];
        } else if (r < VR_X) {
            value[i] = y[r - VR_Y];
        } else if (r < VR_DX) {
            value[i] = m->x[r - VR_X];
        } else if (r < VR_END) {
            value[i] = dx[r - VR_DX];
        } else {
            fmu_log(m, fmi2Error, "fmi2GetReal: no such value reference %u", (unsigned)r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Model *m = (Model *)c;
    size_t i;
    int k;
    for (i = 0; i < nvr; i++) {
        fmi2ValueReference r = vr[i];
        if (r >= VR_Y) {
            fmu_log(m, fmi2Error, "fmi2SetReal: value reference %u is not an input", (unsigned)r);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            fmu_log(m, fmi2Error, "input %u set to a non-finite value", (unsigned)r);
            return fmi2Error;
        }
        m->u[r] = value[i];
        for (k = 0; k < MAX_ORDER; k++) m->du[r][k] = 0.0;
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------ model exchange */
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Model *m = (Model *)c;
    size_t j;
    if (nx != MD_NX) return unsupported(c, "fmi2SetContinuousStates with a wrong state count");
    for (j = 0; j < nx; j++) m->x[j] = x[j];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Model *m = (Model *)c;
    if (nx != MD_NX) return unsupported(c, "fmi2GetDerivatives with a wrong state count");
    md_rhs(m->x, m->u, derivatives);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators;
    return no_variables(c, ni, "fmi2GetEventIndicators");
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Model *m = (Model *)c;
    size_t j;
    if (nx != MD_NX) return unsupported(c, "fmi2GetContinuousStates with a wrong state count");
    for (j = 0; j < nx; j++) x[j] = m->x[j];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    size_t j;
    (void)c;
    for (j = 0; j < nx; j++) x_nominal[j] = 1.0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    Model *m = (Model *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= VR_Y || order[i] < 1 || order[i] > MAX_ORDER || !isfinite(value[i])) {
            fmu_log(m, fmi2Error,
                   "fmi2SetRealInputDerivatives: value reference %u, order %d not supported "
                   "(inputs 0..%d, orders 1..%d, finite values)",
                   (unsigned)vr[i], (int)order[i], MD_NU - 1, MAX_ORDER);
            return fmi2Error;
        }
        m->du[vr[i]][order[i] - 1] = value[i];
    }
    return fmi2OK;
}
static void inputs_at(const Model *m, double s, double *u) {
    int j;
    for (j = 0; j < MD_NU; j++) {
        u[j] = m->u[j] + s * (m->du[j][0] + s * (0.5 * m->du[j][1] + s * (m->du[j][2] / 6.0)));
    }
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    Model *m = (Model *)c;
    double k1[MD_NX], k2[MD_NX], k3[MD_NX], k4[MD_NX], xt[MD_NX];
    double ua[MD_NU], um[MD_NU], ub[MD_NU];
    double h, s0;
    int n, i, j;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!(communicationStepSize >= 0.0) || !isfinite(communicationStepSize)) {
        fmu_log(m, fmi2Error, "fmi2DoStep: bad step size %g", communicationStepSize);
        return fmi2Error;
    }
    n = (int)floor(communicationStepSize / MD_DT + 0.5);
    if (n < 1) n = 1;
    h = communicationStepSize / n;
    for (i = 0; i < n; i++) {
        s0 = i * h;
        inputs_at(m, s0, ua);
        inputs_at(m, s0 + 0.5 * h, um);
        inputs_at(m, s0 + h, ub);
        md_rhs(m->x, ua, k1);
        for (j = 0; j < MD_NX; j++) xt[j] = m->x[j] + 0.5 * h * k1[j];
        md_rhs(xt, um, k2);
        for (j = 0; j < MD_NX; j++) xt[j] = m->x[j] + 0.5 * h * k2[j];
        md_rhs(xt, um, k3);
        for (j = 0; j < MD_NX; j++) xt[j] = m->x[j] + h * k3[j];
        md_rhs(xt, ub, k4);
        for (j = 0; j < MD_NX; j++) {
            m->x[j] = m->x[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
        for (j = 0; j < MD_NX; j++) {
            if (!isfinite(m->x[j])) {
                fmu_log(m, fmi2Error, "fmi2DoStep: the state became non-finite at t = %g s",
                       currentCommunicationPoint + s0 + h);
                return fmi2Error;
            }
        }
    }
    /* the inputs at the end of the step, for the outputs read now */
    inputs_at(m, communicationStepSize, ua);
    for (j = 0; j < MD_NU; j++) m->u[j] = ua[j];
    memset(m->du, 0, sizeof m->du);
    m->base.time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}
