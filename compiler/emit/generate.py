"""``generate_c``: a FormedSystem to C99 source, header, cffi cdef and metadata."""
import re
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, replace

import jinja2
import sympy as sm

from eomc.runtime.cdef import CONST_SPLIT, TREE_LU, TREE_RESIDUAL, TREE_SOLVE
from eomc.runtime.errors import ModelError
from eomc.runtime.switching import GAP_EVENT_PREFIXES
from ..passes import finish_function, optimize_shared
from ..ir import count_program, format_program, verify
from ..ir.program import symbols_of
from .bodies import (BodyContext, dynamics_helper, helper_jacobian_body, jvp_body, matrix_body, needed_assignments, split_on, jacobian_body,
                     linearize_body, plain_body, rhs_body, solved_plain_body, tangent_jacobian_body,
                     void_unused)
from .formulation import KANE, Formulation
from .generated import GeneratedModel
from .layout import check_identifier, make_layout
from .linsolve import choose_ldlt
from .printer import CALLED_C, MINMAX_C, HalfPow, NonFiniteLiteral, print_memo
from .reverse import REVERSE_FUNCTIONS, reverse_body, reverse_nsolve
from .sparse_lu import sparse_lu_solver
from .tree_lu import tree_functions
from .split import (FOLD_MIN, LEAN_MACRO, NEAR_MACRO, NOINLINE_MACRO, PART_LEAN_FUNCTIONS, PART_LEAN_MACRO,
                    lean_attribute, split_body)
from .batch import batch_code
from .forward import forwarded_outputs
from .packed import packed_inputs
from .signatures import BATCH_FUNCTIONS, FUNCTION_ORDER, ON_REQUEST, SIGNATURES, STRUCT_FIELDS, cdef, prototype
from .symbolic import HELPER_USERS

__all__ = ["generate_c", "lower", "ir_listing", "Lowered", "ALL_FUNCTIONS"]

ALL_FUNCTIONS = FUNCTION_ORDER
_ALIASES = {"jacobian": "jac_x"}
# Functions printed from another's program (lower: no program or groups of their own).
GENERATED_LIKE = {"jvp_more": "jvp"}

_SOLVING = ("rhs", "jac_x", "jac_r", "jac_p", "jvp", "vjp", "hvp")


def _eomc_version():
    try:
        from importlib.metadata import version
        return version("eomc")
    except Exception:  # pragma: no cover - not installed
        return "0+unknown"


def _select(functions, ninput, noutput, ncon, nevent=0, has_poses=False, nparam=None, has_energy=False):
    """Requested functions that apply to this model, in canonical order (``functions=None``:
    all but the ones generated only on request: jac_p, jvp, regressor, jac_id)."""
    wanted = set((f for f in ALL_FUNCTIONS if f not in ON_REQUEST) if functions is None else
                 (_ALIASES.get(f, f) for f in functions))
    unknown = sorted(wanted - set(ALL_FUNCTIONS))
    if unknown:
        raise ModelError(f"unknown function(s) {', '.join(unknown)}; "
                         f"choose from {', '.join(ALL_FUNCTIONS)}")
    if "linearize" in wanted:
        wanted |= {"jac_x", "jac_r"}
    if "rhs_batch" in wanted:      # the lanes are the rhs's own code; its scalar tail calls it
        wanted.add("rhs")
    if "jac_x_batch" in wanted:    # likewise jac_x's
        wanted.add("jac_x")
    if "outputs_batch" in wanted:  # and the outputs'
        wanted.add("outputs")
    if "energy" in wanted and has_energy:   # one of the outputs (energy_program)
        wanted.add("outputs")
    if "jvp_more" in wanted:       # jvp's program and code, its loop wrapped (GENERATED_LIKE)
        wanted.add("jvp")
    if "implicit_batch" in wanted:  # and NAME_implicit's (the fixed-step rollout's lanes)
        wanted.add("implicit")
    absent = {"jac_r": ninput == 0, "jac_p": nparam == 0, "outputs": noutput == 0, "outputs_batch": noutput == 0,
              "constraints": ncon == 0, "constraints_jac": ncon == 0, "events": nevent == 0,
              "poses": not has_poses, "energy": not has_energy}
    return tuple(f for f in ALL_FUNCTIONS if f in wanted and not absent.get(f, False))


def with_contact_gaps(functions, events):
    """(functions, events) with ``NAME_events`` kept for the contacts' gaps whatever was asked.

    Why: a contact's penetration (its ``contact_<name>`` event, zero at touch-down and
    lift-off) is the switching function at which every adaptive method ends its step, the
    measure of the run's penetration verdict and the key of the run-time checks of its law's
    parameters (runtime/switching.py, runtime/law_parameters.py).  A build whose function
    set left ``events`` out had none of them: Radau's grown free-fall step carried a sphere
    through the floor and the run ended with status 0 (issue 29).  So a model with contacts
    always gets ``NAME_events``; when ``events`` was not among the requested functions it
    holds the contacts' gaps only (contact_<name> and the F_n >= 0 clip's clip_<name>:
    O(contacts), none of the model's own events).  A model
    without contacts, or one whose build asked for ``events``, is unchanged."""
    if functions is None or not events or "events" in functions:
        return functions, events
    gaps = {k: v for k, v in events.items() if str(k).startswith(GAP_EVENT_PREFIXES)}
    if not gaps:
        return functions, events
    return tuple(functions) + ("events",), gaps


def _environment():
    return jinja2.Environment(loader=jinja2.PackageLoader("eomc.templates", ""),
                              undefined=jinja2.StrictUndefined, keep_trailing_newline=True,
                              trim_blocks=True, lstrip_blocks=True, autoescape=False)


