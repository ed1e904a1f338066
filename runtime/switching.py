"""Where a model's law changes form, and the verdict on a run that crossed such places.

Why this module: a ground contact's force starts at touch-down and stops at lift-off,
a joint limit's spring engages when the coordinate passes the limit.  The right-hand
side is only piecewise smooth there, and an integrator that steps across such a point
can accept a step its error estimate does not see (Radau gained 3.6 MJ on a 4.9 J
bouncing ball, issue 29).  Radau and the explicit integrators end a step at every
crossing of a *switching function* and restart there (runtime/c/eomc_integrators.c; BDF
passes over them, its error test sizing the steps); this module
finds the switching functions by the names the contact and joint-law builders give
(``contact_<name>`` events with the radius ``r_<name>``; ``limit_lo_<joint>`` /
``limit_hi_<joint>`` with the width ``limit_e_<joint>`` on the coordinate
``q_<joint>``) and turns what the integrator saw into a verdict:

- a contact that penetrates deeper than :data:`PENETRATION_FRACTION` of its radius
  (:data:`POINT_PENETRATION` for a point contact, r = 0): a :class:`PhysicsWarning`
  naming the contact -- the law is followed, but the contact is too soft for the load
  (raise k) or the run jumped through the ground;
- a joint past its limit by more than :data:`LIMIT_OVERSHOOT_WIDTHS` widths (0.03 rad or m at
  the default width; the stated overshoot of the default limit stiffness, docs/joint-laws.md):
  a :class:`PhysicsWarning` naming the joint, its stiffness and whether it is the user's own
  or the default;
- a model with an ``energy`` output (a robot read from a file with only ground contacts
  as loads gets one generated: kinetic, gravity's and the contacts' elastic energy) whose
  inputs are absent or zero that *gains* energy while only passive laws act: beyond :func:`energy_tolerance` a :class:`PhysicsWarning`, beyond
  :data:`ENERGY_FAIL` times it a failed run (status :data:`STATUS_ENERGY`), never
  status 0 with energy created from nothing.
"""
import re
import warnings
from dataclasses import dataclass

import numpy as np

from .errors import EomcWarning
from .ground_check import NAMED_AT_MOST, below_ground, depth_span

__all__ = ["CONTACT_EVENT_PREFIX", "CLIP_EVENT_PREFIX", "GAP_EVENT_PREFIXES", "Switches", "find_switches", "PhysicsWarning", "verdict", "warn_outside_limits", "moved_start_text",
           "warn_unchecked",
           "PENETRATION_FRACTION",
           "POINT_PENETRATION", "LIMIT_OVERSHOOT_WIDTHS", "STATUS_ENERGY", "ENERGY_FAIL",
           "energy_tolerance", "energy_verdict", "energy_allowance", "watch_springs", "watched_stats",
           "total_known", "place_words"]

CONTACT_EVENT_PREFIX = "contact_"  # a contact's penetration event: contact_<name> (the compiler emits it always)
CLIP_EVENT_PREFIX = "clip_"        # where a damped contact's normal force reaches 0 in contact (F_n >= 0 clip)
GAP_EVENT_PREFIXES = (CONTACT_EVENT_PREFIX, CLIP_EVENT_PREFIX)   # the compiler keeps these whatever is asked
PENETRATION_FRACTION = 0.5      # of the contact radius
POINT_PENETRATION = 0.01        # m, for a point contact (radius 0)
LIMIT_OVERSHOOT_WIDTHS = 100    # limit widths past the limit (100 x 3e-4 rad = 0.03 rad by default)
STATUS_ENERGY = 20              # a run that created energy (set by the runtime, not by C)
ENERGY_FAIL = 100               # the tolerance multiple beyond which an energy gain fails the run
# in a generated energy output's text (NAME.json "energy", compiler/tree/lower._energy_text) when
# the model's actuators have activation states: the energy holds their bias only, which is all
# they push with while every activation is 0 -- a zero control keeps it there -- so a run is
# judged only from a start with the extra states (the activations, after q and u) at 0
ACTIVATIONS_AT_REST = "judged from a start with the actuators' activations at 0"


class PhysicsWarning(EomcWarning):
    """A run finished, but what it computed breaks a physical expectation (named in the text)."""


@dataclass(frozen=True)
class Contact:
    name: str
    event: str          # the model event (its penetration): contact_<name>
    radius: int         # parameter index of r_<name> (or -1)


@dataclass(frozen=True)
class Limit:
    joint: str
    state: int          # index of q_<joint>
    param: int          # index of limit_lo_/limit_hi_<joint>
    sign: float         # +1: q - hi; -1: lo - q
    width: int          # parameter index of limit_e_<joint> (or -1)
    side: str           # "upper" / "lower"


@dataclass(frozen=True)
class Switches:
    contacts: tuple
    limits: tuple
    unchecked: tuple = ()   # ground contacts (by their law's parameters) with no contact_<name> event
    clips: tuple = ()       # clip_<name> events: switching only (no verdict, not recorded unless asked)

    def __bool__(self):     # a run of such a model is judged (unchecked contacts: its energy)
        return bool(self.contacts or self.limits or self.unchecked)


_LIMIT = re.compile(r"limit_(lo|hi)_(.+)\Z")


def contact_parameter(params, key, name):
    """Index of ``<key>_<name>``, or of ``<key>_<geom>`` for a contact point ``<geom>_<i>`` of an
    MJCF geom with several points (they share the geom's parameters); -1 if neither."""
    if f"{key}_{name}" in params:
        return params[f"{key}_{name}"]
    m = re.match(r"(.+)_\d+\Z", name)
    return params.get(f"{key}_{m.group(1)}", -1) if m else -1


def find_switches(model):
    """The model's contacts and joint limits, found by their parameter and event names."""
    cached = getattr(model, "_switches", None)
    if cached is not None:
        return cached
    params = {n: i for i, n in enumerate(model.param_names)}
    states = {n: i for i, n in enumerate(model.state_names)}
    events = [d["name"] for d in model.metadata.get("events", ())]
    n = len(CONTACT_EVENT_PREFIX)
    contacts = tuple(Contact(e[n:], e, contact_parameter(params, "r", e[n:]))
                     for e in events if e.startswith(CONTACT_EVENT_PREFIX))
    limits = []
    for name, i in params.items():
        m = _LIMIT.match(name)
        if m and f"q_{m.group(2)}" in states:
            joint = m.group(2)
            limits.append(Limit(joint, states[f"q_{joint}"], i, 1.0 if m.group(1) == "hi" else -1.0,
                                params.get(f"limit_e_{joint}", -1), "upper" if m.group(1) == "hi" else "lower"))
    clips = tuple(e for e in events if e.startswith(CLIP_EVENT_PREFIX))
    found = Switches(contacts, tuple(limits), _unchecked(params, {c.name for c in contacts}), clips)
    try:
        model._switches = found
    except AttributeError:
        pass
    return found


