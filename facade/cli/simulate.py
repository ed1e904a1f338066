"""``eomc simulate MODEL [--t-final T] -o traj.csv [--plot traj.png]``: integrate and write a CSV.

MODEL is a model file (``.py``: compiled first through eomc.compiler.driver,
imported only then, so simulating a built model never imports SymPy) or a
built model directory / NAME.json / libNAME.so (loaded with eomc.load).  The
start is the model's ``initial_state`` unless ``--x0`` overrides entries.
"""

from contextlib import contextmanager

from . import common as cli_common

__all__ = ["configure", "run"]


def configure(parser):
    cli_common.add_model_arguments(parser)
    parser.add_argument("--t-final", type=float, default=10.0, metavar="T", help="end time (as check and animate)")
    parser.add_argument("--t0", type=float, default=0.0, help="start time")
    parser.add_argument("-o", "--output", metavar="CSV", help="trajectory CSV to write")
    parser.add_argument("--plot", metavar="PNG", help="also draw the states and outputs to this PNG "
                        "(matplotlib; panels by kind, at most 8 curves each; a robot's run makes "
                        "several pages: traj.png, traj-2.png, ...)")
    parser.add_argument("--plot-states", metavar="NAMES",
                        help="with --plot: only these states and outputs, comma-separated")
    parser.add_argument("--columns", metavar="NAMES",
                        help="with -o: only these CSV columns (t is always written), comma-separated "
                             "names or glob patterns, e.g. 'q_*,energy' (a robot on the ground writes "
                             "5 outputs per contact point)")
    parser.add_argument("--method", default="auto",
                        help="auto (dop853; bdf from the start with contacts (radau at --rtol < 1e-7), or radau from where "
                             "dop853 finds the problem stiff), rk4 (needs --dt), dopri5 (rk45), dop853, "
                             "radau, bdf, implicitfast (needs --dt)")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance")
    parser.add_argument("--dt", type=float, help="fixed step (rk4, implicitfast)")
    parser.add_argument("--points", type=int, default=1001, help="output rows (adaptive methods)")
    parser.add_argument("--max-steps", type=int, default=None, metavar="N",
                        help="step limit (default 100000; a robot on the ground: 100000 per simulated second)")
    parser.add_argument("--consistent", action="store_true",
                        help="constrained models: complete the dependent coordinates and speeds of the "
                             "start on the constraints first, keeping the independent ones")
    parser.add_argument("--project", action="store_true",
                        help="project onto the model's constraints after each step (a start off the "
                             "constraints is first completed keeping the states given with --x0)")
    parser.add_argument("--baumgarte", type=float, default=0.0, metavar="RATE",
                        help="Baumgarte-style constraint stabilization rate (1/time); 0 = off")
    parser.add_argument("--input", nargs="+", action="extend", metavar="NAME=V|CSV", default=[],
                        help="input values: a constant (F=2) or a CSV file with columns t,NAME "
                             "(linear interpolation, held at the ends); others are 0")
    parser.add_argument("--events", metavar="LIST",
                        help="events to detect: names of compiled events or outputs, comma-separated, "
                             "NAME:terminal / NAME:rising / NAME:falling to set options; 'none' for "
                             "none (default: the model file's events)")
    parser.add_argument("--formulation", choices=("auto", "kane", "recursive"), default="auto",
                        help="dynamics formulation: kane (symbolic M and f, numeric LDLT), recursive "
                             "(ABA/RNEA/CRBA over the joint tree) or auto (the cheaper rhs)")
    cli_common.add_frame_argument(parser)


def _input_table(path, name):
    import numpy as np
    try:
        data = np.genfromtxt(path, delimiter=",", names=True)
    except OSError as exc:
        raise ValueError(f"--input {name}: cannot read {path} ({exc.strerror or exc})") from None
    if data.dtype.names is None or "t" not in data.dtype.names:
        raise ValueError(f"--input {name}: {path} needs a header row with a column t "
                         f"(and {name} or one other column)")
    column = name if name in data.dtype.names else next((c for c in data.dtype.names if c != "t"), None)
    if column is None:
        raise ValueError(f"--input {name}: {path} has no value column besides t")
    return np.atleast_1d(data["t"]), np.atleast_1d(data[column])


