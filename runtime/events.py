"""Events for simulate: zero crossings of compiled functions, found and located in C.

Why this module: an event is a scalar function g(t, x, p, r) whose sign
change the user wants to know (a pendulum passing the vertical, a ball
hitting the floor, a bicycle falling over).  The functions are compiled with
the model (a model file's ``events = {...}``: the generated ``NAME_events``)
or are the model's named outputs; the integrator (runtime/c) checks the sign
at every accepted step and locates a crossing on the step's dense output with
Brent's method, so the loop never comes back to Python.  This module turns
the user's choice of events into the C ``eomc_events`` struct and the records
back into arrays by name.
"""
import numbers
from dataclasses import dataclass

import numpy as np

__all__ = ["Event", "resolve_events", "EventsBinding", "DEFAULT_MAX_EVENTS"]

DEFAULT_MAX_EVENTS = 10000    # recorded occurrences; more are counted and reported, not stored
MAX_EVENT_BYTES = 2 ** 30     # one run's event records (t, id, state) beyond this are refused


@dataclass(frozen=True)
class Event:
    """One event: ``name`` of a compiled event function (or of an output).

    terminal: 0 (never stop), or stop the run at this occurrence (True = the first).
    direction: 0 any sign change, +1 only rising (- to +), -1 only falling (+ to -).
    """
    name: str
    terminal: int = 0
    direction: int = 0


def _event(name, options, model):
    if not isinstance(options, dict):
        raise ValueError(f"{model.name}: options of event {name!r} must be a dict with terminal= "
                         f"and/or direction=; got {options!r}")
    unknown = set(options) - {"terminal", "direction"}
    if unknown:
        raise ValueError(f"{model.name}: event {name!r}: unknown option(s) {', '.join(sorted(unknown))}; "
                         f"known: terminal, direction")
    return _checked(Event(name, options.get("terminal", 0), options.get("direction", 0)), model)


def _checked(ev, model):
    terminal, direction = ev.terminal, ev.direction
    if isinstance(terminal, bool):
        terminal = int(terminal)
    if not isinstance(terminal, numbers.Integral) or terminal < 0:
        raise ValueError(f"{model.name}: event {ev.name!r}: terminal must be True/False or a count "
                         f">= 0; got {ev.terminal!r}")
    if isinstance(direction, bool) or direction not in (-1, 0, 1):
        raise ValueError(f"{model.name}: event {ev.name!r}: direction must be -1, 0 or +1; "
                         f"got {ev.direction!r}")
    return Event(str(ev.name), int(terminal), int(direction))


def model_events(model, recorded=False):
    """The model's compiled events with the options its model file gave; ``recorded``: only
    those a run records by default (not the contacts' clip_<name> switching functions,
    runtime/switching.py: they end steps; a run records them only when asked by name)."""
    from .switching import CLIP_EVENT_PREFIX
    return [Event(d["name"], int(d.get("terminal", 0)), int(d.get("direction", 0)))
            for d in model.metadata.get("events", ())
            if not (recorded and d["name"].startswith(CLIP_EVENT_PREFIX))]


def resolve_events(model, events):
    """(source, [Event]) with source "events" or "outputs", or None for no events.

    events: None -> the model's compiled events (none if it has none); False or
    () -> none; a name, an Event, or a list of them; or a dict name -> options
    ({"terminal": ..., "direction": ...}).  Names are the model's events or,
    failing that, its outputs; one run draws them all from one of the two.
    """
    if events is None:      # the model's own: checked once, kept on the model (as find_switches)
        cached = getattr(model, "_recorded_events", None)
        if cached is None:
            cached = (_resolve(model, model_events(model, recorded=True)),)
            try:
                model._recorded_events = cached
            except AttributeError:
                pass
        return None if cached[0] is None else (cached[0][0], list(cached[0][1]))
    if events is False:
        chosen = []
    elif isinstance(events, (str, Event)):
        chosen = [events]
    elif isinstance(events, dict):
        chosen = [_event(k, v, model) for k, v in events.items()]
    else:
        try:
            chosen = list(events)
        except TypeError:
            raise ValueError(f"{model.name}: events must be names, Event objects or a dict name -> "
                             f"options; got {type(events).__name__}") from None
    return _resolve(model, chosen)