# a ground contact's law parameters <key>_<name> (compiler/contact/law.py; a body-body pair has
# no radius, and no switching function yet: not named here)
_LAW_KEYS = ("k", "c", "mu", "vs", "r")


def _unchecked(params, gapped):
    """Ground contacts known by their law's parameters (k_, c_, mu_, vs_, r_<name>) that have no
    penetration event: built by an eomc before every contact model got its gaps, or a
    SymPy-mechanics model that did not add its contacts' ``events``."""
    out = []
    for name in params:
        if not name.startswith("k_"):
            continue
        contact = name[2:]
        if not all(f"{key}_{contact}" in params for key in _LAW_KEYS[1:]):
            continue
        if contact in gapped or any(g.startswith(contact + "_") and g[len(contact) + 1:].isdigit()
                                    for g in gapped):
            continue
        out.append(contact)
    return tuple(out)


def warn_unchecked(model):
    """A PhysicsWarning naming every contact without a penetration event: no method ends its
    steps at its touch-down, and its penetration is not judged (a free-falling sphere's grown
    Radau step went through the floor with status 0 in such a build, issue 29)."""
    names = find_switches(model).unchecked
    if names:
        warnings.warn(PhysicsWarning(
            f"{model.name}: contact{'s' if len(names) > 1 else ''} {', '.join(names)} "
            f"{'have' if len(names) > 1 else 'has'} no penetration event (contact_<name>), so no "
            f"step ends at touch-down and the run's penetration is not checked: rebuild the model "
            f"with this eomc (it always compiles the contacts' events), or add the contact's "
            f"events to the model file's events"), stacklevel=_user_level())


def energy_tolerance(rtol, atol):
    """The energy gain (relative to the energy's scale) a passive run may show from integration
    error: 100 rtol (at least 1e-6) -- the global error of a run of many steps, each held to
    rtol, measured at 1e-5 relative with rtol 1e-6 on the bouncing ball (DOP853, DOPRI5, Radau)."""
    return max(100.0 * rtol, 1e-6)


def _energy_gain(outputs):
    E = outputs.get("energy")
    if E is None or len(E) < 2 or not np.all(np.isfinite(E)):
        return None
    E0 = float(E[0])
    scale = max(abs(E0), float(np.max(np.abs(E - E0))) if len(E) else 0.0, 1e-300)
    gain = float(np.max(E) - E0)
    return gain, scale


def _no_sources(model, a):
    """True when nothing but the model's own passive laws acts: no inputs, or inputs held at
    zero for the whole run (no table of values, no callable, no feedback), and every actuator
    activation the energy needs at 0 starts there (:func:`_activations_at_rest`)."""
    if not _activations_at_rest(model, a):
        return False
    if model.ninput == 0:
        return True
    return "r_fun" not in a and "K" not in a and not np.any(np.asarray(a.get("r_v", 0.0)))


def _activations_at_rest(model, a):
    """False when the energy output holds the actuators' bias only (ACTIVATIONS_AT_REST in its
    text) and the run starts with an activation (an extra state, after q and u) not at 0: the
    actuator then pushes with gain·act, a source the energy does not hold -- not judged."""
    if not model.nz or ACTIVATIONS_AT_REST not in str(model.metadata.get("energy") or ""):
        return True
    return not np.any(np.asarray(a["x0"], dtype=float)[model.nq + model.nu:])


START_DEPTH_SLACK = 1.05    # a contact the run took no more than 5 % deeper than it started: the start's


def _start_depth(outputs, name):
    """A contact's depth at the run's first row (its depth_<name> output), 0 when unknown."""
    values = (outputs or {}).get(f"depth_{name}")
    if values is None or not len(values):
        return 0.0
    d0 = float(np.asarray(values, dtype=float)[0])
    return d0 if np.isfinite(d0) else 0.0