def inputs_argument(model, items):
    """--input items -> r for simulate: None, a constant vector, or a (t_grid, values) table."""
    import numpy as np
    pieces = [p.strip() for text in items for p in text.split(",") if p.strip()]
    if not pieces:
        return None
    const, tables = {}, {}
    for item in pieces:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep:
            raise ValueError(f"--input: expected NAME=VALUE or NAME=FILE.csv, got {item!r}")
        if name not in model.input_names:
            raise ValueError(f"{model.name}: unknown input {name} in --input; inputs: "
                             f"{', '.join(model.input_names) or 'none'}")
        try:
            const[name] = float(value)
        except ValueError:
            tables[name] = _input_table(value.strip(), name)
    if not tables:
        return np.array([const.get(n, 0.0) for n in model.input_names])
    grid = np.unique(np.concatenate([t for t, _ in tables.values()]))
    if grid.size < 2:
        raise ValueError("--input: a CSV input needs at least two distinct times")
    for name, (t, v) in tables.items():
        if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)) or not np.all(np.isfinite(v)):
            raise ValueError(f"--input {name}: times must be finite and strictly increasing, "
                             f"values finite")
    cols = [np.interp(grid, *tables[n]) if n in tables else np.full(grid.size, const.get(n, 0.0))
            for n in model.input_names]
    return grid, np.column_stack(cols)


def events_argument(text):
    """--events text -> the events= of simulate (None: the model's own)."""
    if text is None:
        return None
    if text.strip().lower() == "none":
        return False
    out = {}
    for item in (p.strip() for p in text.split(",") if p.strip()):
        name, *flags = item.split(":")
        options = {}
        for flag in flags:
            if flag == "terminal":
                options["terminal"] = 1
            elif flag in ("rising", "falling"):
                options["direction"] = 1 if flag == "rising" else -1
            else:
                raise ValueError(f"--events {item}: unknown option {flag!r} (terminal, rising, falling)")
        out[name] = options
    return out


def _start(model, x0, given, args, params):
    """The start to run from: completed on the constraints for --consistent, and by default
    (or for --project) when the start is off them beyond max(1e-8, 10 atol), holding what the
    user gave with --x0 (a projection of the whole state would move those too); a note on
    stderr says by how much it was off and what was completed.  An inconsistent start that
    cannot be completed is refused (running it drove the slider-crank into u = 4e7)."""
    import sys

    import numpy as np

    from eomc.errors import ModelError
    from eomc.runtime.consistent import complete_start, start_residual
    if model.nhol + model.nvel == 0:
        return x0
    x = np.array([x0[n] for n in model.state_names])
    p = None if params is None else np.asarray(params, dtype=float)
    hol, vel = start_residual(model, args.t0, x, p)
    limit = max(1e-8, 10 * args.atol)
    if not args.consistent and hol <= limit and vel <= limit:
        return x0
    try:
        done, held = complete_start(model, x, args.t0, p, given=sorted(given))
    except ModelError as error:
        named = f"; the states given with --x0 ({', '.join(sorted(given))}) are held" if given else ""
        raise ModelError(f"the start is off the constraints (position residual {hol:.3g}, velocity "
                         f"residual {vel:.3g}) and cannot be completed on them: {error}{named}; give "
                         f"a consistent --x0 (the dependent coordinates and speeds too)") from None
    moved = [f"{n}={v:.6g}" for n, v, old in zip(model.state_names, done, x) if v != old]
    flag = ("--consistent" if args.consistent else "--project" if args.project else
            f"the start was off the constraints (position residual {hol:.3g}, velocity residual {vel:.3g})")
    if moved:
        print(f"eomc simulate: note: {flag}: completed the start on the constraints: {', '.join(moved)}"
              f" (held: {', '.join(held)})", file=sys.stderr)
    return dict(zip(model.state_names, done.tolist()))


def plot_names(text):
    """--plot-states' names, or None (everything)."""
    if text is None:
        return None
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise ValueError("--plot-states: give names, comma-separated")
    return names


def _columns(model, args):
    """--columns' patterns, checked against the columns the CSV will have; None: all."""
    if args.columns is None:
        return None
    patterns = [n.strip() for n in args.columns.split(",") if n.strip()]
    if not patterns:
        raise ValueError("--columns: give names or glob patterns, comma-separated")
    if not args.output:
        raise ValueError("--columns chooses the CSV's columns: give -o CSV too")
    from eomc.runtime.result import select_columns
    from eomc.runtime.simulate import result_columns
    select_columns(result_columns(model), patterns, what=f"{model.name}: --columns")
    return patterns


