"""``eomc linearize MODEL [--x0 ...] [--reduced]``: A, B and eigenvalues at an operating point.

The point is the model's initial_state with --x0 overrides (completed onto the
constraints with --consistent); --reduced eliminates the dependent states
through the constraint Jacobian (model.linearize_reduced), --fixed names the
independent states to keep instead of the model's own.  A quaternion (MJCF free
and ball joints) is reported in its 3-angle tangent chart, q_<joint>_rotx..z
(eomc.runtime.tangent): its length is no motion, and over its 4 coordinates A
would have an eigenvalue no physics explains.
"""

import shutil
import textwrap

import numpy as np

from . import common as cli_common

__all__ = ["configure", "run"]


def configure(parser):
    cli_common.add_model_arguments(parser)
    cli_common.add_formulation_argument(parser)
    parser.add_argument("--t", type=float, default=0.0, help="time of the operating point")
    parser.add_argument("--input", nargs="+", action="extend", metavar="NAME=V", default=[],
                        help="input values at the operating point (others 0)")
    parser.add_argument("--reduced", action="store_true",
                        help="over the independent states only (constrained models)")
    parser.add_argument("--fixed", metavar="LIST",
                        help="with --reduced: the independent states, comma-separated")
    parser.add_argument("--consistent", action="store_true",
                        help="complete the dependent coordinates and speeds of the point first")