def _resolve(model, chosen):
    if not chosen:
        return None
    declared = {e.name: e for e in model_events(model)}
    out = []
    for item in chosen:
        if isinstance(item, str):
            item = declared.get(item, Event(item))
        if not isinstance(item, Event):
            raise ValueError(f"{model.name}: an event must be a name or an eomc Event; got {item!r}")
        out.append(_checked(item, model))
    names = [e.name for e in out]
    if len(set(names)) != len(names):
        raise ValueError(f"{model.name}: an event is listed twice in {names}")
    if all(n in declared for n in names):
        return "events", out
    if all(n in model.output_names for n in names):
        return "outputs", out
    unknown = [n for n in names if n not in declared and n not in model.output_names]
    known = ", ".join(list(declared) + list(model.output_names)) or "none"
    if unknown:
        raise ValueError(f"{model.name}: unknown event(s) {', '.join(unknown)}: not an event "
                         f"compiled with the model nor an output (known: {known})")
    raise ValueError(f"{model.name}: events {names} mix compiled events and outputs; use one kind "
                     f"per run (or add the outputs' expressions to the model's events)")


def check_max_events(max_events, nx):
    """max_events must be a positive integer whose record buffers fit (MAX_EVENT_BYTES)."""
    if isinstance(max_events, bool) or not isinstance(max_events, numbers.Integral) or max_events < 1:
        raise ValueError(f"max_events must be a positive integer; got {max_events!r}")
    size = float(max_events) * (8 * (nx + 1) + 4)
    if size > MAX_EVENT_BYTES:
        raise ValueError(f"max_events={max_events} would reserve {size / 2 ** 30:.3g} GiB for the event "
                         f"records (time, event and {nx} states each), more than eomc allocates for one "
                         f"run ({MAX_EVENT_BYTES / 2 ** 30:g} GiB); pass a smaller max_events (occurrences "
                         f"beyond it are counted, not stored)")


def nonfinite_names(model, source, events, t, x, p, r):
    """The names of the event functions (or outputs) that are not finite at (t, x): what to
    name when a run stopped on a non-finite value although the state is finite."""
    ffi = model.ffi
    if source == "events":
        names = [d["name"] for d in model.metadata.get("events", ())]
        fn = ffi.cast("eomc_rhs_fn", getattr(model.model_lib, f"{model.name}_events"))
    else:
        names, fn = list(model.output_names), model.c_model.outputs
    out = np.full(len(names), np.nan)
    work = np.zeros(max(1, model.integrators.eomc_integrate_work_size(model.c_model, 0)))
    buf = lambda a: ffi.from_buffer("double[]", a)  # noqa: E731
    x = np.ascontiguousarray(x, dtype=np.float64)
    p = np.ascontiguousarray(p, dtype=np.float64)
    r = np.ascontiguousarray(np.append(np.asarray(r, dtype=np.float64).ravel(), 0.0))
    fn(float(t), buf(x), buf(p), buf(r), buf(out), buf(work))
    return [nm for nm, v in zip(names, out) if not np.isfinite(v)]