def run(args):
    import sys
    import warnings

    from eomc.runtime.consistent import ConstraintWarning
    from eomc.runtime.progress import integration
    from eomc.runtime.simulate import simulate
    cli_common.writable_file(args.output, "-o")
    cli_common.writable_file(args.plot, "--plot")
    if args.plot:       # before the build and the run, not after them
        import importlib.util
        if importlib.util.find_spec("matplotlib") is None:
            from eomc.runtime.errors import MissingExtraError
            raise MissingExtraError("--plot", "plot", ["matplotlib"])
    model = cli_common.load_model(args.model, args.quiet, **cli_common.model_options(args),
                                  **cli_common.read_checks(args),   # --param, from the one reading
                                  methods=(args.method,))
    given = cli_common.parse_assignments(args.x0, "x0")
    x0 = cli_common.initial_state(model, given)
    params = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    chosen = plot_names(args.plot_states)      # checked before the run, not after it
    if chosen is not None:
        unknown = [n for n in chosen if n not in model.state_names and n not in model.output_names]
        if unknown:
            raise ValueError(f"{model.name}: --plot-states names {', '.join(unknown)}, which is no state or "
                             f"output (states: {', '.join(model.state_names[:12])}"
                             f"{', ...' if model.nx > 12 else ''})")
    columns = _columns(model, args)          # checked before the run, not after it
    x0 = _start(model, x0, given, args, params)
    seen = []
    try:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always", ConstraintWarning)
            # long runs report how far they got (a bar on a terminal, a line every ~10 % of
            # the span and >= 5 s otherwise: runtime/progress.py); -q: nothing
            with integration(f"eomc simulate {model.name}", sys.stderr, not args.quiet), \
                    _kept_on_stop(args, columns):
                res = simulate(model, x0, (args.t0, args.t_final), p=params, method=args.method,
                               rtol=args.rtol, atol=args.atol, dt=args.dt, max_steps=args.max_steps,
                               n_points=None if args.dt else args.points, project=args.project,
                               baumgarte=args.baumgarte, r=inputs_argument(model, args.input),
                               events=events_argument(args.events), raise_on_failure=False)
    finally:    # also when the run then fails: the advice explains the failure
        for w in seen:      # in the command line's words (--consistent, not consistent=True)
            message = w.message.cli_text() if isinstance(w.message, ConstraintWarning) else w.message
            warnings.warn_explicit(message, w.category, w.filename, w.lineno)
    if res.status != 0:     # keep what was computed, marked incomplete, then fail
        from eomc.runtime.errors import SimulationError
        kept = ""
        if args.output and len(res.t):
            res.to_csv(args.output, columns=columns)
            kept = (f"; wrote the {len(res.t)} rows computed up to t={res.t[-1]:.9g} to {args.output} "
                    f"(marked '# incomplete' on its last line)")
        raise SimulationError(state_last(cli_advice(f"{res.message}{kept}", args.max_steps)))
    _no_ground(model, res)
    s = res.stats
    print(f"{model.name}: {res.method} t=[{args.t0:g}, {args.t_final:g}]: {s['steps']} steps "
          f"({s['rejected']} rejected), {s['nfev']} rhs, {s['njev']} jacobian, {s['nlu']} LU")
    if len(res.t) > 1 and not (res.x != res.x[0]).any():
        # first hour s21: SymPy's rolling disc (and dm_control's cartpole, acrobot) start at rest
        # on an equilibrium and stay there, which reads as if the run did nothing
        from eomc.runtime.diagnose import leaving_state
        print(f"  nothing moved: the start is an equilibrium (every state stayed at its start value); "
              f"give --x0 to start elsewhere, e.g. --x0 {leaving_state(model, res.x[0], params, args.t0)}=0.1")
    frames = getattr(model, "frame_names", ())
    grouped = _contact_summary(model, res.outputs, res.t)
    zero = []       # outputs 0 at every row (a flat ground's Ftz_): one line, not one each
    for name, values in res.outputs.items():
        if name.partition(".")[0] in frames or name in grouped:  # frames: a line each, below
            continue
        if len(values) > 1 and not (values != 0).any():
            zero.append(name)
            continue
        print(f"  {name}: start {values[0]:.10g}, end {values[-1]:.10g}, "
              f"change {values[-1] - values[0]:.3g}")
    if zero:
        print(f"  0 throughout: {', '.join(zero[:6])}" + (f", ... ({len(zero)} in all)" if len(zero) > 6 else ""))
    for line in grouped.get("", ()):
        print(line)
    if not res.outputs and len(res.t) > 1 and (res.x != res.x[0]).any():
        import numpy as np
        # first hour s22: a URDF robot without limits or contacts (bolt.urdf, borinot) has no
        # energy output, and simulate printed its step count only
        change = np.abs(res.x[-1] - res.x[0])
        n = model.nq if change[:model.nq].any() else model.nx        # a coordinate, where one moved
        k = int(np.argmax(change[:n]))
        why = ("the model defines none" if not model.noutput else      # or a build of chosen functions
               f"the build left out {model.name}_outputs ({', '.join(model.output_names[:3])}"
               f"{', ...' if model.noutput > 3 else ''}): add outputs to eomc build --outputs")
        print(f"  no outputs ({why}); of its {n} {'coordinates' if n == model.nq else 'states'} "
              f"{model.state_names[k]} changed most: start {res.x[0, k]:.10g}, end {res.x[-1, k]:.10g}"
              + ("" if args.output else "; -o FILE writes every state"))
    for name in frames:
        p = res.frame(name).p
        print(f"  {name}: position start ({', '.join(f'{v:.6g}' for v in p[0])}), "
              f"end ({', '.join(f'{v:.6g}' for v in p[-1])})")
    if res.constraint_residual is not None:
        print(f"  constraint residual: max {res.constraint_residual.max():.3g}")
    silent = []     # events that never fired: one line, not one each (a URDF robot's default
    touched = {}    # ground gives a contact event per corner); so are many contacts' touch-downs
    for name, times in (res.t_events or {}).items():
        if not len(times):
            silent.append(name)
            continue
        if f"Fn_{name[len('contact_'):]}" in grouped and name.startswith("contact_"):
            touched[name] = times
            continue
        shown = ", ".join(f"{t:.10g}" for t in times[:5]) + (", ..." if len(times) > 5 else "")
        print(f"  event {name}: {len(times)} at t = {shown}")
    if touched:
        first = min(touched, key=lambda n: touched[n][0])
        print(f"  contact events: {sum(len(t) for t in touched.values())} at {len(touched)} points, the first "
              f"{first} at t = {touched[first][0]:.10g}")
    if silent:
        print(f"  events that never fired: {', '.join(silent[:3])}"
              + (f", ... ({len(silent)} in all)" if len(silent) > 3 else ""))
    if res.event_stop:
        print(f"  stopped by event {res.event_stop} at t={res.t_final:.10g}")
    if args.output:
        print(f"wrote {res.to_csv(args.output, columns=columns)}")
    if args.plot:
        if res.model is None:       # as Model.simulate sets it: the plot knows the contacts
            res.model = model
        written = res.plot(args.plot, names=plot_names(args.plot_states))
        for path in (written if isinstance(written, list) else [written]):
            print(f"wrote {path}")
        if args.plot_states is None:
            from eomc.runtime.plotting import untouched
            idle = untouched(res)
            if idle:
                print(f"  --plot: {len(idle)} contact{'s' if len(idle) > 1 else ''} never touched "
                      f"({', '.join(idle[:3])}{', ...' if len(idle) > 3 else ''}): {'their' if len(idle) > 1 else 'its'}"
                      f" outputs (all 0 but depth_) are not drawn; --plot-states names what to draw")
            from eomc.runtime.plotting import flat_zero
            flat = flat_zero(res)
            if flat:
                print(f"  --plot: {len(flat)} contact output{'s' if len(flat) > 1 else ''} 0 throughout "
                      f"({', '.join(flat[:3])}{', ...' if len(flat) > 3 else ''}) not drawn")
    return 0


