"""What `eomc simulate`, `eomc report` and `eomc check` share: which model, from which state.

MODEL is a model file (compiled on the way, with the build cache) or a built
model directory / NAME.json (loaded without SymPy).  --x0 and --param take
NAME=VALUE items, space- or comma-separated (`--x0 q1=0.5 u1=0` or `--x0 q1=0.5,u1=0`), and
repeated flags add up (`--x0 q1=0.5 --x0 u1=0`: argparse's "extend").
Mistakes in them are ValueErrors, which `eomc` prints as one line (exit status 2).
"""
from pathlib import Path

__all__ = ["with_options", "add_model_arguments", "add_robot_arguments", "add_formulation_argument", "add_frame_argument", "FORMULATION_HELP", "load_model", "model_options", "parse_assignments", "initial_state",
           "parameter_values", "writable_file", "read_checks"]


def add_model_arguments(parser):
    """The positional MODEL and the --x0/--param overrides."""
    parser.add_argument("model", help="model file (.py), robot (.urdf), MuJoCo model (.xml) or built model "
                                      "directory / NAME.json")
    parser.add_argument("--x0", nargs="+", action="extend", metavar="NAME=V", default=[],
                        help="initial state entries; states not named keep the model's initial_state "
                             "(0 when it has none)")
    parser.add_argument("--param", nargs="+", action="extend", metavar="NAME=V", default=[],
                        help="parameter values (others keep their defaults)")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress on stderr (compiling a model file, long runs)")
    add_robot_arguments(parser)


def add_robot_arguments(parser):
    """The options of a robot file (URDF, MJCF), for build, inspect and the model commands."""
    parser.add_argument("--floating-base", action="store_true",
                        help="URDF: a 6-dof floating joint (position + body XYZ Euler angles, or a "
                             "quaternion with --orientation quaternion) between the world and the root link; "
                             "nothing touches the ground without --ground or --contact (the robot falls "
                             "freely, and simulate, animate and check warn)")
    parser.add_argument("--orientation", choices=("euler", "quaternion"), default=None,
                        help="how free (and MJCF ball) joints' orientation is written: quaternion (w, x, "
                             "y, z as MuJoCo's qpos; no singularity, kept unit by the integrators; the MJCF "
                             "default) or euler (body XYZ angles, singular at pitch +-90 deg; the URDF "
                             "--floating-base default)")
    parser.add_argument("--allow-nonphysical-inertia", action="store_true",
                        help="URDF: build moving links whose principal moments are negative (refused "
                             "by default), with a warning naming each")
    add_contact_argument(parser)
    add_ignore_argument(parser)
    add_limits_argument(parser)
    add_pairs_argument(parser)


CONTACT_HELP = ("URDF/MJCF: a ground contact sphere on LINK (an MJCF body), centred at x,y,z in its frame "
                "(default 0,0,0), of the given radius (default 0); repeat for more; @collision adds every "
                "collision sphere; parameters k_/c_/mu_/vs_/r_<link> (see docs/contact.md)")


def add_contact_argument(parser):
    """--contact LINK[:x,y,z[:radius]] (repeatable): ground contacts (eomc.compiler.contact)."""
    parser.add_argument("--contact", action="append", metavar="LINK[:x,y,z[:radius]]", default=None,
                        help=CONTACT_HELP)
    parser.add_argument("--ground", dest="contact", action="append_const", const="@ground",
                        help="URDF: the robot's <collision> geometry (boxes, cylinders, spheres, meshes) touches "
                             "the plane z = 0, with MuJoCo's default contact (same as --contact @ground; MJCF "
                             "models take their collision geoms without it)")
    parser.add_argument("--no-ground", dest="contact", action="append_const", const="@no-ground",
                        help="URDF: only the named --contact spheres touch the ground (by default the "
                             "<collision> geometry of the robot's other bodies meets it too)")


# eomc.compiler.mjcf.model.IGNORABLE, written out: the CLI must not import the compiler to
# configure its parsers (`eomc simulate DIR` starts without it; tests/cli/test_mjcf_cli.py
# checks the two lists agree)
IGNORABLE = ("tendons", "equality", "actuators", "armature", "frictionloss", "limits", "fluid", "plugins")


