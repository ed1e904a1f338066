"""What `eomc simulate`, `eomc report` and `eomc check` share: which model, from which state.

MODEL is a model file (compiled on the way, with the build cache) or a built
model directory / NAME.json (loaded without SymPy).  --x0 and --param take
NAME=VALUE items, space- or comma-separated (`--x0 q1=0.5 u1=0` or `--x0 q1=0.5,u1=0`).
Mistakes in them are ValueErrors, which `eomc` prints as one line (exit status 2).
"""
from pathlib import Path

__all__ = ["add_model_arguments", "load_model", "parse_assignments", "initial_state", "parameter_values"]


def add_model_arguments(parser):
    """The positional MODEL and the --x0/--param overrides."""
    parser.add_argument("model", help="model file (.py) or built model directory / NAME.json")
    parser.add_argument("--x0", nargs="+", metavar="NAME=V", default=(),
                        help="initial state entries (override the model's initial_state; others 0)")
    parser.add_argument("--param", nargs="+", metavar="NAME=V", default=(),
                        help="parameter values (others keep their defaults)")


def load_model(path, quiet=False, formulation="kane"):
    """A runtime Model from a model file (compiled) or a built directory / json (loaded).

    Compiling shows its stages on stderr when that is a terminal, unless ``quiet``.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such model file or built model directory")
    if path.is_file() and path.suffix == ".py":
        from eomc.compiler.driver import compile as compile_model
        return compile_model(str(path), progress=False if quiet else None, formulation=formulation)
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
    """{state: value}: the model's initial_state (zeros if it has none) with overrides applied."""
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
