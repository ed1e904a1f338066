"""Joint formulas shared by the robot readers: literals, symbols for numbers, rotation terms.

Why here: a URDF joint and an MJCF joint are the same mobilizer -- a rotation
R_PC(q) = A cos q + B sin q + C about an axis (Rodrigues), a translation along one, a
parameter symbol per non-zero number -- and the readers must write them identically (the
generated C of a URDF robot and of its MJCF twin agree).  Both readers
(eomc.compiler.urdf.treeir, eomc.compiler.mjcf.treeir) take them from this module.
"""
import numpy as np
import sympy as sm

__all__ = ["snap", "snapped", "Parameters", "lin", "rotation_terms", "cross", "times", "vec"]

_SNAP = 1e-12


def snap(value):
    """A float as the SymPy literal the System path writes: exact 0 and ±1 for numbers
    within 1e-12 of them (as eomc.compiler.urdf.system does), else a 17-digit Float."""
    for exact in (0, 1, -1):
        if abs(value - exact) < _SNAP:
            return sm.Integer(exact)
    return sm.Float(float(value), 17)


def snapped(array):
    """A numpy array with entries within 1e-12 of 0, ±1 made exact (floats still)."""
    out = np.array(array, dtype=float)
    for exact in (0.0, 1.0, -1.0):
        out[np.abs(out - exact) < _SNAP] = exact
    return out


class Parameters:
    """Named symbols for non-zero numbers; exact zeros (and ``fold``) stay literal (as the
    URDF System path writes them; the readers check that names are distinct).  ``values``:
    symbol -> the number, the parameters' defaults."""

    def __init__(self, fold):
        self.fold, self.values = fold, {}

    def __call__(self, name, value):
        value = float(value)
        if value == 0.0:
            return sm.Integer(0)
        if self.fold:
            return snap(value)
        symbol = sm.Symbol(name)
        self.values[symbol] = value
        return symbol


def lin(coefficients, functions):
    """sum(c_k f_k) for numeric c_k (snapped), zero terms dropped."""
    out = sm.S.Zero
    for c, f in zip(coefficients, functions):
        c = snap(c)
        if c != 0:
            out += c * f if f != 1 else c
    return out


def rotation_terms(R0, axis):
    """R_PC = A cos q + B sin q + C for R_PC = R0 Rot(axis, q) (Rodrigues), as numbers."""
    a = np.asarray(axis, dtype=float)
    ax = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    aa = np.outer(a, a)
    return (snapped(R0 @ (np.eye(3) - aa)), snapped(R0 @ ax), snapped(R0 @ aa))


def cross(a, b):
    """a x b of two 3-vectors (lists of expressions)."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def times(M, v):
    """Numeric 3x3 (snapped literals) times a symbolic 3-vector."""
    return [sum((snap(M[i, k]) * v[k] for k in range(3) if snap(M[i, k]) != 0 and v[k] != 0), sm.S.Zero)
            for i in range(3)]


def vec(values):
    """A vector of numbers as snapped SymPy literals."""
    return [snap(v) for v in values]
