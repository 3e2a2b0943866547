/*
 * user_quarter_car.h - the FMI functions of the user's quarter cars (quarter_car.c,
 * air_spring_car.c), which differ only in their states and secondary suspension: the same
 * variables (inputs zr, zr_dot, Fact; outputs x1, v1, x2, v2, a2), the inputs held over a
 * communication step (canInterpolateInputs is false) and N_SUBSTEPS classic RK4 substeps.
 * fmi2GetReal, fmi2SetReal, fmi2SetRealInputDerivatives (refused) and fmi2DoStep.
 *
 * Included after user_fmi2_glue.h; before it a model defines
 *   NX           its number of states, the first four x1, v1, x2, v2 (bogie, carbody)
 *   N_SUBSTEPS   the RK4 substeps of one communication step
 *   the value references VR_ZR, VR_ZR_DOT, VR_FACT, VR_X1, VR_V1, VR_X2, VR_V2, VR_A2
 *   (in this order, consecutive)
 * MODEL_T has the fields `double x[NX]` and `double u[3]` (zr, zr_dot, Fact), and the
 * model has `static void rates(const double *x, const double *u, double *dx)` (dx[3] is
 * the carbody acceleration a2).
 */
#ifndef USER_QUARTER_CAR_H
#define USER_QUARTER_CAR_H

static void rk4(double *x, const double *u, double h) {
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX];
    int i;
    rates(x, u, k1);
    for (i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k1[i];
    rates(y, u, k2);
    for (i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k2[i];
    rates(y, u, k3);
    for (i = 0; i < NX; i++) y[i] = x[i] + h * k3[i];
    rates(y, u, k4);
    for (i = 0; i < NX; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    MODEL_T *q = (MODEL_T *)c;
    double dx[NX];
    size_t i;
    for (i = 0; i < nvr; i++) {
        switch (vr[i]) {
        case VR_ZR: case VR_ZR_DOT: case VR_FACT: value[i] = q->u[vr[i] - VR_ZR]; break;
        case VR_X1: case VR_V1: case VR_X2: case VR_V2: value[i] = q->x[vr[i] - VR_X1]; break;
        case VR_A2: /* from the current state and the current Fact */
            rates(q->x, q->u, dx);
            value[i] = dx[3];
            break;
        default:
            model_log(q, fmi2Error, "fmi2GetReal: no Real variable with value reference %u",
                      (unsigned)vr[i]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

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

#endif /* USER_QUARTER_CAR_H */
