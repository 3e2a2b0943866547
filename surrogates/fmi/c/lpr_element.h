/*
 * Memoryless Legendre element: inputs = features, one output = F(u) (lpr.h), no state.
 * Constants EL_D, EL_T, EL_NMAX, EL_MODE, el_exponents, el_coef, el_lower, el_upper from
 * element_data.h.
 */
#include "lpr.h"

#define EL_NIN EL_D
#define EL_NOUT 1
#define EL_NSTATE 1 /* none used; C arrays cannot be empty */

static void el_init(double *state) { state[0] = 0.0; }

static int el_outputs(const double *u, const double *state, double *y, char *msg, size_t n) {
    int column = 0;
    (void)state;
    if (lpr_value(u, EL_D, EL_T, EL_NMAX, &el_exponents[0][0], el_coef, el_lower, el_upper,
                  EL_MODE, &y[0], &column)) {
        snprintf(msg, n,
                 "input %s = %.17g is outside the training domain [%.17g, %.17g] "
                 "(extrapolation policy \"raise\")",
                 el_input_names[column], u[column], el_lower[column], el_upper[column]);
        return 1;
    }
    return 0;
}

static void el_commit(const double *u, double *state) {
    (void)u;
    (void)state;
}
