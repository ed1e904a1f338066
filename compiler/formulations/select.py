"""Which formulation generates a model: Kane's (formed A, b and a numeric LDLᵀ) or the
recursive one (ABA/RNEA/CRBA over the tree).  ``auto``, the default, never fails where
either one works.

``auto`` reads the tree first (no equations formed) and lowers the recursive form.
Kane's form is then lowered too, and the one whose rhs costs less is kept (all requested
functions' costs when rhs is not requested), only where it can win.  The cost
(:func:`rhs_cost`) weighs the operation counts by what they take in time: a sin/cos call
about 36 operations, a division 4, and Kane's arithmetic 0.78 + 0.13 per speed times the
recursion's (1.04x at 2 speeds, 1.56x at 6), fitted to both rhs measured on 18 models (task
autocost, session 25); counting operations alone kept Kane's slower rhs on the cart at 3-4 links
and on the UR10 and Kinova arms, and weighing Kane's arithmetic the same at every size kept it
on the cart at 2 links and on Bolt (1.10-1.12x slower; benchmarks/results/auto_choice.md).

* Kane's equations are formed for the comparison only for a small tree
  (:data:`AUTO_KANE_MAX_SPEEDS` speeds): forming them is the costly part of a build
  (a minute at 40 bodies, not finishing for a 35-dof humanoid), and on no model measured
  beyond 6 speeds does Kane's rhs win: timed on this machine (benchmarks/results/
  auto_choice.md, 2026-12-01 04:52, the looped rhs from 4 links) it is faster only on the
  cart at n = 1 (16 against 20 ns; 47 against 45 at n = 2) and 1.15x-37x slower from n = 3
  (cart n = 8 705 against 242 ns, n = 20 7911 against 588, n = 40 44612 against 1191;
  UR10 and UR5 1.26x, Kinova 2.1x, Panda 3.2x, Solo12 2.4x), so the cap loses nothing
  measured.  A model file that forms Kane's
  equations itself therefore does not have them forced when auto takes the tree.
* Within that limit, Kane's equations are not formed either for an open tree with a chain of
  more than :data:`AUTO_KANE_MAX_CHAIN` (3) moving joints (:func:`kane_skip_reason`, read from
  the tree before anything is formed): Kane's rhs won on no such tree measured (the cart at
  3-5 links, UR3/5/10, Kinova, so100/so101, hextilt's arm: 1.3-2.8x slower,
  benchmarks/results/auto_skip.md), and forming its equations was most of their build
  (so101: 5.8 of 6.9 s of generate CPU).  The metadata's ``formulation_costs`` says so.
* Lowering Kane's form is skipped when the LDLᵀ of its mass matrix alone (counted
  exactly as the emitter would write it, from the formed matrix's nonzeros) already
  costs as much as the whole recursive rhs.

A tree closed by holonomic constraints (compiler/tree/constrained.py) is treated the
same way, with the same limit, measured on closed n-link chains
(benchmarks/results/loops.md): Kane's rhs has fewer operations up to 6 speeds (the
five-bar 623 against 1145, the 6-link chain 1614 against 2076, about even in time
there), and at 8 speeds the recursive rhs has fewer (3092 against 3171) and runs twice
as fast, while Kane's build took 12.6 s CPU against the recursive build's 1.2 s.  The
closed tree builds the default function set too (jac_x, jac_r and linearize by the KKT
system's tangent, constrained.py), so those no longer send it to Kane: with no flags the
8- and 10-link chains keep the recursive form without Kane's equations being formed.

When the recursion refuses the system (not a tree, nonholonomic constraints, Lagrange's
method)
or the recursive lowering fails in any way, auto uses Kane's formulation and
records why in the metadata (``formulation_note``, shown by `eomc build` and
`eomc inspect`); when Kane's fails and the recursive one worked, the recursive one
is kept, with Kane's failure in the note.
"""
import sympy as sm
from sympy.physics import mechanics as me

from eomc.runtime.errors import EomcError, ModelError

from ..emit.formulation import KANE_IMPLICIT
from ..ir.program import distinct_atoms
from ..mechanics.formed import FormedSystem
from .weights import CALL_WEIGHT, COST_MODEL, DIV_WEIGHT, KANE_OP_WEIGHT, KANE_OP_WEIGHT_PER_SPEED
from ..multibody.formed import model_of_tree
from ..multibody.model import Model
from ..passes.timing import compiler_step
from ..tree.model import NotATree, tree_exprs
from ..tree.recognize import tree_of

