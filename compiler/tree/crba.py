"""Composite-rigid-body algorithm run once on symbols: the mass matrix M entry by entry.

Armature adds a to its joint's diagonal entry (see :mod:`.aba`).
"""
from .spatial import _dot, _sym6_plus, _times, xt_force, xt_inertia_x

__all__ = ["crba"]


def crba(bodies, rec):
    """Composite-rigid-body algorithm: {(row speed, column speed): M entry}, lower and upper."""
    n = len(bodies)
    Ic = [[row[:] for row in b.I] for b in bodies]
    H = {}
    for i in reversed(range(n)):
        b = bodies[i]
        Ii = rec.sym6(Ic[i])
        if b.parent >= 0:
            T = xt_inertia_x(b, rec, Ii)
            Ic[b.parent] = _sym6_plus(Ic[b.parent], T)
        if b.S is not None:
            columns = [(b.speed, b.S)]
        elif b.multi:
            columns = b.multi
        else:
            continue
        for col, (speed, S) in enumerate(columns):
            F = rec.vec(_times(Ii, S))
            for s2, S2 in columns[:col]:
                H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
            H[(speed, speed)] = rec.let(_dot(S, F) + b.armature[col])
            j = i
            while bodies[j].parent >= 0:
                F = rec.vec(xt_force(bodies[j], F))
                j = bodies[j].parent
                if bodies[j].S is not None:
                    H[(speed, bodies[j].speed)] = H[(bodies[j].speed, speed)] = rec.let(_dot(bodies[j].S, F))
                elif bodies[j].multi:
                    for s2, S2 in bodies[j].multi:
                        H[(speed, s2)] = H[(s2, speed)] = rec.let(_dot(S2, F))
    return H