def add_ignore_argument(parser):
    """--ignore for MJCF models: what the tree cannot express, dropped with a warning."""
    parser.add_argument("--ignore", metavar="WHAT[,WHAT]", action="append", default=[],
                        help=f"MJCF (.xml): drop these with a warning instead of refusing the model "
                             f"({', '.join(IGNORABLE)})")


def add_limits_argument(parser):
    """--limits on|off: the model file's joint limits, damping and friction (on by default)."""
    parser.add_argument("--limits", choices=("on", "off"), default="on",
                        help="URDF/MJCF: the file's joint limits (soft), damping and friction act "
                             "(on, default) or are ignored (off)")


# --pairs: eomc.compiler.mjcf.model.MjcfModel(pairs=...) of each choice
PAIRS = {"trees": "trees", "all": None, "none": False}


def add_pairs_argument(parser):
    """--pairs trees|all|none: an MJCF model's body–body contacts (MjcfModel(pairs=...))."""
    parser.add_argument("--pairs", choices=tuple(PAIRS), default=None,
                        help="MJCF: body-body contacts between the file's geoms: all (default: every pair "
                             "MuJoCo collides, self-collisions within one tree included), trees (only "
                             "between kinematic trees, with the world's geoms and the file's <pair>s: "
                             "faster build) or none")


FORMULATION_HELP = ("dynamics formulation: auto (default: the cheaper rhs of the two; kane where the "
                    "recursion cannot take the system, saying why), kane (symbolic M and f, numeric "
                    "LDLT) or recursive (ABA/RNEA/CRBA over the joint tree)")


def add_formulation_argument(parser):
    """--formulation for the commands that compile a model file (auto unless given)."""
    parser.add_argument("--formulation", choices=("auto", "kane", "recursive"), default="auto",
                        help=FORMULATION_HELP)


def floating_base_of(args):
    """The floating_base= of the command line: False, True (Euler angles) or "quaternion"
    (``--floating-base --orientation quaternion``); ``--orientation`` without a free joint to
    apply to is refused."""
    floating = bool(getattr(args, "floating_base", False))
    orientation = getattr(args, "orientation", None)
    if orientation is None:
        return floating
    if not floating:
        model = str(getattr(args, "model", ""))
        if not model.lower().endswith(".urdf"):
            return False      # MJCF: its own free joints (with_options)
        raise ValueError(f"--orientation {orientation}: a URDF robot has a free joint only with "
                         f"--floating-base")
    return "quaternion" if orientation == "quaternion" else True


def model_options(args):
    """Keyword arguments of load_model for the options given: a URDF's floating base, a
    formulation other than the default auto (none unless given, so stand-ins of load_model
    stay simple)."""
    options = {}
    floating = floating_base_of(args)       # --orientation without a free joint: refused here
    if floating:
        options["floating_base"] = floating
    if getattr(args, "orientation", None) and not str(getattr(args, "model", "")).lower().endswith(".urdf"):
        options["orientation"] = args.orientation          # an MJCF model's ball and free joints
    if getattr(args, "allow_nonphysical_inertia", False):
        options["allow_nonphysical_inertia"] = True
    if getattr(args, "contact", None):
        options["contacts"] = args.contact
    if getattr(args, "formulation", None) not in (None, "auto"):
        options["formulation"] = args.formulation
    if getattr(args, "frame", None):
        options["frames"] = list(args.frame)
    if getattr(args, "ignore", None):
        options["ignore"] = args.ignore
    if getattr(args, "limits", "on") == "off":
        options["limits"] = False
    if getattr(args, "pairs", None) is not None:
        options["pairs"] = args.pairs
    return options