__all__ = ["FORMULATIONS", "DEFAULT_FORMULATION", "AUTO_KANE_MAX_SPEEDS", "AUTO_KANE_MAX_CHAIN",
           "chain_length", "kane_skip_reason", "generate_formulation",
           "rhs_cost", "KANE_OP_WEIGHT", "KANE_OP_WEIGHT_PER_SPEED", "kane_op_weight", "DIV_WEIGHT",
           "CALL_WEIGHT", "COST_MODEL",
           "check_formulation", "tree_digest", "kane_tree_formed", "check_tree_finite"]

FORMULATIONS = ("auto", "kane", "recursive")
DEFAULT_FORMULATION = "auto"
AUTO_KANE_MAX_SPEEDS = 6      # see the module docstring: above this Kane's rhs never won
AUTO_KANE_MAX_CHAIN = 3       # joints in a row up to which Kane's rhs can win (see kane_skip_reason)
AUTO_SKIP_KANE = True         # False: auto forms Kane's equations up to 6 speeds whatever the tree (benchmarks)


def check_formulation(formulation):
    if formulation not in FORMULATIONS:
        raise ModelError(f"unknown formulation {formulation!r}; choose from {', '.join(FORMULATIONS)}")
    return formulation


def tree_digest(spec):
    """The tree's expressions and shape (each body's parent and speed: two trees can have
    the same expressions and differ only there) and the reader's notes (the metadata's
    ``tree_notes``), for the generation cache key of a formed-less System."""
    if not isinstance(spec.formed, Model):
        return None
    tree = spec.formed.tree
    # per body: parent, then its speed (>= 0), -1 (fixed) or -2-k followed by a k-speed joint's speeds
    shape = [(b.parent, b.speed) if b.speed is not None else
             (b.parent, -2 - len(b.speeds)) + tuple(b.speeds) if b.speeds else (b.parent, -1)
             for b in tree.bodies]
    notes = list(getattr(tree, "notes", ()))   # they go into the metadata (tree_notes)
    from ..tree.constrained import loop_exprs, tree_loops   # a tree closed by constraints: them too
    return (tree_exprs(tree) + [sm.Integer(k) for pair in shape for k in pair]
            + loop_exprs(tree_loops(tree)) + notes)


def is_eomc_kane(system):
    """An eomc KanesMethod (the only one whose tree is read before its equations are formed)."""
    from ..mechanics.kane import KanesMethod
    return isinstance(system, KanesMethod)


def kane_tree_formed(kane):
    """The Model (a tree: nothing formed) of an eomc KanesMethod, read from its bodies,
    loads and kinematic equations without asking for its formed equations, so that a lazily
    formed KanesMethod is never formed when the recursive formulation takes it.  NotATree
    when the recursion cannot take it."""
    from ..tree.recognize import tree_from_kane
    t = me.dynamicsymbols._t
    try:
        qdot = kane.kindiffdict()
    except EomcError as exc:
        raise NotATree(str(exc)) from None
    try:
        kin = tuple(qdot[c.diff(t)] for c in kane.q)
    except KeyError as exc:
        raise NotATree(f"no kinematic differential equation gives {exc.args[0]}") from None
    if not getattr(kane, "_bodylist", None):
        raise NotATree("the KanesMethod has no bodies (kanes_equations was not called)")
    return model_of_tree(tree_from_kane(kane, kin))   # the KanesMethod's q and u, in order


def _find_tree(spec):
    if isinstance(spec.formed, Model):
        return spec.formed.tree
    if spec.system is None or isinstance(spec.system, FormedSystem):
        raise NotATree("only a FormedSystem was given (pass the System or KanesMethod itself)")
    if spec.formed.method != "kane" and not isinstance(spec.system, me.System):
        raise NotATree(f"the system was formed by {spec.formed.method}'s method")
    return tree_of(spec.system, spec.formed)


_NONFINITE = (sm.nan, sm.zoo, sm.oo, -sm.oo)
_NONFINITE_SET = frozenset(_NONFINITE)