def _body(fn, ctx, prog, sym, layout, nx, functions, formulation=KANE):
    nr = len(layout.r)
    own = formulation.body(fn, ctx, prog, sym, layout, nx)
    if own is not None:
        return own
    if fn == "rhs":
        return rhs_body(ctx, prog)
    if fn in ("mass_matrix", "forcing", "inverse_dynamics"):
        return matrix_body(ctx, fn)
    if fn == "jac_x":
        if _tangent(prog):
            return tangent_jacobian_body(ctx, prog, sym.W, sym.seeds, nx, _tangent_blocks(ctx))
        return jacobian_body(ctx, prog, sym.W, nx, "dkin", "G")
    if fn == "jac_r":
        return helper_jacobian_body(ctx, prog, sym.W, nr, "dkin_r", "Gr")
    if fn in ("jvp", "jvp_more"):
        return jvp_body(ctx, prog, sym.W, sym.seeds, nx, len(layout.p),
                        (("Gtx", 0, nx),) if _tangent(prog) else (), more=fn == "jvp_more")
    if fn in REVERSE_FUNCTIONS:
        return reverse_body(fn, ctx, prog, sym, nx, len(layout.p))
    if fn == "jac_p":
        return helper_jacobian_body(ctx, prog, sym.W, len(layout.p), "dkin_p", "Gp")
    if fn == "linearize":
        return linearize_body(ctx, "jac_r" in functions)
    if fn == "energy" and getattr(sym, "guards", None):
        guards = energy_guards(prog, sym.guards)
        if guards:
            return guarded_energy_body(ctx, prog, guards)
    shapes = {"outputs": ("out", (len(sym.output_names),), "out"),
              "energy": ("en", (1,), "out"),
              "events": ("ev", (len(sym.event_names),), "out"),
              "constraints": ("con", (sym.nhol + sym.nvel,), "out"),
              "constraints_jac": ("dcon", (sym.nhol + sym.nvel, nx), "out"),
              "regressor": ("Y", (nu_of(sym), 10 * len(sym.regressor_bodies)), "out")}
    group, shape, out = shapes[fn]
    if fn in sym.solve_in:
        return solved_plain_body(ctx, prog, group, shape, out)
    return plain_body(ctx, prog, group, shape, out)


def nu_of(sym):
    """Speeds: the unknowns of the dynamics solve that are not multipliers."""
    return len(sym.UD)


def _tangent(prog):
    """True when jac_x loops tangent programs over columns (many states)."""
    return any(k[0] in ("Gtq", "Gtu", "Gtx") for k, _ in prog.results)


def _tangent_blocks(ctx, nq=None, nx=None):
    """(result group, first column, end column) of the coordinates' and speeds' tangents
    (the speeds' block also covers the extra states' columns)."""
    nq = ctx.nq if nq is None else nq
    nx = ctx.nx if nx is None else nx
    return (("Gtq", 0, nq), ("Gtu", nq, nx))


def _tangent_ops(prog, seeds, blocks):
    """Operations of a looped jac_x: the tangent part once per column of its block."""
    loop = split_on(prog, seeds)[1]
    in_loop = {t for t, _ in loop}
    groups = {g for g, _, _ in blocks}
    c = count_program(prog.with_(assignments=tuple(a for a in prog.assignments if a[0] not in in_loop),
                                 results=tuple(r for r in prog.results if r[0][0] not in groups)))
    for group, start, end in blocks:
        gvals = prog.result_exprs(group)
        per_column = count_program(prog.with_(assignments=tuple(needed_assignments(loop, gvals.values())),
                                              results=tuple(gvals.items())))
        for _ in range(end - start):
            c += per_column
    return c


def _ops(fn, prog, solver, nx, nr, seeds=(), helper=None, nu=0, nnz=0, solve_in=(), formulation=KANE,
         sym=None, npar=0, nq=None):
    if fn == "linearize":
        return None
    own = formulation.ops(fn, prog, sym, nx, nr, npar, nq, nu, solve_in)
    if own is not None:     # (the count below was made before this too, and thrown away: G1's build ~0.1 s)
        return own
    c = count_program(prog) if prog is not None else Counter()
    if fn in HELPER_USERS or fn in solve_in:
        c += count_program(helper)
    if fn in solve_in:
        c += solver.factor_ops + solver.solve_ops
    if fn == "inverse_dynamics":
        c += Counter(muls=nnz, adds=nnz)
    if fn == "jac_x" and _tangent(prog):
        c = _tangent_ops(prog, seeds, _tangent_blocks(None, nq=nx - nu if nq is None else nq, nx=nx))
    if fn == "jvp" and _tangent(prog):   # the tangents once (one direction), not per column
        c = count_program(prog)
    if fn in _SOLVING:
        c += solver.factor_ops
        # jvp: per direction; its count is xdot and one direction
        nsolve = 1 + {"rhs": 0, "jac_x": nx, "jac_r": nr, "jac_p": npar, "jvp": 1, **reverse_nsolve}[fn]
        for _ in range(nsolve):
            c += solver.solve_ops
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}


def _tables(name, layout, output_names):
    """Static const name/default tables and the struct's references to them (NULL when empty)."""
    def strings(label, items):
        if not items:
            return None, "NULL"
        body = ", ".join('"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"' for s in items)
        return f"static const char *const {name}_{label}[] = {{{body}}};", f"{name}_{label}"
    tables, refs = [], []
    for label, items in (("state_names", layout.state_names), ("param_names", layout.param_names)):
        t, r = strings(label, items)
        tables.append(t), refs.append(r)
    if layout.param_defaults:
        vals = ", ".join(repr(float(v)) for v in layout.param_defaults)
        tables.append(f"static const double {name}_param_defaults[] = {{{vals}}};")
        refs.append(f"{name}_param_defaults")
    else:
        refs.append("NULL")
    for label, items in (("input_names", layout.input_names), ("output_names", output_names)):
        t, r = strings(label, items)
        tables.append(t), refs.append(r)
    return [t for t in tables if t], refs


def _sparsity(nw, pattern):
    return ["".join("x" if (i, j) in pattern else "." for j in range(nw)) for i in range(nw)]


@dataclass(frozen=True)
class Lowered:
    """A model after the passes: one optimized program per generated function."""
    name: str
    layout: object
    symbolic: object
    functions: tuple
    programs: dict          # function -> Program (None when the function has no own code)
    helper: object          # Program of the shared NAME_dynamics helper (A, b), or None
    formulation: Formulation = KANE   # or the recursive one (eomc.compiler.formulations.recursive)
    poses: dict = None          # pose metadata (compiler/emit/poses.py) when poses is generated
    outputs_by_energy: bool = False   # NAME_outputs is a call of NAME_energy (outputs_by_energy)


