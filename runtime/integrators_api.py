"""cffi declarations of the integrator C API (templates/c/eomc_integrators.h).

Kept beside the C header by hand (they are short); the loader appends
INTEGRATOR_CDEF to the model ABI declarations (which declare ``eomc_model``)
so one FFI object sees both.  No macros: cffi's ABI mode cannot read them,
so the method numbers and status names live here as Python constants.
"""

__all__ = ["INTEGRATOR_CDEF", "METHOD_IDS", "METHOD_ALIASES", "STATUS_NAMES", "STATUS_OK"]

INTEGRATOR_CDEF = """
typedef struct eomc_options {
    int method;
    double rtol, atol;
    double h0;
    double hmax;
    long max_steps;
    int project;
    int stiff_check;
    double baumgarte;
} eomc_options;

typedef struct eomc_stats {
    long steps;
    long accepted, rejected;
    long nfev;
    long njev;
    long nlu;
    long nproj;
    int status;
    int n_out;
    double t;
    double t_fail;
    double h;
    double stiff_hlambda;
    double max_residual;
} eomc_stats;

size_t eomc_integrate_work_size(const eomc_model *m, int method);

int eomc_integrate(const eomc_model *m, const eomc_options *opt,
                   double t0, double t1, const double *x0, const double *p,
                   int n_rgrid, const double *r_tgrid, const double *r_values,
                   int n_eval, const double *t_eval, double *x_out,
                   double *x_last, eomc_stats *stats,
                   double *work, size_t work_len);

int eomc_eval_along(const eomc_model *m, int which, int n, const double *t,
                    const double *X, const double *p, int n_rgrid,
                    const double *r_tgrid, const double *r_values,
                    double *out, double *work, size_t work_len);
"""

# Canonical method name -> EOMC_* number in eomc_integrators.h.
METHOD_IDS = {"rk4": 0, "dopri5": 1, "dop853": 2, "radau": 3}
# Other accepted spellings.
METHOD_ALIASES = {"rk45": "dopri5", "radau5": "radau", "radauiia": "radau"}

STATUS_OK = 0
# eomc_status (templates/c/eomc_model.h) -> short reason for messages.
STATUS_NAMES = {
    0: "ok",
    1: "singular mass matrix",
    2: "singular constraints (projection could not be solved)",
    3: "non-finite value in the state or its derivative",
    4: "bad argument",
    5: "step size underflow",
    6: "maximum number of steps reached",
    7: "the problem is stiff for this explicit method",
    8: "a function needed by this method was not generated for the model",
}