def nonfinite(expr):
    """The first non-finite constant (nan, zoo, ±oo, in that order) in ``expr``, or None.

    One walk over the expression's distinct subexpressions: ``expr.has(bad)`` once per
    constant walked the whole tree four times, shared subtrees as often as they occur, which
    was most of a Kane build's "generate" (so101, a 6-joint arm: the checks of its mass matrix
    and forcing, 325 expressions, ~46 of 111 s wall under cProfile, session 24)."""
    expr = sm.sympify(expr)
    if not isinstance(expr, sm.Basic):
        return next((bad for bad in _NONFINITE if expr.has(bad)), None)
    found = {e for e in distinct_atoms([expr]) if e in _NONFINITE_SET}
    return next((bad for bad in _NONFINITE if bad in found), None)


def _sources_on(system, body_name):
    """What of ``system`` acts on the body named ``body_name``: its actuators (by type and
    pathway) and loads, for a message about a load the tree holds for that body."""
    if not isinstance(system, me.System):
        return ""
    body = next((b for b in system.bodies if b.name == body_name), None)
    if body is None:
        return ""
    where = {body.masscenter} | ({body.frame} if isinstance(body, me.RigidBody) else set())
    found = []
    for act in system.actuators:
        try:
            hits = any(ld.location in where for ld in act.to_loads())
        except Exception:             # noqa: BLE001 -- only a hint for the message
            hits = False
        if hits:
            path = getattr(act, "pathway", None)
            found.append(type(act).__name__ + (f" on a {type(path).__name__}" if path is not None else ""))
    for ld in system.loads:
        if ld.location in where:
            found.append(f"{type(ld).__name__} {ld.vector}")
    return f"; acting there: {', '.join(found)}" if found else ""


def check_tree_finite(tree, system=None):
    """ModelError naming the body, joint or load whose expression holds nan, zoo or ±oo:
    the recursion would carry it into every u' as a literal NAN."""
    for b in tree.bodies:
        for what, exprs in (("mass", [b.mass]), ("inertia", list(b.inertia)),
                            ("rotation", list(b.rotation)), ("position", list(b.position)),
                            ("joint axis", [c for m in b.dofs for c in (m[1] or ())])):
            for e in exprs:
                bad = nonfinite(e)
                if bad is not None:
                    raise ModelError(f"recursive formulation: the {what} of body {b.name} "
                                     f"(joint {b.joint}) is {bad}: {e}")
    for k, load in enumerate(tree.loads):
        body = tree.bodies[load.body]
        for what in ("force", "moment", "offset"):
            for e in getattr(load, what):
                bad = nonfinite(e)
                if bad is not None:
                    raise ModelError(
                        f"recursive formulation: the {what} of load {k + 1} on body {body.name} "
                        f"(joint {body.joint}{_sources_on(system, body.name)}) has the "
                        f"non-finite component {e}")
    for i, e in enumerate(tree.gravity):
        if nonfinite(e) is not None:
            raise ModelError(f"recursive formulation: gravity component {i} is {e}")


def check_formed_finite(spec):
    """ModelError naming the coordinate, speed, output or event whose expression holds a
    non-finite constant (it would be printed as a literal NAN or INFINITY)."""
    f = spec.formed
    rows = [(f"the kinematic equation of {c}", e) for c, e in zip(f.coordinates, f.kinematics)]
    if not isinstance(f, Model):
        speeds = list(f.speeds) + list(f.multipliers)
        rows += [(f"the mass matrix row of {speeds[i] if i < len(speeds) else i}", e)
                 for i in range(f.dynamics_matrix.rows) for e in f.dynamics_matrix.row(i)]
        rows += [(f"the forcing of {speeds[i] if i < len(speeds) else i}", e)
                 for i, e in enumerate(f.dynamics_rhs)]
    rows += [(f"holonomic constraint {i + 1}", e) for i, e in enumerate(f.holonomic_constraints)]
    rows += [(f"velocity constraint {i + 1}", e) for i, e in enumerate(f.velocity_constraints)]
    rows += [(f"output {name!r}", e) for name, e in (spec.outputs or {}).items()]
    rows += [(f"event {name!r}", e) for name, e in (spec.events or {}).items()]
    for where, e in rows:
        bad = nonfinite(e)
        if bad is not None:
            raise ModelError(f"{where} contains {bad} (a non-finite constant), so the generated C "
                             f"would compute NaN or inf: {e}")


