"""Which formulation generates a model: Kane's (formed A, b and a numeric LDLᵀ) or the
recursive one (ABA/RNEA/CRBA over the tree).

``auto`` builds the tree when the system is one, lowers both formulations and
keeps the one whose rhs has fewer operations (all requested functions' operations
when rhs is not requested).  A System without formed equations has no Kane form
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
    shape = [(b.parent, -1 if b.speed is None else b.speed) for b in tree.bodies]
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


def generate_formulation(spec, functions, fold_parameters, formulation="kane"):
    """GeneratedModel of ``spec`` in the requested formulation (see module docstring)."""
    from ..emit import generate_c
    check_formulation(formulation)
    options = dict(parameters=spec.parameters, inputs=spec.inputs, outputs=spec.outputs,
                   functions=functions, fold_parameters=fold_parameters, events=spec.events,
                   event_options=spec.event_options)
    if formulation == "kane":
        return generate_c(_kane_formed(spec), spec.name, **options)
    try:
        tree = _find_tree(spec)
    except NotATree as exc:
        if formulation == "recursive":
            raise ModelError(f"recursive formulation: {exc} (formulation 'kane' takes it, and "
                             f"'auto' falls back to kane)") from None
        generated = generate_c(spec.formed, spec.name, **options)
        generated.metadata["formulation_note"] = f"kane, the fallback (not a tree: {exc})"
        return generated
    recursive = generate_c(spec.formed, spec.name, tree=tree, **options)
    if formulation == "recursive" or spec.formed.method == "tree":
        return recursive
    kane = generate_c(spec.formed, spec.name, **options)
    chosen = recursive if _rhs_cost(recursive) < _rhs_cost(kane) else kane
    chosen.metadata["formulation_costs"] = {"kane": _rhs_cost(kane), "recursive": _rhs_cost(recursive)}
    return chosen
