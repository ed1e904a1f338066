"""``eomc show MODEL.py``: derive the model and print its equations of motion readably.

Printed with SymPy's mechanics pretty printer (q1 instead of q1(t), dots for
time derivatives): coordinates and speeds, the kinematic equations q' = ...,
the mass matrix and forcing of A u' = b (A [u'; lambda] = b with Lagrange
multipliers), constraints, inputs and parameters -- parameters in the order
of the runtime's and the C code's p[] vector, with their defaults.
"""
__all__ = ["configure", "run", "format_equations"]


def configure(parser):
    parser.add_argument("model", help="model file (Python) defining `system`, or a robot's URDF file")
    parser.add_argument("--ascii", action="store_true", help="ASCII art instead of Unicode")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def _pretty(expr, ascii_only):
    from sympy.physics.vector.printing import vpprint
    return vpprint(expr, use_unicode=not ascii_only, wrap_line=False).rstrip()


def parameter_order(spec):
    """(symbol, default) in p[] order: the `parameters` dict's order, then the rest by name at 1.0.

    This is the order the code generator lays out p[] (eomc.compiler.emit.layout).
    """
    from eomc.compiler.emit.layout import DEFAULT_PARAMETER_VALUE
    given = dict(spec.parameters or {})
    used = set(spec.formed.parameters)
    rest = sorted((s for s in used if s not in given), key=lambda s: s.name)
    return [(s, float(v)) for s, v in given.items() if s in used] + \
        [(s, DEFAULT_PARAMETER_VALUE) for s in rest]


def format_equations(spec, ascii_only=False):
    """The text `eomc show` prints for a ModelSpec."""
    import sympy as sm
    f = spec.formed
    from eomc.compiler.multibody import Model
    read = isinstance(f, Model)     # read straight into the joint tree (a robot file), never formed
    out = [f"model {spec.name} ({'multibody model as read' if read else f.method}): nq={f.nq}, nu={f.nu}"]
    out.append("coordinates q: " + ", ".join(_pretty(s, ascii_only) for s in f.coordinates))
    out.append("speeds u:      " + ", ".join(_pretty(s, ascii_only) for s in f.speeds))
    extra = tuple(getattr(f, "extra_states", ()))
    if extra:
        out.append("states z:      " + ", ".join(_pretty(s, ascii_only) for s in extra))
    if f.multipliers:
        out.append("multipliers:   " + ", ".join(map(str, f.multipliers)))
    out.append("inputs:        " + (", ".join(_pretty(s, ascii_only) for s in f.inputs) or "-"))
    out.append("parameters:    " + (", ".join(f"{s}={v:g}" for s, v in parameter_order(spec)) or "-"))
    out.append("\nkinematics  q' =")
    out.append(_pretty(sm.Matrix(f.kinematics), ascii_only))
    if read:
        out.append("\nmass matrix and forcing: not formed (the model is read straight into the joint tree "
                   "and built by the recursive formulation; `eomc inspect` shows its operation counts, "
                   "a built model's mass_matrix and forcing give the numbers)")
    else:
        out.append("\nmass matrix  (A in A [u'; lambda] = b)" if f.multipliers else "\nmass matrix  (A in A u' = b)")
        out.append(_pretty(sm.Matrix(f.dynamics_matrix), ascii_only))
        out.append("\nforcing  b =")
        out.append(_pretty(sm.Matrix(f.dynamics_rhs), ascii_only))
    if extra:
        out.append("\nextra states  z' =")
        out.append(_pretty(sm.Matrix(list(f.extra_rhs)), ascii_only))
    for label, matrix in (("holonomic constraints (= 0)", f.holonomic_constraints),
                          ("velocity constraints (= 0)", f.velocity_constraints)):
        if matrix is not None and len(matrix):
            out.append(f"\n{label}")
            out.append(_pretty(sm.Matrix(matrix), ascii_only))
    if spec.outputs:
        out.append("\noutputs")
        for name, expr in spec.outputs.items():
            out.extend([f"{name} =", _pretty(expr, ascii_only)])
    return "\n".join(out)


def run(args):
    from eomc.compiler.driver import Progress
    from eomc.compiler.model import model_spec
    progress = Progress(False if args.quiet else None)
    with progress.stage("derive"):
        spec = model_spec(args.model)
    # the pretty printer is most of the time on a robot (UR5: derive 1 s, print 23 s CPU of 14 MB):
    # a stage of its own, so a terminal or log is not silent through it (first hour s26)
    with progress.stage("pretty-print"):
        text = format_equations(spec, ascii_only=args.ascii)
    print(text)
    return 0
