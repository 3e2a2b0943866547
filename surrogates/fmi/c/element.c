/*
 * FMI 2.0 model exchange and co-simulation implementation of one surrogate element, written by
 * railgym's surrogates.fmi. This file is generic; the generated element_data.h holds the
 * element's constants and includes its model header, which defines
 *
 *   EL_NIN, EL_NOUT, EL_NSTATE          numbers of inputs, outputs and discrete states
 *   el_start[EL_NIN], el_input_names[]  start values and names of the inputs
 *   el_init(state)                      initial discrete state
 *   el_outputs(u, state, y, msg, n)     outputs y[EL_NOUT] at the inputs u; nonzero (with a
 *                                       message in msg) if they cannot be computed
 *   el_commit(u, state)                 state update at the end of a communication step
 *
 * lpr_element.h: a memoryless Legendre element (model exchange and co-simulation);
 * hysteretic_element.h: a crash element with a permanent set (co-simulation).
 * lpr.h evaluates a Legendre regression with the arithmetic of surrogates.models.lpr; compile
 * without floating-point contraction (gcc -ffp-contract=off) to reproduce it to rounding.
 *
 * Value references: 0 .. EL_NIN-1 the inputs, EL_NIN .. EL_NIN+EL_NOUT-1 the outputs.
 * The FMI functions shared with railgym's reference models are in fmi2_common.h.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "element_data.h"

#define FMU_GUID EL_GUID
#define FMU_NOUN "element"
#include "fmi2_common.h"

typedef struct {
    FmuBase base;
    fmi2Real u[EL_NIN];
    fmi2Real state[EL_NSTATE];
} Element;

static fmi2Component fmu_new(void) { return calloc(1, sizeof(Element)); }

static void fmu_reset(fmi2Component c) {
    Element *e = (Element *)c;
    int j;
    for (j = 0; j < EL_NIN; j++) e->u[j] = el_start[j];
    el_init(e->state);
}

static fmi2Status bad_reference(Element *e, fmi2ValueReference vr, const char *what) {
    fmu_log(e, fmi2Error, "%s: no such value reference %u", what, (unsigned)vr);
    return fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Element *e = (Element *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] < EL_NIN) {
            value[i] = e->u[vr[i]];
        } else if (vr[i] < EL_NIN + EL_NOUT) {
            fmi2Real y[EL_NOUT];
            char msg[256];
            if (el_outputs(e->u, e->state, y, msg, sizeof msg)) {
                fmu_log(e, fmi2Error, "fmi2GetReal: %s", msg);
                return fmi2Error;
            }
            value[i] = y[vr[i] - EL_NIN];
        } else {
            return bad_reference(e, vr[i], "fmi2GetReal");
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Element *e = (Element *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= EL_NIN) return bad_reference(e, vr[i], "fmi2SetReal (inputs only)");
        if (!isfinite(value[i])) {
            fmu_log(e, fmi2Error, "input %s set to a non-finite value", el_input_names[vr[i]]);
            return fmi2Error;
        }
        e->u[vr[i]] = value[i];
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------ model exchange */
/* A model-exchange element has no continuous states and no event indicators. */
static fmi2Status no_states(fmi2Component c, size_t n, const char *what) {
    if (n == 0) return fmi2OK;
    fmu_log(c, fmi2Error, "%s: the element has no states", what);
    return fmi2Error;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    (void)x;
    return no_states(c, nx, "fmi2SetContinuousStates");
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    (void)derivatives;
    return no_states(c, nx, "fmi2GetDerivatives");
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators;
    return no_states(c, ni, "fmi2GetEventIndicators");
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    (void)x;
    return no_states(c, nx, "fmi2GetContinuousStates");
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[],
                                             size_t nx) {
    (void)x_nominal;
    return no_states(c, nx, "fmi2GetNominalsOfContinuousStates");
}

/* ------------------------------------------------------------------ co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    Element *e = (Element *)c;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!(communicationStepSize >= 0.0)) {
        fmu_log(e, fmi2Error, "fmi2DoStep: negative step size %g", communicationStepSize);
        return fmi2Error;
    }
    el_commit(e->u, e->state);
    e->base.time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}