def lower(formed, name, *, parameters=None, inputs=None, outputs=None, functions=None,
          fold_parameters=False, events=None, formulation=KANE, poses=None, frames=None):
    """FormedSystem (or Model) -> :class:`Lowered` (the IR the C printer and ``--print-ir`` read).

    ``formulation`` (:mod:`.formulation`) lowers the dynamics: Kane's from the formed A and
    b, or the recursive one (ABA, RNEA, CRBA) from its joint tree.
    """
    check_identifier(name)
    uses = {s for e in list((outputs or {}).values()) + list((events or {}).values())
            for s in getattr(e, "free_symbols", ())}
    layout = make_layout(formed, parameters, inputs, fold_parameters, uses)
    functions, events = with_contact_gaps(functions, events)
    ncon = len(formed.holonomic_constraints) + len(formed.velocity_constraints)
    nframe = 0 if frames is None else len(frames.names())   # frame outputs (compiler/tree/frames.py)
    fns = _select(functions, len(layout.r), len(outputs or {}) + nframe, ncon, len(events or {}),
                  poses is not None, len(layout.p), "energy" in (outputs or {}))
    if "implicit" in fns and not formulation.builds_implicit(
            functions is not None and ("implicit" in functions or "implicit_batch" in functions)):
        fns = tuple(f for f in fns if f not in ("implicit", "implicit_batch"))
    refusal = formulation.refusal(fns)
    if refusal:
        raise ModelError(refusal)
    groups, helper_users = formulation.groups, formulation.helper_users
    base = tuple(f for f in fns if f not in ("poses", "energy") and f not in BATCH_FUNCTIONS   # poses: appended below
                 and f not in GENERATED_LIKE)
    # NAME_implicit with its energy slot for the lanes rollout's watch (tree/lower.implicit_layout):
    # asked only of the formulation that builds NAME_implicit (builds_implicit above)
    lanes = {"implicit_energy": True} if "implicit_batch" in fns else {}
    # NAME_energy read by itself alone (NAME_outputs its call): a formulation may sum its bodies' shares in a loop
    if getattr(formulation, "body_loops", False) and _energy_alone(fns, outputs, nframe):
        lanes["body_loops"] = True
    sym = formulation.symbolic(formed, layout, base, outputs, events, **lanes)
    if getattr(sym, "function_groups", None):   # this model's own choice (tree/lower.py: the loop kernel or not)
        groups = sym.function_groups
    if nframe and "outputs" in fns:   # appended to the outputs, after the model's own
        sym = frames.lowered(sym, layout, formed.nq)
    pose_meta = None
    if "poses" in fns:   # appended to the shared program: sin/cos and products shared with rhs
        from .poses import POSE_GROUP, POSE_TABLE, with_poses
        sym, pose_meta = with_poses(sym, poses, layout, loops=formulation.pose_loops(sym, fns, poses))
        table = pose_meta.pop("table", None)
        if table is not None:     # the formulation's loop over its bodies reads the table (Formulation.pose_loops)
            sym = replace(sym, body_loops={**(sym.body_loops or {}), "poses": table})
        groups = {**groups, "poses": (POSE_GROUP,) if table is None else (POSE_TABLE,)}
    shared = verify(optimize_shared(sym.program, sym.derivatives))
    energy = energy_program(shared, sym) if "energy" in fns else None
    if "energy" in fns and energy is None:
        fns = tuple(f for f in fns if f != "energy")
    by_energy = outputs_by_energy(fns, sym)
    if (sym.body_loops or {}).get("energy") and not by_energy:     # (_energy_alone's promise)
        raise RuntimeError(f"{name}: NAME_energy's loop needs NAME_outputs to be its call")
    programs = {fn: finish_function(_mass_inputs_only(shared, sym, fn), groups[fn])
                if fn not in BATCH_FUNCTIONS and groups[fn] and not (by_energy and fn == "outputs") else None
                for fn in fns if fn not in GENERATED_LIKE and fn != "energy"}
    if energy is not None:
        programs["energy"] = energy
    programs = {fn: _taped(p, exact=_exactness(fn, p)) for fn, p in programs.items()}
    if hasattr(formulation, "finish_programs"):     # (recursive: contact/table.slopes_into)
        programs = formulation.finish_programs(programs)
    programs.update((fn, programs[GENERATED_LIKE[fn]]) for fn in fns if fn in GENERATED_LIKE)
    helper = (finish_function(shared, ("A", "b")) if set(fns) & set(helper_users) or sym.solve_in
              else None)
    return Lowered(name, layout, sym, fns, programs, helper, formulation, pose_meta, by_energy)


def _energy_alone(fns, outputs, nframe):
    """Whether the ``energy`` output will be read by NAME_energy alone (:func:`outputs_by_energy`
    as far as the lowering can tell before it: the model's only output, no frame outputs, no
    lanes rewriting printed code), so that its formulation may compute part of it in C of its own."""
    return ("energy" in fns and "outputs" in fns and not nframe and list(outputs or {}) == ["energy"]
            and not any(f.endswith("_batch") for f in fns))


def outputs_by_energy(fns, sym):
    """True when NAME_outputs is one call of NAME_energy: the model's outputs are its ``energy``
    alone (a URDF robot's default outputs) and NAME_energy is generated, without the outputs'
    lanes (outputs_batch rewrites the outputs' own printed code).

    Why: both printed the same program (energy_program: the value bit for bit), and the copy was
    67 kB of G1's 711 kB of C -- its optimization, printing and compilation ~0.3 s of the default
    build.  The call costs the outputs nothing measurable; NAME_energy may be the faster of the
    two (its contact guards: energy_guards)."""
    return ("outputs" in fns and "energy" in fns and "outputs_batch" not in fns
            and tuple(sym.output_names) == ("energy",) and "outputs" not in sym.solve_in)


def outputs_energy_body(ctx):
    """NAME_outputs' body where it is NAME_energy's call (:func:`outputs_by_energy`)."""
    from .bodies import IND
    return [f"{IND}return {ctx.name}_energy(t, x, p, r, out, work);"]


