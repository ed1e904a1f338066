"""Which formulation generates a model: Kane's (formed A, b and a numeric LDLᵀ) or the
recursive one (ABA/RNEA/CRBA over the tree).

``auto`` builds the tree when the system is one, lowers both formulations and
keeps the one whose rhs has fewer operations (all requested functions' operations
when rhs is not requested).  Lowering Kane's form of a large tree is the costly
part of a build (minutes at 40 bodies), and there its rhs cannot win: it must at
least factor and solve the formed mass matrix.  So the recursive form is lowered
first, and Kane's is skipped when the LDLᵀ of its mass matrix alone (counted
exactly as the emitter would write it, from the formed matrix's nonzeros) already
costs as much as the whole recursive rhs.  A System without formed equations has no Kane form
to compare with: forming it costs more than the whole recursive build, so auto
takes the recursive one there.
"""
import sympy as sm
from sympy.physics import mechanics as me

from eomc.runtime.errors import ModelError

from ..mechanics.formed import FormedSystem
from .formed import tree_exprs
from .model import NotATree
from .recognize import tree_of

__all__ = ["FORMULATIONS", "generate_formulation", "check_formulation", "tree_digest"]

FORMULATIONS = ("auto", "kane", "recursive")


def check_formulation(formulation):
    if formulation not in FORMULATIONS:
        raise ModelError(f"unknown formulation {formulation!r}; choose from {', '.join(FORMULATIONS)}")
    return formulation


def tree_digest(spec):
    """The tree's expressions and shape (each body's parent and speed: two trees can have
    the same expressions and differ only there), for the generation cache key of a
    formed-less System."""
    tree = getattr(spec.formed, "_tree", None)
    if tree is None:
        return None
    # per body: parent, then its speed (>= 0), -1 (fixed) or -2-k followed by a k-speed joint's speeds
    shape = [(b.parent, b.speed) if b.speed is not None else
             (b.parent, -2 - len(b.speeds)) + tuple(b.speeds) if b.speeds else (b.parent, -1)
             for b in tree.bodies]
    return tree_exprs(tree) + [sm.Integer(k) for pair in shape for k in pair]


def _find_tree(spec):
    tree = getattr(spec.formed, "_tree", None)
    if tree is not None:
        return tree
    if spec.system is None or isinstance(spec.system, FormedSystem):
        raise NotATree("only a FormedSystem was given (pass the System or KanesMethod itself)")
    if spec.formed.method != "kane" and not isinstance(spec.system, me.System):
        raise NotATree(f"the system was formed by {spec.formed.method}'s method")
    return tree_of(spec.system, spec.formed)


def _kane_formed(spec):
    """The Kane FormedSystem.  An unformed System reaches here formed already: model_spec
    forms it with eomc's Kane when the kane formulation is asked for."""
    if spec.formed.method == "tree":
        raise ModelError("the kane formulation needs formed equations; this System was read as a "
                         "joint tree only (compile it with formulation='kane' from the start)")
    return spec.formed


def _rhs_cost(generated):
    counts = generated.metadata["op_counts"]
    fns = ["rhs"] if "rhs" in counts else [f for f in counts if counts[f]]
    return sum(sum(counts[f].values()) for f in fns if counts[f])


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


def generate_formulation(spec, functions, fold_parameters, formulation="kane"):
    """GeneratedModel of ``spec`` in the requested formulation (see module docstring)."""
    from ..emit import generate_c
    check_formulation(formulation)
    options = dict(parameters=spec.parameters, inputs=spec.inputs, outputs=spec.outputs,
                   functions=functions, fold_parameters=fold_parameters, events=spec.events,
                   event_options=spec.event_options, poses=getattr(spec, "poses", None))
    if formulation == "kane":
        return generate_c(_kane_formed(spec), spec.name, **options)
    try:
        tree = _find_tree(spec)
    except NotATree as exc:
        if formulation == "recursive":
            raise recursive_refusal(exc) from None
        generated = generate_c(spec.formed, spec.name, **options)
        generated.metadata["formulation_note"] = f"kane, the fallback (not a tree: {exc})"
        return generated
    recursive = generate_c(spec.formed, spec.name, tree=tree, **options)
    if formulation == "recursive" or spec.formed.method == "tree":
        return recursive
    if "rhs" in functions and spec.formed.method == "kane":
        floor = kane_solve_floor(spec.formed)
        if floor >= _rhs_cost(recursive):
            recursive.metadata["formulation_costs"] = {"kane": f">= {floor} (its LDLT alone)",
                                                       "recursive": _rhs_cost(recursive)}
            return recursive
    kane = generate_c(spec.formed, spec.name, **options)
    chosen = recursive if _rhs_cost(recursive) < _rhs_cost(kane) else kane
    chosen.metadata["formulation_costs"] = {"kane": _rhs_cost(kane), "recursive": _rhs_cost(recursive)}
    return chosen
