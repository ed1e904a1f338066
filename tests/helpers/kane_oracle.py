"""Helpers shared by the Kane tests: evaluate symbolic matrices at random points.

Every symbol, dynamic symbol and derivative gets a random value (the same
for both systems compared), the matrices are evaluated in 30-digit floats,
and compared with a relative tolerance.
"""
import random

import sympy as sm
from sympy.core.function import AppliedUndef

__all__ = ["random_point", "evaluate", "assert_close", "compare_kane"]


def _atoms(mats):
    out = set()
    for m in mats:
        for e in m:
            out |= e.atoms(AppliedUndef, sm.Derivative, sm.Symbol)
    return out


def random_point(mats, seed):
    rng = random.Random(seed)
    t = sm.Symbol("t")
    pt = {}
    for a in sorted(_atoms(mats), key=sm.default_sort_key):
        if a == t:
            continue
        pt[a] = sm.Float(rng.uniform(0.5, 1.5) * rng.choice([-1, 1]), 30)
    pt[t] = sm.Float(rng.uniform(0, 1), 30)
    return pt


def evaluate(mat, point):
    """Numeric value of ``mat`` at ``point``; derivatives are replaced before their functions."""
    derivs = {k: v for k, v in point.items() if isinstance(k, sm.Derivative)}
    rest = {k: v for k, v in point.items() if not isinstance(k, sm.Derivative)}
    return mat.xreplace(derivs).xreplace(rest).evalf(30)


def assert_close(a, b, rtol=1e-12, what=""):
    assert a.shape == b.shape, f"{what}: shapes {a.shape} != {b.shape}"
    scale = max([1.0] + [abs(float(x)) for x in b])
    for i, (x, y) in enumerate(zip(a, b)):
        assert abs(complex(x) - complex(y)) <= rtol * scale, \
            f"{what}[{i}]: {x} != {y} (scale {scale})"


def compare_kane(ours, ref, seeds=(1, 2), rhs=True, attrs=("mass_matrix_full", "forcing_full")):
    """Assert our KanesMethod matches SymPy's at random states."""
    mats = {a: (getattr(ours, a), getattr(ref, a)) for a in attrs}
    if rhs:
        mats["rhs"] = (ours.rhs(), ref.rhs())
    every = [m for pair in mats.values() for m in pair]
    for seed in seeds:
        pt = random_point(every, seed)
        for name, (x, y) in mats.items():
            assert_close(evaluate(x, pt), evaluate(y, pt), what=name)
