"""The :class:`~eomc.compiler.multibody.model.Model` of a joint tree: its state's variables.

A tree read from a SymPy System or KanesMethod (nothing formed) or built by a robot
reader becomes a Model here: coordinates and speeds in the tree's order, inputs and
parameters sorted by name, the loops' constraints -- what the model checks and the
generator read, as they read Kane's FormedSystem.
"""
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics import mechanics as me

from ..tree.model import tree_exprs
from ..tree.recognize import system_kinematics, tree_from_system
from .model import Frame, Model, Provenance

__all__ = ["tree_formed", "model_of_tree", "body_frames"]


def tree_formed(system):
    """The Model of a SymPy System with joints whose equations were not formed (only the
    recursive formulation generates it).  NotATree (naming the joint or body) when the
    recursion cannot take it."""
    tree = tree_from_system(system, system_kinematics(system))
    return model_of_tree(tree)     # the tree's coordinates and speeds are the System's


_IDENTITY = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def body_frames(tree):
    """A System's frames: each body of its tree, at its mass centre with its frame."""
    return tuple(Frame(b.name, i, _IDENTITY, (0, 0, 0)) for i, b in enumerate(tree.bodies))


def model_of_tree(tree, source=None, **fields):
    """The :class:`Model` of ``tree`` (see the module docstring): states in the tree's order,
    inputs and parameters sorted by name, its loops' constraints; ``fields``: what the
    reader adds (frames, poses, defaults, ...; a System's tree gets its bodies as frames)."""
    q, u = tuple(tree.coordinates), tuple(tree.speeds)
    t = me.dynamicsymbols._t
    states = set(q) | set(u)          # a set: membership in a tuple costs O(n) SymPy comparisons
    inputs, params = set(), set()
    for e in tree_exprs(tree):
        inputs |= {a for a in e.atoms(AppliedUndef) if a not in states}
        params |= {s for s in e.free_symbols if s != t}
    fields.setdefault("frames", body_frames(tree))
    model = Model(tree=tree, coordinates=q, speeds=u, kinematics=sm.Matrix(list(tree.kinematics)),
                  holonomic_constraints=sm.Matrix(), velocity_constraints=sm.Matrix(),
                  inputs=tuple(sorted(inputs, key=str)),
                  parameters=tuple(sorted(params, key=lambda s: s.name)),
                  source=source or Provenance("system"), **fields)
    from ..tree.constrained import with_loops     # loop-closing constraints, if the tree has any
    return with_loops(model, tree)