def with_options(model, name=None, *, floating_base=False, allow_nonphysical_inertia=False, limits=True,
                 ignore=(), orientation=None, pairs=None):
    """(model, name) for the driver with the command line's model options: an MJCF file's
    (``--ignore``, ``--limits off``: :func:`eomc.compiler.mjcf.model.with_ignore`) or a URDF's
    (:func:`eomc.compiler.urdf.model.with_options`, which refuses URDF flags on anything else)."""
    from eomc.compiler.mjcf.model import is_mjcf_path, with_ignore
    from eomc.compiler.urdf.model import with_options as urdf_options
    if pairs is not None and not is_mjcf_path(model):
        raise ValueError(f"--pairs applies to MuJoCo models (.xml), not to {model}")
    if is_mjcf_path(model) and not (floating_base or allow_nonphysical_inertia):
        return with_ignore(model, name, ignore, limits=limits, orientation=orientation,
                           pairs=PAIRS[pairs] if pairs else None)
    with_ignore(model, name, ignore)        # --ignore on anything but MJCF: says what it applies to
    return urdf_options(model, name, floating_base=floating_base,
                        allow_nonphysical_inertia=allow_nonphysical_inertia, limits=limits)


FRAME_HELP = ("output the world pose, velocity and Jacobian of this frame (a URDF link, tool0 and "
              "other welded links too; an MJCF or System body) or, for 'com', the centre of mass "
              "and its velocity; repeatable")


def add_frame_argument(parser):
    """--frame NAME (repeatable): frame outputs (eomc.compiler.tree.frames)."""
    parser.add_argument("--frame", action="append", metavar="NAME", help=FRAME_HELP)


# The methods that read NAME_implicit (the fixed step's contact and damping terms,
# runtime/simulate.implicit_terms); every other method runs the same without it.
IMPLICIT_READERS = ("implicitfast",)


def without_implicit():
    """What a command that runs none of IMPLICIT_READERS builds when no function list is given:
    the driver's default set (functions=None) without NAME_implicit.  Why: on a robot with
    ground contacts NAME_implicit is a fifth to a quarter of the build (Solo12 --ground: 59 -> 43 s CPU,
    benchmarks/results/ground_run.md) and the default method (auto: BDF or Radau on contacts)
    never reads it."""
    from eomc.compiler.emit.generate import ALL_FUNCTIONS
    from eomc.compiler.emit.signatures import ON_REQUEST
    return [f for f in ALL_FUNCTIONS if f not in ON_REQUEST and f != "implicit"]


def reads_implicit(methods):
    """Whether any of ``methods`` (names or aliases as the commands take them) reads NAME_implicit;
    ValueError for a name that is no method (load_model checks them before any build)."""
    from eomc.runtime.simulate import resolve_method
    return any([resolve_method(method) in IMPLICIT_READERS for method in methods])   # every name checked


def load_model(path, quiet=False, floating_base=False, formulation="auto", frames=None, ignore=(),
               contacts=None, allow_nonphysical_inertia=False, limits=True, functions=None, check=None,
               orientation=None, pairs=None, methods=None, params=None):
    """A runtime Model from a model file (.py, .urdf, MuJoCo's .xml; compiled) or a built
    directory / json (loaded).  ``ignore``: an MJCF model's ignorable elements (--ignore).

    ``methods``: the integration methods the command will run (None: not known).  When none of
    them reads NAME_implicit and no ``functions`` are given, a build of the default functions
    found in the cache is taken, else one without NAME_implicit (:func:`without_implicit`) is
    taken or built; a command that runs implicitfast is only ever served a model with it.  A
    name that is no method is a ValueError before anything is read or built.

    Compiling shows its stages on stderr when that is a terminal, unless ``quiet``.
    ``frames``: frame outputs to compile in; a built model must already have them.
    ``check``: called with the model as read, before anything is derived (:func:`read_checks`).
    ``params``: the command's --param values ({name: value}, from :func:`read_checks`): the build's
    warning of a singular mass matrix at the default start is judged again with them
    (:func:`_judged_with`), so following its own advice (--param Ixx_head=...) silences it.

    A model file built before with the same options, whose bytes (and the files its build
    read) have not changed, is loaded from the build cache without deriving it again
    (eomc.compiler.build.reuse): the second `eomc simulate` of a robot starts at once.
    """
    path = Path(path)
    if methods:     # a misspelt --method is refused before the build, not after it (s27)
        reads_implicit(methods)
    if not path.exists():
        raise ValueError(f"{path}: no such model file or built model directory")
    if not path.is_dir():
        from eomc.runtime.readable import check_regular_file
        check_regular_file(path, "model file")        # a FIFO or device: refused before it is opened
    if ignore and not (path.is_file() and path.suffix.lower() in (".xml", ".mjcf")):
        from eomc.compiler.mjcf.model import with_ignore
        with_ignore(str(path), ignore=ignore)        # says what --ignore applies to
    if path.is_file() and path.suffix.lower() in (".py", ".urdf", ".xml", ".mjcf"):
        if not quiet:
            fixed_base_note(path, floating_base)
        options = reuse_options(floating_base=floating_base, formulation=formulation, frames=frames, ignore=ignore,
                                contacts=contacts, allow_nonphysical_inertia=allow_nonphysical_inertia,
                                limits=limits, functions=functions, orientation=orientation, pairs=pairs)
        return _judged_with(params, lambda: _reused_or_compiled(path, options, quiet, check, functions, methods))
    if contacts:
        raise ValueError(f"{path}: --contact applies to a robot (.urdf, .xml) being compiled, not to a built model")
    from eomc.runtime.loader import load
    model = load(path)
    missing = [f for f in (frames or ()) if f not in model.frame_names]
    if missing:
        have = ", ".join(model.frame_names) or "none"
        raise ValueError(f"{path}: built without the frame output(s) {', '.join(missing)} (it has: "
                         f"{have}); frames are compiled in: rebuild with eomc build "
                         f"{' '.join('--frame ' + f for f in missing)}, or simulate the model file")
    return model