def verdict(model, a, result, gmax, sw, watched=None, outputs=None, place=None):
    """Warnings (and a failed status for created energy) from what the run saw; returns
    (status, message addition) -- (0, "") when the physics looks right."""
    notes = []
    p = np.asarray(a["p"], dtype=float)
    x0 = np.asarray(a["x0"], dtype=float)
    ncontact, nlimit = len(sw.contacts), len(sw.limits)
    seen = np.full(ncontact + nlimit, -np.inf)
    if gmax is not None:
        got_ = np.asarray(gmax, dtype=float)[:ncontact + nlimit]
        seen[:got_.size] = got_
    # vectorised over contacts and limits (a robot has dozens): a run's Python tail is part of
    # the time a user waits at loose tolerances (benchmarks/results/contact_wp.md)
    r, allowed, e, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    run_outputs = result.outputs if outputs is None else outputs
    with np.errstate(invalid="ignore"):
        depth = seen[:ncontact]
        started = []        # (depth at the start, words)
        for j in np.flatnonzero(np.isfinite(depth) & (depth > allowed)):
            c, rj = sw.contacts[j], float(r[j])
            what = (f"{PENETRATION_FRACTION:g} of its radius {rj:g} m" if rj > 0
                    else f"{POINT_PENETRATION:g} m (a point contact)")
            d0 = _start_depth(run_outputs, c.name)
            if d0 > allowed[j] and depth[j] <= d0 * START_DEPTH_SLACK:
                started.append((d0, f"{c.name} ({d0:.3g} m, more than {what})"))
                continue
            notes.append(f"contact {c.name} penetrated {depth[j]:.3g} m, more than {what}: the contact is "
                         f"too soft for the load (raise k_{c.name}) or the run went through the ground")
        if started:
            # first hour s24: gymnasium's humanoidstandup.xml starts its arms 0.035 m into the floor
            # (MuJoCo's mj_forward at qpos0 says so too): the start's doing, not the stiffness's
            # first hour s27: a1.urdf --ground (a fixed base, welded with its legs 0.34 m into the
            # floor) named 96 contacts here, 9 kB: the deepest few, the rest counted
            many = len(started) > 1
            started.sort(key=lambda item: -item[0])
            named = [words for _, words in started[:NAMED_AT_MOST]]
            rest = started[NAMED_AT_MOST:]
            listed = ", ".join(named) + (f" and {len(rest)} more ({depth_span(rest[-1][0], rest[0][0])})"
                                         if rest else "")
            notes.append(f"contact{'s' if many else ''} {listed} started that deep: the start "
                         f"puts {'them' if many else 'it'} into the ground or another body, and the run "
                         f"pressed {'them' if many else 'it'} no deeper (the start's doing, not the "
                         f"stiffness's; start out of contact, --x0 / x0=, to avoid it)")
        start = ix["sign"] * (x0[ix["state"]] - limit_at)
        over = seen[ncontact:]
        # (a joint that started outside and only came back is warned about at the start)
        past = np.flatnonzero(np.isfinite(over) & (over > LIMIT_OVERSHOOT_WIDTHS * e) & (over > start + e))
        past, thrown = _thrown(sw, past, over, start, e)
        notes += _overshoot_notes(model, p, sw, past, over, e)
        notes += _thrown_notes(sw, thrown, over, start, limit_at)
    notes += below_ground(model, result.t, result.x, p, POINT_PENETRATION, PENETRATION_FRACTION)
    from .pair_check import passed_through
    notes += passed_through(model, result.t, result.x, p, outputs=result.outputs)   # bodies into each other
    # outputs: the run's, with the start's row first when t_eval left it out (simulate.with_start:
    # the verdict reads the start's energy and depths); place: energy_verdict's (simulate.place_finder)
    status, extra, said = energy_verdict(model, a, result.outputs if outputs is None else outputs, sw, x=result.x,
                                         t=result.t, watched=watched, place=place)
    notes += said
    if notes:       # one warning per run, naming every contact and joint
        warnings.warn(PhysicsWarning(f"{model.name}: " + "; ".join(notes)), stacklevel=_user_level())
    return status, extra


def energy_verdict(model, a, outputs, sw, x=None, t=None, watched=None, place=None):
    """simulate's energy verdict, shared by ``verdict`` and rollout's implicitfast rows: (status,
    message addition, warning notes) -- (STATUS_ENERGY, why, ...) for a passive run (``sw``
    judged, an ``energy`` output, no sources: ``_no_sources(model, a)``) whose energy rose
    beyond ENERGY_FAIL x energy_tolerance(a["rtol"], a["atol"]) of its scale, (0, "", [])
    when not judged.  outputs: {output: values} along the run, the first row at its start
    (a["x0"], parameters a["p"]): the whole trajectory, or (rollout's record="final") the start,
    the energy's lowest and highest values over the run and the end, which give the same gain and
    scale (_energy_gain).  x (t): the states (times) at the outputs' rows, when known (NaN rows:
    not known there): the total energy -- the output plus the limit springs it leaves out -- is
    then judged by its rise above its running minimum (:func:`_energy_rise`), with the same
    tolerance: a passive model's total energy never rises, so a gain after the springs gave their
    energy back and the damping took it out is seen too (session 22: the fixed step's ant, a foot
    landing inside a whole step, +9 J at t = 0.18 s, below what the start's springs held).  Such
    a rise warns (its notes), beyond the failing multiple as "the integration is wrong here", and
    leaves the status alone (why: docs/contact.md, "The energy verdict").

    watched: the fixed step's C watch over every step (:func:`watched_stats`: eomc_stats watch_*,
    simulate's and rollout's implicitfast runs): the output's range joins ``outputs["energy"]``
    for the gain and its scale, and the total's rise is the watch's (every step, the limit springs
    by eomc_spring's tables), not the recorded rows' -- so simulate and rollout's rows, with either
    record, judge the same numbers.  place: a callable(t) -> words naming what touched down or
    entered a limit in the step that ends at t (:func:`place_words`), or None."""
    if not (sw and "energy" in outputs and _no_sources(model, a)):
        return 0, "", []
    if watched is not None and np.isfinite(watched["lo"]) and len(outputs["energy"]):
        # the start's value (outputs' first row: the run's start) and the watch's range over every
        # step: simulate's and rollout's rows judge the same three numbers, whatever they recorded
        outputs = dict(outputs, energy=np.array([float(outputs["energy"][0]), watched["lo"], watched["hi"]]))
    got = _energy_gain(outputs)
    status, extra, notes = 0, "", []
    p = np.asarray(a["p"], dtype=float)
    in_contact = any(len(outputs.get(f"depth_{c.name}", ())) and outputs[f"depth_{c.name}"][0] > 0
                     for c in sw.contacts)
    held, sprung, start, e = energy_allowance(model, p, np.asarray(a["x0"], dtype=float), in_contact, sw)
    if got is not None:
        gain, scale = got
        tol = energy_tolerance(a["rtol"], a["atol"]) * scale
        if gain - held > max(tol, min(ENERGY_FAIL * tol, 0.05 * scale)) and not sprung:
            status = STATUS_ENERGY
            extra = (f"the energy rose by {gain:.3g} (from {outputs['energy'][0]:.6g})"
                     + (f", {gain - held:.3g} more than the {held:.3g} the start's limit springs held,"
                        if held else "")
                     + f" in a model whose contacts and limits can only take energy out: the integration "
                       f"is wrong here (method {a['method']}, rtol {a['rtol']:g})")
        elif gain > tol and sprung:
            notes.append(f"the energy rose by {gain:.3g} (from {outputs['energy'][0]:.6g}): "
                         + _released(model, p, sw, start, e, outputs))
        elif gain - held > tol:
            notes.append(f"the energy rose by {gain:.3g} (from {outputs['energy'][0]:.6g}, "
                         f"{gain / scale:.2g} of its scale) with only passive contacts and limits acting: "
                         f"more than the tolerance explains (method {a['method']}, rtol {a['rtol']:g}); "
                         f"tighten rtol")
    if (x is not None or watched is not None) and not sprung and not status and not notes:
        if watched is not None:
            risen = _watched_rise(model, sw, watched)
        else:
            risen = _energy_rise(model, p, sw, outputs, x, t)
        if risen is not None:
            rise, scale, what = risen
            tol = energy_tolerance(a["rtol"], a["atol"]) * scale
            # a warning, not a failed status: rollout's record="final" rows cannot see this rise
            # (the C watch keeps the output's lowest and highest values, not the total's rise), and
            # a row's status is simulate's (rollout's contract)
            where = ""
            if rise > tol and place is not None and watched is not None and np.isfinite(watched["t_jump"]):
                where = place(float(watched["t_jump"])) or ""
            if rise > max(tol, min(ENERGY_FAIL * tol, 0.05 * scale)):
                notes.append(f"{what}{where} in a model whose contacts and limits can only take energy out: the "
                             f"integration is wrong here (method {a['method']}, rtol {a['rtol']:g}; a smaller "
                             f"step or an adaptive method checks it)")
            elif rise > tol:
                notes.append(f"{what}{where} ({rise / scale:.2g} of its scale) with only passive contacts and limits "
                             f"acting: more than the tolerance explains (method {a['method']}, rtol {a['rtol']:g})")
    return status, extra, notes


