"""The whole pipeline in one function: model -> formed system -> C -> library -> loaded Model.

    derive    eomc.compiler.model.model_spec   (run the model file, .formed(), check variables)
    generate  eomc.compiler.emit.generate_c    (IR, optimization passes, C text, metadata;
                                                cached by the formed equations: build.gencache)
    compile   eomc.compiler.build.build        (content-addressed cache; C compiler on a miss)
    export    eomc.compiler.build.export       (only with output_dir: the files `eomc build` writes)
    load      eomc.runtime.loader.load         (cffi dlopen or the Cython extension)
"""
import contextlib
import gc
import os
import sys
import threading
import time

from eomc.runtime.errors import EomcError, ModelError
from eomc.runtime.progress import is_terminal, ticker

from .build import build, cache_root
from .build.builder import compile_jobs
from .build.cache import BadEntry
from .build.gencache import cached_generate
from .emit.poses import pose_digest
from .tree.frames import frames_digest
from .build.export import export
from .model.ceiling import check_ceiling
from .model.spec import read_model, spec_of
from .model.validate import Invalid, check_functions
from .passes.timing import reporting

__all__ = ["compile", "generate", "build_and_load", "Progress"]


class Progress:
    """Stage timings on stderr, e.g. ``eomc: generate  0.84 s``; silent when off."""

    PASS_SHOWN = 0.25   # seconds: compiler passes at least this long are listed under their stage
    # quiet (-q) on a terminal: a stage that lasts this long still gets its live line (a
    # 5000-link robot builds for many minutes; silence would look like a hang)
    QUIET_LIVE_AFTER = 20.0
    # a log (stderr not a terminal, progress on or left to its default): a stage still running after this
    # many seconds gets a plain line, and then its time when it ends, so a CI log or `2> run.log` is
    # not silent for the minutes a contact-rich robot builds (Go2 --ground: ~70 s CPU); short stages
    # print nothing, as runtime/progress.py's integration lines do
    LOG_AFTER = 15.0
    # ... and then one more line every LOG_EVERY seconds while it runs, with the compiler pass it
    # is past, so a build of many minutes (dm_control's dog, humanoid_CMU: > 200 s of generate)
    # does not look hung after its first line (firsthour5, session 24); a 5-minute stage prints
    # about ten lines, never a spinner
    LOG_EVERY = 30.0
    PASS_LABELS = {"cse": "common subexpressions", "differentiate": "Jacobians",
                   "tangent": "Jacobians (tangent)", "share_sincos": "sharing sin/cos",
                   "fold_constants": "folding constants", "fold_parameters": "folding parameters",
                   "dce": "dropping unused code", "expand_powers": "powers to products",
                   "contacts": "contact laws", "jacobian_plan": "Jacobians (plan)",
                   "kane_form": "Kane's equations (auto)"}

    def __init__(self, enabled=None, stream=None):
        """``enabled``: None (on when stderr is a terminal; in a log only a stage lasting
        LOG_AFTER seconds gets its lines), True, False, or "quiet" (the command line's -q: off,
        but a stage lasting QUIET_LIVE_AFTER seconds on a terminal still gets its live line)."""
        self.stream = stream or sys.stderr
        self.quiet_live = enabled == "quiet"
        # a log (not a terminal) gets the sparse lines of a long stage both by default and when
        # asked for progress (`eomc build 2> build.log`: the stage and pass lines come only as
        # they end, so a 70 s pass was a silent 70 s)
        self.log_long = enabled in (None, True) and not is_terminal(self.stream)
        enabled = False if self.quiet_live else enabled
        self.enabled = is_terminal(self.stream) if enabled is None else bool(enabled)
        self.timings = {}
        self.doing = None       # what a long stage's later log lines say it is past
        self.passes_done = 0
        self.now = None         # ... and what it is at now (passes.timing.doing), until the next pass ends
        self.live = ticker("", self.stream, enabled=False)

    def stage(self, label):
        progress = self

        class _Stage:
            def __enter__(self):
                # on a terminal, a live line with the seconds so far (runtime/progress.py)
                progress.live = (ticker(f"eomc: {label}", progress.stream, progress.enabled)
                                 if not progress.quiet_live else
                                 ticker(f"eomc: {label}", progress.stream, True,
                                        delay=progress.QUIET_LIVE_AFTER))
                if progress.enabled and not progress.live.active:
                    print(f"eomc: {label} ...", file=progress.stream, flush=True)
                self.start = time.perf_counter()
                self.said = threading.Event()
                self.done = threading.Event()
                self.timer = None
                progress.doing, progress.passes_done, progress.now = None, 0, None
                if progress.log_long:
                    self.timer = threading.Thread(target=self._still_running, daemon=True,
                                                  name="eomc-progress-log")
                    self.timer.start()

            def _still_running(self):
                # the first line at LOG_AFTER s, then one every LOG_EVERY s until the stage ends
                wait, first = progress.LOG_AFTER, True
                while not self.done.wait(wait):
                    self.said.set()
                    so_far = (f"{progress.LOG_AFTER:g}" if first else
                              f"{time.perf_counter() - self.start:.0f}")
                    doing = f", {progress.doing}" if progress.doing else ""
                    doing += f"{';' if doing else ','} now {progress.now}" if progress.now else ""
                    print(f"eomc: {label} ... (still running after {so_far} s{doing})",
                          file=progress.stream, flush=True)
                    wait, first = progress.LOG_EVERY, False

            def __exit__(self, *exc):
                progress.timings[label] = elapsed = time.perf_counter() - self.start
                progress.live.close()
                if self.timer is not None:
                    self.done.set()
                    self.timer.join()
                if (progress.enabled or self.said.is_set()) and exc[0] is None:
                    print(f"eomc: {label:<9} {elapsed:7.3f} s", file=progress.stream, flush=True)
        return _Stage()

    def pass_done(self, name, seconds):
        """A compiler pass finished: shown when it took long enough to be noticed."""
        label = self.PASS_LABELS.get(name, name.replace("_", " "))
        self.live.note(f"after {label}")
        self.passes_done += 1
        self.doing = f"{self.passes_done} passes done, the last {label}"
        self.now = None
        if self.enabled and seconds >= self.PASS_SHOWN:
            line = f"eomc:   {label:<22} {seconds:7.3f} s"
            if self.live.active:
                self.live.write(line)
            else:
                print(line, file=self.stream, flush=True)

    def now_doing(self, text):
        """What the running step is at (passes.timing.doing): the next log line says it."""
        self.now = text