def _reused_or_compiled(path, options, quiet, check, functions, methods):
    """load_model's model file: reused from the build cache, or compiled."""
    model, key = _reused(path, options, check)      # the default set serves every method
    if model is not None:
        return model
    if functions is None and methods is not None and not reads_implicit(methods):
        full_key = key
        options = {**options, "functions": without_implicit()}
        model, key = _reused(path, options, check)
        if model is not None:
            return model
        return _compiled(path, options, key, quiet, check, also=full_key)
    return _compiled(path, options, key, quiet, check)


def _judged_with(params, get):
    """get()'s model, its build's warnings given as they came, except a SingularStartWarning that
    the command's --param values ``params`` mend: the mass matrix at the default start with them is
    not singular.  Why: the warning names the --param values that give a body without inertia
    some (icub.urdf's head), and a user who gives them should not be told again, with the file's
    parameters, that the start is singular (session 36)."""
    if not params:
        return get()
    import warnings

    from eomc.compiler.build import reuse
    from eomc.runtime.errors import GimbalLockWarning, SingularStartWarning
    still = {SingularStartWarning: _singular_start, GimbalLockWarning: _gimbal_locks_in_reach}
    model, recorded = None, []
    try:
        with warnings.catch_warnings(record=True) as recorded:
            model = get()
    finally:
        for w in recorded:
            if not (model is not None and w.category in still and not still[w.category](model, params)):
                reuse.warn_again(w.message, w.filename, w.lineno, w.source)
    return model


def _singular_start(model, params):
    """Whether the mass matrix is singular (to rounding) at the model's default start with the
    parameters ``params`` ({name: value}) -- the build's test (compiler/driver._warn_singular_start)."""
    import numpy as np

    from eomc.runtime.diagnose import singular_direction
    try:
        p = np.asarray(parameter_values(model, params), dtype=float)
        base = getattr(model, "initial_state", None)       # the build's start (no note, no move)
        x = np.zeros(model.nx) if base is None else np.asarray(base, dtype=float)
        return bool(singular_direction(model, 0.0, x, p=p, semidefinite=True))
    except Exception:       # noqa: BLE001 -- unknown: keep the build's warning
        return True