WATCHED = ("lo", "hi", "total0", "total_lo", "total_hi", "rise", "low", "t_low", "peak", "t_peak", "t_jump")


def watched_stats(stats, springs):
    """The C energy watch's numbers of one run (an eomc_stats: watch_lo, watch_hi, watch_total0
    ... watch_t_jump) as energy_verdict's ``watched``; springs: the eomc_spring count the watch
    added (its words then say so)."""
    out = {k: float(getattr(stats, f"watch_{k}")) for k in WATCHED}
    out["springs"] = int(springs)
    return out


def watched_rows(columns, springs):
    """watched_stats of every row from an eomc_stats array's columns (rollout's _stats_columns:
    {"watch_lo": (n,) array, ...}): the same numbers (Python floats of the same doubles), without
    a cffi attribute read per field and row (gymnasium's ant: 64 rows x 11 fields a rollout)."""
    return WatchedRows(columns, springs)


class WatchedRows:
    """The rows' watched_stats as a sequence (row i: the dict watched_stats gives), made per row
    only when asked, and the columns themselves (:meth:`column`: field k of every row) for the
    verdict's vector tests.  Why: rollout's verdict reads a few fields of every row and the whole
    dict of the one or two rows it words; 64 dicts a call were a tenth of its Python."""

    def __init__(self, columns, springs):
        self._columns = {k: columns[f"watch_{k}"] for k in WATCHED}
        self._springs = int(springs)
        self._n = len(self._columns[WATCHED[0]])

    def column(self, k):
        """Field ``k`` (one of WATCHED) of every row, an (n,) array of the C doubles."""
        return self._columns[k]

    def __len__(self):
        return self._n

    def __getitem__(self, i):
        if not -self._n <= i < self._n:
            raise IndexError(i)
        return dict({k: float(c[i]) for k, c in self._columns.items()}, springs=self._springs)

    def __iter__(self):
        return (self[i] for i in range(self._n))


def total_known(model, sw):
    """True when the C watch's total is the model's whole energy: an energy output eomc generated
    (it counts the contacts' elastic energy) or no contacts, and the limit springs counted by it
    (URDF) or all of known shape (MJCF's ``limit_laws``: :func:`watch_springs` gives them)."""
    meta = str(model.metadata.get("energy") or "")
    if sw.contacts and not meta:
        return False
    return not sw.limits or "joint limits" in meta or _spring_specs(model, sw) is not None


def _watched_rise(model, sw, watched):
    """_energy_rise's (rise, scale, words) from the C watch (``watched``), or None when the total
    is not known (:func:`total_known`) or did not rise."""
    rise = watched["rise"]
    if not (np.isfinite(rise) and rise > 0) or not total_known(model, sw):
        return None
    T0 = watched["total0"]
    scale = max(abs(T0), watched["total_hi"] - T0, T0 - watched["total_lo"], 1e-300)
    what = (f"the energy{' with the limit springs it leaves out' if watched['springs'] else ''} "
            f"rose by {rise:.3g} above its lowest value ({watched['low']:.6g} at t = {watched['t_low']:.6g} s) "
            f"to {watched['peak']:.6g} at t = {watched['t_peak']:.6g} s")
    return rise, scale, what


def _spring_specs(model, sw):
    """[(limit, stiffness index, width index, shape)] of the limit springs the energy output leaves
    out ([] when it counts them: URDF's), or None when one's shape is unknown (the total is then not
    known).  Kept on the Switches."""
    got = sw.__dict__.get("_spring_specs", False)
    if got is not False:
        return got
    meta = str(model.metadata.get("energy") or "")
    specs = []
    if sw.limits and "joint limits" not in meta:
        laws = model.metadata.get("limit_laws") or {}
        names = {n: i for i, n in enumerate(model.param_names)}
        for lim in sw.limits:
            shape = laws.get(lim.joint)
            k, e = names.get(f"limit_k_{lim.joint}"), names.get(f"limit_e_{lim.joint}")
            if shape is None or k is None or e is None:
                specs = None
                break
            specs.append((lim, k, e, (float(shape.get("push", 0.0)),
                                      tuple(float(v) for v in shape["hold"]) if shape.get("hold") else None)))
    object.__setattr__(sw, "_spring_specs", specs)
    return specs


def watch_springs(model, ffi, p):
    """(n, eomc_spring[n] or NULL, keep-alive): the limit springs the energy output leaves out, for
    the C energy watch (eomc_options.nspring, .spring) with parameters ``p`` (their widths: the
    tables'; a row with another width makes the watch's total not known).  (0, NULL, None) when there
    are none or one's shape is unknown.  The tables (runtime/limit_energy.spring_table) are kept on
    the model per width and shape, the structs per widths."""
    sw = find_switches(model)
    specs = _spring_specs(model, sw) if sw.limits else None
    if not specs:
        return 0, ffi.NULL, None
    p = np.asarray(p, dtype=float)
    widths = tuple(float(p[e]) for _, _, e, _ in specs)
    cache = model.__dict__.setdefault("_watch_springs", {})
    key = (id(ffi), widths)
    got = cache.get(key)
    if got is not None:
        return got
    from .limit_energy import SPRING_BITS, spring_table
    tables = model.__dict__.setdefault("_spring_tables", {})
    arr = ffi.new("eomc_spring[]", len(specs))
    keep = [arr]
    for i, ((lim, k, e, (push, hold)), E) in enumerate(zip(specs, widths)):
        tk = (E, push, hold)
        if tk not in tables:
            tables[tk] = spring_table(E, push, hold)
        base, S, f = tables[tk]
        s = arr[i]
        s.state, s.bound, s.stiffness, s.width = lim.state, lim.param, k, e
        s.sign, s.E, s.bits, s.base, s.n = lim.sign, E, SPRING_BITS, base, len(S)
        keep += [S, f, ffi.from_buffer("double[]", S), ffi.from_buffer("double[]", f)]
        s.S, s.f = keep[-2], keep[-1]
    got = cache[key] = (len(specs), arr, keep)
    return got