@contextlib.contextmanager
def _fewer_collections(young=20000):
    """Python's cyclic garbage collector run less often while SymPy makes and drops millions
    of small objects (reference counting frees them: they hold no cycles).  Its default, a
    young collection per 700 new containers, was 12 % of gymnasium ant's generate phase
    (0.57 of 4.54 s CPU, measured with the collector off); one per 20000 kept all but 0.09 s
    of that.  Cyclic garbage only waits a little longer; the thresholds are restored after."""
    old = gc.get_threshold()
    gc.set_threshold(max(young, old[0]), *old[1:])
    try:
        yield
    finally:
        gc.set_threshold(*old)


def _with_poses(spec, functions):
    """``spec`` with the PoseSource of its system (compiler/emit/poses.py) when poses is
    generated (the default set, or asked for); a bad `geometry` dict is reported at its line."""
    import dataclasses
    from .emit.poses import pose_source
    if functions is not None and "poses" not in functions:
        return spec
    try:
        if spec.system is None and spec.model is not None:   # a robot read straight into the tree
            poses = spec.model.poses
        else:
            robot = spec.model if spec.model is not None and spec.model.source.format != "system" else None
            poses = pose_source(spec.system, spec.geometry, robot)
    except (ModelError, ValueError) as exc:
        if spec.path is not None and spec.path.suffix == ".py":
            from eomc.runtime.errors import ModelFileError
            from .model.modelfile import assignment_lines
            line = assignment_lines(spec.path.read_text()).get("geometry")
            raise ModelFileError(str(exc), str(spec.path), line) from None
        raise ModelError(str(exc)) from None
    except Exception as exc:   # poses are extra: a system they cannot read still builds, without them
        import warnings
        from eomc.runtime.errors import EomcWarning
        warnings.warn(f"{spec.name}: built without poses (the animation's body positions): reading the "
                      f"bodies failed with {type(exc).__name__}: {exc}", EomcWarning, stacklevel=3)
        poses = None
    return dataclasses.replace(spec, poses=poses)


def _with_frames(spec, frames, functions):
    """``spec`` with the FrameSource of the frames asked for (compiler/tree/frames.py): they are
    outputs, so a ``functions`` list without 'outputs' cannot carry them."""
    import dataclasses
    from .tree.frames import resolve_frames
    source = resolve_frames(spec, frames)
    if source is None:
        return spec
    if functions is not None and "outputs" not in functions:
        raise ModelError(f"{spec.name}: frame outputs ({', '.join(frames if not isinstance(frames, str) else [frames])}) "
                         f"are outputs of the model: add 'outputs' to the functions (--outputs ...,outputs)")
    return dataclasses.replace(spec, frames=source)