@contextmanager
def _kept_on_stop(args, columns):
    """Ctrl-C or SIGTERM (a job scheduler's, `kill`'s) during the run: the C loop stops at once
    (runtime/native.py arms both), and the rows it computed are written to -o, marked as stopped on
    the CSV's last line, before the command exits 130 / 143 (s27: SIGTERM waited for the whole run,
    and what was computed was lost)."""
    import sys
    try:
        yield
    except BaseException as stop:
        res = getattr(stop, "partial_result", None)
        if res is None or isinstance(stop, Exception):
            raise
        what = "interrupted (SIGINT, Ctrl-C)" if isinstance(stop, KeyboardInterrupt) else "terminated (SIGTERM)"
        reached = float(res.t_final)
        kept = ""
        if args.output and len(res.t):
            if res.status == 0:     # the run had ended as the signal came: its rows are whole
                kept = f"; the run had finished: wrote its {len(res.t)} rows to {args.output}"
            else:
                res.message = (f"{what} at t={reached:.9g} of [{args.t0:g}, {args.t_final:g}]: the rows "
                               f"computed up to it")
                kept = (f"; wrote the {len(res.t)} rows computed up to t={res.t[-1]:.9g} to {args.output} "
                        f"(marked '# incomplete' on its last line)")
            res.to_csv(args.output, columns=columns)
        print(f"eomc simulate: {what.split()[0]} at t={reached:.9g} of [{args.t0:g}, {args.t_final:g}] "
              f"after {res.stats.get('steps', 0)} steps{kept}", file=sys.stderr)
        raise


