/*
 * FMI 2.0 model exchange and co-simulation implementation of one memoryless Legendre
 * polynomial regression (LPR) surrogate element, written by railgym's surrogates.fmi.
 *
 * The element: inputs u_j (j < EL_D) in their own units, output v = F(u).
 *   t_j = (u_j - lower_j) * (2 / (upper_j - lower_j)) - 1            (domain map to [-1, 1])
 *   P_0 = 1, P_1 = t, P_{k+1} = (2k+1)/(k+1) t P_k - k/(k+1) P_{k-1}  (Bonnet recurrence)
 *   v = sum_i coef_i prod_j P_{E_ij}(t_j)
 * Outside the training box [lower, upper] the extrapolation policy EL_MODE applies:
 *   0 "linear": value at the clipped point plus its gradient times (u - u_clipped),
 *               with P'_{k+1} = P'_{k-1} + (2k+1) P_k;
 *   1 "clip":   value at the clipped point;
 *   2 "raise":  fmi2GetReal returns fmi2Error and logs the offending input.
 * The arithmetic follows surrogates.models.lpr term by term; compile without floating-point
 * contraction (gcc -ffp-contract=off) to reproduce it to rounding.
 *
 * The element has no state: model exchange exposes no continuous states and no event
 * indicators, and fmi2DoStep only advances the communication time.
 *
 * Value references: 0 .. EL_D-1 the inputs, EL_D the output. The coefficients, exponents
 * and the training box are in element_data.h (generated).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "element_data.h"

#define EL_WIDTH (EL_NMAX + 2)

typedef struct {
    fmi2Real u[EL_D];
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

/* Evaluate the element at u; returns 1 (and leaves *value untouched) if u is outside the box
   under the "raise" policy, with *column the first offending input. */
static int el_eval(const fmi2Real *u, fmi2Real *value, int *column) {
    double P[EL_D][EL_WIDTH];
    double dP[EL_WIDTH];
    double uc[EL_D];
    double t[EL_D];
    double scale[EL_D];
    double v = 0.0;
    int outside = 0;
    int i, j, k;
    for (j = 0; j < EL_D; j++) {
        uc[j] = u[j] < el_lower[j] ? el_lower[j] : (u[j] > el_upper[j] ? el_upper[j] : u[j]);
        if (uc[j] != u[j]) {
            if (!outside) *column = j;
            outside = 1;
        }
    }
    if (outside && EL_MODE == 2) return 1;
    for (j = 0; j < EL_D; j++) {
        scale[j] = 2.0 / (el_upper[j] - el_lower[j]);
        t[j] = (uc[j] - el_lower[j]) * scale[j] - 1.0;
        P[j][0] = 1.0;
        P[j][1] = t[j];
        for (k = 1; k < EL_NMAX; k++) {
            P[j][k + 1] = (double)(2 * k + 1) / (double)(k + 1) * t[j] * P[j][k]
                          - (double)k / (double)(k + 1) * P[j][k - 1];
        }
    }
    for (i = 0; i < EL_T; i++) {
        double term = P[0][el_exponents[i][0]];
        for (j = 1; j < EL_D; j++) term *= P[j][el_exponents[i][j]];
        v += term * el_coef[i];
    }
    if (outside && EL_MODE == 0) {
        double ext = 0.0;
        for (j = 0; j < EL_D; j++) {
            double g = 0.0;
            if (uc[j] == u[j]) continue;
            dP[0] = 0.0;
            dP[1] = 1.0;
            for (k = 1; k < EL_NMAX; k++) dP[k + 1] = dP[k - 1] + (double)(2 * k + 1) * P[j][k];
            for (i = 0; i < EL_T; i++) {
                double term = j == 0 ? dP[el_exponents[i][0]] : P[0][el_exponents[i][0]];
                int m;
                for (m = 1; m < EL_D; m++) {
                    term *= m == j ? dP[el_exponents[i][m]] : P[m][el_exponents[i][m]];
                }
                g += term * el_coef[i];
            }
            ext += g * scale[j] * (u[j] - uc[j]);
        }
        v += ext;
    }
    *value = v;
    return 0;
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
    for (j = 0; j < EL_D; j++) e->u[j] = el_start[j];
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
    for (j = 0; j < EL_D; j++) e->u[j] = el_start[j];
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
        if (vr[i] < EL_D) {
            value[i] = e->u[vr[i]];
        } else if (vr[i] == EL_D) {
            int column = 0;
            if (el_eval(e->u, &value[i], &column)) {
                logmsg(e, fmi2Error, "logStatusError",
                       "input %s = %.17g is outside the training domain [%.17g, %.17g] "
                       "(extrapolation policy \"raise\")",
                       el_input_names[column], e->u[column], el_lower[column],
                       el_upper[column]);
                return fmi2Error;
            }
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
        if (vr[i] >= EL_D) return bad_reference(e, vr[i], "fmi2SetReal (inputs only)");
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