def generate(system, name=None, *, parameters=None, inputs=None, outputs=None, functions=None,
             fold_parameters=False, progress=None, cache_dir=None, use_cache=True, events=None,
             formulation="auto", states=None, contacts=None, frames=None, target=None, check=None):
    """Derive and generate C without compiling: returns (ModelSpec, GeneratedModel).

    ``check``: called with the :class:`~eomc.compiler.model.spec.Reading` as soon as the
    model is read (a robot file's multibody Model, a model file's variables once it has
    run), before anything is derived: the command line checks its run options (--x0,
    --input, --frame, --param names and values) there, so a typo costs the reading, not
    the build, and the file is still read once.

    ``target``: "c99-f64" (the default: double C and the eomc_model ABI) or "c99-f32"
    (float C for firmware, with NAME_step_rk4 and without the struct; see
    eomc.compiler.emit.target).  The generation cache holds the double C; the float C
    is derived from it.

    ``contacts``: ground contacts on a URDF robot's links (eomc.compiler.contact.tree).

    ``formulation``: "auto" (the default: the recursive form where it is cheaper, Kane's
    where it is or where the recursion cannot take the system, with the reason in the
    metadata's ``formulation_note``; see eomc.compiler.formulations.select), "kane" (formed A, b;
    numeric LDLᵀ) or "recursive" (ABA/RNEA/CRBA over the joint tree, eomc.compiler.tree).
    ``frames``: names of frames (URDF links, MJCF or System bodies, "com" for the centre of
    mass) whose pose, velocity and Jacobian become outputs (eomc.compiler.tree.frames).
    ``states``: {z: dz/dt} extra first-order states, appended to x after q and u (a
    System's musculotendons bring theirs without it).

    With ``use_cache`` the C comes from the generation cache when the formed
    equations and options were seen before (see eomc.compiler.build.gencache).
    """
    from .formulations.select import check_formulation, generate_formulation, tree_digest
    from .emit.target import check_target, check_target_functions, retarget
    progress = progress if isinstance(progress, Progress) else Progress(progress)
    check_formulation(formulation)
    target = check_target(target)
    if contacts:
        from .model.spec import with_contact_specs
        system = with_contact_specs(system, contacts)
    try:
        functions = check_functions(functions)
    except Invalid as exc:
        raise ModelError(str(exc)) from None
    check_target_functions(target, functions)   # before the model is read: c99-f32 builds no batch

    def derive(form):
        spec = spec_of(read, parameters=parameters, inputs=inputs, outputs=outputs,
                       events=events, formulation=form, states=states)
        return _with_poses(spec, functions)
    note = None
    with progress.stage("derive"), _fewer_collections():
        # every file is read here, once; each formulation auto compares derives from the reading
        read = read_model(system, name, poses=functions is None or "poses" in functions)
        if check is not None:
            check(read)
        check_ceiling(read, functions, name)     # a robot too large for dense Jacobians: at once
        try:
            spec = derive(formulation)
        except EomcError as exc:
            if formulation != "auto":
                raise
            # the tree was read but the model's variables do not fit it (e.g. a parameters
            # dict without the inertias of the tree's bodies): Kane's form, or its own error
            spec = derive("kane")
            note = f"kane, the fallback (recursive formulation: {exc})"
        # after the fallback: a frame name the model lacks is the user's mistake, not the tree's
        spec = _with_frames(spec, frames, functions)
    def run_generator():
        generated = generate_formulation(spec, functions, fold_parameters, formulation,
                                         kane_spec=lambda: _with_frames(derive("kane"), frames, functions))
        if note is not None:
            generated.metadata["formulation_note"] = note
        return generated
    with progress.stage("generate"), reporting(progress.pass_done, progress.now_doing), _fewer_collections():
        if use_cache:
            generated, _ = cached_generate(spec, functions, fold_parameters, run_generator,
                                           cache_root(cache_dir),
                                           extra=[formulation, tree_digest(spec), note or ""]
                                           + ([] if spec.poses is None else pose_digest(spec.poses))
                                           + frames_digest(spec.frames))
        else:
            generated = run_generator()
        generated = retarget(generated, target)
    return spec, generated