def place_words(model, p, sw, t_jump, xa, xb, oa, ob):
    """Words naming where the total energy rose most in one step, the step from state xa to xb
    (outputs oa, ob: {name: value}) that ends at t_jump: the contacts that touched down and the
    joints that entered a limit in it, else those in contact or past a limit at its end."""
    _, _, _, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    da = ix["sign"] * (np.asarray(xa, dtype=float)[ix["state"]] - limit_at)
    db = ix["sign"] * (np.asarray(xb, dtype=float)[ix["state"]] - limit_at)
    down, touching = [], []
    for c in sw.contacts:
        a_, b_ = oa.get(f"depth_{c.name}"), ob.get(f"depth_{c.name}")
        if a_ is None or b_ is None:
            continue
        if b_ > 0:
            (down if not a_ > 0 else touching).append(c.name)
    entered = [f"{sw.limits[j].joint} ({sw.limits[j].side})" for j in np.flatnonzero((db > 0) & ~(da > 0))]
    past = [f"{sw.limits[j].joint} ({sw.limits[j].side})" for j in np.flatnonzero((db > 0) & (da > 0))]
    parts = []
    if down:
        parts.append(f"contact{'s' if len(down) > 1 else ''} {', '.join(down)} touched down")
    if entered:
        parts.append(f"joint{'s' if len(entered) > 1 else ''} {', '.join(entered)} entered "
                     f"{'their limits' if len(entered) > 1 else 'its limit'}")
    held = []
    if touching:
        held.append(f"in contact: {', '.join(touching)}")
    if past:
        held.append(f"past a limit: {', '.join(past)}")
    if not parts and not held:
        return f" (its largest one-step rise in the step to t = {t_jump:.6g} s, nothing in contact)"
    text = f" (its largest one-step rise in the step to t = {t_jump:.6g} s"
    if parts:
        text += ", where " + " and ".join(parts)
    if held:
        text += ("; also " if parts else ", while ") + "; ".join(held)
    return text + ")"


def _energy_rise(model, p, sw, outputs, x, t=None):
    """(rise, scale, words) of energy_verdict's total energy along a run, or None when it cannot
    be known: the energy output plus the limit springs it leaves out (MJCF's, whose shapes
    NAME.json ``limit_laws`` gives: runtime/limit_energy.stored_along at each row's depths);
    rise, its largest rise above its running minimum; scale, max(|E0|, |E - E0|) of the total.
    Rows whose state is not finite are left out (rollout's record="final": the start and the
    end only).  None: an energy output that may leave a contact's elastic energy out (not one
    eomc generated) on a model with contacts, or limit springs left out whose shape is unknown --
    the total is then not known, and a spring's compression shows as a fall, its release as a
    rise."""
    E = np.asarray(outputs["energy"], dtype=float)
    X = np.asarray(x, dtype=float)
    if X.ndim != 2 or X.shape[0] != E.size or E.size < 2:
        return None
    meta = str(model.metadata.get("energy") or "")
    if sw.contacts and not meta:
        return None
    total = E.copy()
    if sw.limits and "joint limits" not in meta:
        springs = _springs_along(model, p, sw, X)
        if springs is None:
            return None
        total = total + springs
    keep = np.isfinite(total) & np.all(np.isfinite(X), axis=1)
    if np.count_nonzero(keep) < 2:
        return None
    rows = np.flatnonzero(keep)
    total = total[rows]
    low = np.minimum.accumulate(total)
    k1 = int(np.argmax(total - low))
    rise = float(total[k1] - low[k1])
    if not rise > 0:
        return None
    k0 = int(np.argmin(total[:k1 + 1]))
    scale = max(abs(float(total[0])), float(np.max(np.abs(total - total[0]))), 1e-300)
    at = (lambda k: f" at t = {float(t[rows[k]]):.6g} s") if t is not None and len(t) == E.size else (lambda k: "")
    what = (f"the energy{' with the limit springs it leaves out' if not np.array_equal(total, E[rows]) else ''} "
            f"rose by {rise:.3g} above its lowest value ({float(total[k0]):.6g}{at(k0)}) to "
            f"{float(total[k1]):.6g}{at(k1)}")
    return rise, scale, what


def _springs_along(model, p, sw, X):
    """The energy the limit springs the energy output leaves out hold at each row of states X
    (rows, nx), or None when some limit's shape is unknown (see _held_sum)."""
    from .limit_energy import stored_along
    specs = _spring_specs(model, sw)      # (called when the energy output leaves the springs out)
    if specs is None:
        return None
    _, _, _, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    depth = ix["sign"][None, :] * (X[:, ix["state"]] - limit_at[None, :])
    total = np.zeros(X.shape[0])
    for j in np.flatnonzero(np.any(depth > 0, axis=0)):
        _, k, e, (push, hold) = specs[j]
        total += stored_along(depth[:, j], p[k], p[e], push, hold)
    return total


def energy_allowance(model, p, x0, in_contact, sw):
    """(held, sprung, start, e) of energy_verdict for a start x0 with parameters p: held, the
    energy (J) the limit springs held at the start that the energy output leaves out (0.0: none);
    sprung, the start held energy the output leaves out and that cannot be sized (a gain is then
    no proof); start, e: each limit's distance past its bound at the start and its width.
    in_contact: some contact starts in touch (its depth output > 0 at the start).  energy_verdict
    says nothing on a gain g with g - held <= its tolerance unless sprung (rollout's rows skip
    it then)."""
    _, _, e, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    start = ix["sign"] * (x0[ix["state"]] - limit_at)
    # a start past a limit holds spring energy an energy output may leave out (the one generated
    # for a URDF robot counts it: metadata "energy" names the joint limits), a start in contact
    # its elastic energy, which a model's own energy output may leave out (the one generated for a
    # robot counts it: metadata "energy"): a gain is then no proof
    counted = "joint limits" in str(model.metadata.get("energy") or "")
    # a start past a limit whose spring the energy output leaves out (MJCF's): the spring energy
    # it held is known (runtime/limit_energy.py), and a gain beyond it is still the integrator's
    held = None if counted else _held_at_start(model, p, sw, start)
    sprung = not counted and held is None and bool(np.any(start > e))
    if not model.metadata.get("energy"):
        sprung = sprung or bool(in_contact)
    return held or 0.0, sprung, start, e


