"""Where a robot starts relative to the ground: the one rule that lifts a floating base whose
default start puts its contacts under the ground, for the command line (facade/cli/common.py,
which prints a note) and for Python's x0=None (runtime/start.py, which warns): one rule, two voices.

Why: a URDF's zero pose has the base at z = 0, so a standing robot's feet start tens of
centimetres inside the ground; the contact law then throws it out violently (Go2: feet 0.45 m
deep, a run no tolerance follows) instead of letting it stand or collapse.  The lift stops
GROUND_CLEARANCE above the ground, not on it: a start exactly on the ground sits on the contact
law's onset, where k d^1.5 has no second derivative (`eomc check`'s Jacobian test saw a 56x error)."""
from dataclasses import dataclass

GROUND_CLEARANCE = 1e-3     # m between the lowest contact and the ground at a lifted start


@dataclass(frozen=True)
class GroundStart:
    """What :func:`onto_ground` found: ``kind`` "lifted" (``state`` set to ``value``) or "welded"
    (a fixed root that cannot be lifted); ``deepest`` the deepest contact's depth (m) before."""
    kind: str
    deepest: float
    state: str = ""
    value: float = 0.0


def onto_ground(model, x0, given=()):
    """(start, found): ``x0`` ({state: value}) with a floating base lifted (its height only) until
    the deepest contact is GROUND_CLEARANCE above the ground, and a :class:`GroundStart` saying so;
    ``found`` None when nothing was changed or needs saying.

    Nothing is lifted when the base height is in ``given`` (the caller chose it), when the base's
    z does not move the contacts straight up, or when no contact is under the ground.  A robot
    whose root is welded cannot be lifted: a start deeper than a point contact may go is reported
    as "welded" and the start kept."""
    from eomc.runtime.switching import POINT_PENETRATION, find_switches
    zs = [n for n in model.state_names[:model.nq] if n.endswith("_floating_z")]
    welded = not zs and "ground_check" in ((getattr(model, "metadata", None) or {}))
    if not (len(zs) == 1 or welded) or (zs and zs[0] in given) or model.noutput == 0:
        return x0, None
    contacts = find_switches(model).contacts
    depths = [f"depth_{c.name}" for c in contacts if f"depth_{c.name}" in model.output_names]
    if not depths:
        return x0, None
    out = model.outputs(0.0, [x0[n] for n in model.state_names])
    deepest = max(out[d] for d in depths)
    if not deepest > 0.0:
        return x0, None
    if welded:
        return x0, (GroundStart("welded", deepest) if deepest > POINT_PENETRATION else None)
    lifted = dict(x0)
    lifted[zs[0]] = x0[zs[0]] + deepest + GROUND_CLEARANCE
    after = model.outputs(0.0, [lifted[n] for n in model.state_names])
    if abs(max(after[d] for d in depths) + GROUND_CLEARANCE) > 1e-9 * max(1.0, deepest):
        return x0, None     # the base's z does not move the contacts straight up: leave the start
    return lifted, GroundStart("lifted", deepest, zs[0], lifted[zs[0]])