def _with_ground(contacts, ground):
    """``contacts`` with compile's ``ground=`` added as its "@ground" / "@no-ground" entry.

    Why a keyword: the command line says --ground, and ``eomc.compile(urdf, ground=True)`` was a
    bare TypeError (first hour s28)."""
    if ground is None:
        return contacts
    if not isinstance(ground, bool):
        raise ValueError(f"ground= takes True (the robot's <collision> geometry touches the plane z = 0, "
                         f"as --ground), False (as --no-ground) or None; got {ground!r}")
    from .contact.tree import ContactSpec
    if isinstance(contacts, (str, dict, ContactSpec)):
        contacts = [contacts]
    return list(contacts or ()) + ["@ground" if ground else "@no-ground"]


def compile(system, name=None, *, parameters=None, inputs=None, outputs=None, functions=None,
            fold_parameters=False, backend="cffi", cflags=None, cache_dir=None, output_dir=None,
            progress=None, events=None, formulation="auto", states=None, contacts=None, frames=None,
            target=None, check=None, portable=False, floating_base=False, ground=None):
    """Compile a model file (path) or a formed system into a loaded :class:`eomc.runtime.model.Model`.

    ``ground``: True lets a URDF robot's <collision> geometry touch the plane z = 0 (the command
    line's ``--ground``, the same as ``contacts=["@ground"]``); False keeps it off the ground
    beside named contacts (``--no-ground``, ``"@no-ground"``); None (the default) as the file and
    ``contacts`` say.  An MJCF model's collision geoms touch its ground without it.

    ``floating_base``: a URDF path's root on a free joint (True: Euler angles, "quaternion"), as
    the command line's ``--floating-base`` (the same as passing
    ``eomc.compiler.urdf.model.UrdfModel(path, floating_base=...)``).

    ``formulation``: "auto" (default), "kane" or "recursive" (see :func:`generate`).
    ``frames``: e.g. ``["tool0", "com"]``: frame poses, velocities, Jacobians and the centre of
    mass as outputs (see :func:`generate`; read them with ``model.frame(name, t, x)``).
    ``target``: "c99-f64" (default) or "c99-f32" (float C for firmware; the model loads as an
    :class:`eomc.runtime.float32.Float32Model`, which evaluates but does not simulate).
    ``check``: see :func:`generate`.
    ``portable``: build the library for any CPU of this platform, not for this machine's
    (see :func:`eomc.compiler.build.build`; the result bits are the same either way).

    Progress (stage timings on stderr) defaults to on when stderr is a terminal.
    """
    progress = Progress(progress)
    contacts = _with_ground(contacts, ground)
    if floating_base:
        from .model.spec import with_floating_base
        system, name = with_floating_base(system, name, floating_base)
    spec, generated = generate(system, name, parameters=parameters, inputs=inputs, outputs=outputs,
                               functions=functions, fold_parameters=fold_parameters, progress=progress,
                               cache_dir=cache_dir, events=events, formulation=formulation,
                               states=states, contacts=contacts, frames=frames, target=target,
                               check=check)
    extra = {"initial_state": spec.initial_state} if spec.initial_state is not None else None
    if getattr(spec, "timestep", None) is not None:      # the file's own step (MJCF <option timestep>)
        extra = {**(extra or {}), "timestep": spec.timestep}
    if getattr(spec, "ground_check", None) is not None:   # runtime/ground_check.py: bodies under the ground
        extra = {**(extra or {}), "ground_check": spec.ground_check}
    if getattr(spec, "pair_check", None):      # runtime/pair_check.py: pairs that passed into each other
        extra = {**(extra or {}), "pair_check": spec.pair_check}
    if getattr(spec, "limit_laws", None):      # runtime/limit_energy.py: a start past a limit
        extra = {**(extra or {}), "limit_laws": spec.limit_laws}
    if getattr(spec, "start_in_range", None):      # the joints the default start moved into range
        extra = {**(extra or {}), "start_in_range": list(spec.start_in_range)}
    if getattr(spec, "gimbal_locks", None):        # runtime/diagnose.gimbal_passed
        extra = {**(extra or {}), "gimbal_locks": list(spec.gimbal_locks)}
    bodies = _body_parameters(spec)
    if bodies:      # runtime/law_parameters.py: a body's mass or inertia given at run time
        extra = {**(extra or {}), "body_parameters": bodies}
    source = system if isinstance(system, (str, os.PathLike)) else None
    model = build_and_load(generated, backend=backend, cflags=cflags, cache_dir=cache_dir,
                           output_dir=output_dir, extra_metadata=extra, source=source, progress=progress,
                           portable=portable)
    if getattr(spec, "start_in_range", None):
        _warn_moved_start(generated.name, spec.start_in_range)
    _warn_singular_start(model, spec.initial_state)
    if generated.metadata.get("target", "c99-f64") != "c99-f64":   # what float cannot hold, said at build
        import warnings
        from eomc.runtime.errors import EomcWarning
        for concern in model.float_concerns(spec.initial_state):
            warnings.warn(f"{generated.name} ({generated.metadata['target']}): {concern}", EomcWarning,
                          stacklevel=2)
    return model