def energy_allowances(model, p, X0, in_contact, sw):
    """energy_allowance's (held, sprung) for many starts X0 ((m, nx)) sharing the parameters p,
    as two arrays (in_contact: (m,) bools).  Bit for bit the per-start function's numbers: each
    row's start is the same elementwise sign * (x - bound), and each distinct start past a bound
    is summed once by _held_sum.  Why: rollout judges every row that ran to the end, and a start
    past a limit (gymnasium's ant: every row, its ankles outside their range) took each row
    through energy_allowance's gathers, ~7 us a row."""
    m = len(X0)
    _, _, e, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    start = ix["sign"][None, :] * (X0[:, ix["state"]] - limit_at[None, :])
    held = np.zeros(m)
    sprung = np.zeros(m, dtype=bool)
    if "joint limits" not in str(model.metadata.get("energy") or ""):
        past = start > 0
        sums = {}
        for k in np.flatnonzero(past.any(axis=1)):
            key = start[k].tobytes()
            if key not in sums:
                sums[key] = _held_sum(model, p, sw, start[k], np.flatnonzero(past[k]))
            if sums[key] is None:
                sprung[k] = bool(np.any(start[k] > e))
            else:
                held[k] = sums[key]
    if not model.metadata.get("energy"):
        sprung |= np.asarray(in_contact, dtype=bool)
    return held, sprung


def _held_at_start(model, p, sw, start):
    """The energy the limit springs held at the start (J), for a model whose limits'
    shapes are in its metadata (``limit_laws``: MJCF's, whose springs the energy output leaves
    out); 0.0 when no limit starts past its bound; None when one does and its shape is unknown.
    Kept on the Switches for the last (p, start) seen, as _bounds: rollout's rows judged one
    after another share them (gymnasium's ant: half of the verdict's time per row)."""
    past = np.flatnonzero(start > 0)
    if not past.size:
        return 0.0
    key = (p.tobytes(), start.tobytes())
    got = sw.__dict__.get("_held")
    if got is not None and got[0] == key:
        return got[1]
    total = _held_sum(model, p, sw, start, past)
    object.__setattr__(sw, "_held", (key, total))     # one tuple: a thread reads key and value together
    return total


def _held_sum(model, p, sw, start, past):
    """_held_at_start's sum over the limits past their bound at the start (not kept)."""
    laws = _held_laws(model, sw)
    from .limit_energy import stored
    total = 0.0
    for j in past:
        law = laws[j]
        if law is None:
            return None
        k, e, push, hold = law
        total += stored(start[j], p[k], p[e], push, hold)
    return total


def _held_laws(model, sw):
    """Per limit of ``sw``, (stiffness index, width index, push, hold) of its law for _held_sum, or
    None where its shape (the metadata's ``limit_laws``) or parameters are unknown; kept on the
    Switches (a model's are fixed).  Why: rollout's verdict sums a start's held energy per distinct
    start, and the parameter names' list and its searches were most of each sum (gymnasium's ant)."""
    got = sw.__dict__.get("_held_laws")
    if got is None:
        laws = model.metadata.get("limit_laws") or {}
        names = list(getattr(model, "param_names", ()))
        got = []
        for lim in sw.limits:
            shape, k, e = laws.get(lim.joint), f"limit_k_{lim.joint}", f"limit_e_{lim.joint}"
            got.append(None if shape is None or k not in names or e not in names else
                       (names.index(k), names.index(e), shape.get("push", 0.0), shape.get("hold")))
        got = tuple(got)
        object.__setattr__(sw, "_held_laws", got)
    return got


def _released(model, p, sw, start, e, outputs):
    """Why the energy rose on a start outside a joint's range (or inside a contact): the energy
    output leaves the limit springs (contacts) out, so the spring energy the start held shows
    as a gain (gymnasium's ant, its ankles 0.52 rad outside: 218 J).  Not the integrator's
    fault: tightening rtol does not change it.  The estimate is the springs' K·r²/2 at the start
    (the law's near-limit stiffening adds a few per cent); the gain is less by what the limit's
    damping took."""
    names = list(getattr(model, "param_names", ()))
    parts, total = [], 0.0
    for j in np.flatnonzero(start > e):
        lim = sw.limits[j]
        key = f"limit_k_{lim.joint}"
        energy = 0.5 * float(p[names.index(key)]) * float(start[j]) ** 2 if key in names else float("nan")
        deep, depth = f"limit_kd_{lim.joint}", f"limit_d_{lim.joint}"
        if deep in names and depth in names:      # the entry spring's, limit_d deeper (joint_laws.entry_gains)
            energy += 0.5 * float(p[names.index(deep)]) * max(float(start[j]) - float(p[names.index(depth)]), 0.0) ** 2
        total += energy
        parts.append(f"joint {lim.joint} ({float(start[j]):.3g} past its {lim.side} limit)")
    if parts:
        return (f"the start outside the range of {', '.join(parts)} held about {total:.3g} J in the limit "
                f"spring{'s' if len(parts) > 1 else ''}, which the energy output does not count: released, it "
                f"shows as a gain (start inside the range to keep the energy check strict)")
    inside = [c.name for c in sw.contacts if len(outputs.get(f"depth_{c.name}", ()))
              and outputs[f"depth_{c.name}"][0] > 0]
    return (f"the start inside contact {', '.join(inside)} released its elastic energy, which the energy "
            f"output does not count (start out of contact to keep the energy check strict)")