def _kane_formed(spec):
    """The Kane FormedSystem.  An unformed System reaches here formed already: model_spec
    forms it with eomc's Kane when the kane formulation is asked for."""
    if isinstance(spec.formed, Model) and spec.formed.kane_refusal:
        raise ModelError(spec.formed.kane_refusal)
    if isinstance(spec.formed, Model):
        raise ModelError("the kane formulation needs formed equations; this System was read as a "
                         "joint tree only (compile it with formulation='kane' from the start)")
    return spec.formed


# The cost model's weights (CALL_WEIGHT, DIV_WEIGHT, KANE_OP_WEIGHT, KANE_OP_WEIGHT_PER_SPEED) and
# COST_MODEL, its words: weights.py (imported above), a module without SymPy for the command line.


def kane_op_weight(speeds):
    """The weight of one of Kane's adds/multiplies in a model of ``speeds`` speeds."""
    return KANE_OP_WEIGHT + KANE_OP_WEIGHT_PER_SPEED * speeds


def rhs_cost(counts, formulation, speeds):
    """The estimated cost of a function from its operation counts ({adds, muls, divs, calls}) in a
    model of ``speeds`` speeds, so that auto compares time, not the number of operations: a call
    weighs CALL_WEIGHT operations, a division DIV_WEIGHT, and Kane's arithmetic
    kane_op_weight(speeds) (see above)."""
    flops = counts.get("adds", 0) + counts.get("muls", 0)
    weight = kane_op_weight(speeds) if formulation == "kane" else 1.0
    return round(weight * flops + DIV_WEIGHT * counts.get("divs", 0)
                 + CALL_WEIGHT * counts.get("calls", 0))


def _rhs_cost(generated, formulation):
    counts = generated.metadata["op_counts"]
    # linearize only calls jac_x and jac_r: its counts are theirs again
    fns = ["rhs"] if "rhs" in counts else [f for f in counts if counts[f] and f != "linearize"]
    return sum(rhs_cost(counts[f], formulation, generated.metadata["nu"]) for f in fns if counts[f])


def kane_solve_floor(formed):
    """Operations of the numeric LDLᵀ factor + solve that Kane's rhs would contain (a
    lower bound on that rhs), from the nonzero pattern of the formed mass matrix."""
    from ..emit.linsolve import choose_ldlt
    A = formed.dynamics_matrix
    n = A.shape[0]
    pattern = {(i, j) for i in range(n) for j in range(i + 1) if A[i, j] != 0}
    solver = choose_ldlt("floor", n, pattern)
    return sum(solver.factor_ops.values()) + sum(solver.solve_ops.values())


def recursive_refusal(exc):
    """The ModelError for a system the recursion cannot take (``exc``: its NotATree)."""
    return ModelError(f"recursive formulation: {exc} (formulation 'kane' takes it, and "
                      f"'auto' falls back to kane)")


def _reason(exc, formulation="recursive"):
    """One line saying why a formulation failed (eomc's own errors as they are)."""
    if isinstance(exc, NotATree):
        return f"not a tree: {exc}"
    text = str(exc).replace(f"{formulation} formulation: ", "", 1)
    if not isinstance(exc, EomcError):
        text = f"{type(exc).__name__}: {text}"
    return f"{formulation} formulation: {text}"


def _options(spec, functions, fold_parameters):
    return dict(parameters=spec.parameters, inputs=spec.inputs, outputs=spec.outputs,
                functions=functions, fold_parameters=fold_parameters, events=spec.events,
                event_options=spec.event_options, poses=getattr(spec, "poses", None),
                frames=getattr(spec, "frames", None))


def _generate_kane(spec, functions, fold_parameters):
    from ..emit import generate_c
    check_formed_finite(spec)
    generated = generate_c(_kane_formed(spec), spec.name, **_options(spec, functions, fold_parameters))
    note = getattr(spec, "energy_note", None)
    if note and "energy" in generated.metadata.get("output_names", ()):
        # a robot's energy output made for Kane's route (urdf.model._kane_energy): NAME.json says what
        # it holds as the recursive form's does (the runtime's verdict reads "joint limits" in it)
        generated.metadata["energy"] = note
    return generated


def _generate_recursive(spec, functions, fold_parameters):
    from ..emit import generate_c
    from .recursive import Recursive
    tree = _find_tree(spec)
    check_tree_finite(tree, spec.system)
    check_formed_finite(spec)
    generated = generate_c(spec.formed, spec.name, formulation=Recursive(tree),
                           **_options(spec, functions, fold_parameters))
    if getattr(tree, "notes", ()):   # joints the System reader took through SymPy's kinematics, and why
        generated.metadata["tree_notes"] = list(tree.notes)
    return generated


