"""Checking and normalising what a user hands to KanesMethod.

Everything here turns malformed input into :class:`eomc.runtime.errors.ModelError`
with a message that names the offending symbol, load, body or equation, so
a user never has to read a traceback from deep inside SymPy.
"""
import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.mechanics import Particle, Point, ReferenceFrame, RigidBody
from sympy.physics.vector import Vector, dynamicsymbols

from eomc.runtime.errors import ModelError

__all__ = [
    "names", "as_symbol_list", "check_time_functions", "is_body_list", "is_load_list",
    "split_bodies_and_loads", "parse_loads", "check_bodies", "point_velocity",
]


def names(symbols):
    """'q1, q2' for [q1(t), q2(t)]: dynamic symbols as users write them."""
    return ", ".join(str(s).replace("(t)", "") for s in symbols)


def as_symbol_list(value, role):
    """``None``/empty -> [], an iterable -> list, anything else -> ModelError."""
    if value is None:
        return []
    if isinstance(value, sm.MatrixBase):
        return list(value)
    if isinstance(value, (sm.Basic, str)) or not hasattr(value, "__iter__"):
        raise ModelError(f"{role} must be given as a list, got {value!r}")
    return list(value)


def check_time_functions(symbols, role):
    """Every coordinate/speed must be a function of time alone, like q1(t)."""
    t = dynamicsymbols._t
    seen = set()
    for i, s in enumerate(symbols):
        if not (isinstance(s, AppliedUndef) and s.args == (t,)):
            raise ModelError(
                f"{role} #{i + 1} ({s}) is not a function of time; create it with "
                f"dynamicsymbols('{s}')")
        if s in seen:
            raise ModelError(f"{role} {s} is listed twice")
        seen.add(s)


def _is_body(x):
    return isinstance(x, (Particle, RigidBody))


def _is_load(x):
    return (isinstance(x, tuple) and len(x) == 2
            and isinstance(x[0], (Point, ReferenceFrame)))


def is_body_list(items):
    items = list(items)
    return bool(items) and all(_is_body(b) for b in items)


def is_load_list(items):
    items = list(items)
    return bool(items) and all(_is_load(x) for x in items)


def split_bodies_and_loads(first, second):
    """Tell ``(loads, bodies)`` (the seed's order) from ``(bodies, loads)`` by content.

    Returns (bodies, loads); either may be None when not given.
    """
    def kind(x):
        if x is None:
            return None
        if not hasattr(x, "__iter__") or isinstance(x, (sm.Basic, str)):
            raise ModelError(
                f"kanes_equations expects lists of bodies and of loads, got {x!r}")
        x = list(x)
        if not x:
            return "empty"
        has_body = any(_is_body(i) for i in x)
        has_load = any(_is_load(i) for i in x)
        if has_body and has_load:
            return "mixed"
        return "bodies" if has_body else "loads" if has_load else "unknown"

    k1, k2 = kind(first), kind(second)
    if k1 == "unknown" and k2 in ("bodies", "loads"):
        k1 = "loads" if k2 == "bodies" else "bodies"
    if k2 == "unknown" and k1 in ("bodies", "loads"):
        k2 = "loads" if k1 == "bodies" else "bodies"
    if "mixed" in (k1, k2):
        raise ModelError("a list passed to kanes_equations mixes bodies and loads; "
                         "pass the bodies and the loads as two separate lists")
    if k1 == "loads" or k2 == "bodies":
        return (None if second is None else list(second)), (None if first is None else list(first))
    return (None if first is None else list(first)), (None if second is None else list(second))


def check_bodies(bodies):
    if bodies is None:
        raise ModelError("no bodies were given: pass a list of Particle/RigidBody objects "
                         "to kanes_equations or as bodies= to KanesMethod")
    if not hasattr(bodies, "__iter__"):
        raise ModelError(f"bodies must be a list of Particle/RigidBody objects, got {bodies!r}")
    bodies = list(bodies)
    for i, b in enumerate(bodies):
        if not _is_body(b):
            raise ModelError(
                f"body #{i + 1} ({b!r}) is not a Particle or RigidBody")
    return bodies


def point_velocity(point, frame, what):
    """The velocity of ``point`` in ``frame``, or a ModelError naming ``what``."""
    try:
        return point.vel(frame)
    except (ValueError, KeyError):
        raise ModelError(
            f"{what}: the velocity of point {point.name} in the inertial frame "
            f"{frame.name} is undefined (set it with {point.name}.set_vel({frame.name}, ...) "
            f"or v2pt_theory)") from None


def frame_ang_vel(frame, inertial, what):
    try:
        return frame.ang_vel_in(inertial)
    except (ValueError, KeyError):
        raise ModelError(
            f"{what}: the angular velocity of frame {frame.name} in {inertial.name} "
            "is undefined (orient the frame or set its angular velocity)") from None


def parse_loads(loads, inertial, velocities=True):
    """Return a list of (label, kind, velocity, vector, point or frame), kind 'force' or 'torque'
    (velocity None when not ``velocities``: the shapes checked, the kinematics left for later)."""
    if loads is None:
        return []
    if not hasattr(loads, "__iter__") or isinstance(loads, (sm.Basic, str)):
        raise ModelError(f"loads must be a list of (Point, Vector) or "
                         f"(ReferenceFrame, Vector) pairs, got {loads!r}")
    out = []
    for i, item in enumerate(loads):
        shape = (f"load #{i + 1} ({item!r})")
        if not (isinstance(item, tuple) and len(item) == 2):
            raise ModelError(f"{shape} is not a (Point, Vector) or (ReferenceFrame, Vector) pair")
        where, vec = item
        if not isinstance(where, (Point, ReferenceFrame)):
            raise ModelError(f"{shape}: its first item must be a Point or a ReferenceFrame, "
                             f"got {where!r}")
        if vec == 0:
            vec = Vector(0)
        if not isinstance(vec, Vector):
            raise ModelError(f"{shape}: its second item must be a Vector, got {vec!r}")
        if isinstance(where, Point):
            label = f"load #{i + 1} on point {where.name}"
            out.append((where.name, "force", point_velocity(where, inertial, label) if velocities
                        else None, vec, where))
        elif isinstance(where, ReferenceFrame):
            label = f"load #{i + 1} on frame {where.name}"
            out.append((where.name, "torque", frame_ang_vel(where, inertial, label) if velocities
                        else None, vec, where))
        else:
            raise ModelError(f"{shape}: its first item must be a Point or a ReferenceFrame, "
                             f"got {where!r}")
    return out
