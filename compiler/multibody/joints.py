"""Joint formulas shared by the robot readers: literals, symbols for numbers, rotation terms.

Why here: a URDF joint and an MJCF joint are the same mobilizer -- a rotation
R_PC(q) = A cos q + B sin q + C about an axis (Rodrigues), a translation along one, a
parameter symbol per non-zero number -- and the readers must write them identically (the
generated C of a URDF robot and of its MJCF twin agree).  Both readers
(eomc.compiler.urdf.treeir, eomc.compiler.mjcf.treeir) take them from this module.
"""
import re

import numpy as np
import sympy as sm

from ..tree.spatial import cross
from eomc.compiler import fixed_order as fo

__all__ = ["snap", "snapped", "Parameters", "lin", "rotation_terms", "cross", "times", "vec", "z_to",
           "actuation", "identifier"]

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


def identifier(name):
    """``name`` as a C identifier fragment: other characters become ``_`` (every reader names
    its symbols q_<joint>, m_<body>, ... with it)."""
    text = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return text if text and not text[0].isdigit() else f"_{text}"


class Parameters:
    """Named symbols for non-zero numbers; exact zeros (and ``fold``) stay literal (as the
    URDF System path writes them; the readers check that names are distinct).  ``values``:
    symbol -> the number, the parameters' defaults."""

    def __init__(self, fold):
        self.fold, self.values = fold, {}

    def __call__(self, name, value, keep=False):
        """``keep``: a symbol even at 0 (a joint limit's position: a knee's range starts at 0,
        and the runtime finds a limit by its parameter, runtime/switching.find_switches)."""
        value = float(value)
        if value == 0.0 and not (keep and not self.fold):
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
    return (snapped(fo.matmul(R0, np.eye(3) - aa)), snapped(fo.matmul(R0, ax)), snapped(fo.matmul(R0, aa)))


def times(M, v):
    """Numeric 3x3 (snapped literals) times a symbolic 3-vector."""
    return [sum((snap(M[i, k]) * v[k] for k in range(3) if snap(M[i, k]) != 0 and v[k] != 0), sm.S.Zero)
            for i in range(3)]


def vec(values):
    """A vector of numbers as snapped SymPy literals."""
    return [snap(v) for v in values]


def z_to(axis):
    """A rotation matrix whose third column is the unit vector ``axis`` (exact for ±x, ±y, ±z)."""
    z = np.asarray(axis, dtype=float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - fo.dot(helper, z) * z
    x /= fo.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def actuation(sliding, tau, a, R0, c, p, cp, child, parent):
    """A joint's torque (a hinge: ``sliding`` false) or force (a slide) ``tau`` along its axis
    ``a`` on the child tree body and its reaction on the parent (none on the ground: it does
    no work), as the Tree's loads in body components (``R0``: the joint's rotation at q = 0;
    ``c``/``cp``: the child's and parent's mass centres, ``p``: the joint's origin in the
    parent)."""
    from eomc.compiler.tree.model import Load
    zero = sm.zeros(3, 1)
    on_child = sm.Matrix([snap(v) * tau for v in a])
    on_parent = sm.Matrix([-snap(v) * tau for v in snapped(fo.matmul(R0, a))])
    out = []
    if sliding:
        out.append(Load(body=child, frame="body", moment=zero, force=on_child,
                        offset=sm.Matrix([-x for x in c])))
        if parent >= 0:
            out.append(Load(body=parent, frame="body", moment=zero, force=on_parent,
                            offset=sm.Matrix([p[k] - cp[k] for k in range(3)])))
        return out
    out.append(Load(body=child, frame="body", moment=on_child, force=zero, offset=zero))
    if parent >= 0:
        out.append(Load(body=parent, frame="body", moment=on_parent, force=zero, offset=zero))
    return out