def _thrown(sw, past, over, start, e):
    """(past, thrown): the limits of ``past`` split by cause.  A joint that started outside its
    range on one side by s holds the spring energy of s; released, the spring can throw it across
    the range, and with the same stiffness on both sides no further than s past the other limit:
    an overshoot o <= s on the other side is the start's doing (gymnasium's ant file starts its
    ankles 0.524 rad below their lower limits; they go 0.064 past the upper, and 0.058 in MuJoCo's
    mj_step from the same start), not a too-soft stiffness's.  thrown: (limit, other side's limit)."""
    kept, thrown = [], []
    for j in past:
        joint = sw.limits[j].joint
        other = [k for k, lim in enumerate(sw.limits) if lim.joint == joint and k != j]
        k = next((k for k in other if start[k] > e[k] and over[j] <= start[k]), None)
        if k is None:
            kept.append(j)
        else:
            thrown.append((j, k))
    return np.asarray(kept, dtype=int), thrown


def _thrown_notes(sw, thrown, over, start, limit_at):
    """One note for the joints a start outside their range threw past the other limit (_thrown)."""
    if not thrown:
        return []
    each = ", ".join(f"joint {sw.limits[j].joint} went {over[j]:.3g} past its {sw.limits[j].side} limit "
                     f"{limit_at[j]:g} (it started {start[k]:.3g} past its {sw.limits[k].side})" for j, k in thrown)
    many = len(thrown) > 1
    return [f"{each}: the start outside the range released {'their' if many else 'its'} limit "
            f"spring{'s' if many else ''}, which threw {'them' if many else 'it'} across the range "
            f"(less far than {'they' if many else 'it'} started outside: the start's doing, not the "
            f"stiffness's; start inside the range to avoid it)"]


def _overshoot_notes(model, p, sw, past, over, e):
    """The notes for limits ``past`` (indices into sw.limits) that gave more than they may.

    Joints whose stiffness is eomc's default by one rule and whose allowed overshoot is the same
    share one note that states the rule and the remedy once (a limp arm strikes several wrist
    limits in one run: example-robot-data's UR10 and Panda, four each); a joint with the user's
    own stiffness, or alone in its group, gets its own."""
    groups, notes = {}, []
    for j in past:
        lim = sw.limits[j]
        where = f"{over[j]:.3g} past its {lim.side} limit {float(p[lim.param]):g}"
        allowed = f"{LIMIT_OVERSHOOT_WIDTHS * e[j]:.3g}"
        rule, k = _default_stiffness(model, p, lim.joint)
        groups.setdefault((allowed, rule), []).append((lim.joint, where, k))
    for (allowed, rule), joints in groups.items():
        if rule is None or len(joints) == 1:
            for joint, where, _ in joints:
                soft = f", {SOLREF_SOFT}" if rule == SOLREF_RULE else " is too soft for the load it met"
                notes.append(f"joint {joint} went {where}, more than the {LIMIT_OVERSHOOT_WIDTHS} widths "
                             f"({allowed}) a limit may give: {_stiffness_text(model, p, joint)}{soft}")
            continue
        each = ", ".join(f"joint {joint} went {where} (limit_k_{joint} = {k:.4g})" for joint, where, k in joints)
        soft = (f", {SOLREF_SOFT}: a stiffer one with --param limit_k_<joint>=..." if rule == SOLREF_RULE
                else " and too soft for the loads they met: raise one with --param limit_k_<joint>=...")
        notes.append(f"{each}: each more than the {LIMIT_OVERSHOOT_WIDTHS} widths ({allowed}) a limit may give; "
                     f"their limit stiffnesses are the default ({rule}, docs/joint-laws.md){soft}")
    return notes


def _default_stiffness(model, p, joint):
    """(the default's rule, k) when joint's limit stiffness (and its entry spring's, where it has
    one: compiler/tree/joint_laws.entry_gains) is eomc's default, else (None, None)."""
    name = f"limit_k_{joint}"
    names = list(getattr(model, "param_names", ()))
    if name not in names:
        return None, None
    i = names.index(name)
    k = float(p[i])
    if _changed(model, p, joint):
        return None, None
    return _stiffness_rule(model, joint), k


# a URDF limit's parameters that make its stiffness: its own spring's and its entry spring's
_STIFFNESS = ("limit_k", "limit_kd", "limit_cd", "limit_d")


def _changed(model, p, joint):
    """[(name, value, default)] of joint's stiffness parameters (_STIFFNESS) that p changes."""
    names = list(getattr(model, "param_names", ()))
    defaults = np.asarray(model.param_defaults, dtype=float)
    out = []
    for key in _STIFFNESS:
        name = f"{key}_{joint}"
        if name in names and float(p[names.index(name)]) != float(defaults[names.index(name)]):
            out.append((name, float(p[names.index(name)]), float(defaults[names.index(name)])))
    return out


# An MJCF joint's default limit stiffness is its file's solref (MuJoCo's soft limit) on the inertia it
# carries: MuJoCo's own mj_step lets such limits give as much (gymnasium's inverted_pendulum 0.083 rad
# past its hinge limit, walker2d's knees 0.085-0.091, from qpos0 over 10 s; docs/joint-laws.md), so the
# overshoot note says so rather than calling the file's limit too soft for its load.
SOLREF_RULE = "from the joint's MuJoCo solref on the inertia it carries"
SOLREF_SOFT = "as soft as MuJoCo's own under the file's solref"


def _stiffness_rule(model, joint):
    return (SOLREF_RULE if joint in (model.metadata.get("limit_laws") or {})
            else "from the load and inertia the joint carries")


def _stiffness_text(model, p, joint):
    """Whose limit stiffness failed: the user's own (a p= / --param value), or eomc's default
    (docs/joint-laws.md states the rule: from the load and inertia the joint carries; MJCF
    from the joint's solref on that inertia)."""
    name = f"limit_k_{joint}"
    names = list(getattr(model, "param_names", ()))
    if name not in names:
        return f"its limit stiffness {name}"
    i = names.index(name)
    k = float(p[i])
    changed = _changed(model, p, joint)
    if changed:
        return "your " + " and ".join(f"limit {'stiffness' if n == name else 'parameter'} {n} = {v:.4g} (the "
                                      f"default is {d:.4g})" for n, v, d in changed)
    rule = _stiffness_rule(model, joint)
    entry = f"limit_kd_{joint}"
    if entry in names:      # the entry spring (compiler/tree/joint_laws.entry_gains) stops a fast entry
        return (f"its limit stiffness {name} = {k:.4g} with {entry} = {float(p[names.index(entry)]):.4g} from "
                f"limit_d_{joint} = {float(p[names.index(f'limit_d_{joint}')]):.3g} past the limit (the default: "
                f"{rule}, docs/joint-laws.md; raise them with --param {name}=... {entry}=...)")
    return (f"its limit stiffness {name} = {k:.4g} (the default: {rule}, docs/joint-laws.md; raise it with "
            f"--param {name}=...)")