class EventsBinding:
    """The C ``eomc_events`` struct for one run and every buffer it points to.

    ``switches`` (runtime/switching.py): the model's contacts and joint limits, whose
    switching functions end the integrator's steps; a contact event the caller did not
    ask for is added as switching only (never recorded), and each limit is a linear
    switching function of one coordinate and one parameter.  ``gmax`` receives the
    largest value each switching function reached (``contact_gmax``, ``limit_gmax``)."""

    def __init__(self, model, source, events, max_events=DEFAULT_MAX_EVENTS, switches=None,
                 observe_only=False):
        ffi = model.ffi
        self.model, self.events = model, list(events)
        lay = _layout(model, source, self.events, switches)
        check_max_events(max_events, model.nx)
        self.contact_slots, self.limit_slots = lay.contact_slots, lay.limit_slots
        self.col, self.direction, self.terminal = lay.col, lay.direction, lay.terminal
        self.switching, self.lin_x, self.lin_p, self.lin_s = lay.switching, lay.lin_x, lay.lin_p, lay.lin_s
        n, nlim = lay.n, lay.nlim
        cap = int(max_events) if self.events else 1     # switching only: nothing is recorded
        # what the C run writes: fresh per binding, so runs in parallel threads never share it
        self.gmax = np.full(n + nlim + 1, -np.inf)
        self.sw_scratch = np.empty(lay.sw_scratch_len)
        self.t_rec = np.empty(cap)
        self.id_rec = np.empty(cap, dtype=np.intc)
        self.x_rec = np.empty((cap, model.nx))
        self.scratch = np.empty(lay.scratch_len)
        ev = self.struct = ffi.new("eomc_events *")
        dbl = lambda a: ffi.from_buffer("double[]", a)  # noqa: E731
        ev.n, ev.fn, ev.ncol = n, lay.fn, lay.ncol
        ev.col, ev.direction, ev.terminal = lay.c_col, lay.c_direction, lay.c_terminal
        ev.capacity = cap
        ev.t_rec, ev.id_rec, ev.x_rec = dbl(self.t_rec), ffi.from_buffer("int[]", self.id_rec), dbl(self.x_rec)
        ev.scratch = dbl(self.scratch)
        ev.nlin = nlim
        ev.switching = lay.c_switching
        ev.lin_x, ev.lin_p, ev.lin_s = lay.c_lin_x, lay.c_lin_p, lay.c_lin_s
        ev.gmax, ev.sw_scratch = dbl(self.gmax), dbl(self.sw_scratch)
        ev.sw_observe = int(bool(observe_only))
        # cffi keeps a from_buffer pointer valid only while its cdata lives (the layout's
        # pointers live on the layout, which this list keeps too)
        self._keep = [lay, ev.t_rec, ev.id_rec, ev.x_rec, ev.scratch, ev.gmax, ev.sw_scratch]

    def switch_maxima(self):
        """The largest value each contact's penetration and each limit's overshoot reached
        (contacts first, then limits, in find_switches' order; -inf where not tracked)."""
        return np.array([self.gmax[s] if s >= 0 else -np.inf for s in self.contact_slots]
                        + [self.gmax[s] for s in self.limit_slots])

    def results(self):
        """(t_events, x_events, stopped_by, dropped): dicts name -> times (k,) / states (k, nx),
        the terminal event's name (or None), occurrences counted beyond max_events."""
        ev = self.struct
        k = min(ev.n_rec, ev.capacity)
        ids = self.id_rec[:k]
        t_events, x_events = {}, {}
        if ev.n_rec == 0 and not ev.terminated:     # nothing recorded: no masks to build
            nx = self.x_rec.shape[1]
            for e in self.events:
                t_events[e.name], x_events[e.name] = np.empty(0), np.empty((0, nx))
            return t_events, x_events, None, max(0, ev.n_rec - ev.capacity)
        # one stable sort instead of a mask per event (a robot has dozens): each event's
        # occurrences stay in time order, each event's arrays its own copy
        order = np.argsort(ids, kind="stable")
        bounds = np.searchsorted(ids[order], np.arange(len(self.events) + 1))
        t_sorted, x_sorted = self.t_rec[order], self.x_rec[order]
        for i, e in enumerate(self.events):
            lo, hi = bounds[i], bounds[i + 1]
            t_events[e.name] = t_sorted[lo:hi].copy()
            x_events[e.name] = x_sorted[lo:hi].copy()
        stopped_by = None
        if ev.terminated and ev.n_rec <= ev.capacity:
            stopped_by = self.events[int(ids[k - 1])].name
        elif ev.terminated:
            stopped_by = "?"
        return t_events, x_events, stopped_by, max(0, ev.n_rec - ev.capacity)


class _Layout:
    """What an EventsBinding reads and never changes for one (model, source, events,
    switches): the slot tables and their C pointers.  Built once and kept on the model
    (``_events_layouts``), so a run's Python set-up is a handful of allocations: on a
    small contact model at loose tolerances that set-up is a large part of the call
    (benchmarks/results/contact_wp.md).  The C side only reads these (const in
    eomc_events), so runs in parallel threads may share them."""