def energy_program(shared, sym):
    """NAME_energy's program: the ``energy`` output's result alone (as group ``en``), everything
    it does not read dropped (dce), or None when the model has no such output or its energy
    reads the dynamics solve's unknowns (NAME_outputs then solves; the watch falls back to it).

    Why: rollout's per-step energy watch (eomc_options.watch_fn) read one value of the whole
    outputs call (the ant: 126 outputs for one).  The expression is the outputs' own, printed
    by the same printer from the same shared program, so the value is the outputs' bit for bit."""
    names = list(sym.output_names)
    if "energy" not in names:
        return None
    key = ("out", names.index("energy"))
    results = tuple((("en", 0), e) for k, e in shared.results if k == key)
    if len(results) != 1:
        return None
    prog = finish_function(shared.with_(results=results), ("en",))
    unknowns = set(sym.W) | set(sym.UD)
    if any(symbols_of(e) & unknowns for _, e in (*prog.assignments, *prog.results)):
        return None
    return _half_pows(prog)


def energy_guards(prog, guards):
    """The rhs's broad-phase guards (compiler/emit/guards.py: a body's or a pair's clearance, inside
    it a guard per contact point whose clearance is -δ) as NAME_energy's: each outer clearance
    guarding its points' depths δ, where ``prog`` reads each δ only as its positive part
    (δ + |δ|)/2 -- a skipped δ is 0 instead of < 0, and the positive part +0 either way: the same
    bits.  Only depths that take a square root (_takes_a_root: a narrow phase).  Why: the hopper's
    three inlined self-pairs ran their narrow phase at every watch call, a fourth of its NAME_energy
    (106 -> 81 ns); [] where none applies (the energy then prints straight)."""
    out = []
    defs = dict(prog.assignments)
    readers, held = {}, {}      # symbol -> the statements that read it; depth -> its verdict
    for t, e in (*prog.assignments, *prog.results):
        if isinstance(e, sm.Basic):
            for s in symbols_of(e):
                readers.setdefault(s, []).append((t, e))
    for clearance, _exports, inner in guards:
        depths = tuple(-c for c, _, _ in inner if (-c).is_Symbol)
        for d in depths:
            if d not in held:
                held[d] = d in defs and _positive_only(prog, d, readers.get(d, ())) and _takes_a_root(defs, d)
        depths = tuple(d for d in depths if held[d])
        if depths:
            out.append((clearance, depths, ()))
    return out


def _takes_a_root(defs, d):
    """Whether depth ``d`` reads a square root (through the temporaries ``defs``): a narrow phase's
    distance (a pair's, an ellipsoid's support), worth a guard.  A ground point's depth is a height
    less a reach: measured on the ant, its bodies' guards made NAME_energy slower (235 -> 262 ns)."""
    seen, stack = set(), [d]
    while stack:
        s = stack.pop()
        if s in seen or s not in defs:
            continue
        seen.add(s)
        e = defs[s]
        if not isinstance(e, sm.Basic):
            continue
        if any(n.is_Pow and n.exp == sm.S.Half for n in sm.preorder_traversal(e)):
            return True
        stack.extend(x for x in e.free_symbols if x in defs)
    return False


def _positive_only(prog, d, readers=None):
    """Whether symbol ``d`` is read by ``prog`` only inside (d + |d|)/2 (and defined there).
    ``readers``: the statements whose expressions have ``d`` among their free symbols, where
    the caller knows them (energy_guards: one walk for all its depths, not one per depth)."""
    if readers is None and not any(t == d for t, _ in prog.assignments):
        return False
    half = sm.Rational(1, 2)
    part = {half * d, half * sm.Abs(d)}
    mark = sm.Dummy()
    for t, e in ((*prog.assignments, *prog.results) if readers is None else readers):
        if t == d or not isinstance(e, sm.Basic) or not e.has(d):
            continue
        rest = e.replace(lambda n: isinstance(n, sm.Add) and set(n.args) == part, lambda _: mark)
        if rest.has(d):
            return False
    return True


def guarded_energy_body(ctx, prog, guards):
    """NAME_energy's body with its contact points' depths under the broad phase (energy_guards)."""
    from .bodies import IND, store
    from .guards import guarded_temps
    pr = ctx.printer(prog)
    lines, pr = guarded_temps(prog, pr, guards)
    lines.append(store("out[0]", prog.result_exprs("en").get(("en", 0), 0.0), pr))
    lines.append(f"{IND}return {ctx.name}_finite(out, 1);")
    return lines


def _half_pows(prog):
    """``prog`` with its powers x**(k/2), k odd >= 3, as printer.HalfPow (pow skipped at x = 0, the
    same bits: the contacts' elastic energies, zero out of contact)."""
    def swap(e):
        if not isinstance(e, sm.Basic) or not e.has(sm.Pow):
            return e
        return e.replace(lambda n: n.is_Pow and HalfPow.applies(n), lambda n: HalfPow(n.base, n.exp))
    return prog.with_(assignments=tuple((t, swap(e)) for t, e in prog.assignments),
                      results=tuple((k, swap(e)) for k, e in prog.results))


def ir_listing(formed, name, **options):
    """The optimized IR of every generated function as text (``--print-ir``)."""
    low = lower(formed, name, **options)
    progs = dict(low.programs)
    if low.helper is not None:
        progs["dynamics"] = low.helper
    return "".join(format_program(p, title=f"{name}_{fn}") for fn, p in progs.items()
                   if p is not None)


def generate_c(formed, name, *, parameters=None, inputs=None, outputs=None, functions=None,
               fold_parameters=False, events=None, event_options=None, formulation=KANE, poses=None,
               frames=None):
    """Lower ``formed`` (a FormedSystem) to C; returns a :class:`GeneratedModel`.

    ``parameters``: {symbol: default} giving order and defaults (others follow, sorted by
    name, default 1.0); ``inputs``: order of the specified symbols (default
    ``formed.inputs``); ``outputs``: {name: expression in q, u, q', p, r, t};
    ``functions``: subset of :data:`ALL_FUNCTIONS` ("jacobian" = jac_x; None = all).
    Functions that do not apply (jac_r without inputs, outputs without outputs,
    constraints without constraints) are not generated, and their struct pointer is NULL;
    linearize brings jac_x and jac_r.  ``fold_parameters`` turns parameters into literals.
    ``events``: {name: expression} compiled into NAME_events (zero crossings for simulate),
    ``event_options``: their default terminal/direction, kept in the metadata.
    ``poses``: a :class:`~.poses.PoseSource` (NAME_poses: body frames and points in the world).
    ``frames``: a :class:`~eomc.compiler.tree.frames.FrameSource` (frame outputs).
    Deterministic: identical input gives byte-identical output.  The printer's templates
    (:func:`~.printer.print_memo`) live while it runs.
    """
    with print_memo():
        return _generate_c(formed, name, parameters=parameters, inputs=inputs, outputs=outputs,
                           functions=functions, fold_parameters=fold_parameters, events=events,
                           event_options=event_options, formulation=formulation, poses=poses, frames=frames)


