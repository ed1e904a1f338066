"""Where each body of a joint tree is: its world rotation and origin, placed from its parent's.

One job, written once for every consumer that lowers positions along the tree into a
program: frame outputs (:mod:`.frames`), ground contacts and other velocity-dependent
loads (:mod:`.contacts`).  Why along the tree and named: a body's rotation is its parent's
times its joint's, its origin its parent's plus the joint offset turned into the world, so
each entry is one named temporary (``let``: the recursion's Recorder) and a body at depth d
costs O(1) code beyond its parent's, never the nested SymPy products of the whole chain.

The convention: ``rotation(i)[a][c]`` is the world component a of body i's axis c (world
<- body; rows of :func:`to_world`), ``origin(i)`` the body's origin in the world.  A
body's ``E`` (the tree's ``rotation``: parent -> body components) and ``r`` (its origin
from the parent's, parent components) come from the caller, already in the program's
symbols.  Each body is placed once, parents first, when first asked for; ``by_columns``
names a rotation's entries column by column (the order the contact lowering has always
emitted them in; frames name them row by row), so the generated C stays what it was.
"""
import sympy as sm

__all__ = ["Placement", "IDENTITY", "ZERO"]

_ONE, _ZERO = sm.S.One, sm.S.Zero
IDENTITY = tuple(tuple(_ONE if a == c else _ZERO for c in range(3)) for a in range(3))
ZERO = (_ZERO, _ZERO, _ZERO)


class Placement:
    """World rotations and origins of a tree's bodies (see the module docstring).

    ``parents``: each body's parent index (-1: the ground), parents before children;
    ``E(i)``/``r(i)``: the body's joint rotation (3x3 rows, parent -> body components) and
    origin offset (3, parent components); ``let``: names an expression (a Recorder's)."""

    def __init__(self, parents, E, r, let, by_columns=False):
        self.parents, self._E, self._r, self.let, self.by_columns = list(parents), E, r, let, by_columns
        self.R, self.p, self.arms = {}, {}, {}

    def _chain(self, i, done):
        """Bodies from ``i`` up to the first one in ``done`` (exclusive), deepest first."""
        chain = []
        while i >= 0 and i not in done:
            chain.append(i)
            i = self.parents[i]
        return chain

    def rotation(self, i):
        """Body i's axes in world components (i < 0: the ground's, the identity)."""
        if i < 0:
            return IDENTITY
        for j in reversed(self._chain(i, self.R)):
            self.R[j] = self._rotated(j)
        return self.R[i]

    def _rotated(self, j):
        Rp, E, let = self.rotation(self.parents[j]), self._E(j), self.let
        R = [[None] * 3 for _ in range(3)]
        order = ([(a, c) for c in range(3) for a in range(3)] if self.by_columns else
                 [(a, c) for a in range(3) for c in range(3)])
        for a, c in order:
            R[a][c] = let(_dot(Rp[a], E[c]))
        return R

    def origin(self, i):
        """Body i's origin in the world (i < 0: the world's origin).  Its parent's rotation
        is placed first (and with it every ancestor's), then the origins from the root down."""
        if i < 0:
            return ZERO
        chain = self._chain(i, self.p)
        if chain:
            self.rotation(self.parents[chain[0]])
        for j in reversed(chain):
            parent = self.parents[j]
            Rp, pp = self.rotation(parent), self.origin(parent)
            arm = to_world(Rp, self._r(j))
            self.arms[j] = arm
            self.p[j] = [self.let(pp[k] + arm[k]) for k in range(3)]
        return self.p[i]

    def fork(self, let):
        """This placement naming anything not yet placed with ``let`` (a forked Recorder's),
        leaving this one as it is."""
        other = Placement(self.parents, self._E, self._r, let, self.by_columns)
        other.R, other.p, other.arms = dict(self.R), dict(self.p), dict(self.arms)
        return other

    def world_to_body(self, i):
        """Body i's rotation as rows world -> body components: the transpose of
        :meth:`rotation` (the same named entries, nothing new emitted)."""
        R = self.rotation(i)
        return [[R[s][r] for s in range(3)] for r in range(3)]

    def arm(self, i):
        """Body i's origin from its parent's, world components (as placed; not named)."""
        self.origin(i)
        return self.arms[i]

    def to_world(self, i, v):
        """Body i's components of ``v`` -> world components (unnamed expressions)."""
        return to_world(self.rotation(i), v)

    def to_body(self, i, v):
        """World components of ``v`` -> body i's components (unnamed expressions)."""
        return to_body(self.rotation(i), v)


def to_world(R, v):
    """R v: body components -> world (R: world <- body, rows)."""
    return [_dot(R[a], v) for a in range(3)]


def to_body(R, v):
    """Rᵀ v: world components -> body."""
    return [_dot([R[k][a] for k in range(3)], v) for a in range(3)]


def _dot(xs, ys):
    """``sum(x * y for x, y in zip(xs, ys))`` as SymPy builds it (the same sums in the same
    order), without asking SymPy for the products with an exact 0 (then nothing is added) or 1
    (then the other factor).  Why: half of G1's rotation products are such (a joint's axis
    rotation has four zeros and a one): SymPy's Mul and Add of them were ~0.07 s of its
    default build (the energy's and the poses' placements)."""
    total = _ZERO
    for x, y in zip(xs, ys):
        if x is _ZERO or y is _ZERO:
            continue
        total += y if x is _ONE else (x if y is _ONE else x * y)
    return total
