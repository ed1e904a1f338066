"""``eomc show MODEL.py``: derive the model and print its equations of motion readably.

Printed with SymPy's mechanics pretty printer (q1 instead of q1(t), dots for
time derivatives): coordinates and speeds, the kinematic equations q' = ...,
the mass matrix and forcing of A u' = b (A [u'; lambda] = b with Lagrange
multipliers), constraints, inputs and parameters -- parameters in the order
of the runtime's and the C code's p[] vector, with their defaults.
"""
__all__ = ["configure", "run", "format_equations"]

# Beyond these an entry is summarized (operation count, characters), not pretty-printed: UR5's
# Kane form pretty-printed to 14 MB in 23 s CPU, lines up to 335 kB, which no one reads (first
# hour s26).  Characters are of the one-line form (vsprint); the 2-D print is larger.
ENTRY_CHARS = 400
TOTAL_CHARS = 100_000


def configure(parser):
    parser.add_argument("model", help="model file (Python) defining `system`, or a robot's URDF file")
    parser.add_argument("--ascii", action="store_true", help="ASCII art instead of Unicode")
    parser.add_argument("--full", action="store_true",
                        help="pretty-print every entry however large (by default an entry over "
                             f"{ENTRY_CHARS} characters, or every entry once the whole passes "
                             f"{TOTAL_CHARS // 1000} kB, is given as its operation count and size)")
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


def _line(expr):
    """SymPy's one-line form, q1 not q1(t) (the mechanics printer), as the 2-D print names them."""
    from sympy.physics.vector.printing import vsprint
    return vsprint(expr)


def _entries(value):
    """A matrix's entries in row order, or [value] for one expression (an output)."""
    return list(value) if hasattr(value, "cols") else [value]


def _block(value, ascii_only, lengths, summarize_all):
    """(text, summarized): a matrix or expression pretty-printed, or entry by entry when it
    holds an entry too large to read (each large one as its operation count and size, the
    others on one line)."""
    import sympy as sm
    if not summarize_all and max(lengths) <= ENTRY_CHARS:
        return _pretty(value, ascii_only), False
    lines = []
    for k, (entry, n) in enumerate(zip(_entries(value), lengths)):
        i, j = divmod(k, getattr(value, "cols", 1))
        at = "" if not hasattr(value, "cols") else f"[{i}, {j}]" if value.cols > 1 else f"[{i}]"
        lines.append(f"  {at} = {_line(entry)}" if n <= ENTRY_CHARS else
                     f"  {at}: {sm.count_ops(entry)} operations, {n} characters")
    return "\n".join(lines), True


def format_equations(spec, ascii_only=False, full=False):
    """The text `eomc show` prints for a ModelSpec.  Unless ``full``, an entry over ENTRY_CHARS
    characters (every entry once the whole passes TOTAL_CHARS) is given as its operation count
    and size, and one line says so."""
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
    blocks = [("\nkinematics  q' =", sm.Matrix(f.kinematics))]
    if read:
        blocks.append(("\nmass matrix and forcing: not formed (the model is read straight into the joint tree "
                       "and built by the recursive formulation; `eomc inspect` shows its operation counts, "
                       "a built model's mass_matrix and forcing give the numbers)", None))
    else:
        blocks.append(("\nmass matrix  (A in A [u'; lambda] = b)" if f.multipliers
                       else "\nmass matrix  (A in A u' = b)", sm.Matrix(f.dynamics_matrix)))
        blocks.append(("\nforcing  b =", sm.Matrix(f.dynamics_rhs)))
    if extra:
        blocks.append(("\nextra states  z' =", sm.Matrix(list(f.extra_rhs))))
    for label, matrix in (("holonomic constraints (= 0)", f.holonomic_constraints),
                          ("velocity constraints (= 0)", f.velocity_constraints)):
        if matrix is not None and len(matrix):
            blocks.append((f"\n{label}", sm.Matrix(matrix)))
    if spec.outputs:
        blocks.append(("\noutputs", None))
        blocks.extend((f"{name} =", expr) for name, expr in spec.outputs.items())
    lengths = [None if full or v is None else [len(_line(e)) for e in _entries(v)] for _, v in blocks]
    summarize_all = not full and sum(sum(n) for n in lengths if n) > TOTAL_CHARS
    body, summarized = [], False
    for (label, value), n in zip(blocks, lengths):
        body.append(label)
        if value is None:
            continue
        text, cut = (_pretty(value, ascii_only), False) if full else _block(value, ascii_only, n, summarize_all)
        body.append(text)
        summarized |= cut
    if summarized:
        total = sum(sum(n) for n in lengths if n)
        out.append(f"(too large to read whole, {total / 1000:.0f} kB: entries over {ENTRY_CHARS} characters are "
                   f"given as operation count and size{', the rest one per line' if summarize_all else ''}; "
                   f"`eomc inspect` shows the generated code's operation counts, --full prints everything)")
    return "\n".join(out + body)


def run(args):
    from eomc.compiler.driver import Progress
    from eomc.compiler.model import model_spec
    progress = Progress(False if args.quiet else None)
    with progress.stage("derive"):
        spec = model_spec(args.model)
    # the pretty printer is most of the time on a robot (UR5: derive 1 s, print 23 s CPU of 14 MB):
    # a stage of its own, so a terminal or log is not silent through it (first hour s26)
    with progress.stage("pretty-print"):
        text = format_equations(spec, ascii_only=args.ascii, full=args.full)
    print(text)
    return 0
