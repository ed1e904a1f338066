"""The recursions' input: a tree body in slot symbols, its transform's entries named once.

A body's transform from its parent is E (parent to body components) and r (body origin
from the parent origin, parent components).  Joints of k > 1 speeds carry ``multi``
(see :mod:`.aba`); armature is an inertia on a joint's own speed (M_ii += a).
"""
__all__ = ["LoweredBody"]


class LoweredBody:
    """A TreeBody in slot symbols, with its transform's entries named once."""

    def __init__(self, body, rec, E, r, S, mass, inertia, fext, multi=None, armature=None):
        self.parent, self.speed, self.name, self.joint = body.parent, body.speed, body.name, body.joint
        self.multi = multi         # [(speed index, 6-list axis)] of a k > 1 speed joint, else None
        # per speed (S's, or multi's in order): the armature, in slot symbols (zeros when none)
        self.armature = list(armature) if armature else [0] * (1 if S is not None else len(multi or ()))
        self.E = [[rec.let(E[i, j]) for j in range(3)] for i in range(3)]
        self.r = rec.vec(r)
        self.S = list(S) if S is not None else None
        m = mass
        Ic = inertia
        self.I = [[Ic[i, j] if i < 3 and j < 3 else 0 for j in range(6)] for i in range(6)]
        for k in range(3, 6):
            self.I[k][k] = m
        self.fext = fext           # 6-list or None
