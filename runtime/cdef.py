"""cffi declarations of the model ABI (runtime/c/eomc_model.h) and the batch helper.

cffi's ABI mode (``ffi.dlopen``) needs the C declarations as text; they are
read from the shipped headers themselves (:mod:`.header_cdef`), so the struct
layout Python uses is the one the C compiler saw.  ``test_loader`` checks the
sizes and names read through this layout against each built model's metadata.
"""

from .header_cdef import header_cdef

__all__ = ["ABI_VERSION", "MODEL_CDEF", "BATCH_CDEF", "STATUS_NAMES", "STATUS_SINGULAR_MASS_MATRIX",
           "STATUS_ABORTED", "model_function_cdef", "CONST_SPLIT", "TREE_LU", "TREE_SOLVE", "TREE_RESIDUAL"]

ABI_VERSION = 1

MODEL_CDEF = header_cdef("eomc_model.h")
BATCH_CDEF = header_cdef("eomc_batch.h")

# eomc_status values (eomc_model.h) -> what went wrong, in words.
STATUS_NAMES = {
    0: "ok",
    1: "the mass matrix is singular",
    2: "the constraint equations are singular (dependent speeds cannot be solved)",
    3: "a non-finite value appeared",
    4: "bad argument",
    5: "the step size became too small",
    6: "the maximum number of steps was reached",
    7: "the problem looks stiff for an explicit method",
    8: "the function was not generated for this model",
    9: "the run was stopped: an input callable failed, or it was interrupted",
    10: "a contact went deeper into the ground than its limit",
}
STATUS_SINGULAR_MASS_MATRIX = 1   # EOMC_SINGULAR_MASS_MATRIX
STATUS_ABORTED = 9                # EOMC_ABORTED: a callback failed or Ctrl-C; the run stops at once

_SIGNATURES = {
    "rhs": "int {n}_rhs(double t, const double *x, const double *p, const double *r, double *xdot, double *work);",
    "forcing": "int {n}_forcing(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "outputs": "int {n}_outputs(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "energy": "int {n}_energy(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "constraints": "int {n}_constraints(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "jac_x": "int {n}_jac_x(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "jac_r": "int {n}_jac_r(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "jac_p": "int {n}_jac_p(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "mass_matrix": "int {n}_mass_matrix(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "constraints_jac": "int {n}_constraints_jac(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "inverse_dynamics": "int {n}_inverse_dynamics(double t, const double *x, const double *udot, const double *p, const double *r, double *tau, double *work);",
    "regressor": "int {n}_regressor(double t, const double *x, const double *udot, const double *p, const double *r, double *out, double *work);",
    "jac_id": "int {n}_jac_id(double t, const double *x, const double *udot, const double *p, const double *r, double *out, double *work);",
    "jvp": "int {n}_jvp(double t, const double *x, const double *p, const double *r, int k, const double *dirs, double *xdot, double *out, double *work);",
    "jvp_more": "int {n}_jvp_more(double t, const double *x, const double *p, const double *r, int k, const double *dirs, double *xdot, double *out, double *work, eomc_more_fn more, void *mctx);",
    "vjp": "int {n}_vjp(double t, const double *x, const double *p, const double *r, const double *lam, double *xdot, double *gx, double *gp, double *work);",
    "hvp": "int {n}_hvp(double t, const double *x, const double *p, const double *r, const double *lam, const double *v, double *out, double *work);",
    "hess_id": "int {n}_hess_id(double t, const double *x, const double *udot, const double *p, const double *r, double *out, double *work);",
    "linearize": "int {n}_linearize(double t, const double *x, const double *p, const double *r, double *A, double *B, double *work);",
    "events": "int {n}_events(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "poses": "int {n}_poses(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "implicit": "int {n}_implicit(double t, const double *x, const double *p, const double *r, double *out, double *work);",
    "rhs_batch": "int {n}_rhs_batch(int n, double t, const double *X, const double *p, const double *R, double *XDOT, int *status, double *work);",
    "jac_x_batch": "int {n}_jac_x_batch(int n, double t, const double *X, const double *p, const double *R, double *OUT, int *status, double *work);",
    "implicit_batch": "int {n}_implicit_batch(int n, double t, const double *X, const double *p, const double *R, double *OUT, int *status, double *work);",
    "outputs_batch": "int {n}_outputs_batch(int n, double t, const double *X, const double *p, const double *R, double *OUT, int *status, double *work);",
}


# A function whose constant outputs are apart (NAME.json's "const_outputs"; compiler/tree/emit.py's
# implicit_constants): NAME_fn_const writes them, NAME_fn_var the rest, NAME_fn both in turn.
CONST_SPLIT = {"implicit": ("void {n}_implicit_const(double *out);",
                            "int {n}_implicit_var(double t, const double *x, const double *p, const double *r, "
                            "double *out, double *work);")}

# The fixed step's factorisation of M's tree pattern, its solves and M's product as straight-line C
# (NAME.json's "tree_lu": true; compiler/emit/tree_lu.py; eomc_implicit.tree_lu)
TREE_LU = "int {n}_tree_lu(double *A);"
TREE_SOLVE = "void {n}_tree_solve(const double *A, double *b, double *c);"
TREE_RESIDUAL = "void {n}_tree_residual(const double *M, const double *f, const double *du, double h, double *r);"


def model_function_cdef(name, functions, const_split=(), tree_lu=False):
    """Declarations of a model's exported functions, rebuilt from its metadata.

    Used when a build directory's metadata carries no ``cdef`` text; the
    signatures are fixed by the ABI, so the function list is enough (with
    ``const_split``: the functions whose constant outputs are apart, CONST_SPLIT).
    """
    lines = [f"const eomc_model *{name}_model(void);"]
    lines += [_SIGNATURES[f].format(n=name) for f in functions if f in _SIGNATURES]
    if "poses" in functions:
        lines.append(f"int {name}_pose_count(void);")
    lines += [d.format(n=name) for f in const_split if f in functions for d in CONST_SPLIT[f]]
    if tree_lu and "implicit" in functions:
        lines += [TREE_LU.format(n=name), TREE_SOLVE.format(n=name), TREE_RESIDUAL.format(n=name)]
    return "\n".join(lines) + "\n"
