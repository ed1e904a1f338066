"""``eomc check MODEL --t-final T``: stability checks on a user's model (issue 4 §6).

Runs eomc.runtime.stability.check_model from the model's initial state (or
--x0) and prints each check with what was expected and what was measured.
Exit status 1 when a check failed, so it can gate CI.
"""
import argparse
import sys

from eomc.errors import EomcError

from . import cli_simulate
from .cli_simulate import _initial_state, parse_assignments

__all__ = ["configure", "run"]


def configure(parser):
    parser.add_argument("model", help="model file (.py) or built model directory")
    parser.add_argument("--t-final", type=float, default=10.0, metavar="T", help="horizon")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance to check")
    parser.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance to check")
    parser.add_argument("--x0", metavar="NAME=V,...", help="initial state entries to override")
    parser.add_argument("--param", metavar="NAME=V,...", help="parameter values to override")
    parser.add_argument("--methods", default="dopri5,dop853,radau", help="methods to check")
    parser.formatter_class = argparse.ArgumentDefaultsHelpFormatter


def run(args):
    from eomc.runtime.stability import check_model, format_checks
    try:
        model = cli_simulate.load_model(args.model)
        x0 = _initial_state(model, parse_assignments(args.x0, "x0"))
        params = parse_assignments(args.param, "param")
        p = None
        if params:
            unknown = sorted(set(params) - set(model.param_names))
            if unknown:
                raise ValueError(f"--param: unknown parameter {', '.join(unknown)}")
            p = [params.get(n, d) for n, d in zip(model.param_names, model.param_defaults)]
        x0 = [x0.get(n, 0.0) for n in model.state_names]
        checks = check_model(model, x0, args.t_final, p=p, rtol=args.rtol, atol=args.atol,
                             methods=tuple(m for m in args.methods.split(",") if m))
    except ValueError as exc:
        if isinstance(exc, EomcError):
            raise
        print(f"eomc check: error: {exc}", file=sys.stderr)
        return 2
    print(f"eomc check {model.name}: t_final={args.t_final:g}, rtol={args.rtol:g}, "
          f"atol={args.atol:g}")
    print(format_checks(checks))
    return 0 if all(c.passed for c in checks) else 1
