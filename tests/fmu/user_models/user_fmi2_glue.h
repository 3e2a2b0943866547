/*
 * user_fmi2_glue.h - the user's own FMI 2.0 glue shared by their hand-written models
 * (quarter_car.c, air_spring_car.c, coach.c): still no railgym code, only the FMI 2.0
 * standard headers. The FMI functions that do the same in every model live here; each
 * model writes its own fmi2GetReal, and fmi2SetReal, fmi2SetRealInputDerivatives and
 * fmi2DoStep (those of the quarter cars: user_quarter_car.h).
 *
 * Before including it a model defines
 *   MODEL_T      its instance struct, whose first fields are
 *                  fmi2CallbackFunctions cb; char *name; fmi2Boolean logging; double time;
 *   MODEL_ID     its model identifier (the default instance name), e.g. "quarter_car"
 *   MODEL_GUID   its GUID (the modelDescription's guid)
 *   MODEL_LABEL  its name in messages, e.g. "the quarter car"
 * and `static void start_values(MODEL_T *q)`, the state at instantiation and reset.
 */
#ifndef USER_FMI2_GLUE_H
#define USER_FMI2_GLUE_H

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"

static void model_log(MODEL_T *q, fmi2Status status, const char *fmt, ...) {
    char msg[400];
    va_list ap;
    if (q == NULL || q->cb.logger == NULL) return;
    if (status == fmi2OK && !q->logging) return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    q->cb.logger(q->cb.componentEnvironment, q->name, status,
                 status == fmi2OK ? "logAll" : "logStatusError", "%s", msg);
}

/* ------------------------------------------------------------------ FMI 2.0 functions */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories;
    (void)categories;
    ((MODEL_T *)c)->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    MODEL_T *q;
    const char *name = instanceName ? instanceName : MODEL_ID;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL) return NULL;
    if (functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error,
                              "logStatusError",
                              "fmi2Instantiate: allocateMemory and freeMemory are required");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error,
                              "logStatusError", MODEL_ID " is a co-simulation FMU only");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error,
                              "logStatusError", "GUID %s does not match %s",
                              fmuGUID ? fmuGUID : "(null)", MODEL_GUID);
        return NULL;
    }
    q = (MODEL_T *)functions->allocateMemory(1, sizeof(MODEL_T));
    if (q == NULL) return NULL;
    q->cb = *functions;
    q->name = (char *)functions->allocateMemory(strlen(name) + 1, 1);
    if (q->name == NULL) {
        functions->freeMemory(q);
        return NULL;
    }
    strcpy(q->name, name);
    q->logging = loggingOn;
    start_values(q);
    return q;
}

void fmi2FreeInstance(fmi2Component c) {
    MODEL_T *q = (MODEL_T *)c;
    if (q == NULL) return;
    q->cb.freeMemory(q->name);
    q->cb.freeMemory(q);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    ((MODEL_T *)c)->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    start_values((MODEL_T *)c);
    return fmi2OK;
}

static fmi2Status none_of_type(fmi2Component c, size_t nvr, const char *fn) {
    if (nvr == 0) return fmi2OK;
    model_log((MODEL_T *)c, fmi2Error, "%s: " MODEL_LABEL " has no such variables", fn);
    return fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2GetInteger");
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2GetBoolean");
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2GetString");
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2SetInteger");
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2SetBoolean");
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr; (void)value;
    return none_of_type(c, nvr, "fmi2SetString");
}

static fmi2Status not_supported(fmi2Component c, const char *fn) {
    model_log((MODEL_T *)c, fmi2Error, "%s is not supported by " MODEL_LABEL, fn);
    return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)s;
    return not_supported(c, "fmi2GetFMUstate");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    (void)s;
    return not_supported(c, "fmi2SetFMUstate");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)s;
    return not_supported(c, "fmi2FreeFMUstate");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)s; (void)n;
    return not_supported(c, "fmi2SerializedFMUstateSize");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)s; (void)b; (void)n;
    return not_supported(c, "fmi2SerializeFMUstate");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                   fmi2FMUstate *s) {
    (void)b; (void)n; (void)s;
    return not_supported(c, "fmi2DeSerializeFMUstate");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vu[],
                                        size_t nu, const fmi2ValueReference vk[], size_t nk,
                                        const fmi2Real dvk[], fmi2Real dvu[]) {
    (void)vu; (void)nu; (void)vk; (void)nk; (void)dvk; (void)dvu;
    return not_supported(c, "fmi2GetDirectionalDerivative");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return not_supported(c, "fmi2GetRealOutputDerivatives");
}

/* the check every model's fmi2DoStep starts with */
static int step_size_ok(MODEL_T *q, fmi2Real communicationStepSize) {
    if (communicationStepSize > 0.0) return 1;
    model_log(q, fmi2Error, "fmi2DoStep: communication step %g s is not positive",
              communicationStepSize);
    return 0;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return not_supported(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return not_supported(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    MODEL_T *q = (MODEL_T *)c;
    if (s == fmi2LastSuccessfulTime) {
        *value = q->time;
        return fmi2OK;
    }
    return not_supported(c, "fmi2GetRealStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return not_supported(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s; (void)value;
    return not_supported(c, "fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return not_supported(c, "fmi2GetStringStatus");
}

#endif /* USER_FMI2_GLUE_H */