def _gimbal_locks_in_reach(model, params):
    """Whether a hinge triple's gimbal lock (NAME.json ``gimbal_locks``) is still within reach of its
    middle joint's range with the limits ``params`` gives (the build's test:
    compiler/urdf/tree._check_gimbal_locks, GIMBAL_MARGIN past a limit)."""
    from eomc.compiler.urdf.tree import GIMBAL_MARGIN
    try:
        values = dict(zip(model.param_names, (float(v) for v in parameter_values(model, params))))
        for lock in model.metadata.get("gimbal_locks") or ():
            joint, angle = lock["state"][2:], float(lock["angle"])
            lo, hi = values.get(f"limit_lo_{joint}", -float("inf")), values.get(f"limit_hi_{joint}", float("inf"))
            if lo - GIMBAL_MARGIN <= angle <= hi + GIMBAL_MARGIN:
                return True
        return False
    except Exception:       # noqa: BLE001 -- unknown: keep the build's warning
        return True


def reuse_options(floating_base=False, formulation="auto", frames=None, ignore=(), contacts=None,
                  allow_nonphysical_inertia=False, limits=True, functions=None, orientation=None, pairs=None):
    """The build options a reuse key holds (:func:`load_model`'s, and `eomc build`'s when it builds
    what load_model would: build.remember_build)."""
    options = dict(floating_base=floating_base if floating_base == "quaternion" else bool(floating_base),
                   formulation=formulation, frames=list(frames or ()),
                   ignore=list(ignore or ()), contacts=list(contacts or ()),
                   allow_nonphysical_inertia=bool(allow_nonphysical_inertia), limits=bool(limits),
                   functions=None if functions is None else list(functions))
    if orientation:        # only when given: the reuse key of every other build stays as it was
        options["orientation"] = orientation
    if pairs:              # likewise
        options["pairs"] = pairs
    return options


def _reused(path, options, check):
    """(model, key): the model built before from this file and options, loaded from the build
    cache and checked, or (None, key) -- key None when nothing can be reused."""
    import contextlib

    from eomc.compiler.build import reuse
    from eomc.compiler.build.cache import cache_root
    from eomc.runtime.loader import LoadError, load
    try:
        root = cache_root(None)
        key = reuse.source_key(path, options)
    except (OSError, ValueError):
        return None, None
    with contextlib.ExitStack() as held:
        found = reuse.find(root, key, held)
        if found is None:
            return None, key
        try:
            model = load(found[0], found[1])
        except (LoadError, OSError):
            return None, key
    if check is not None:
        check(model)
    return model, key


def _compiled(path, options, key, quiet, check, also=None):
    """Derive, generate, compile and load the model file (eomc.compiler.driver.compile),
    recording what the reuse shortcut needs (the files read, the warnings given).

    ``also``: the default build's key, under which a build without NAME_implicit is recorded
    too when the default build would not have had one either (a model that touches nothing:
    NAME_implicit is built for contacts only), so a later implicitfast run does not build it again."""
    import warnings

    from eomc.compiler.build import reuse
    from eomc.compiler.build.cache import cache_root
    from eomc.compiler.driver import compile as compile_model
    from eomc.runtime.errors import DefaultStartWarning
    source, name = with_options(str(path), name=None, floating_base=options["floating_base"],
                                allow_nonphysical_inertia=options["allow_nonphysical_inertia"],
                                limits=options["limits"], ignore=options["ignore"],
                                orientation=options.get("orientation"), pairs=options.get("pairs"))
    extra = {} if check is None else {"check": check}
    recorded = []
    try:
        with reuse.recording() as reads, warnings.catch_warnings(record=True) as recorded:
            model = compile_model(source, name, progress="quiet" if quiet else None,
                                  functions=options["functions"], formulation=options["formulation"],
                                  frames=options["frames"] or None, contacts=options["contacts"] or None,
                                  **extra)
    finally:    # the build's warnings, as if nothing had listened
        # but the default start's: the command's note says it, leaving out what --x0 gives
        recorded = [w for w in recorded if not issubclass(w.category, DefaultStartWarning)]
        for w in recorded:
            reuse.warn_again(w.message, w.filename, w.lineno, w.source)
    if key is not None:
        reuse.remember(cache_root(None), key, path, model, reads, recorded)
    if also is not None and not _touches(model):
        reuse.remember(cache_root(None), also, path, model, reads, recorded)
    return model


def _touches(model):
    """Whether the model has contacts (ground or body-body: the gaps NAME_implicit's build keys
    on, compiler/formulations/recursive.builds_implicit); True when that cannot be told."""
    try:
        from eomc.runtime.switching import find_switches
        found = find_switches(model)
        return bool(found.contacts or found.unchecked)
    except Exception:       # noqa: BLE001 -- unknown: not recorded as the default build
        return True


