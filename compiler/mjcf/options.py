"""MJCF ``<option><flag .../>``: each of MuJoCo's disable/enable flags applied, or refused by name.

One job: read ``m.opt.disableflags``/``enableflags`` of the compiled model and make eomc's
model do what MuJoCo's ``mj_forward`` does with them, by changing eomc's private copy of
the ``MjModel`` before the tree is read (so no reader needs to know about flags):

- ``gravity``      gravity zero (the parameters gx, gy, gz default to 0)
- ``spring``       joint and tendon stiffness zero
- ``damper``       joint and tendon damping zero
- ``actuation``    actuator forces zero: the actuators are left out (the model has no inputs), with a warning
- ``clampctrl``    controls not clamped to ctrlrange
- ``limit``        joint range limits off (as ``limits=False`` for the limits)
- ``frictionloss`` frictionloss off
- ``contact``      no contacts (:mod:`.collision`); ``filterparent`` and ``refsafe`` there too
- ``equality``     equality constraints off (joint couplings left out)
- ``constraint``   all of MuJoCo's constraints off: limits, frictionloss, contacts, equalities
- no effect on the continuous-time dynamics eomc generates (accepted): ``warmstart``,
  ``sensor``, ``midphase``, ``eulerdamp``, ``autoreset``, ``nativeccd``, ``island``,
  ``multiccd``; enable flags ``energy``, ``fwdinv``, ``invdiscrete``, ``diagexact``, ``ipc``,
  ``speculative`` (solver and diagnostics options)
- refused, named: enable ``override`` (contact parameters overridden globally) and ``sleep``
  (bodies frozen while they rest), which change the motion in ways eomc does not model.

Gravity and the time step come from ``<option>`` too: gravity is the tree's (``m.opt.gravity``),
the time step is recorded in the built model's metadata (``model.timestep``).
"""
from eomc.runtime.errors import ModelFileError

__all__ = ["apply_flags", "EFFECTS", "refsafe_step"]

EFFECTS = ("gravity", "spring", "damper", "actuation", "clampctrl", "limit", "frictionloss", "contact",
           "equality", "constraint", "filterparent", "refsafe")
NO_EFFECT = ("warmstart", "sensor", "midphase", "eulerdamp", "autoreset", "nativeccd", "island", "multiccd")
ENABLE_NO_EFFECT = ("energy", "fwdinv", "invdiscrete", "diagexact", "ipc", "speculative")
ENABLE_REFUSED = {"override": "contact parameters overridden for every pair (o_margin, o_solref, o_solimp, "
                              "o_friction)",
                  "sleep": "bodies put to sleep while they rest"}


def _bits(enum, prefix):
    return {name[len(prefix):].lower(): int(value) for name, value in enum.__members__.items()
            if name.startswith(prefix) and not name.startswith(prefix.replace("_", "") + "N")
            and not name[len(prefix):].startswith("N")}


def disabled(m):
    """The names of the disable flags set in ``m`` (MuJoCo's spelling: 'limit', 'gravity', ...)."""
    import mujoco
    return {name for name, bit in _bits(mujoco.mjtDisableBit, "mjDSBL_").items() if m.opt.disableflags & bit}


def apply_flags(m, path, where_of=lambda path, tag: (str(path), None)):
    """Apply the flags to ``m`` (eomc's copy); returns (limits, frictionloss, actuation): whether
    each still acts.  ModelFileError naming a flag eomc cannot honour (its ``<flag>``'s file and
    line: ``where_of(path, "flag")``)."""
    import mujoco
    off = disabled(m)
    enabled = {name for name, bit in _bits(mujoco.mjtEnableBit, "mjENBL_").items() if m.opt.enableflags & bit}
    for name in sorted(enabled):
        if name in ENABLE_REFUSED:
            raise ModelFileError(f"<option><flag {name}=\"enable\"/>: {ENABLE_REFUSED[name]}: eomc does not "
                                 f"model it", *where_of(path, "flag"))
    unknown = off - set(EFFECTS) - set(NO_EFFECT)
    if unknown:      # a MuJoCo newer than this table
        raise ModelFileError(f"<option><flag {sorted(unknown)[0]}=\"disable\"/>: eomc does not know what this "
                             f"MuJoCo flag changes", *where_of(path, "flag"))
    if "gravity" in off:
        m.opt.gravity[:] = 0
    if "spring" in off:
        m.jnt_stiffness[:] = 0
        m.tendon_stiffness[:] = 0
    if "damper" in off:
        m.dof_damping[:] = 0
        m.tendon_damping[:] = 0
    if "clampctrl" in off:
        m.actuator_ctrllimited[:] = 0
    constraint = "constraint" in off
    if "limit" in off or constraint:
        m.jnt_limited[:] = 0
        m.tendon_limited[:] = 0
    if "frictionloss" in off or constraint:
        m.dof_frictionloss[:] = 0
        m.tendon_frictionloss[:] = 0
    if constraint and not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT):
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return "limit" not in off and not constraint, "frictionloss" not in off and not constraint, "actuation" not in off


def refsafe_step(m):
    """MuJoCo's time step where its refsafe rule (a constraint's time constant at least 2 steps)
    applies, else None (``<flag refsafe="disable"/>``)."""
    import mujoco
    return None if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE) else float(m.opt.timestep)
