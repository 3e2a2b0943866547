/*
 * user_held_inputs.h - the input and step functions of the user's models whose inputs are
 * held over a communication step (quarter_car.c, air_spring_car.c): fmi2SetReal,
 * fmi2SetRealInputDerivatives (refused: canInterpolateInputs is false) and fmi2DoStep
 * (N_SUBSTEPS classic RK4 substeps with the inputs held at the values set before the step).
 *
 * Included after user_fmi2_glue.h; before it a model defines
 *   VR_FACT      its last input's value reference (the inputs are 0 .. VR_FACT)
 *   N_SUBSTEPS   the RK4 substeps of one communication step
 * MODEL_T has the fields `double x[]` (the states) and `double u[]` (the inputs), and the
 * model has `static void rk4(double *x, const double *u, double h)`.
 */
#ifndef USER_HELD_INPUTS_H
#define USER_HELD_INPUTS_H

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    MODEL_T *q = (MODEL_T *)c;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (vr[i] > VR_FACT) {
            model_log(q, fmi2Error, "fmi2SetReal: value reference %u is not an input",
                      (unsigned)vr[i]);
            return fmi2Error;
        }
        q->u[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return not_supported(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    MODEL_T *q = (MODEL_T *)c;
    double h = communicationStepSize / N_SUBSTEPS;
    int k;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!step_size_ok(q, communicationStepSize)) return fmi2Error;
    for (k = 0; k < N_SUBSTEPS; k++) rk4(q->x, q->u, h);
    q->time = currentCommunicationPoint + communicationStepSize;
    return fmi2OK;
}

#endif /* USER_HELD_INPUTS_H */
