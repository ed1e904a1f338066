"""Which run-time parameters are a body's mass or inertia: NAME.json ``body_parameters``.

Why: a SymPy script's ``m1`` is only a symbol to eomc, so ``--param m1=-1`` ran and ended at
t = 0 in "the mass matrix is singular ... a body with no mass", naming no parameter (issue 29
item 4, first hour s21 L3).  The bodies the user handed to ``kanes_equations`` say which
symbol is whose mass: this module records, per body whose mass or central inertia is made of
parameters, each entry as a monomial ``[coefficient, [[parameter, exponent], ...]]`` (a plain
number when it has no parameter), so that eomc.runtime.law_parameters can evaluate them for any
parameter vector and refuse a mass <= 0 or an inertia that is not positive semi-definite or
misses the triangle inequality, naming the parameter and the body -- the build's rule for a
robot's links (eomc.compiler.urdf.tree).  An entry that is not a monomial of parameters (a sum,
a function) leaves that part of the body unrecorded: nothing is guessed.

Robots read into the tree IR (a URDF or MJCF file under the recursive formulation, whose
Model has no SymPy bodies) are read from ``Model.tree``'s bodies (mass, central inertia in body
components): a URDF link's ``m_<link>`` and ``I.._<link>`` are run-time parameters (all of them
under ``all_inertial_parameters``), and ``--param m_<link>=-1`` ran unchecked.  A tree body's
inertia reduced to the part its motion excites (a planar chain's: one moment) is not recorded:
its mass still is.
"""
import sympy as sm

__all__ = ["body_parameters"]


def _monomial(expr, names):
    """``expr`` as a float, or ``[coefficient, [[name, exponent], ...]]`` over ``names``, or None."""
    expr = sm.sympify(expr)
    if expr.is_number:
        try:
            return float(expr)
        except (TypeError, ValueError):
            return None
    coeff, factors = expr.as_coeff_mul()
    powers = []
    for f in factors:
        base, exp = f.as_base_exp()
        if not (isinstance(base, sm.Symbol) and base in names and exp.is_Rational):
            return None
        powers.append([base.name, float(exp)])
    try:
        return [float(coeff), powers]
    except (TypeError, ValueError):
        return None


def _has_parameter(entry):
    return isinstance(entry, list)


def _central_inertia(body):
    """The body's central inertia as a 3x3 matrix in its own frame, or None."""
    frame = getattr(body, "frame", None)
    if frame is not None:         # a SymPy body
        try:
            return body.central_inertia.to_matrix(frame)
        except Exception:     # an inertia SymPy cannot move to the mass centre: not recorded
            return None
    inertia = getattr(body, "inertia", None)      # a tree IR body (compiler.tree.model.TreeBody)
    if not (isinstance(inertia, sm.MatrixBase) and inertia.shape == (3, 3)):
        return None
    # A tree keeps only the part of a body's inertia its motion can excite (tree.recognize.
    # effective_inertias: a planar chain's link feels a a^T I a a^T, one entry on the diagonal
    # when a is a frame axis); that is not the body's tensor, so it is not judged as one.
    return inertia if sum(inertia[k, k] != 0 for k in range(3)) >= 2 else None


def body_parameters(system, parameters):
    """[{"body": name, "mass": entry or absent, "inertia": 3x3 entries or absent}] for the bodies of
    ``system`` (a KanesMethod/LagrangesMethod/System with ``bodies``, or a tree IR
    (compiler.tree.model.Tree) whose bodies carry ``mass`` and a central ``inertia`` matrix) whose
    mass or central inertia involves one of ``parameters`` (symbols).  [] when the system has no
    such bodies."""
    names = set(parameters or ())
    found = []
    for body in getattr(system, "bodies", None) or ():
        name = getattr(body, "name", None)
        mass = getattr(body, "mass", None)
        if name is None or mass is None:
            continue
        row = {"body": str(name)}
        m = _monomial(mass, names)
        if _has_parameter(m):
            row["mass"] = m
        matrix = _central_inertia(body)
        if matrix is not None:
            entries = [[_monomial(matrix[i, j], names) for j in range(3)] for i in range(3)]
            if all(e is not None for r in entries for e in r) and any(_has_parameter(e) for r in entries
                                                                       for e in r):
                row["inertia"] = entries
        if len(row) > 1:
            found.append(row)
    return found