def _layout(model, source, events, switches):
    key = (source, tuple((e.name, e.terminal, e.direction) for e in events),
           None if switches is None else id(switches))
    cache = model.__dict__.setdefault("_events_layouts", {})
    got = cache.get(key)
    if got is not None and got.switches is switches:
        return got
    got = _build_layout(model, source, events, switches)
    if len(cache) >= 32:        # many different event sets: keep the newest few
        cache.pop(next(iter(cache), None), None)
    cache[key] = got
    return got


def _build_layout(model, source, events, switches):
    ffi = model.ffi
    if source is None:      # no events asked for: the switching functions only
        source = "events" if (switches is not None and switches.contacts) else None
    if source == "events":
        names = [d["name"] for d in model.metadata.get("events", ())]
        fn = ffi.cast("eomc_rhs_fn", getattr(model.model_lib, f"{model.name}_events"))
    elif source == "outputs":
        names = list(model.output_names)
        fn = model.c_model.outputs
        if fn == ffi.NULL:
            raise ValueError(f"{model.name}: was built without outputs, so outputs cannot be events")
    else:
        names, fn = [], ffi.NULL
    everything = list(events)
    switching = [0] * len(everything)
    column_of = {nm: i for i, nm in enumerate(names)}          # dicts: a robot has ~50 of each
    slot_of = {e.name: i for i, e in enumerate(everything)}
    lay = _Layout()
    lay.switches, lay.fn, lay.ncol = switches, fn, len(names)
    lay.contact_slots = []
    for c in (switches.contacts if switches is not None else ()):
        column = c.event if source == "events" else f"depth_{c.name}"
        if column not in column_of:
            lay.contact_slots.append(-1)
            continue
        slot = slot_of.get(column)
        if slot is None:
            everything.append(Event(column))
            switching.append(2)         # switching only: not recorded, never terminal
            slot = slot_of[column] = len(everything) - 1
        else:
            switching[slot] = 1
        lay.contact_slots.append(slot)
    for clip in (switches.clips if switches is not None and source == "events" else ()):
        slot = slot_of.get(clip)
        if slot is None and clip in column_of:
            everything.append(Event(clip))
            switching.append(2)         # switching only: the F_n >= 0 clip's kink
            slot_of[clip] = len(everything) - 1
        elif slot is not None:
            switching[slot] = 1
    limits = switches.limits if switches is not None else ()
    n = lay.n = len(everything)
    lay.nlim = len(limits)
    lay.col = np.array([column_of[e.name] for e in everything], dtype=np.intc)
    lay.direction = np.array([e.direction for e in everything], dtype=np.intc)
    lay.terminal = np.array([e.terminal if s != 2 else 0 for e, s in zip(everything, switching)],
                            dtype=np.intc)
    lay.switching = np.array(switching + [0], dtype=np.intc)
    lay.lin_x = np.array([lim.state for lim in limits] + [0], dtype=np.intc)
    lay.lin_p = np.array([lim.param for lim in limits] + [0], dtype=np.intc)
    lay.lin_s = np.array([lim.sign for lim in limits] + [0.0])
    for a in (lay.col, lay.direction, lay.terminal, lay.switching, lay.lin_x, lay.lin_p, lay.lin_s):
        a.flags.writeable = False       # shared by every run of this layout
    lay.limit_slots = list(range(n, n + len(limits)))
    lay.sw_scratch_len = model.integrators.eomc_switch_scratch_size(n, len(limits))
    lay.scratch_len = model.integrators.eomc_events_scratch_size(model.c_model, len(names), n)
    ints = lambda a: ffi.from_buffer("int[]", a)  # noqa: E731
    lay.c_col, lay.c_direction, lay.c_terminal = ints(lay.col), ints(lay.direction), ints(lay.terminal)
    has_switch = any(switching) or limits
    lay.c_switching = ints(lay.switching) if has_switch else ffi.NULL
    lay.c_lin_x, lay.c_lin_p = ints(lay.lin_x), ints(lay.lin_p)
    lay.c_lin_s = ffi.from_buffer("double[]", lay.lin_s)
    return lay
