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
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "element_data.h"

typedef struct {
    fmi2Real u[EL_NIN];
    fmi2Real state[EL_NSTATE];
    fmi2Real time;
    fmi2Type type;
    fmi2Boolean logging;
    fmi2CallbackFunctions cb;
    char *name;
} Element;

static void logmsg(Element *e, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    if (e == NULL || e->cb.logger == NULL) return;
    if (status == fmi2OK && !e->logging) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    e->cb.logger(e->cb.componentEnvironment, e->name, status, category, "%s", buf);
}

/* ------------------------------------------------------------------ common functions */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories;
    (void)categories;
    ((Element *)c)->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Element *e;
    int j;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || fmuGUID == NULL || strcmp(fmuGUID, EL_GUID) != 0) {
        if (functions != NULL && functions->logger != NULL) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logStatusError", "GUID %s does not match this FMU (%s)",
                              fmuGUID ? fmuGUID : "(null)", EL_GUID);
        }
        return NULL;
    }
    e = (Element *)calloc(1, sizeof(Element));
    if (e == NULL) return NULL;
    e->name = (char *)malloc(strlen(instanceName ? instanceName : "") + 1);
    if (e->name == NULL) {
        free(e);
        return NULL;
    }
    strcpy(e->name, instanceName ? instanceName : "");
    e->cb = *functions;
    e->type = fmuType;
    e->logging = loggingOn;
    for (j = 0; j < EL_NIN; j++) e->u[j] = el_start[j];
    el_init(e->state);
    return (fmi2Component)e;
}

void fmi2FreeInstance(fmi2Component c) {
    Element *e = (Element *)c;
    if (e == NULL) return;
    free(e->name);
    free(e);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    ((Element *)c)->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Element *e = (Element *)c;
    int j;
    for (j = 0; j < EL_NIN; j++) e->u[j] = el_start[j];
    el_init(e->state);
    e->time = 0.0;
    return fmi2OK;
}

static fmi2Status bad_reference(Element *e, fmi2ValueReference vr, const char *what) {
    logmsg(e, fmi2Error, "logStatusError", "%s: no such value reference %u", what,
           (unsigned)vr);
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
                logmsg(e, fmi2Error, "logStatusError", "fmi2GetReal: %s", msg);
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
            logmsg(e, fmi2Error, "logStatusError", "input %s set to a non-finite value",
                   el_input_names[vr[i]]);
            return fmi2Error;
        }
        e->u[vr[i]] = value[i];
    }
    return fmi2OK;
}

static fmi2Status no_variables(fmi2Component c, size_t nvr, const char *what) {
    if (nvr == 0) return fmi2OK;
    logmsg((Element *)c, fmi2Error, "logStatusError", "%s: the element has no such variables",
           what);
    return fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2GetInteger");
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2GetBoolean");
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2GetString");
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2SetInteger");
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2SetBoolean");
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return no_variables(c, nvr, "fmi2SetString");
}

static fmi2Status unsupported(fmi2Component c, const char *what) {
    logmsg((Element *)c, fmi2Error, "logStatusError", "%s is not supported by this FMU", what);
    return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2GetFMUstate");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2SetFMUstate");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2FreeFMUstate");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate;
    (void)size;
    return unsupported(c, "fmi2SerializedFMUstateSize");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte state[],
                                 size_t size) {
    (void)FMUstate;
    (void)state;
    (void)size;
    return unsupported(c, "fmi2SerializeFMUstate");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate) {
    (void)serializedState;
    (void)size;
    (void)FMUstate;
    return unsupported(c, "fmi2DeSerializeFMUstate");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown[],
                                        size_t nUnknown, const fmi2ValueReference vKnown[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown;
    (void)nUnknown;
    (void)vKnown;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

/* ------------------------------------------------------------------ model exchange */
/* A model-exchange element has no continuous states and no event indicators. */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    (void)c;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    (void)c;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    (void)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    ((Element *)c)->time = time;
    return fmi2OK;
}

static fmi2Status no_states(fmi2Component c, size_t n, const char *what) {
    if (n == 0) return fmi2OK;
    logmsg((Element *)c, fmi2Error, "logStatusError", "%s: the element has no states", what);
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
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint) {
    Element *e = (Element *)c;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!(communicationStepSize >= 0.0)) {
        logmsg(e, fmi2Error, "logStatusError", "fmi2DoStep: negative step size %g",
               communicationStepSize);
        return fmi2Error;
    }
    el_commit(e->u, e->state);
    e->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (s == fmi2LastSuccessfulTime) {
        *value = ((Element *)c)->time;
        return fmi2OK;
    }
    return unsupported(c, "fmi2GetRealStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (s == fmi2Terminated) {
        *value = fmi2False;
        return fmi2OK;
    }
    return unsupported(c, "fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetStringStatus");
}
