"""Numerical comparison of symbolic matrices at random points (shared by the Lagrange tests).

Every dynamic symbol (and derivative) and every constant symbol is replaced by
a random value; both sides are evaluated with the same values in double
precision, and compared relative to the size of the entries.
"""
import numpy as np
import sympy as sm
from sympy.core.sorting import default_sort_key
from sympy.physics.mechanics import dynamicsymbols, find_dynamicsymbols

__all__ = ["random_values", "evaluate", "assert_same", "compile_matrix",
           "assert_same_at_seeds"]

_t = dynamicsymbols._t


def _atoms(mats):
    dyn, free = set(), set()
    for m in mats:
        m = sm.Matrix(m)
        dyn |= find_dynamicsymbols(m)
        free |= m.free_symbols
    return dyn, free


def random_values(mats, seed=0, low=0.5, high=1.5):
    """A dict {atom: float} covering every dynamic and constant symbol in ``mats``."""
    rng = np.random.default_rng(seed)
    dyn, free = _atoms(mats)
    atoms = sorted(dyn, key=default_sort_key) + sorted(free, key=default_sort_key)
    return {a: float(rng.uniform(low, high)) * (1 if rng.random() < 0.7 else -1)
            for a in atoms}


def compile_matrix(mat, keys):
    """A numpy function of the values of ``keys`` (a list) evaluating ``mat``."""
    dummies = {a: sm.Dummy() for a in keys}
    plain = sm.Matrix(mat).xreplace(dummies)  # top-down: q'(t) before q(t)
    left = find_dynamicsymbols(plain) | (plain.free_symbols - set(dummies.values()))
    assert not left, f"no value for {left}"
    f = sm.lambdify([list(dummies.values())], plain, "numpy")
    return lambda values: np.asarray(f([values[a] for a in keys]), dtype=float)


def evaluate(mat, values):
    """``mat`` as a float array at ``values``."""
    return compile_matrix(mat, list(values))(values)


def _close(x, y, rtol, what):
    assert x.shape == y.shape, (what, x.shape, y.shape)
    scale = max(1.0, float(np.max(np.abs(x))) if x.size else 1.0)
    err = float(np.max(np.abs(x - y))) if x.size else 0.0
    assert err <= rtol * scale, f"{what}: max |diff| {err:.3e} > {rtol:.0e} * {scale:.3e}"


def assert_same_at_seeds(pairs, seeds, rtol=1e-12):
    """``pairs`` of (name, ours, reference) agree at random values for every seed."""
    values = [random_values([ref for _, _, ref in pairs] + [o for _, o, _ in pairs], seed=s)
              for s in seeds]
    keys = list(values[0])
    for what, ours, ref in pairs:
        f, g = compile_matrix(ours, keys), compile_matrix(ref, keys)
        for vals in values:
            _close(f(vals), g(vals), rtol, what)


def assert_same(a, b, values, rtol=1e-12, what=""):
    """Assert two symbolic matrices agree numerically at ``values``."""
    _close(evaluate(a, values), evaluate(b, values), rtol, what)
