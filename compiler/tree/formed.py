"""The FormedSystem of a SymPy System of joints whose equations were never formed.

Its method is "tree": it has coordinates, speeds, kinematics, inputs and
parameters, but no A and b, so only the recursive formulation generates it;
the Tree found on the way is kept on it for the generator.
"""
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics import mechanics as me

from ..mechanics.formed import FormedSystem
from .recognize import system_kinematics, tree_from_system

__all__ = ["tree_formed", "tree_exprs", "formed_of_tree"]


def tree_exprs(tree):
    out = list(tree.kinematics) + list(tree.gravity)
    for b in tree.bodies:
        out += list(b.rotation) + list(b.position) + list(b.motion or ()) + [b.mass] + list(b.inertia)
        out += [c for m in b.motions for c in m] + list(b.armature)
    for load in tree.loads:
        out += list(load.moment) + list(load.force) + list(load.offset)
        out += list(getattr(load, "exprs", ()))      # a ground contact's parameters (compiler/contact)
    return [sm.sympify(e) for e in out]


def tree_formed(system):
    """FormedSystem of a SymPy System with joints whose equations were not formed
    (method "tree": no A and b; only the recursive formulation can generate it).
    NotATree (naming the joint or body) when the recursion cannot take it."""
    tree = tree_from_system(system, system_kinematics(system))
    formed = formed_of_tree(tree)     # the tree's coordinates and speeds are the System's
    return formed


def formed_of_tree(tree):
    """The FormedSystem (method "tree") of a Tree built directly, not read from a System
    (the URDF reader's, eomc.compiler.urdf.treeir): the same record :func:`tree_formed`
    makes -- states in the tree's order, inputs and parameters sorted by name, the tree
    kept on it for the generator -- without any SymPy mechanics object."""
    q, u = tuple(tree.coordinates), tuple(tree.speeds)
    t = me.dynamicsymbols._t
    states = set(q) | set(u)          # a set: membership in a tuple costs O(n) SymPy comparisons
    inputs, params = set(), set()
    for e in tree_exprs(tree):
        inputs |= {a for a in e.atoms(AppliedUndef) if a not in states}
        params |= {s for s in e.free_symbols if s != t}
    nu = len(u)
    formed = FormedSystem(method="tree", coordinates=q, speeds=u, n_dependent_coordinates=0,
                          n_dependent_speeds=0, kinematics=sm.Matrix(list(tree.kinematics)),
                          dynamics_matrix=sm.zeros(nu, nu), dynamics_rhs=sm.zeros(nu, 1),
                          multipliers=(), holonomic_constraints=sm.Matrix(),
                          velocity_constraints=sm.Matrix(),
                          inputs=tuple(sorted(inputs, key=str)),
                          parameters=tuple(sorted(params, key=lambda s: s.name)))
    object.__setattr__(formed, "_tree", tree)
    from .constrained import with_loops     # loop-closing constraints, if the tree has any
    return with_loops(formed, tree)
