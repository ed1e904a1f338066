"""The forward pass every recursion starts from: body velocities and velocity-product accelerations."""
from .construct import _add, _mul
from .spatial import cross_motion, x_motion

__all__ = ["velocities"]


def velocities(bodies, rec, speeds, root_v=None):
    """Body spatial velocities v_i and velocity-product accelerations c_i (``root_v``: a root's
    parent's velocity, for a part of a tree (:mod:`.limbs`); default the ground's, 0)."""
    v, c = [], []
    for b in bodies:
        vp = v[b.parent] if b.parent >= 0 else root_v or [0] * 6
        vi = x_motion(b, vp)
        if b.S is not None:
            vj = [_mul(s, speeds[b.speed]) for s in b.S]
            vi = [_add((vi[k], vj[k])) for k in range(6)]
            vi = rec.vec(vi)
            c.append(rec.vec(cross_motion(vi, vj)))
        elif b.multi:
            vj = [_add([_mul(S[k], speeds[s]) for s, S in b.multi]) for k in range(6)]
            vi = rec.vec([_add((vi[k], vj[k])) for k in range(6)])
            c.append(rec.vec(cross_motion(vi, vj)))
        else:
            vi = rec.vec(vi)
            c.append([0] * 6)
        v.append(vi)
    return v, c