def _generate_c(formed, name, *, parameters, inputs, outputs, functions, fold_parameters, events,
                event_options, formulation, poses, frames):
    low = lower(formed, name, parameters=parameters, inputs=inputs, outputs=outputs,
                functions=functions, fold_parameters=fold_parameters, events=events,
                formulation=formulation, poses=poses, frames=frames)
    layout, sym, fns = low.layout, low.symbolic, low.functions
    nq, nu, nx, nw = formed.nq, formed.nu, len(layout.x), sym.nw   # x = [q; u; z]
    solver = (choose_ldlt(name, nw, sym.pattern) if sym.symmetric else
              sparse_lu_solver(name, nw, sym.pattern, sym.row_order))
    slots = dict(layout.c_names)
    slots.update({s: f"w[{j}]" for j, s in enumerate(sym.W)})
    slots.update({s: f"udot[{j}]" for j, s in enumerate(sym.UD)})
    slots.update({s: f"dx[{j}]" for j, s in enumerate(sym.seeds)})
    ctx = BodyContext(name, nq, nu, nw, solver, slots, sym.symmetric, sym.pattern)
    ctx.nz = nx - nq - nu
    ctx.functions = tuple(fns)      # a body may call code shared with the others (Formulation.shared_code)
    with _naming_nonfinite(name, "dynamics helper (the mass matrix and forcing)"):
        helper = dynamics_helper(ctx, low.helper) if low.helper is not None else ""
    dynamics_text = helper
    helper = "\n".join(c for c in (helper, formulation.c_helpers(name, sym, fns, nq)) if c)
    routines, routines_split = _called_routines([p for p in (*low.programs.values(), low.helper) if p is not None])
    if routines:        # static functions the bodies call (a body-body pair's narrow phase)
        helper = "\n".join(c for c in (routines, helper) if c)
        ctx.split = ctx.split or routines_split
    rendered, op_counts, meta_batch, printed, defined = [], {}, {}, {}, set()
    for fn in fns:
        if fn in BATCH_FUNCTIONS:   # the printed lines, rewritten into lanes (compiler/emit/batch.py)
            scalar = BATCH_FUNCTIONS[fn]
            first = next(f for f in fns if f in BATCH_FUNCTIONS)     # its code holds the prelude
            before, body, meta_batch[fn] = batch_code(name, nx, len(layout.r), printed[scalar], dynamics_text,
                                                      len(layout.p), fn=scalar, defined=defined,
                                                      prelude=fn == first, kernels=helper,
                                                      nout=_batch_outputs(scalar, sym, fns, formulation))
            rendered.append({"prototype": prototype(name, fn), "body": body, "parts": [before]})
            op_counts[fn] = dict(op_counts[scalar])
            continue
        prog = low.programs[fn]
        shared = formulation.shared_code(fn, ctx, prog, sym, fns)
        if shared is not None:      # a static function this and later bodies call
            sname, sbody, ssig, *shelpers = shared      # (and the static functions it calls: tree/law_loop.py)
            with _naming_nonfinite(name, sname):
                slines, sparts = split_body(sbody, f"{name}_{sname}_part")
            sparts = [*(shelpers[0] if shelpers else ()), *sparts]
            ctx.split = ctx.split or bool(sparts)
            args = ", ".join(f"{c}{a}" if c.endswith("*") else f"{c} {a}" for c, a in ssig)
            rendered.append({"prototype": f"static void {name}_{sname}({args})",
                             "body": void_unused(fn, slines, ssig), "parts": sparts})
        with _naming_nonfinite(name, fn):
            body = ((formulation.body(fn, ctx, prog, sym, layout, nx)
                     or plain_body(ctx, prog, "pose", (low.poses["size"],), "out")) if fn == "poses" else
                    outputs_energy_body(ctx) if fn == "outputs" and low.outputs_by_energy else
                    _body(fn, ctx, prog, sym, layout, nx, fns, formulation))
        consts, ctx.constant_stores = ctx.constant_stores, None
        full = body
        if consts is not None:      # NAME_implicit: its constant outputs apart (tree/emit.implicit_constants)
            body = [line for line in body if line not in consts[0]]
        near = formulation.restrict_scratch(fn)     # split.WINDOW_MIN: the scalar code only, not the lanes twin
        if ctx.windows is not None and near:        # the body's own threshold (tree/limbs.py)
            near, ctx.windows = ctx.windows, None
        lines, parts = split_body(body, f"{name}_{fn}_part", restrict=formulation.restrict_scratch(fn), windows=near)
        if lean_attribute(fn, lines) and len(lines) > FOLD_MIN:   # a long body left between guard blocks
            lines, parts = split_body(body, f"{name}_{fn}_part", restrict=formulation.restrict_scratch(fn),
                                      blocks=True, block_attribute=PART_LEAN_FUNCTIONS.get(fn), windows=near)
        ctx.split = ctx.split or bool(parts)
        asked, ctx.parts = ctx.parts, []             # functions the body asked for (bodies.BodyContext.parts)
        parts = asked + parts
        if fn in BATCH_FUNCTIONS.values() and any(BATCH_FUNCTIONS.get(f) == fn for f in fns):
            # the lanes twin: with the branch blocks left in the body (its rewrite turns the guards
            # into lane masks), and writing every output each call (the lanes rollout copies them all)
            blines, bparts = split_body(full, f"{name}_{fn}_part", restrict=formulation.restrict_scratch(fn))
            printed[fn] = (blines, bparts if consts is not None else asked + bparts)
        lean = lean_attribute(fn, lines)
        lines, parts = formulation.scalar_text(fn, name, sym, lines, parts)   # after the lanes twin's copy
        if fn == "implicit":    # its contact loops read their inputs in place (.packed)
            lines, parts = packed_inputs(lines, parts, f"{name}_{fn}_part")
            lines, parts = forwarded_outputs(lines, parts, f"{name}_{fn}_part")
        if consts is not None:
            rendered += _constants_apart(name, fn, consts[1], lines, parts, lean)
            meta_batch.setdefault("const_outputs", {})[fn] = sum(1 for line in full if line in consts[0])
        else:
            lines, parts = _block_zeroed(lines), [_block_zeroed(part) for part in parts]
            rendered.append({"prototype": f"{lean} {prototype(name, fn)}" if lean else prototype(name, fn),
                             "body": void_unused(fn, lines), "parts": parts, "lean": bool(lean)})
        op_counts[fn] = (dict(op_counts[GENERATED_LIKE[fn]]) if fn in GENERATED_LIKE else
                         _ops(fn, prog, solver, nx, len(layout.r), sym.seeds, low.helper, nu,
                              sum(1 for i, j in sym.pattern if i < nu and j < nu), sym.solve_in,
                              formulation, sym, len(layout.p), nq))
    if "poses" in fns:   # the number of doubles NAME_poses writes (the loader checks NAME.json by it)
        from .poses import pose_metadata
        rendered.append({"prototype": f"int {name}_pose_count(void)",
                         "body": f"    return {low.poses['size']};", "parts": []})
    if getattr(sym, "inverse_dynamics_calls", "") in op_counts and "inverse_dynamics" in op_counts:   # a call of it
        op_counts["inverse_dynamics"] = dict(op_counts[sym.inverse_dynamics_calls])
    if getattr(sym, "forcing_calls", "") in op_counts and "forcing" in op_counts:   # forcing is a call of it
        op_counts["forcing"] = dict(op_counts[sym.forcing_calls])
    if low.outputs_by_energy:       # a call of it
        op_counts["outputs"] = dict(op_counts["energy"])
    if "linearize" in op_counts:
        op_counts["linearize"] = {k: sum(op_counts[f][k] for f in ("jac_x", "jac_r") if f in op_counts)
                                  for k in ("adds", "muls", "divs", "calls")}
    meta = _metadata(name, formed, layout, sym, fns, op_counts)
    if "events" in fns:
        by_name = {o["name"]: o for o in (event_options or ())}
        meta["events"] = [by_name.get(n, {"name": n, "terminal": 0, "direction": 0})
                          for n in sym.event_names]
    if sym.energy:      # the runtime's verdict may trust it from a start in contact (runtime/switching.py)
        meta["energy"] = sym.energy
    meta["formulation"] = formulation.name
    meta.update(meta_batch)
    meta.update(formulation.metadata(sym, fns))
    if low.poses is not None:
        meta["poses"] = pose_metadata(low.poses)
    tree = tree_functions(name, meta["implicit"]["parents"]) if "implicit" in meta else []
    if tree:        # the fixed step's factorisation of M's tree pattern and its solves (compiler/emit/tree_lu.py)
        rendered += tree
        meta["tree_lu"] = True
    return _render(name, meta, fns, rendered, solver, layout, sym, helper, ctx.split, formulation,
                   ctx.solver_parts)


