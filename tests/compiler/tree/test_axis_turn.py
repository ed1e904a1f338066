"""The double-angle turn of an articulated inertia (spatial.xt_inertia_x when E turns about one
body axis, issue 31's operation count) equals the general Eᵀ I E and shift it replaces."""
import numpy as np
import pytest
import sympy as sm

from eomc.compiler.tree.lowered import axis_turn
from eomc.compiler.tree.recorder import Recorder
from eomc.compiler.tree.spatial import xt_inertia_x


class _Body:
    def __init__(self, E, r, axis):
        self.E, self.r, self.axis = E, r, axis


def _turns(k, q, sign):
    c, s = sm.cos(q), sign * sm.sin(q)
    i, j = [m for m in range(3) if m != k]
    E = sm.zeros(3, 3)
    E[k, k] = 1
    E[i, i], E[i, j], E[j, i], E[j, j] = c, s, -s, c
    return E


def _evaluate(rec, M, q, value):
    env = {q: value}
    for sym, expr in rec.assignments:
        env[sym] = float(sm.sympify(expr).xreplace(env))
    return np.array([[float(sm.sympify(x).xreplace(env)) for x in row] for row in M])


@pytest.mark.parametrize("k", [0, 1, 2])
@pytest.mark.parametrize("sign", [1, -1])
def test_turn_matches_general_transform(k, sign):
    """Random symmetric 6x6 (general B block) and shift: the turned form equals the general one."""
    rng = np.random.default_rng(10 * k + sign + 1)
    q = sm.Symbol("q", real=True)
    E = _turns(k, q, sign)
    assert axis_turn(E) is not None
    X = rng.normal(size=(6, 6))
    I = (X + X.T).tolist()
    r = [sm.Float(v) for v in rng.normal(size=3)]
    out = []
    for axis in (axis_turn(E), None):
        rec = Recorder()
        b = _Body([[rec.let(E[a, c]) for c in range(3)] for a in range(3)], r, axis)
        out.append(_evaluate(rec, xt_inertia_x(b, rec, [[sm.Float(v) for v in row] for row in I]), q, 0.7))
    assert np.max(np.abs(out[0] - out[1])) < 1e-13 * np.max(np.abs(out[1]))


def test_other_rotations_take_the_general_path():
    """A constant rotation (the identity included), a turn after a fixed rotation and a turn
    whose cosines differ are not the pattern."""
    q = sm.Symbol("q", real=True)
    assert axis_turn(sm.eye(3)) is None
    R0 = sm.Matrix([[0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    assert axis_turn(_turns(0, q, 1) * R0) is None
    E = _turns(2, q, 1)
    E[1, 1] = sm.cos(2 * q)
    assert axis_turn(E) is None
