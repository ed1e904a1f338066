"""The recursions' input: a tree body in slot symbols, its transform's entries named once.

A body's transform from its parent is E (parent to body components) and r (body origin
from the parent origin, parent components).  Joints of k > 1 speeds carry ``multi``
(see :mod:`.aba`); armature is an inertia on a joint's own speed (M_ii += a).

``axis``: when E is a turn about one of the body's coordinate axes (a revolute joint
about x, y or z with no fixed rotation before it: most joints of the URDF robots), the
indices (k, i, j) with E_kk = 1, row and column k otherwise zero and the 2x2 block
[[E_ii, E_ij], [E_ji, E_jj]] = [[c, s], [-s, c]] -- then a symmetric 3x3 turns by the
double angle in fewer operations (:func:`.spatial.xt_inertia_x`); None for any other E.
"""
import sympy as sm

__all__ = ["LoweredBody"]


def axis_turn(E):
    """(k, i, j) of a turn about coordinate axis k (see the module docstring), or None.
    Judged on E's expressions: the pattern must hold structurally, not by value, so a
    constant fixed rotation (an identity included, whose s is zero) is None."""
    for k in range(3):
        i, j = [m for m in range(3) if m != k]
        if E[k, k] != 1 or any(E[k, m] != 0 or E[m, k] != 0 for m in (i, j)):
            continue
        c, s = E[i, i], E[i, j]
        if s != 0 and not s.is_number and sm.expand(E[j, j] - c) == 0 and sm.expand(E[j, i] + s) == 0:
            return k, i, j
    return None


class LoweredBody:
    """A TreeBody in slot symbols, with its transform's entries named once."""

    def __init__(self, body, rec, E, r, S, mass, inertia, fext, multi=None, armature=None):
        self.parent, self.speed, self.name, self.joint = body.parent, body.speed, body.name, body.joint
        self.multi = multi         # [(speed index, 6-list axis)] of a k > 1 speed joint, else None
        # per speed (S's, or multi's in order): the armature, in slot symbols (zeros when none)
        self.armature = list(armature) if armature else [0] * (1 if S is not None else len(multi or ()))
        self.axis = axis_turn(E)
        self.E = [[rec.let(E[i, j]) for j in range(3)] for i in range(3)]
        self.r = rec.vec(r)
        self.S = list(S) if S is not None else None
        m = mass
        Ic = inertia
        self.I = [[Ic[i, j] if i < 3 and j < 3 else 0 for j in range(6)] for i in range(6)]
        for k in range(3, 6):
            self.I[k][k] = m
        self.fext = fext           # 6-list or None