def _number(text):
    """A number, or an arithmetic of numbers and pi (``pi``, ``-pi/2``, ``2*pi``, ``(pi/4)``):
    angles are written so in URDF tools and papers; anything else is ValueError."""
    import ast
    import math
    import operator
    try:
        return float(text)
    except ValueError:
        pass
    ops = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.USub: operator.neg, ast.UAdd: operator.pos}

    def value(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in ops:
            return ops[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in ops:
            return ops[type(node.op)](value(node.operand))
        raise ValueError
    try:
        return float(value(ast.parse(text.strip(), mode="eval").body))
    except (SyntaxError, ValueError, ZeroDivisionError, RecursionError):
        raise ValueError from None


def parse_assignments(items, what):
    """['a=1', 'b=2,c=3', 'th=pi/2'] (or one string) -> {'a': 1.0, 'b': 2.0, 'c': 3.0, 'th': 1.5707...};
    ValueError naming a bad item and what a value may be."""
    if isinstance(items, str):
        items = [items]
    out = {}
    for item in (piece.strip() for text in (items or ()) for piece in text.split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--{what}: expected NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = _number(value)
        except ValueError:
            # first hour s28: `--x0 th=pi` said "expected NAME=VALUE, got 'th=pi'"
            raise ValueError(f"--{what}: {item!r}: the value {value.strip()!r} is not a number (give a number, "
                             f"or numbers and pi with + - * /, e.g. {name.strip()}=pi/2)") from None
    return out


def initial_state(model, overrides):
    """{state: value}: the model's initial_state (zeros if it has none) with overrides applied
    (the rule of simulate()'s dict x0 too: runtime.simulate.state_defaults)."""
    unknown = sorted(set(overrides) - set(model.state_names))
    if unknown:      # as a model file's --x0 is checked before its build (read_checks)
        raise _unknown(model.name, "state", "--x0", unknown, list(model.state_names))
    x0 = {n: 0.0 for n in model.state_names}
    base = getattr(model, "initial_state", None)
    if base is not None:
        x0.update(zip(model.state_names, (float(v) for v in base)))
    x0.update(overrides)
    _start_note(model, overrides)
    return _onto_ground(model, x0, overrides)


def _start_note(model, overrides, choose="give --x0 to choose"):
    """One line on stderr naming the joints whose zero is outside their range and which the
    model's default start put inside (eomc.compiler.urdf.model.start_in_range), unless --x0
    gives them."""
    import sys
    moved = [m for m in (getattr(model, "metadata", None) or {}).get("start_in_range") or ()
             if m["state"] not in overrides]
    if not moved:
        return
    from eomc.runtime.switching import moved_start_text
    print(f"eomc: note: {moved_start_text(model.name, moved)}: the default start puts "
          f"{'them' if len(moved) > 1 else 'it'} just inside the nearest limit ({choose})",
          file=sys.stderr)


def _onto_ground(model, x0, overrides):
    """The start lifted onto the ground by the runtime's rule (eomc.runtime.ground_start, which
    Python's x0=None uses too), with a note on stderr: a floating base lifted until its deepest
    contact is GROUND_CLEARANCE above the ground (a base height given with --x0 is kept), or a
    welded root that cannot be lifted, named with --floating-base."""
    import sys

    from eomc.runtime.ground_start import GROUND_CLEARANCE, onto_ground
    start, found = onto_ground(model, x0, overrides)
    if found is None:
        return start
    if found.kind == "welded":
        # first hour s27: `eomc simulate a1.urdf --ground` (no --floating-base) welded the trunk
        # at the origin, its legs 0.34 m into the floor: 2 MN on each foot from the start, and a
        # warning naming every contact whose remedy (--x0) cannot lift a welded base
        print(f"eomc: note: {model.name}'s start puts its contacts up to {found.deepest:.4g} m under the "
              f"ground, and its root link is welded to the world (a fixed base), so eomc cannot lift "
              f"the start onto it: pose the links above the ground with --x0, or give --floating-base "
              f"for a robot that stands on the ground", file=sys.stderr)
        return start
    print(f"eomc: note: {model.name}'s start put its contacts up to {found.deepest:.4g} m under the ground; "
          f"starting with {found.state} = {found.value:.6g}, the deepest {GROUND_CLEARANCE * 1e3:g} mm above it "
          f"(give --x0 {found.state}=... to choose)", file=sys.stderr)
    return start


def parameter_values(model, overrides):
    """Parameter vector with overrides applied, or None for the defaults."""
    if not overrides:
        return None
    unknown = sorted(set(overrides) - set(model.param_names))
    if unknown:      # as a model file's --param is checked before its build (read_checks)
        raise _unknown(model.name, "parameter", "--param", unknown, list(model.param_names))
    return [overrides.get(n, float(d)) for n, d in zip(model.param_names, model.param_defaults)]


def writable_file(path, what):
    """Check, before any work, that ``path`` can be written: its folder exists and it is not a folder.

    The trajectory and plot are written after the simulation; a typo in -o
    must not cost the whole run (and must not end in a traceback).
    """
    import os
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{what} {path} is a directory; give a file name (e.g. {path / 'traj.csv'})")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"{what} {path}: the directory {parent} does not exist")
    _probe(parent, path, what)      # says why: permission denied, read-only file system, disk full
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise ValueError(f"{what} {path}: not writable (permission denied)")
    return path


def _probe(parent, path, what):
    """Create and remove a file in ``parent``: the only test a read-only mount, a full disk or a
    root user's view of file modes cannot fool (os.access trusts the mode bits)."""
    import os
    import tempfile
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".eomc-probe", dir=parent)
    except OSError as exc:
        raise ValueError(f"{what} {path}: cannot write in {parent} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(name)


def _unknown(stem, kind, option, unknown, known):
    """One line: the unknown names, the nearest known ones, and a short list of what there is."""
    import difflib
    from eomc.runtime.names import euler_hint
    near = sorted({m for n in unknown for m in difflib.get_close_matches(n, known, n=2, cutoff=0.6)})
    hint = euler_hint(unknown, known) or (f" (did you mean {', '.join(near)}?)" if near else "")
    shown = ", ".join(known[:12]) + (f", ... ({len(known)} in all)" if len(known) > 12 else "")
    return ValueError(f"{stem}: unknown {kind} {', '.join(unknown)} in {option}{hint}; {kind}s: {shown or 'none'}")


def read_checks(args):
    """{"check": ...} for :func:`load_model`: the run options (--x0, --input, --frame and
    --param of a robot file, .urdf or .xml; --param of a .py model file) checked against the
    model's names once the file is read -- a robot's tree, a model file's `parameters` once
    it has run -- in the build's one reading, before anything is derived or compiled: a typo
    costs the reading, not the build (G1: 83 s).  An unknown name is one line with the
    nearest ones; a parameter value the build would refuse (a negative contact stiffness:
    eomc.runtime.law_parameters) too.  A --contact link the robot lacks is refused by the
    reader itself.  {} when there is nothing to check that early (other names are checked
    after loading)."""
    path = Path(args.model)
    suffix = path.suffix.lower()
    if not (path.is_file() and suffix in (".urdf", ".xml", ".mjcf", ".py")):
        return {}
    robot = suffix != ".py"
    given = parse_assignments(getattr(args, "param", ()), "param")
    x0 = parse_assignments(getattr(args, "x0", ()), "x0") if robot else {}
    pieces = [p.strip() for text in getattr(args, "input", ()) or () for p in text.split(",") if p.strip()]
    inputs = [p.partition("=")[0].strip() for p in pieces if "=" in p] if robot else []
    frames = [f for f in (getattr(args, "frame", None) or ()) if f != "com"] if robot else []
    if not (given or x0 or inputs or frames):
        return {}
    floated = bool(floating_base_of(args)) or suffix != ".urdf"

    def check(read):
        names = _RunNames.of(read, path.stem)
        stem = names.stem
        if names.states is not None:
            unknown = [n for n in x0 if n not in names.states]
            if unknown:
                error = _unknown(stem, "state", "--x0", unknown, names.states)
                if not floated and any(n.startswith("q_") and "floating" in n for n in unknown):
                    error = ValueError(f"{error} (floating-base coordinates exist with --floating-base)")
                raise error
        if names.inputs is not None:
            unknown = [n for n in inputs if n not in names.inputs]
            if unknown:
                raise _unknown(stem, "input", "--input", unknown, names.inputs)
        if names.has_frame is not None:
            unknown = [f for f in frames if not names.has_frame(f)]
            if unknown:
                raise _unknown(stem, "frame", "--frame", unknown, ["com"] + names.frames)
        if names.params is not None:
            unknown = [n for n in given if n not in names.params]
            if unknown:
                raise _unknown(stem, "parameter", "--param", unknown, names.params)
            if given and names.law_check is not None:
                names.law_check(given)
    return {"check": check, "params": given}


class _RunNames:
    """The names run options refer to, from what is known: a robot's multibody Model, a
    model file's variables (its parameters only), or a loaded Model (a reused build).
    None: not known yet (checked after loading)."""

    def __init__(self, stem, states=None, inputs=None, frames=None, has_frame=None, params=None,
                 law_check=None):
        self.stem, self.states, self.inputs, self.frames = stem, states, inputs, frames or []
        self.has_frame, self.params, self.law_check = has_frame, params, law_check

    @classmethod
    def of(cls, read, stem):
        from collections.abc import Mapping
        if hasattr(read, "state_names"):          # a loaded runtime Model (a reused build)
            from eomc.runtime.law_parameters import check_law_parameters

            def laws(given):
                check_law_parameters(read, [given.get(n, float(d)) for n, d in
                                            zip(read.param_names, read.param_defaults)])
            # its frames are those the command asked for (they are in the reuse key)
            return cls(stem, list(read.state_names), list(read.input_names), params=list(read.param_names),
                       law_check=laws)
        model = getattr(read, "model", None)
        if getattr(read, "kind", None) == "robot" and model is not None:
            states = [_plain(v) for v in (*model.coordinates, *model.speeds, *model.extra_states)]
            params = [str(p) for p in model.parameters]
            return cls(stem, states, [_plain(v) for v in model.inputs], [f.name for f in model.frames],
                       lambda f: model.frame(f) is not None, params,
                       lambda given: _check_law_values(stem, model, params, given))
        values = getattr(read, "values", None) or {}
        if getattr(read, "kind", None) == "file" and isinstance(values.get("parameters"), Mapping):
            # a model file's parameters dict must name every parameter (eomc.compiler.model.validate)
            return cls(stem, params=[k if isinstance(k, str) else getattr(k, "name", str(k))
                                     for k in values["parameters"]])
        return cls(stem)


def _plain(v):
    """A state's or input's name: q_hinge for q_hinge(t)."""
    text = str(v)
    return text[:-3] if text.endswith("(t)") else text


def _check_law_values(stem, read, names, given):
    """The build's refusals (eomc.runtime.law_parameters) on the defaults with ``given``
    applied, on a stand-in of the built model made of what the reader knows: parameter
    and state names and the contacts (``contact_<name>`` events)."""
    from types import SimpleNamespace

    from eomc.runtime.law_parameters import check_law_parameters

    defaults = {str(s): float(v) for s, v in read.defaults.items()}
    values = [given.get(n, defaults.get(n, float("nan"))) for n in names]
    stand_in = SimpleNamespace(name=stem, param_names=names,
                               state_names=[_plain(v) for v in (*read.coordinates, *read.speeds)],
                               metadata={"events": [{"name": str(e)} for e in read.events]})
    check_law_parameters(stand_in, values)


def fixed_base_note(path, floating_base, stream=None):
    """One line on stderr when a URDF robot is built with its root welded to the world (a
    quadruped then hangs in the air): what happened and the option that floats it."""
    import sys
    path = Path(path)
    if floating_base or path.suffix.lower() != ".urdf":
        return
    print(f"eomc: note: {path.name}: fixed base (the root link is welded to the world); "
          f"--floating-base lets the whole robot move", file=stream or sys.stderr)
