"""What `eomc simulate`, `eomc report` and `eomc check` share: which model, from which state.

MODEL is a model file (compiled on the way, with the build cache) or a built
model directory / NAME.json (loaded without SymPy).  --x0 and --param take
NAME=VALUE items, space- or comma-separated (`--x0 q1=0.5 u1=0` or `--x0 q1=0.5,u1=0`).
Mistakes in them are ValueErrors, which `eomc` prints as one line (exit status 2).
"""
from pathlib import Path

__all__ = ["with_options", "add_model_arguments", "add_formulation_argument", "FORMULATION_HELP", "load_model", "model_options", "parse_assignments", "initial_state",
           "parameter_values", "writable_file"]


def add_model_arguments(parser):
    """The positional MODEL and the --x0/--param overrides."""
    parser.add_argument("model", help="model file (.py), robot (.urdf) or built model directory / NAME.json")
    parser.add_argument("--x0", nargs="+", metavar="NAME=V", default=(),
                        help="initial state entries; states not named keep the model's initial_state "
                             "(0 when it has none)")
    parser.add_argument("--param", nargs="+", metavar="NAME=V", default=(),
                        help="parameter values (others keep their defaults)")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress on stderr (compiling a model file, long runs)")
    parser.add_argument("--floating-base", action="store_true",
                        help="URDF: a 6-dof floating joint between the world and the root link")
    add_limits_argument(parser)


def add_limits_argument(parser):
    """--limits on|off: the model file's joint limits, damping and friction (on by default)."""
    parser.add_argument("--limits", choices=("on", "off"), default="on",
                        help="URDF/MJCF: the file's joint limits (soft), damping and friction act "
                             "(on, default) or are ignored (off)")


FORMULATION_HELP = ("dynamics formulation: auto (default: the cheaper rhs of the two; kane where the "
                    "recursion cannot take the system, saying why), kane (symbolic M and f, numeric "
                    "LDLT) or recursive (ABA/RNEA/CRBA over the joint tree)")


def add_formulation_argument(parser):
    """--formulation for the commands that compile a model file (auto unless given)."""
    parser.add_argument("--formulation", choices=("auto", "kane", "recursive"), default="auto",
                        help=FORMULATION_HELP)


def model_options(args):
    """Keyword arguments of load_model for the options given: a URDF's floating base, a
    formulation other than the default auto (none unless given, so stand-ins of load_model
    stay simple)."""
    options = {}
    if getattr(args, "floating_base", False):
        options["floating_base"] = True
    if getattr(args, "formulation", None) not in (None, "auto"):
        options["formulation"] = args.formulation
    if getattr(args, "limits", "on") == "off":
        options["limits"] = False
    return options


def with_options(model, name=None, *, floating_base=False, limits=True):
    """(model, name) for the driver with the command line's model options: a URDF's
    (:func:`eomc.compiler.urdf.model.with_options`), or an MJCF file with ``--limits off``."""
    from eomc.compiler.mjcf.model import MjcfModel, is_mjcf_path
    if not limits and not floating_base and is_mjcf_path(model):
        from eomc.compiler.model.validate import sanitize_name
        return MjcfModel(Path(model), limits=False), name or sanitize_name(Path(model).stem)
    from eomc.compiler.urdf.model import with_options as urdf_options
    return urdf_options(model, name, floating_base=floating_base, limits=limits)


def load_model(path, quiet=False, floating_base=False, formulation="auto", limits=True):
    """A runtime Model from a model file (compiled) or a built directory / json (loaded).

    Compiling shows its stages on stderr when that is a terminal, unless ``quiet``.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such model file or built model directory")
    if path.is_file() and path.suffix.lower() in (".py", ".urdf"):
        from eomc.compiler.driver import compile as compile_model
        source, name = with_options(str(path), floating_base=floating_base, limits=limits)
        return compile_model(source, name, progress=False if quiet else None,
                             formulation=formulation)
    from eomc.runtime.loader import load
    return load(path)


def parse_assignments(items, what):
    """['a=1', 'b=2,c=3'] (or one string) -> {'a': 1.0, 'b': 2.0, 'c': 3.0}; ValueError naming a bad item."""
    if isinstance(items, str):
        items = [items]
    out = {}
    for item in (piece.strip() for text in (items or ()) for piece in text.split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise ValueError(f"--{what}: expected NAME=VALUE, got {item!r}") from None
    return out


def initial_state(model, overrides):
    """{state: value}: the model's initial_state (zeros if it has none) with overrides applied
    (the rule of simulate()'s dict x0 too: runtime.simulate.state_defaults)."""
    unknown = sorted(set(overrides) - set(model.state_names))
    if unknown:
        raise ValueError(f"{model.name}: unknown state {', '.join(unknown)} in --x0; "
                         f"states: {', '.join(model.state_names)}")
    x0 = {n: 0.0 for n in model.state_names}
    base = getattr(model, "initial_state", None)
    if base is not None:
        x0.update(zip(model.state_names, (float(v) for v in base)))
    x0.update(overrides)
    return x0


def parameter_values(model, overrides):
    """Parameter vector with overrides applied, or None for the defaults."""
    if not overrides:
        return None
    unknown = sorted(set(overrides) - set(model.param_names))
    if unknown:
        raise ValueError(f"{model.name}: unknown parameter {', '.join(unknown)} in --param; "
                         f"parameters: {', '.join(model.param_names) or 'none'}")
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
