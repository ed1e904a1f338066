"""Recursive Newton-Euler run once on symbols: the generalized forces of given accelerations.

Armature adds a u'_i to its joint's force (see :mod:`.aba`).
"""
from .construct import _add, _mul
from .spatial import _dot, _root_acceleration, _times, cross_force, x_motion, xt_force

__all__ = ["rnea"]


def rnea(bodies, rec, speed_accels, gravity, v, c):
    """Recursive Newton-Euler: {speed index: generalized force} for given accelerations."""
    n = len(bodies)
    f = [None] * n
    a = [None] * n
    for i, b in enumerate(bodies):
        ap = a[b.parent] if b.parent >= 0 else _root_acceleration(gravity)
        ai = [_add((x, y)) for x, y in zip(x_motion(b, ap), c[i])]
        if b.S is not None:
            ai = [_add((ai[k], _mul(b.S[k], speed_accels[b.speed]))) for k in range(6)]
        elif b.multi:
            for s, S in b.multi:
                ai = [_add((ai[k], _mul(S[k], speed_accels[s]))) for k in range(6)]
        a[i] = rec.vec(ai)
        fi = [_add((x, y)) for x, y in zip(_times(b.I, a[i]), cross_force(v[i], _times(b.I, v[i])))]
        if b.fext is not None:
            fi = [_add((fi[k], -b.fext[k])) for k in range(6)]
        f[i] = fi
    tau = {}
    for i in reversed(range(n)):
        b = bodies[i]
        fi = rec.vec(f[i])
        if b.S is not None:
            tau[b.speed] = rec.let(_dot(b.S, fi) + b.armature[0] * speed_accels[b.speed])
        elif b.multi:
            for (s, S), arm in zip(b.multi, b.armature):
                tau[s] = rec.let(_dot(S, fi) + arm * speed_accels[s])
        if b.parent >= 0:
            fp = xt_force(b, fi)
            f[b.parent] = [_add((f[b.parent][k], fp[k])) for k in range(6)]
    return tau