def _constants_apart(name, fn, const_lines, lines, parts, lean):
    """The rendered NAME_fn_const (the constant outputs), NAME_fn_var (the body without them) and
    NAME_fn (the two in turn: what it always was, for every caller that does not keep its
    output buffer; with the pairs' slope block zeroed between them when NAME_fn_var's loop keeps
    it, contact/table.KEPT_BLOCK).  The fixed step calls NAME_fn_const once per buffer and run, then
    NAME_fn_var per step (runtime/c/eomc_integrators.h, eomc_implicit.terms_const)."""
    var = prototype(name, fn).replace(f" {name}_{fn}(", f" {name}_{fn}_var(", 1)
    args = ", ".join(a for _, a in SIGNATURES[fn])
    block = [m.groups() for text in [*lines, *parts] for m in _KEPT_CALL.finditer(text)]
    zero = "".join(f"    for (int k = 0; k < {n}; ++k) out[{off} + k] = 0.0;\n" for off, n in block)
    return [{"prototype": f"void {name}_{fn}_const(double *out)", "body": "\n".join(const_lines), "parts": []},
            {"prototype": f"{lean} {var}" if lean else var, "body": void_unused(fn, lines), "parts": parts,
             "lean": bool(lean)},
            {"prototype": prototype(name, fn),
             "body": f"    {name}_{fn}_const(out);\n{zero}    return {name}_{fn}_var({args});", "parts": []}]


# the pairs' loop writing its slope block into out[] and keeping it (contact/table.KEPT_BLOCK): its
# place and length
_KEPT_CALL = re.compile(r"eomc_pairs_slopes\(.*, &out\[(\d+)\], (\d+), 1\);$", re.M)


def _block_zeroed(text):
    """``text`` (a body's lines, or a part's C) with the pairs' loop told to zero its slope block
    (kept = 0): NAME_implicit with no constant outputs apart has no NAME_implicit_var, and its
    caller's buffer may hold anything."""
    if isinstance(text, list):
        return [_block_zeroed(t) for t in text]
    return re.sub(r"(eomc_pairs_slopes\(.*, &out\[\d+\], \d+), 1\);$", r"\1, 0);", text, flags=re.M)


def const_prototypes(name, meta):
    """The header's and cdef's declarations of NAME_implicit_const and NAME_implicit_var, when the
    model has them (metadata "const_outputs"): the runtime's (runtime/cdef.CONST_SPLIT, what the
    loader declares and checks NAME.json's cdef against)."""
    return [d.format(n=name).rstrip(";") for f in (meta.get("const_outputs") or {}) for d in CONST_SPLIT[f]]


def _batch_outputs(scalar, sym, fns, formulation):
    """Doubles per state of the batch function of ``scalar`` (None: batch_code's own count)."""
    if scalar == "outputs":
        return len(sym.output_names)
    if scalar == "implicit":
        return formulation.metadata(sym, fns)["implicit"]["layout"]["size"]
    return None


def _mass_inputs_only(program, sym, fn):
    """``program`` without the kernels' inputs (``anx``) that mass_matrix and jac_r do not read
    where the plan has contacts (``sym.mass_inputs``, compiler/tree/lower.contact_mass_inputs):
    their loop kernels read M's inputs only, and the contact terms are jac_x's."""
    keep = set(getattr(sym, "mass_inputs", ()))
    if not keep or fn not in ("mass_matrix", "jac_r"):
        return program
    alone = fn == "mass_matrix"     # NAME_dyn's M reads an[] alone (not CRBA's A, which NAME_implicit prints)
    return program.with_(results=tuple(r for r in program.results
                                       if (r[0][1] in keep if r[0][0] == "anx" else not alone)))