def generate_formulation(spec, functions, fold_parameters, formulation=DEFAULT_FORMULATION,
                         kane_spec=None):
    """GeneratedModel of ``spec`` in the requested formulation (see module docstring).

    ``kane_spec()``: the same model with Kane-formed equations (a ModelSpec), for auto
    when ``spec`` holds only the tree (method "tree"); without it such a spec has no
    Kane form."""
    check_formulation(formulation)
    if formulation == "kane":
        return _generate_kane(spec, functions, fold_parameters)
    if formulation == "recursive":
        try:
            return _generate_recursive(spec, functions, fold_parameters)
        except NotATree as exc:
            raise recursive_refusal(exc) from None
    return _generate_auto(spec, functions, fold_parameters, kane_spec)


def _kane_side(spec, kane_spec):
    if not isinstance(spec.formed, Model):
        return spec
    if kane_spec is None:
        raise ModelError("the System's equations are not formed")
    # forming Kane's equations for auto's comparison is most of a URDF arm's "generate" (so101:
    # ~15 of ~35 s CPU): a named step, so the progress listing accounts for it
    with compiler_step("kane_form"):
        spec = kane_spec()
        _kane_formed(spec)    # a model with no System to form (MJCF) is refused here, saying so
    return spec


def chain_length(tree):
    """The most moving joints on one path from the ground to a leaf of ``tree`` (a joint of
    several speeds, e.g. a free joint, counts once; fixed joints not at all)."""
    depth = []
    for b in tree.bodies:             # parents before children
        depth.append((depth[b.parent] if b.parent >= 0 else 0) + (1 if b.dofs else 0))
    return max(depth, default=0)


def kane_skip_reason(tree):
    """Why auto need not form Kane's equations for an open ``tree`` of at most
    AUTO_KANE_MAX_SPEEDS speeds, or None (form them and compare).

    A chain of more than AUTO_KANE_MAX_CHAIN moving joints: every entry of Kane's mass matrix
    and forcing carries the orientation of the whole chain above it (sin/cos of sums of angles
    from a System, long products of rotations from a URDF), so its rhs grows with the square of
    the chain or faster while the recursion's grows with its length.  On no such tree measured
    does Kane's rhs win (benchmarks/results/auto_skip.md: the cart at 3-5 links, UR3/5/10, Kinova,
    so100/so101, hextilt's 5-joint arm, all by cost and in time), and forming its equations was
    most of their build (so101: 5.8 of 6.9 s of generate CPU).  The trees where it does win are
    short or branched (the cart at 1-2 links, the double pendulums, finger_edu's 3-joint fingers,
    Bolt's two 3-joint legs): those are still compared.  A tree closed by constraints is compared
    as before (Kane's rhs has fewer operations on closed chains up to 6 speeds, loops.md)."""
    if tree.loops is not None:
        return None
    chain = chain_length(tree)
    if chain > AUTO_KANE_MAX_CHAIN:
        return f"a chain of {chain} joints > {AUTO_KANE_MAX_CHAIN}: Kane's rhs has not won there"
    return None


