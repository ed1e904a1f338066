"""Linearization of a model with quaternion coordinates in their 3-angle tangent chart.

Why this module: a unit quaternion (MJCF free and ball joints by default) is 4 coordinates for 3
degrees of freedom, so ``model.linearize``'s A, taken over all 4, has a direction that is no
motion: the quaternion's length (the rhs does not depend on it, and it never changes along a
run -- the integrators keep it 1).  That direction adds a zero eigenvalue to A's spectrum which
no physics explains, and an LQR designed on A sees a state it cannot control.  Here each
quaternion q of the operating point is replaced by a rotation vector dtheta in the body frame,

    q = q0 (x) Exp(dtheta),   Exp(dtheta) = (cos |dtheta|/2, sin(|dtheta|/2) dtheta/|dtheta|),

the chart MuJoCo's own derivatives use (mjd_transitionFD: tangent space of qpos) and the one
the joint's speeds live in (q' = q (x) (0, w) / 2, w the body-frame angular speed).  So
dx = T dxi with T's quaternion block dq/ddtheta = L(q0)[:, 1:] / 2 (L: left multiplication by
q0), and back dxi = S dx with S's block 2 L(q0)[:, 1:]^T (S T = 1; S kills the length
direction q0).  The linearization in the chart is

    dxi' = S A T dxi + S B dr,

exact at every operating point, not only at equilibria: d(S(xi))/dxi . f vanishes in the chart
(the term from the changing S and the one from Exp's Jacobian cancel: dtheta' = w + O(dtheta^2)
along the exact flow, as J_r(dtheta)^-1 w differs from w by dtheta x w / 2, which S A T already
holds through the quaternion rows' dependence on q).  The chart's states are named after the
quaternion's: q_<joint>_qw..qz become q_<joint>_rotx, _roty, _rotz.
"""
from collections import namedtuple

import numpy as np

__all__ = ["TangentChart", "tangent_chart", "linearize_tangent", "ReducedLinearization"]

# Defined here, not in reduced.py, so that the import runs one way (reduced -> tangent): reduced.py
# re-exports it and reads tangent_chart.
ReducedLinearization = namedtuple("ReducedLinearization", "A B states basis")
ReducedLinearization.__doc__ = """A (n x n), B (n x ninput) over the independent ``states`` (names,
model order); ``basis`` T (nx x n) maps their perturbations to the full state's."""

TangentChart = namedtuple("TangentChart", "T S states x columns")
TangentChart.__doc__ = """T (nx x n) maps the chart's perturbations to the full state's, S (n x nx)
the full state's back (S T = 1), ``states`` the chart's names, ``x`` the operating point with its
quaternions made unit, ``columns`` each full state's column in the chart (-1: a quaternion's)."""


def _left(q):
    """L(q): q (x) p = L(q) p for quaternions (w, x, y, z)."""
    w, a, b, c = q
    return np.array([[w, -a, -b, -c], [a, w, -c, b], [b, c, w, -a], [c, -b, a, w]])


def _chart_name(name):
    """q_<joint>_qw -> q_<joint>_rot (the rotation vector's components get x, y, z)."""
    return (name[:-2] if name.endswith("qw") else name + "_") + "rot"


def tangent_chart(model, x):
    """The chart of the module docstring at the state ``x`` (a model without quaternions: T = S = 1)."""
    x = np.array(x, dtype=np.float64)
    starts = set(getattr(model, "quaternions", ()) or ())
    names = list(model.state_names)
    n = model.nx - len(starts)
    T, S = np.zeros((model.nx, n)), np.zeros((n, model.nx))
    states, columns, i, j = [], [], 0, 0
    while i < model.nx:
        if i in starts:
            norm = np.linalg.norm(x[i:i + 4])
            if not (norm > 1e-150 and np.isfinite(norm)):
                raise ValueError(f"{model.name}: the quaternion ({', '.join(names[i:i + 4])}) of the operating "
                                 f"point is {'zero' if np.isfinite(norm) else 'not finite'}: it is no orientation "
                                 f"(upright is {names[i]}=1, the others 0)")
            x[i:i + 4] /= norm
            K = _left(x[i:i + 4])[:, 1:]
            T[i:i + 4, j:j + 3] = 0.5 * K
            S[j:j + 3, i:i + 4] = 2.0 * K.T
            base = _chart_name(names[i])
            states += [base + "x", base + "y", base + "z"]
            columns += [-1] * 4
            i, j = i + 4, j + 3
        else:
            T[i, j] = S[j, i] = 1.0
            states.append(names[i])
            columns.append(j)
            i, j = i + 1, j + 1
    return TangentChart(T, S, tuple(states), x, tuple(columns))


def linearize_tangent(model, t, x, p=None, r=None):
    """(A, B, states, basis) with each quaternion in its tangent chart (the module docstring):
    A = S A_full T, B = S B_full at ``x`` (its quaternions made unit first), ``basis`` = T.
    A model without quaternions: model.linearize's A and B, basis 1."""
    chart = tangent_chart(model, x)
    A, B = model.linearize(t, chart.x, p, r)
    if not getattr(model, "quaternions", ()):
        return ReducedLinearization(A, B, chart.states, chart.T)
    return ReducedLinearization(chart.S @ A @ chart.T, chart.S @ B, chart.states, chart.T)
