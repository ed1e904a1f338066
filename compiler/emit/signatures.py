"""The one table of generated C signatures: header, definitions and cffi cdef all come from it."""

__all__ = ["SIGNATURES", "FUNCTION_ORDER", "ON_REQUEST", "STRUCT_FIELDS", "prototype", "cdef"]

_RHS = (("double", "t"), ("const double *", "x"), ("const double *", "p"),
        ("const double *", "r"))

SIGNATURES = {
    "rhs": _RHS + (("double *", "xdot"), ("double *", "work")),
    "jac_x": _RHS + (("double *", "out"), ("double *", "work")),
    "jac_r": _RHS + (("double *", "out"), ("double *", "work")),
    "jac_p": _RHS + (("double *", "out"), ("double *", "work")),
    "mass_matrix": _RHS + (("double *", "out"), ("double *", "work")),
    "forcing": _RHS + (("double *", "out"), ("double *", "work")),
    "outputs": _RHS + (("double *", "out"), ("double *", "work")),
    # the output named "energy" alone into out[0], bit for bit NAME_outputs' (rollout's per-step
    # energy watch, runtime/c/eomc_integrators.c fs_watch); models with that output only
    "energy": _RHS + (("double *", "out"), ("double *", "work")),
    "constraints": _RHS + (("double *", "out"), ("double *", "work")),
    "constraints_jac": _RHS + (("double *", "out"), ("double *", "work")),
    "inverse_dynamics": (("double", "t"), ("const double *", "x"), ("const double *", "udot"),
                         ("const double *", "p"), ("const double *", "r"),
                         ("double *", "tau"), ("double *", "work")),
    "regressor": (("double", "t"), ("const double *", "x"), ("const double *", "udot"),
                  ("const double *", "p"), ("const double *", "r"),
                  ("double *", "out"), ("double *", "work")),
    # d tau / d x of inverse dynamics at given udot, row-major nu x nx (compiler/tree/inverse_derivatives.py)
    "jac_id": (("double", "t"), ("const double *", "x"), ("const double *", "udot"),
               ("const double *", "p"), ("const double *", "r"),
               ("double *", "out"), ("double *", "work")),
    "jvp": _RHS + (("int", "k"), ("const double *", "dirs"), ("double *", "xdot"), ("double *", "out"),
                   ("double *", "work")),
    # jvp, then (once) more directions at the same point from the callback: Radau's staggered
    # sensitivities (runtime/c/eomc_integrators.c, sg_more) carry their second iteration in it
    "jvp_more": _RHS + (("int", "k"), ("const double *", "dirs"), ("double *", "xdot"), ("double *", "out"),
                        ("double *", "work"), ("eomc_more_fn", "more"), ("void *", "mctx")),
    # wᵀ·∂rhs/∂x and wᵀ·∂rhs/∂p by one reverse sweep (compiler/emit/reverse.py); xdot, gp may be NULL
    "vjp": _RHS + (("const double *", "lam"), ("double *", "xdot"), ("double *", "gx"), ("double *", "gp"),
                   ("double *", "work")),
    # (∂²(lamᵀ·rhs)/∂x²)·v, forward over reverse
    "hvp": _RHS + (("const double *", "lam"), ("const double *", "v"), ("double *", "out"), ("double *", "work")),
    # ∂²τ/∂x² of inverse dynamics at given udot, nu x nx x nx row-major (recursive formulation)
    "hess_id": (("double", "t"), ("const double *", "x"), ("const double *", "udot"),
                ("const double *", "p"), ("const double *", "r"), ("double *", "out"), ("double *", "work")),
    "linearize": _RHS + (("double *", "A"), ("double *", "B"), ("double *", "work")),
    "events": _RHS + (("double *", "out"), ("double *", "work")),
    # body frames' positions and rotations, named points' positions (compiler/emit/poses.py)
    "poses": _RHS + (("double *", "out"), ("double *", "work")),
    # what one step of the fixed-step implicit integrator needs (compiler/tree/lower.implicit_layout)
    "implicit": _RHS + (("double *", "out"), ("double *", "work")),
    # the rhs at n states in SIMD lanes (compiler/emit/batch.py): X and XDOT are nx x n, R ninput x n
    # (structure of arrays: component i of state k at [i*n + k]), p shared; status (n, or NULL) per state
    "rhs_batch": (("int", "n"), ("double", "t"), ("const double *", "X"), ("const double *", "p"),
                  ("const double *", "R"), ("double *", "XDOT"), ("int *", "status"), ("double *", "work")),
    # jac_x at n states in SIMD lanes: OUT is (nx*nx) x n, element (i, j) of state k at [(i*nx + j)*n + k]
    "jac_x_batch": (("int", "n"), ("double", "t"), ("const double *", "X"), ("const double *", "p"),
                    ("const double *", "R"), ("double *", "OUT"), ("int *", "status"), ("double *", "work")),
    # the outputs at n states in SIMD lanes: OUT is noutput x n, output i of state k at [i*n + k]
    "outputs_batch": (("int", "n"), ("double", "t"), ("const double *", "X"), ("const double *", "p"),
                      ("const double *", "R"), ("double *", "OUT"), ("int *", "status"), ("double *", "work")),
    # NAME_implicit at n states in SIMD lanes: OUT is size x n (implicit_layout), entry i of state k at [i*n + k]
    "implicit_batch": (("int", "n"), ("double", "t"), ("const double *", "X"), ("const double *", "p"),
                       ("const double *", "R"), ("double *", "OUT"), ("int *", "status"), ("double *", "work")),
}

# Each batch function and the scalar function whose printed lines it rewrites into lanes.
BATCH_FUNCTIONS = {"rhs_batch": "rhs", "jac_x_batch": "jac_x", "outputs_batch": "outputs",
                   "implicit_batch": "implicit"}

FUNCTION_ORDER = ("rhs", "jac_x", "jac_r", "jac_p", "mass_matrix", "forcing", "inverse_dynamics",
                  "outputs", "energy", "constraints", "constraints_jac", "linearize", "events", "poses", "regressor",
                  "jvp", "jvp_more", "jac_id", "vjp", "hvp", "hess_id", "implicit", "rhs_batch",
                  "jac_x_batch", "outputs_batch", "implicit_batch")

# Generated only on request (``functions`` naming them), not by default.
ON_REQUEST = ("jac_p", "regressor", "jvp", "jvp_more", "jac_id", "vjp", "hvp", "hess_id", "rhs_batch", "jac_x_batch",
              "outputs_batch", "implicit_batch")

# eomc_model fields holding function pointers (the rest are exported only).
STRUCT_FIELDS = ("rhs", "jac_x", "jac_r", "mass_matrix", "forcing", "outputs",
                 "constraints", "constraints_jac")


def _arg(ctype, name):
    return f"{ctype}{name}" if ctype.endswith("*") else f"{ctype} {name}"


def prototype(name, function):
    """``int NAME_function(args)`` without the semicolon."""
    args = ", ".join(_arg(c, a) for c, a in SIGNATURES[function])
    return f"int {name}_{function}({args})"


def cdef(name, functions):
    """cffi declarations of a model's exported functions (``eomc_model`` must be declared first)."""
    lines = [prototype(name, f) + ";" for f in FUNCTION_ORDER if f in functions]
    if "poses" in functions:   # how many doubles NAME_poses writes: the loader checks NAME.json by it
        lines.append(f"int {name}_pose_count(void);")
    lines.append(f"const eomc_model *{name}_model(void);")
    return "\n".join(lines) + "\n"