def _matrix(label, M, rows, cols, columns=None):
    """The matrix as a table under its column names, its rows named: the names' column as wide
    as the longest (first hour s27: hopper's q_thigh_joint rows were pushed three places right
    of the others under a 10-wide column), and -0 printed 0.  A table wider than ``columns``
    characters (the terminal's, 100 when not a terminal) is printed in blocks of columns, each
    under "A (columns i-j of n):" with the rows named again: A1 --floating-base --ground's 36
    columns made lines of ~700 characters (first hour s28)."""
    width = max([len(c) for c in cols] + [12])
    head = max([len(r) for r in rows] + [10])
    columns = columns or _terminal_columns()
    per = max(1, (columns - head) // (width + 1))
    blocks = [range(lo, min(len(cols), lo + per)) for lo in range(0, len(cols), per)] or [range(0)]
    lines = []
    for block in blocks:
        lines.append(f"{label}:" if len(blocks) == 1 else
                     f"{label} (columns {block.start + 1}-{block.stop} of {len(cols)}):")
        lines.append(" " * head + "".join(cols[j].rjust(width + 1) for j in block))
        for name, row in zip(rows, M):
            lines.append(f"{name:>{head}}" + "".join(f"{row[j] + 0.0:{width + 1}.6g}" for j in block))
    return "\n".join(lines)


def _terminal_columns():
    return max(60, shutil.get_terminal_size((100, 24)).columns)


def _wrapped(text, columns=None):
    """A long line of comma-separated items (the operating point, the eigenvalues) broken
    between items to the terminal's width, its continuation lines indented."""
    return textwrap.fill(text, width=columns or _terminal_columns(), subsequent_indent="  ",
                         break_on_hyphens=False, break_long_words=False)


def run(args):
    model = cli_common.load_model(args.model, **cli_common.model_options(args),
                                  **cli_common.read_checks(args),   # --param, from the one reading
                                  methods=())                       # no run: no NAME_implicit
    x0 = cli_common.initial_state(model, cli_common.parse_assignments(args.x0, "x0"))
    p = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    inputs = cli_common.parse_assignments(args.input, "input")
    unknown = sorted(set(inputs) - set(model.input_names))
    if unknown:
        raise ValueError(f"{model.name}: unknown input {', '.join(unknown)} in --input; inputs: "
                         f"{', '.join(model.input_names) or 'none'}")
    r = np.array([inputs.get(n, 0.0) for n in model.input_names]) if model.ninput else None
    x = np.array([x0[n] for n in model.state_names], dtype=float)
    if args.consistent:
        x = model.consistent_state(x, args.t, p, r)
    if args.reduced:
        fixed = [s.strip() for s in args.fixed.split(",")] if args.fixed else None
        lin = model.linearize_reduced(args.t, x, p, r, fixed=fixed)
        A, B, states = lin.A, lin.B, lin.states
    else:
        from eomc.runtime.tangent import linearize_tangent
        lin = linearize_tangent(model, args.t, x, p, r)     # no quaternions: model.linearize's A, B
        A, B, states = lin.A, lin.B, lin.states
    print(_wrapped(f"eomc linearize {model.name} at t={args.t:g}: "
                   + ", ".join(f"{n}={v:.6g}" for n, v in zip(model.state_names, x))))
    if model.quaternions:
        print(_wrapped("quaternions in their tangent chart: q_<joint>_rotx, _roty, _rotz = the rotation "
                       "vector (body frame) from the point's orientation, q = q0 (x) Exp(rot)"))
    print(_matrix("A", A, states, states))
    if model.ninput:
        print(_matrix("B", B, states, model.input_names))
    print(eigenvalue_text(A))
    return 0


def eigenvalue_text(A, columns=None):
    """"eigenvalues: ..." of A, each part within round-off of 0 printed as 0, and a note saying
    how many and below what.  Why: a floating base's position and heading are free, so A has
    zero eigenvalues in Jordan blocks, which LAPACK returns as small nonzero values: A1
    --floating-base --ground printed twelve such values, some with a positive real part that
    reads as an unstable mode (first hour s28).  A part below sqrt(eps |A|) was printed as 0;
    but at A1's lifted start A is nilpotent with blocks of size 4 (a base tilt turns gravity
    into a linear acceleration: q_rx -> v_y -> q_y), whose zeros LAPACK returns as +-2.4e-7j,
    above that (s29).  So the zero eigenvalue's multiplicity m and largest block k are read
    from the ranks of A, A^2, ... (_zero_blocks), and the m eigenvalues nearest 0 print as 0
    when they lie within (n eps)^(1/k) |A|, the round-off of a zero in a block of size k.

    A real part below sqrt(eps |A|) that is not one of those zeros (the ranks and LAPACK agreeing)
    is printed as computed, with a note: diag(-1e-9, ...) printed its slow real mode as 0 (session
    30's papercut), though the ranks find no zero eigenvalue and a simple eigenvalue is computed to
    ~eps |A|; only a real part below n eps |A|, the round-off of one product (a centre's 1e-18),
    prints as 0 there.  Imaginary parts keep the sqrt(eps |A|) rule: a double real eigenvalue in a
    Jordan block comes back as a pair split by up to that much."""
    A = np.asarray(A, dtype=float)
    eig = np.linalg.eigvals(A) if A.size else np.zeros(0)
    tol = float(np.sqrt(np.finfo(float).eps * max(1.0, np.linalg.norm(A, 1) if A.size else 1.0)))
    m, k = _zero_blocks(A)
    block_tol = float((A.shape[0] * np.finfo(float).eps) ** (1.0 / k) * np.linalg.norm(A, 2)) if m else 0.0
    nearest = np.argsort(np.abs(eig))[:m]
    zeros = [i for i in nearest if abs(eig[i]) <= block_tol]
    agree = len(zeros) == m        # the ranks and LAPACK agree: those m are A's zero eigenvalue, no other
    # a real part below this is round-off of one product; between it and tol a real mode printed as computed
    # when the ranks and LAPACK agree (else every part below tol prints as 0, as before session 31)
    floor = min(tol, A.shape[0] * np.finfo(float).eps * max(1.0, np.linalg.norm(A, 1))) if agree and A.size else tol
    clean = [complex(0.0 if abs(z.real) < floor else z.real, 0.0 if abs(z.imag) < tol else z.imag) for z in eig]
    if agree:
        for i in zeros:
            clean[i] = 0j
    slow = sorted({c.real for c in clean if c.real and abs(c.real) < tol}, key=abs)
    rounded = sum(1 for z, c in zip(eig, clean) if z != c)
    text = ", ".join(f"{z.real:.6g}{z.imag:+.6g}j" if z.imag else f"{z.real:.6g}"
                     for z in sorted(clean, key=lambda z: (z.real, z.imag)))
    beyond = max((abs(eig[i]) for i in zeros if abs(eig[i].real) >= tol or abs(eig[i].imag) >= tol),
                 default=0.0) if agree else 0.0
    if slow:
        text += "\n" + textwrap.fill(
            f"({', '.join(f'{v:.2g}' for v in slow)} {'is' if len(slow) == 1 else 'are'} below {tol:.2g} = "
            f"sqrt(eps |A|), where a zero eigenvalue's round-off in a Jordan block can lie: numerically "
            f"indistinguishable from 0 there; the ranks of A, A^2, ... find no zero eigenvalue "
            f"{'here' if not m else 'beyond the ' + str(m) + ' printed as 0'}, so printed as computed)",
            width=columns or _terminal_columns(), initial_indent="  ", subsequent_indent="   ",
            break_on_hyphens=False, break_long_words=False)
    if not rounded:
        return _wrapped_first(f"eigenvalues: {text}", columns)
    if beyond:
        note = (f"({rounded} of them printed as 0: A's zero eigenvalue is {m}-fold, in Jordan blocks of "
                f"up to size {k} (the ranks of A, A^2, ...), which LAPACK returns within (n eps)^(1/{k}) |A| "
                f"= {block_tol:.2g} of 0, here up to {beyond:.2g}; other parts within round-off of 0 "
                f"are below {tol:.2g} = sqrt(eps |A|))")
    else:       # one line, as before s30
        return (_wrapped_first(f"eigenvalues: {text}", columns) + f"\n  ({rounded} of them had a real or "
                f"imaginary part within round-off of 0, below {tol:.2g} = sqrt(eps |A|): printed as 0)")
    return _wrapped_first(f"eigenvalues: {text}", columns) + "\n" + textwrap.fill(
        note, width=columns or _terminal_columns(), initial_indent="  ", subsequent_indent="   ",
        break_on_hyphens=False, break_long_words=False)


def _wrapped_first(text, columns=None):
    """:func:`_wrapped` of the first line (the eigenvalues), the lines after it (a note) as they are."""
    first, *rest = text.split("\n", 1)
    return "\n".join([_wrapped(first, columns), *rest])


def _zero_blocks(A):
    """(m, k): the multiplicity of A's eigenvalue 0 and the size of its largest Jordan block, from
    the numerical ranks of A, A^2, ... (rank(A^j) stops falling at j = k; m = n - rank(A^k)).
    A singular value of A^j counts below n j eps |A|^j, the round-off of j products."""
    n = A.shape[0] if A.ndim == 2 else 0
    norm = float(np.linalg.norm(A, 2)) if n else 0.0
    if norm == 0.0:
        return 0, 1
    eps = np.finfo(float).eps
    power, rank = np.eye(n), n
    for j in range(1, n + 1):
        power = power @ A
        now = int(np.sum(np.linalg.svd(power, compute_uv=False) > n * j * eps * norm ** j))
        if now == rank:
            return n - rank, max(j - 1, 1)
        rank = now
    return n - rank, n