def _no_ground(model, res):
    """A warning when a floating-base robot with no contact fell (runtime.diagnose.no_ground):
    with the options that give it a ground."""
    import warnings

    from eomc.runtime.diagnose import no_ground
    from eomc.runtime.switching import PhysicsWarning
    text = no_ground(model, res.t, res.x)
    if text:
        warnings.warn(text, PhysicsWarning, stacklevel=2)


def cli_advice(message, max_steps):
    """A failed run's advice in the command line's flags: the runtime's message names keyword
    arguments (sweep s27: Talos --floating-base --ground stopped with 'raise max_steps', and
    explicit methods out of steps were told to "use method='radau'").  The runtime's says how
    many steps were allowed ("raise max_steps (200000 now: the default for ...)")."""
    return (message.replace("raise max_steps (", "raise --max-steps (")
            .replace("raise max_steps", f"raise --max-steps ({max_steps} now)")
            .replace("use method='radau'", "use --method radau"))


def state_last(message):
    """A failure's message with its '; state n=v, ...' part moved to the end: the diagnosis and
    what was written come first (first hour s23: human.urdf's gimbal lock was named after 88
    values, 3.5 kB of them).  A state holds no ';', so the diagnosis is what follows its next one."""
    head, mark, rest = message.partition("; state ")
    if not mark:
        return message
    state, sep, after = rest.partition("; ")
    return f"{head}; {after}; state {state}" if sep else message


def _when(outputs, kind, name, t):
    """' at t = ...' of the row where output kind_name is largest ('' without the times)."""
    import numpy as np
    values = np.asarray(outputs[f"{kind}_{name}"])
    if t is None or not len(t) or not values.max() > 0:      # never touched: no time worth a word
        return ""
    return f" at t = {float(t[int(np.argmax(values))]):.6g}"


CONTACT_LINES = 4   # more contacts than this: their outputs in a few lines, not five lines each
_CONTACT_KINDS = ("Fn", "Ftx", "Fty", "Ftz", "depth")


def _contact_summary(model, outputs, t=None):
    """Output name -> True for the contact outputs summarised instead of listed (a URDF robot's
    --ground gives 32 points per mesh: Go2 608, 3,040 lines; gymnasium's humanoid 109 self-pairs,
    each with its point px_/py_/pz_), and under "" the summary lines."""
    from eomc.runtime.switching import find_switches
    import numpy as np
    names = [c.name for c in find_switches(model).contacts
             if all(f"{k}_{c.name}" in outputs for k in _CONTACT_KINDS)]
    if len(names) <= CONTACT_LINES:
        return {}
    grouped = {f"{k}_{c}": True for c in names for k in _CONTACT_KINDS}
    pairs = [c for c in names if all(f"p{a}_{c}" in outputs for a in "xyz")]    # MJCF pairs' points
    grouped.update({f"p{a}_{c}": True for c in pairs for a in "xyz"})
    force = {c: float(np.max(outputs[f"Fn_{c}"])) for c in names}
    depth = {c: float(np.max(outputs[f"depth_{c}"])) for c in names}
    touching = [c for c in names if outputs[f"Fn_{c}"][-1] > 0]
    strongest, deepest = max(force, key=force.get), max(depth, key=depth.get)
    grouped[""] = [
        f"  contacts: {len(names)} points (Fn_, Ftx_, Fty_, Ftz_, depth_<point>"
        f"{f'; px_, py_, pz_ of {len(pairs)} pairs' if pairs else ''} in the CSV), "
        f"{sum(f > 0 for f in force.values())} touched, {len(touching)} touching at the end",
        f"  contacts: largest normal force Fn_{strongest} = {force[strongest]:.6g}{_when(outputs, 'Fn', strongest, t)}, "
        f"deepest depth_{deepest} = {depth[deepest]:.6g}{_when(outputs, 'depth', deepest, t)} (maxima over the run"
        f"{'' if t is None else chr(39) + 's rows'}; a touch-down's peak is short: docs/contact.md)"]
    return grouped