def _bounds(sw, p):
    """(contact radii, allowed penetrations, limit widths, limit positions) for parameters p,
    kept on the Switches for the last p seen: runs repeated with the same parameters (a
    sweep over starts or tolerances) skip the gathers (a run's Python tail is part of the
    time a user waits at loose tolerances, benchmarks/results/contact_wp.md)."""
    key = p.tobytes()
    got = sw.__dict__.get("_bounds")
    if got is not None and got[0] == key:
        return got[1]
    ix = _indices(sw)
    with np.errstate(invalid="ignore"):
        r = np.where(ix["radius"] >= 0, p[np.maximum(ix["radius"], 0)], 0.0)
        allowed = np.where(r > 0, PENETRATION_FRACTION * r, POINT_PENETRATION)
        e = np.where(ix["width"] >= 0, p[np.maximum(ix["width"], 0)], 3e-4)
        limit_at = p[ix["param"]]
    for arr in (r, allowed, e, limit_at):
        arr.flags.writeable = False
    out = (r, allowed, e, limit_at)
    object.__setattr__(sw, "_bounds", (key, out))     # one tuple: a thread reads key and values together
    return out


def _indices(sw):
    """The contacts' radius and the limits' state, parameter, width and sign indices as arrays
    (kept on the Switches: a model's are fixed)."""
    got = sw.__dict__.get("_indices")
    if got is None:
        got = dict(radius=np.array([c.radius for c in sw.contacts], dtype=int),
                   state=np.array([lim.state for lim in sw.limits], dtype=int),
                   param=np.array([lim.param for lim in sw.limits], dtype=int),
                   width=np.array([lim.width for lim in sw.limits], dtype=int),
                   sign=np.array([lim.sign for lim in sw.limits], dtype=float))
        object.__setattr__(sw, "_indices", got)
    return got


def warn_outside_limits(model, x0, p):
    """A PhysicsWarning naming every joint that starts outside its range, with its start, the
    range and what the run does (Go2's zero pose has its knees 0.84 rad outside; gymnasium's ant
    file starts its ankles 0.52 rad outside: the limits' springs then fire at once, issue 29).

    eomc keeps such a start as given, as MuJoCo does with a file's qpos0 (its limits are soft
    constraints): the ant's ankles are thrown across their ranges the same way in both (eomc
    0.064 rad past the other limit, MuJoCo's mj_step 0.058, docs/joint-laws.md).  The overshoot
    that follows is put down to the start, not to the stiffness (verdict: _thrown_notes)."""
    sw = find_switches(model)
    if not sw.limits:
        return
    x0, p = np.asarray(x0, dtype=float), np.asarray(p, dtype=float)
    out, first = [], None
    for lim in sw.limits:
        past = lim.sign * (x0[lim.state] - p[lim.param])
        e = float(p[lim.width]) if lim.width >= 0 else 3e-4
        if past > e:
            lo, hi = _range_of(sw, p, lim.joint)
            out.append(f"{lim.joint} (q_{lim.joint} = {x0[lim.state]:.6g}, {past:.3g} "
                       f"{'above' if lim.sign > 0 else 'below'} its {lim.side} limit {p[lim.param]:.6g}) "
                       f"of range [{lo:.6g}, {hi:.6g}]")
            if first is None:
                first = f"q_{lim.joint}={p[lim.param]:.6g}"
    if out:
        base = getattr(model, "initial_state", None)
        states = [lim.state for lim in sw.limits]
        files = (base is not None and "limit_laws" in (model.metadata or {})
                 and np.array_equal(np.asarray(base, dtype=float)[states], x0[states]))
        whose = ("the file's start (its qpos0)" if files else "the start")
        many = len(out) > 1
        warnings.warn(PhysicsWarning(
            f"{model.name}: {whose} is outside the range of joint{'s' if many else ''} {'; '.join(out)}: "
            f"{'kept, as MuJoCo keeps it' if files else 'kept as given'}: the limit spring{'s' if many else ''} "
            f"push{'' if many else 'es'} {'them' if many else 'it'} back at once and may throw "
            f"{'them' if many else 'it'} across the range (give x0 inside to avoid it, e.g. {first})"),
            stacklevel=_user_level())


def _range_of(sw, p, joint):
    """(lower, upper) limit of joint for parameters p (-inf/inf for a side it has not)."""
    lo, hi = -np.inf, np.inf
    for lim in sw.limits:
        if lim.joint == joint:
            if lim.sign > 0:
                hi = float(p[lim.param])
            else:
                lo = float(p[lim.param])
    return lo, hi


def moved_start_text(name, moved):
    """What the default start moved, for the CLI's note and eomc.compile's DefaultStartWarning:
    ``{name}: the zero pose is outside the range of joint knee (range [-2.5, -0.8]; starts at
    q_knee = -0.81)`` for each joint of ``moved`` (metadata["start_in_range"] entries); joints
    of one range and start are named together, ``FR_calf_joint, FL_calf_joint, ... (range [-2.69653,
    -0.916298]; each starts at -0.926298)`` (first hour s27: A1's four knees repeated theirs)."""
    groups = {}
    for m in moved:
        key = (f"{m['lower']:.6g}", f"{m['upper']:.6g}", f"{m['value']:.6g}")
        groups.setdefault(key, []).append(m)
    parts = []
    for (lower, upper, value), ms in groups.items():
        if len(ms) == 1:
            parts.append(f"{ms[0]['joint']} (range [{lower}, {upper}]; starts at {ms[0]['state']} = {value})")
        else:
            parts.append(f"{', '.join(m['joint'] for m in ms)} (range [{lower}, {upper}]; each starts at {value})")
    return f"{name}: the zero pose is outside the range of joint{'s' if len(moved) > 1 else ''} {'; '.join(parts)}"


def _user_level():
    import sys
    frame, level = sys._getframe(2), 2
    while frame is not None and frame.f_globals.get("__name__", "").startswith("eomc"):
        frame, level = frame.f_back, level + 1
    return level