def _body_parameters(spec):
    """The bodies whose mass or inertia is made of run-time parameters (SymPy systems, and the
    robots whose reader asks for it: spec.body_tree, eomc.compiler.mechanics.body_parameters), or
    [] (spec.body_checks False: a build for identification, whose fits pass unphysical vectors
    through simulate on purpose -- examples/identify_arm.py's Gauss-Newton steps through
    m_l2 = -1.37; MJCF files for now: tests/runtime/test_rollout_lanes.py sets the hopper's
    m_foot = 0 to make zero pivots)."""
    from .mechanics.body_parameters import body_parameters
    if not getattr(spec, "body_checks", True):
        return []
    params = spec.parameters if spec.parameters is not None else getattr(spec.formed, "parameters", ())
    source = spec.system if spec.system is not None else getattr(spec, "body_tree", None)
    try:
        return body_parameters(source, params)
    except Exception:     # what cannot be read is not checked: the build itself does not depend on it
        return []


def _warn_singular_start(model, x0):
    """A warning when the mass matrix is singular (to rounding) at the default start, naming the
    speeds nothing resists: a run from there is so stiff that its step collapses (icub.urdf of
    example-robot-data: a head with next to no inertia about its neck joints), and the user
    should hear it at the build, not after a failed simulation.  One mass_matrix call."""
    import warnings

    import numpy as np

    from eomc.runtime.diagnose import singular_direction
    from eomc.runtime.errors import SingularStartWarning
    from .model.spec import caller_level
    try:
        x = np.zeros(model.nx) if x0 is None else np.asarray(x0, dtype=float)
        why = singular_direction(model, 0.0, x, semidefinite=True) if x.shape == (model.nx,) else ""
    except Exception:                    # a warning must never break a build that worked
        why = ""
    if why:
        warnings.warn(SingularStartWarning(
            f"{model.name}: at the default start {why[2:]}; a simulation from there will be very stiff "
            f"or stop" + ("" if "--param" in why else " (give those bodies inertia, or start elsewhere)")),
            stacklevel=caller_level())


def _warn_moved_start(name, moved):
    """A DefaultStartWarning naming the joints the default start put inside their ranges
    (eomc.compiler.urdf.model.start_in_range), at the user's call: the Python API's channel
    for what the command line prints as a note."""
    import warnings

    from eomc.runtime.errors import DefaultStartWarning
    from eomc.runtime.switching import moved_start_text
    from .model.spec import caller_level
    many = len(moved) > 1
    warnings.warn(DefaultStartWarning(
        f"{moved_start_text(name, moved)}: the default start (initial_state) puts "
        f"{'them' if many else 'it'} just inside the nearest limit (give x0 to simulate from "
        f"another start; the joints are in model.metadata['start_in_range'])"), stacklevel=caller_level())


def build_and_load(generated, *, backend="cffi", cflags=None, cache_dir=None, output_dir=None,
                   extra_metadata=None, source=None, progress=None, portable=False):
    """compile -> (export) -> load of generated C: the second half of :func:`compile`.

    The cache entry is held (a shared lock) while it is copied and loaded, so a concurrent
    `eomc cache clear`/prune cannot remove it midway.  An entry that vanished or changed
    anyway, or that does not load, is a miss: rebuilt once, never copied over good output.
    The hold is released before that rebuild, which takes the key's lock exclusively.
    """
    from eomc.runtime.loader import LoadError, load
    progress = progress if isinstance(progress, Progress) else Progress(progress)
    options = dict(backend=backend, cflags=cflags, cache_dir=cache_dir, extra_metadata=extra_metadata,
                   portable=portable)
    for attempt in (1, 2):
        with contextlib.ExitStack() as held:
            with progress.stage("compile"):
                jobs = compile_jobs(generated, cflags) if progress.enabled or progress.log_long else 1
                if jobs > 1:            # said on the live line and in a log's "still running" lines
                    progress.live.note(f"on {jobs} cores")
                    progress.now_doing(f"on {jobs} cores")
                built = build(generated, force=attempt > 1, hold_in=held, **options)
            try:
                directory = (export(built, output_dir, source=source) if output_dir is not None
                             else built.directory)
                with progress.stage("load"):
                    return load(directory, generated.name, backend=backend)
            except BadEntry:
                if attempt > 1:
                    raise
            except LoadError:
                if output_dir is not None or attempt > 1:
                    raise
