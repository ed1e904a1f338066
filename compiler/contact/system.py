"""Ground contact for models written with SymPy mechanics (a System or KanesMethod).

    import eomc.contact
    foot = eomc.contact.ground(P, body, world=system, radius=0.02, mu=0.8, name="foot")
    system.add_loads(*foot.loads)
    parameters.update(foot.parameters); outputs.update(foot.outputs); events.update(foot.events)

One job: turn a point (a sphere's centre) on a body into the loads of the
contact law (:mod:`.law`) as SymPy vectors -- a force at the point and the moment of
that force about it (the force really acts at the contact point, radius r below
the centre) -- plus its named parameters with their defaults, its forces as
outputs and its penetration as an event (touch-down and lift-off are its zero
crossings), so the adaptive step lands on them.  The loads are ordinary
``(point, vector)`` and ``(frame, vector)`` pairs: Kane's formulation and the
recursive one (which reads them as world loads on the body) both take them.
"""
import sympy as sm

from eomc.runtime.errors import ModelError

from .law import DEFAULTS, check_value, damping_from_restitution, ground_forces

__all__ = ["GroundContact", "ground", "contact_symbols"]


class GroundContact:
    """The pieces of one contact, to add to a model file's variables."""

    def __init__(self, name, loads, parameters, outputs, events, forces):
        self.name = name
        self.loads = loads              # [(Point, Vector), (ReferenceFrame, Vector)]
        self.parameters = parameters    # {Symbol: default}
        self.outputs = outputs          # {"Fn_<name>", "Ftx_<name>", ...: expression}
        self.events = events            # {"contact_<name>": penetration}: zero at touch-down/lift-off;
                                        # "clip_<name>": zero where the damped normal force reaches 0
        self.forces = forces            # the law's ContactForces (expressions)

    def __repr__(self):
        return f"GroundContact({self.name!r}, parameters={[str(s) for s in self.parameters]})"


def contact_symbols(name):
    """{"k", "c", "mu", "vs", "r"} -> the parameters ``k_<name>``, ``c_<name>``, ..."""
    return {key: sm.Symbol(f"{key}_{name}", real=True) for key in DEFAULTS}


def _world(world):
    if isinstance(world, tuple) and len(world) == 2:
        return world
    frame, origin = getattr(world, "frame", None), getattr(world, "fixed_point", None)
    if frame is None or origin is None:
        raise ModelError(f"contact: world must be a System or a (frame, origin point) pair, "
                         f"not {type(world).__name__}")
    return frame, origin


def _frame_of(body):
    from sympy.physics.vector import ReferenceFrame
    if body is None:
        return None
    if isinstance(body, ReferenceFrame):
        return body
    frame = getattr(body, "frame", None)
    if frame is None and type(body).__name__ != "Particle":
        raise ModelError(f"contact: {body!r} is neither a body nor a reference frame")
    return frame


def parameter_defaults(name, k=None, c=None, mu=None, vs=None, radius=None, restitution=None,
                       impact_speed=None, where=None):
    """{"k", ...} -> checked defaults (``restitution`` with ``impact_speed`` gives c)."""
    values = dict(DEFAULTS)
    given = {"k": k, "c": c, "mu": mu, "vs": vs, "r": radius}
    if restitution is not None:
        if c is not None:
            raise ValueError(f"contact {name!r}: give the damping c or a restitution, not both")
        if impact_speed is None:
            raise ValueError(f"contact {name!r}: a restitution needs the impact_speed it holds at "
                             f"(c = (1 - e)/v_in depends on it)")
        try:
            given["c"] = damping_from_restitution(restitution, impact_speed)
        except ValueError as exc:
            raise ValueError(f"contact {name!r}: {exc}") from None
    for key, value in given.items():
        if value is not None:
            values[key] = check_value(name, key, value, where)
    return values


def unit_normal(normal, name):
    import math
    try:
        n = [float(x) for x in normal]
    except (TypeError, ValueError):
        raise ValueError(f"contact {name!r}: normal must be 3 numbers, not {normal!r}") from None
    size = math.sqrt(sum(x * x for x in n)) if len(n) == 3 else 0.0
    if len(n) != 3 or not math.isfinite(size) or size == 0.0:
        raise ValueError(f"contact {name!r}: normal must be 3 finite numbers, not all zero: {normal!r}")
    return [sm.Integer(int(x)) if x == int(x) and size == 1.0 else sm.Float(x / size, 17) for x in n]


def ground(point, body, world, *, name=None, radius=None, k=None, c=None, restitution=None,
           impact_speed=None, mu=None, vs=None, normal=(0, 0, 1), height=0.0):
    """A sphere of ``radius`` centred at ``point`` (fixed in ``body``: a RigidBody or its
    frame; a Particle has no rotation) touching the plane n·x = height of ``world`` (a
    System, or a (frame, origin) pair).  Parameters ``k_<name>``, ``c_<name>``,
    ``mu_<name>``, ``vs_<name>``, ``r_<name>`` with the given (or default) values; see
    :mod:`.law` for the law and :data:`.law.DEFAULTS` for the defaults and why."""
    name = name or getattr(point, "name", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"contact name {name!r} is not an identifier (it names parameters and outputs)")
    values = parameter_defaults(name, k, c, mu, vs, radius, restitution, impact_speed)
    n = unit_normal(normal, name)
    N, O = _world(world)
    frame = _frame_of(body)
    try:
        r = point.pos_from(O)
    except ValueError as exc:
        raise ModelError(f"contact {name!r}: point {point} is not connected to the world origin "
                         f"{O}: {exc}") from None
    centre = [r.dot(N.x), r.dot(N.y), r.dot(N.z)]
    v = getattr(point, "_vel_dict", {}).get(N)     # set by the model (a joint, set_vel) ...
    if v is None:                                   # ... or the rate of its position from the
        v = r.dt(N)                                 # world origin, which is fixed in N
    velocity = [v.dot(N.x), v.dot(N.y), v.dot(N.z)]
    w = frame.ang_vel_in(N) if frame is not None else None
    omega = [w.dot(N.x), w.dot(N.y), w.dot(N.z)] if w is not None else [0, 0, 0]
    syms = contact_symbols(name)
    forces = ground_forces(centre, velocity, omega, syms, n, sm.Float(float(height), 17) if height else 0)
    F = forces.force[0] * N.x + forces.force[1] * N.y + forces.force[2] * N.z
    loads = [(point, F)]
    if frame is not None:
        a = forces.point_offset
        arm = a[0] * N.x + a[1] * N.y + a[2] * N.z
        loads.append((frame, arm.cross(F)))
    outputs = {f"Fn_{name}": forces.normal, f"Ftx_{name}": forces.friction[0],
               f"Fty_{name}": forces.friction[1], f"Ftz_{name}": forces.friction[2],
               f"depth_{name}": forces.depth}
    events = {f"contact_{name}": forces.depth, f"clip_{name}": forces.parts["clip"]}
    parameters = {syms[key]: values[key] for key in syms}
    return GroundContact(name, loads, parameters, outputs, events, forces)
