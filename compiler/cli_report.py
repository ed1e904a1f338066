"""``eomc report MODEL``: error against run time over a grid of methods and tolerances.

MODEL is a model file (``.py``: compiled first, SymPy imported only then) or
a built model directory / ``NAME.json`` (``eomc.load``: no SymPy).  Writes
OUTDIR/report.csv, report.png and report.md (see eomc.runtime.report for what
each column means) and prints the table and the recommendation; progress goes
to stderr.
"""
import argparse
import sys
from pathlib import Path

from eomc.errors import ModelError

__all__ = ["configure", "run", "load_model", "parse_assignments", "initial_state"]


def configure(parser):
    from eomc.runtime.report import DEFAULT_METHODS, DEFAULT_TARGET, DEFAULT_TOLERANCES
    parser.formatter_class = argparse.ArgumentDefaultsHelpFormatter
    parser.add_argument("model", help="model file (.py) or built model directory / NAME.json")
    parser.add_argument("--t-final", type=float, default=10.0, help="end of the time span")
    parser.add_argument("--t0", type=float, default=0.0, help="start of the time span")
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS),
                        help="integration methods (space or comma separated)")
    parser.add_argument("--tolerances", nargs="+", type=float, default=list(DEFAULT_TOLERANCES),
                        help="tolerances (rtol = atol); rk4's dt follows DOPRI5's step count")
    parser.add_argument("--target", type=float, default=DEFAULT_TARGET,
                        help="accuracy target: max scaled RMS error relative to each state's size")
    parser.add_argument("-o", "--output", metavar="OUTDIR",
                        help="directory for report.csv/.png/.md (default: report_NAME)")
    parser.add_argument("--x0", nargs="+", metavar="NAME=VALUE", default=(),
                        help="initial state (overrides the model's initial_state; others 0)")
    parser.add_argument("--param", nargs="+", metavar="NAME=VALUE", default=(),
                        help="parameter values (others keep their defaults)")
    parser.add_argument("--repeats", type=int, default=3, help="timing samples per run (median)")
    parser.add_argument("--points", type=int, default=201, help="output times the error is measured at")
    parser.add_argument("--reference-tol", type=float, default=1e-13,
                        help="tolerance of the DOP853 reference")
    parser.add_argument("--reference-check", default="auto",
                        choices=("auto", "scipy", "radau", "dop853-half", "none"),
                        help="second computation the reference is checked against")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def load_model(path, quiet=False):
    """A runtime Model from a model file (compiled) or a built directory / json (loaded)."""
    path = Path(path)
    if not path.exists():
        raise ModelError(f"{path}: no such model file or built model directory")
    if path.is_file() and path.suffix == ".py":
        from eomc.compiler.driver import compile
        return compile(str(path), progress=not quiet)
    from eomc.runtime.loader import load
    return load(path)


def parse_assignments(items, what):
    """['a=1', 'b=2,c=3'] -> {'a': 1.0, 'b': 2.0, 'c': 3.0}; ModelError naming a bad item."""
    out = {}
    for item in (piece for text in items for piece in text.split(",") if piece):
        name, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise ModelError(f"--{what}: expected NAME=VALUE, got {item!r}") from None
    return out


def initial_state(model, overrides):
    """The model's initial_state (zeros if it has none) with NAME=VALUE overrides applied."""
    base = model.initial_state if getattr(model, "initial_state", None) is not None else None
    x0 = {n: 0.0 for n in model.state_names}
    if base is not None:
        x0.update(zip(model.state_names, (float(v) for v in base)))
    unknown = sorted(set(overrides) - set(model.state_names))
    if unknown:
        raise ModelError(f"{model.name}: unknown state name(s) {', '.join(unknown)} in --x0; "
                         f"states: {', '.join(model.state_names)}")
    x0.update(overrides)
    return x0


def _command(args, methods):
    """The eomc report command line that reproduces this report (for report.md)."""
    parts = ["eomc report", str(args.model), f"--t-final {args.t_final:g}",
             "--methods " + " ".join(methods),
             "--tolerances " + " ".join(f"{t:g}" for t in args.tolerances),
             f"--target {args.target:g}", f"--repeats {args.repeats}"]
    if args.t0:
        parts.insert(2, f"--t0 {args.t0:g}")
    if args.x0:
        parts.append("--x0 " + " ".join(args.x0))
    if args.param:
        parts.append("--param " + " ".join(args.param))
    return " ".join(parts)


def run(args):
    from eomc.runtime.report import work_precision
    model = load_model(args.model, args.quiet)
    methods = [m for text in args.methods for m in text.split(",") if m]
    x0 = initial_state(model, parse_assignments(args.x0, "x0"))
    p = parse_assignments(args.param, "param") or None
    if all(v == 0.0 for v in x0.values()) and not args.quiet:
        print(f"eomc report: {model.name} has no initial_state and no --x0 was given: "
              f"starting from rest at x = 0", file=sys.stderr)
    try:
        report = work_precision(model, x0, (args.t0, args.t_final), p=p, methods=methods,
                                tolerances=args.tolerances, repeats=args.repeats,
                                progress=not args.quiet, n_points=args.points,
                                reference_tol=args.reference_tol,
                                reference_check=args.reference_check)
    except ValueError as exc:
        raise ModelError(f"{model.name}: {exc}") from None
    out = Path(args.output or f"report_{model.name}")
    out.mkdir(parents=True, exist_ok=True)
    report.to_csv(out / "report.csv")
    report.plot(out / "report.png", target_error=args.target)
    summary = report.summary_markdown(args.target) + f"\nGenerated by `{_command(args, methods)}`.\n"
    (out / "report.md").write_text(summary)
    print(report.table())
    print()
    print(report.recommendation_text(args.target))
    print(f"\nwrote {out / 'report.csv'}, {out / 'report.png'}, {out / 'report.md'}")
    return 0
