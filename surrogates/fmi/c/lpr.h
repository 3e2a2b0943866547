/*
 * Legendre regression of surrogates.models.lpr, for the FMU sources (included once).
 *
 *   t_j = (u_j - lower_j) * (2 / (upper_j - lower_j)) - 1            (domain map to [-1, 1])
 *   P_0 = 1, P_1 = t, P_{k+1} = (2k+1)/(k+1) t P_k - k/(k+1) P_{k-1}  (Bonnet recurrence)
 *   v = sum_i coef_i prod_j P_{E_ij}(t_j)
 *
 * Outside the training box: mode 0 "linear" (value at the clipped point plus its gradient times
 * (u - u_clipped), with P'_{k+1} = P'_{k-1} + (2k+1) P_k), mode 1 "clip" (value at the clipped
 * point), mode 2 "raise" (returns 1 with *column the first input outside). LPR_MAXD and
 * LPR_MAXW (largest number of inputs and nmax + 2) come from element_data.h.
 */
static int lpr_value(const double *u, int d, int T, int nmax, const int *E, const double *coef,
                     const double *lower, const double *upper, int mode, double *value,
                     int *column) {
    double P[LPR_MAXD][LPR_MAXW];
    double dP[LPR_MAXW];
    double uc[LPR_MAXD];
    double scale[LPR_MAXD];
    double v = 0.0;
    int outside = 0;
    int i, j, k, m;
    for (j = 0; j < d; j++) {
        uc[j] = u[j] < lower[j] ? lower[j] : (u[j] > upper[j] ? upper[j] : u[j]);
        if (uc[j] != u[j]) {
            if (!outside) *column = j;
            outside = 1;
        }
    }
    if (outside && mode == 2) return 1;
    for (j = 0; j < d; j++) {
        double t;
        scale[j] = 2.0 / (upper[j] - lower[j]);
        t = (uc[j] - lower[j]) * scale[j] - 1.0;
        P[j][0] = 1.0;
        P[j][1] = t;
        for (k = 1; k < nmax; k++) {
            P[j][k + 1] = (double)(2 * k + 1) / (double)(k + 1) * t * P[j][k]
                          - (double)k / (double)(k + 1) * P[j][k - 1];
        }
    }
    for (i = 0; i < T; i++) {
        double term = P[0][E[i * d]];
        for (j = 1; j < d; j++) term *= P[j][E[i * d + j]];
        v += term * coef[i];
    }
    if (outside && mode == 0) {
        double ext = 0.0;
        for (j = 0; j < d; j++) {
            double g = 0.0;
            if (uc[j] == u[j]) continue;
            dP[0] = 0.0;
            dP[1] = 1.0;
            for (k = 1; k < nmax; k++) dP[k + 1] = dP[k - 1] + (double)(2 * k + 1) * P[j][k];
            for (i = 0; i < T; i++) {
                double term = j == 0 ? dP[E[i * d]] : P[0][E[i * d]];
                for (m = 1; m < d; m++) term *= m == j ? dP[E[i * d + m]] : P[m][E[i * d + m]];
                g += term * coef[i];
            }
            ext += g * scale[j] * (u[j] - uc[j]);
        }
        v += ext;
    }
    *value = v;
    return 0;
}