def _generate_auto(spec, functions, fold_parameters, kane_spec):
    try:
        recursive = _generate_recursive(spec, functions, fold_parameters)
    except Exception as exc:          # noqa: BLE001 -- auto must not fail where Kane works
        why = _reason(exc)
        if isinstance(exc, EomcError) and isinstance(spec.formed, Model) and spec.formed.kane_refusal:
            # no Kane form to fall back to (an MJCF file): the recursive form's reason is the
            # whole answer, not an aside after "has the recursive formulation only"
            raise ModelError(str(exc)) from None
        try:
            generated = _generate_kane(_kane_side(spec, kane_spec), functions, fold_parameters)
        except Exception as kane_exc:
            if isinstance(exc, NotATree) or not isinstance(kane_exc, EomcError):
                raise
            if str(kane_exc) == KANE_IMPLICIT and isinstance(exc, EomcError):
                raise ModelError(str(exc)) from None     # Kane never builds implicit: the tree's reason is the answer
            raise ModelError(f"{kane_exc} (auto tried the recursive form first: {why})") from None
        generated.metadata["formulation_note"] = f"kane, the fallback ({why})"
        return generated
    nu = spec.formed.nu
    if isinstance(spec.formed, Model) and nu > AUTO_KANE_MAX_SPEEDS:
        recursive.metadata["formulation_costs"] = {
            "kane": f"not formed ({nu} speeds > {AUTO_KANE_MAX_SPEEDS}: Kane's rhs has not won there)",
            "recursive": _rhs_cost(recursive, "recursive")}
        return recursive
    refusal = spec.formed.kane_refusal if isinstance(spec.formed, Model) else None
    if refusal:
        # nothing to compare (an MJCF model): say so as the choice's reason, not as a failure of a
        # Kane form nobody asked for ("recursive (kane formulation: an MJCF model has ...)" read as
        # if the user had asked for Kane's; first hour, session 26)
        before = recursive.metadata.get("formulation_note")
        recursive.metadata["formulation_note"] = f"recursive ({refusal})" + (
            f"; {before}" if before else "")
        return recursive
    # a tree whose Kane's equations auto would form
    lazy = isinstance(spec.formed, Model)
    skip = kane_skip_reason(spec.formed.tree) if AUTO_SKIP_KANE and lazy else None
    if skip is not None:
        recursive.metadata["formulation_costs"] = {"kane": f"not formed ({skip})",
                                                   "recursive": _rhs_cost(recursive, "recursive")}
        return recursive
    try:
        kspec = _kane_side(spec, kane_spec)
        if functions is None or "rhs" in functions:
            # a lower bound on Kane's cost: its LDLT's operations, each at least a flop of Kane's
            floor = round(kane_op_weight(nu) * kane_solve_floor(kspec.formed))
            if floor >= _rhs_cost(recursive, "recursive"):
                recursive.metadata["formulation_costs"] = {
                    "kane": f">= {floor} (its LDLT alone)",
                    "recursive": _rhs_cost(recursive, "recursive")}
                return recursive
        kane = _generate_kane(kspec, functions, fold_parameters)
    except Exception as exc:          # noqa: BLE001 -- the recursive form works: keep it
        before = recursive.metadata.get("formulation_note")     # e.g. functions left out
        recursive.metadata["formulation_note"] = (f"recursive ({_reason(exc, 'kane')})"
                                                  + (f"; {before}" if before else ""))
        return recursive
    costs = {"kane": _rhs_cost(kane, "kane"), "recursive": _rhs_cost(recursive, "recursive")}
    lacks = _kane_lacks(kane, recursive)
    chosen = recursive if lacks or costs["recursive"] < costs["kane"] else kane
    chosen.metadata["formulation_costs"] = costs
    if lacks:
        before = recursive.metadata.get("formulation_note")
        recursive.metadata["formulation_note"] = (f"recursive (Kane's form has no {lacks})"
                                                  + (f"; {before}" if before else ""))
    return chosen


def _kane_lacks(kane, recursive):
    """The outputs and events the recursive candidate has and Kane's lacks, as words, or "".

    A URDF tree's Kane side is formed from its SymPy System, which carries no contact outputs
    (a robot with contacts is refused on Kane's route: auto keeps the recursive form) and had
    no joint-limit ones: a robot with limits and no contact had its ``energy`` output (the
    limits' springs, the run's energy verdict reads it) on the recursive side only, and picking
    Kane's rhs by cost dropped the output and the verdict (a 1-joint arm with a limit, session
    25).  Kane's route now makes the same output (eomc.compiler.urdf.model._kane_energy; on the
    example-robot-data trees auto compares, this finds nothing missing); this guard stays for
    anything else one side has and the other not: auto keeps the form that has everything the
    build evaluates."""
    words = []
    built = set(recursive.metadata.get("functions") or ())
    for key, what, uses in (("output_names", "output", {"outputs", "energy"}), ("events", "event", {"events"})):
        if not built & uses:          # not evaluated by this build (e.g. rhs only): nothing lost
            continue

        def names(meta):
            return [e["name"] if isinstance(e, dict) else e for e in meta.get(key) or ()]
        gone = [n for n in names(recursive.metadata) if n not in set(names(kane.metadata))]
        if gone:
            words.append(f"{what}{'s' * (len(gone) > 1)} " + ", ".join(gone))
    return " or ".join(words)