def _taped(prog, exact=False):
    """``prog`` with the calls whose derivative calls read their tape in the variant that writes it:
    an expression with ``tape_of()`` (the temporaries it reads a tape from; compiler/contact/
    narrow.py's NarrowDot; a result too, compiler/contact/table.py's PairTableKernelTape) makes
    their definitions ``taped()``.  Per function, so that a function
    without the derivative (rhs) calls the routine that writes no tape."""
    if prog is None:
        return None
    prog = _variants(prog, exact)
    want = {s for _, e in (*prog.assignments, *prog.results) if hasattr(e, "tape_of") for s in e.tape_of()}
    if not want:
        return prog
    return prog.with_(assignments=tuple((t, e.taped() if t in want else e) for t, e in prog.assignments))


def _exactness(fn, prog):
    """for_program's ``exact`` of function ``fn``'s pairs' loop: the outputs, every pair exact (users
    read each point's depth and position); NAME_energy too, unless it reads the points' depths only
    as their positive parts (compiler/contact/table.reads_depths_positive_only): then the loop's
    broad phase (DEPTHS_POSITIVE), the same bits."""
    if fn == "energy" and prog is not None:     # the loop's node says (emit does not import contact)
        calls = [e for _, e in prog.assignments if hasattr(e, "reads_depths_positive_only")]
        if calls and calls[0].reads_depths_positive_only(prog):
            return calls[0].DEPTHS_POSITIVE
        return True
    return fn.startswith("outputs")


def _variants(prog, exact=False):
    """``prog`` with each call that has a ``for_program(reads)`` method (compiler/contact/table.py's
    pairs loop and its tangent) in the variant its function needs: ``reads``, the output indices
    that the program's nodes with a ``read_index()`` method read (the pairs' loop evaluates every
    pair only where a contact point's quantities are read: outputs, events)."""
    if not any(hasattr(e, "for_program") for _, e in prog.assignments):
        return prog
    reads = set()
    for e in [e for _, e in prog.assignments] + [e for _, e in prog.results]:
        if isinstance(e, sm.Basic):
            reads.update(node.read_index() for node in sm.preorder_traversal(e) if hasattr(node, "read_index"))
    return prog.with_(assignments=tuple((t, e.for_program(reads, exact) if hasattr(e, "for_program") else e)
                                        for t, e in prog.assignments))


def _called_routines(programs):
    """(C text of the static routines the programs' call nodes name -- an expression with a
    ``c_routines()`` method, e.g. compiler/contact/narrow.py's -- each once in key order, whether
    any was cut into sub-functions)."""
    found = {}
    for prog in programs:
        for _, e in (*prog.assignments, *prog.results):     # (a result: table.PairTableKernelTape)
            hook = getattr(e, "c_routines", None)
            if hook is not None:
                for key, text, split in hook():
                    found[key] = (text, split)
    return "\n".join(found[k][0] for k in sorted(found)), any(s for _, s in found.values())


@contextmanager
def _naming_nonfinite(name, fn):
    """The C printer's last guard, as a ModelError naming the function: a NaN or infinite
    constant is never written into generated C (the callers check the model's expressions
    first and name the load, body or output; this catches what lowering itself produced)."""
    try:
        yield
    except NonFiniteLiteral as exc:
        raise ModelError(f"{name}_{fn} would compute the constant {exc} (a NaN or infinite "
                         f"literal in the generated C): an expression of the model evaluates to "
                         f"nan, zoo or oo; no C was written") from None


def _metadata(name, formed, layout, sym, fns, op_counts):
    return {
        "name": name, "abi_version": 1, "eomc_version": _eomc_version(),
        "nq": formed.nq, "nu": formed.nu, "nx": len(layout.x), "nparam": len(layout.p),
        "ninput": len(layout.r), "noutput": len(sym.output_names), "nhol": sym.nhol,
        "nvel": sym.nvel, "work_size": 0,
        "state_names": list(layout.state_names), "param_names": list(layout.param_names),
        "param_defaults": list(layout.param_defaults), "input_names": list(layout.input_names),
        "output_names": list(sym.output_names), "functions": list(fns),
        "op_counts": op_counts, "mass_matrix_sparsity": _sparsity(sym.nw, sym.pattern),
        "solver": "ldlt" if sym.symmetric else "lu", "folded_parameters": dict(layout.folded),
    }


def _vector_docs(meta):
    """The header's comment on x[], p[], r[] and the outputs: which index is which (and p's defaults).

    A C user reads NAME.h, not NAME.json; without this the order of p[] is a guess.
    """
    def entries(names, defaults=None):
        if defaults is None:
            return [f"[{i}] {n}" for i, n in enumerate(names)]
        return [f"[{i}] {n} = {float(d)!r}" for i, (n, d) in enumerate(zip(names, defaults))]
    nz = meta["nx"] - meta["nq"] - meta["nu"]
    extra = f", then nz = {nz} extra first-order states" if nz else ""
    return [
        ("x", f"state (nx = {meta['nx']}: nq = {meta['nq']} coordinates, then nu = {meta['nu']} speeds"
              f"{extra}; udot, tau, forcing and mass_matrix rows follow the speeds)",
         entries(meta["state_names"])),
        ("p", f"parameters (nparam = {meta['nparam']}), with the model's defaults",
         entries(meta["param_names"], meta["param_defaults"])),
        ("r", f"inputs (ninput = {meta['ninput']})", entries(meta["input_names"])),
        ("outputs", f"out[] of {meta['name']}_outputs (noutput = {meta['noutput']})" + _energy_doc(meta),
         entries(meta["output_names"])),
    ] + _pose_docs(meta)


def _energy_doc(meta):
    """The header's word on NAME_energy, where the model has it."""
    if "energy" not in meta["functions"]:
        return ""
    k = meta["output_names"].index("energy")
    return (f";\n *     {meta['name']}_energy writes out[{k}] energy alone into its out[0] (the same bits, "
            f"none of the other\n *     outputs computed: what eomc's rollout reads after every step)")


def _pose_docs(meta):
    """Where each body and point is in out[] of NAME_poses (NAME_pose_count() doubles)."""
    poses = meta.get("poses")
    if not poses:
        return []
    nf = len(poses["frames"])
    rows = [f"[{12 * i}] {n}: origin x, y, z, then R row by row" for i, n in enumerate(poses["frames"])]
    rows += [f"[{12 * nf + 3 * j}] {n}: x, y, z" for j, n in enumerate(poses["points"])]
    return [("poses", f"out[] of {meta['name']}_poses ({poses['size']} doubles, world frame; R's "
                      f"columns are the body's axes)", rows)]


def _minmax_code(helper_code, rendered):
    """The inline fmax and fmin (printer.MINMAX_C) and the helpers of printer.CALLED_C that some
    text calls ("" when none: a model without them keeps its C as before; an unused static
    function is a -Wunused-function warning)."""
    texts = [helper_code] + [t for f in rendered for t in (f["body"], *f["parts"])]
    helpers = {**MINMAX_C, **CALLED_C}
    # one scan of each text for all the helpers' calls (the name and its "(" first, as
    # plain text: a regex per helper and text took G1's default build ~0.02 s)
    called = _called(helpers, texts)
    return "\n\n".join(code for fn, code in helpers.items() if fn in called)


def _called(names, texts):
    """The names in ``names`` that some text calls (``name(`` after a non-word character)."""
    found = set()
    pattern = re.compile(r"\b(" + "|".join(re.escape(n) for n in names) + r")\(")
    for t in texts:
        if any(n + "(" in t for n in names if n not in found):
            found.update(pattern.findall(t))
            if len(found) == len(names):
                break
    return found


def _render(name, meta, fns, rendered, solver, layout, sym, helper, split=False, formulation=KANE,
            solver_parts=()):
    tables, table_refs = _tables(name, layout, sym.output_names)
    pointers = [f"{name}_{f}" if f in fns else "NULL" for f in STRUCT_FIELDS]
    # the recursive formulation's rhs, jac_x and jac_r solve by ABA (no factorization)
    uses_solver = ((formulation.solves and any(f in fns for f in _SOLVING)) or bool(sym.solve_in))
    env = _environment()
    common = {k: meta[k] for k in ("nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol",
                                   "nvel", "work_size", "eomc_version")}
    header = env.get_template("model.h.j2").render(
        name=name, prototypes=[prototype(name, f) for f in fns]
        + ([f"int {name}_pose_count(void)"] if "poses" in fns else [])
        + _const_docs(name, meta, any(_KEPT_CALL.search(t) for f in rendered for t in [f["body"], *f["parts"]]))
        + ([f"int {name}_rhs_batch_p(int n, double t, const double *X, const double *P, const double *R, "
            f"double *XDOT, int *status, double *work)"] if "rhs_batch" in fns else [])
        + ([f"/* {name}_tree_lu(A): A (nu x nu, by rows) = its LU over the mass matrix's tree pattern, in place, as\n"
            f" * the fixed step's loop makes it (runtime/c/eomc_fixedstep.c, fs_tree_lu); 1: a pivot too small.\n"
            f" * {name}_tree_solve(A, b, c): b := A^-1 b with that A, and c := A^-1 c unless c is NULL.\n"
            f" * {name}_tree_residual(M, f, du, h, r): r = M du - h f over the mass matrix's pattern */\n"
            + TREE_LU.format(n=name).rstrip(";"), TREE_SOLVE.format(n=name).rstrip(";"),
            TREE_RESIDUAL.format(n=name).rstrip(";")]
           if meta.get("tree_lu") else []),
        vectors=_vector_docs(meta), quaternions=meta.get("quaternions", ()), **common)
    helper_code = "\n".join(c for c in ((solver.code if uses_solver else ""), *solver_parts, helper) if c)
    source = env.get_template("model.c.j2").render(
        name=name, functions=rendered, helper_code=helper_code, minmax=_minmax_code(helper_code, rendered),
        tables=tables, table_refs=table_refs, pointers=pointers,
        noinline=NOINLINE_MACRO if split else "", wide_finite="implicit" in fns,
        lean="\n".join(m for m, used in ((LEAN_MACRO, any(f.get("lean") for f in rendered)),
                                           (PART_LEAN_MACRO, any(p.startswith("static EOMC_PART_LEAN ")
                                                                 for f in rendered for p in f["parts"])),
                                           (NEAR_MACRO, any(p.startswith("static EOMC_NEAR ")
                                                            for f in rendered for p in f["parts"])))
                       if used), **common)
    return GeneratedModel(name=name, c_source=source, header=header,
                          cdef=cdef(name, fns) + "".join(f"{p};\n" for p in const_prototypes(name, meta))
                          + "".join(f.format(n=name) + "\n" for f in (TREE_LU, TREE_SOLVE, TREE_RESIDUAL)
                                    if meta.get("tree_lu")),
                          metadata=meta)


def _const_docs(name, meta, kept=False):
    """const_prototypes with the header's word on them (``kept``: NAME_implicit_var keeps its pairs'
    slope block, contact/table.KEPT_BLOCK)."""
    protos = const_prototypes(name, meta)
    if not protos:
        return []
    return [f"/* {name}_implicit(...) is {name}_implicit_const(out), then {name}_implicit_var(...): the\n"
            f" * first writes the outputs that are constants ({meta['const_outputs']['implicit']} of "
            f"{meta['implicit']['layout']['size']}), the second the rest.\n"
            f" * A caller that calls it again and again into the same out[] (the fixed step: once per run)\n"
            f" * may call {name}_implicit_const once and then {name}_implicit_var alone"
            + (".\n * Its body-body pairs' slope block (a record of 25 a pair point: depth, p, v, K, C) is kept\n"
               f" * between calls: {name}_implicit_var zeroes only the records it wrote at its last call into that\n"
               " * out[] (NaN-filled or zeroed first: all of them).  A record whose depth is not > 0 is out of\n"
               " * touch: read its depth alone (a record written with depth and p all exactly 0 keeps its\n"
               " * other entries); " + f"{name}_implicit zeroes the block. */\n"
               if kept else ". */\n") + protos[0]] + protos[1:]
