"""``eomc simulate MODEL --t-final T -o traj.csv [--plot traj.png]``: integrate and write a CSV.

MODEL is a model file (``.py``: compiled first through eomc.compiler.driver,
imported only then, so simulating a built model never imports SymPy) or a
built model directory / NAME.json / libNAME.so (loaded with eomc.load).  The
start is the model's ``initial_state`` unless ``--x0`` overrides entries.
"""
import argparse

from . import common as cli_common

__all__ = ["configure", "run"]


def configure(parser):
    cli_common.add_model_arguments(parser)
    parser.add_argument("--t-final", type=float, required=True, metavar="T", help="end time")
    parser.add_argument("--t0", type=float, default=0.0, help="start time")
    parser.add_argument("-o", "--output", metavar="CSV", help="trajectory CSV to write")
    parser.add_argument("--plot", metavar="PNG", help="also draw the states to this PNG (matplotlib)")
    parser.add_argument("--method", default="dop853",
                        help="rk4 (needs --dt), dopri5 (rk45), dop853, radau")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance")
    parser.add_argument("--dt", type=float, help="fixed step (rk4)")
    parser.add_argument("--points", type=int, default=1001, help="output rows (adaptive methods)")
    parser.add_argument("--max-steps", type=int, default=100000, help="step limit")
    parser.add_argument("--project", action="store_true",
                        help="project onto the model's constraints after each step")
    parser.add_argument("--baumgarte", type=float, default=0.0, metavar="RATE",
                        help="Baumgarte-style constraint stabilization rate (1/time); 0 = off")
    parser.add_argument("--formulation", choices=("auto", "kane", "recursive"), default="kane",
                        help="dynamics formulation: kane (symbolic M and f, numeric LDLT), recursive "
                             "(ABA/RNEA/CRBA over the joint tree) or auto (the cheaper rhs)")
    parser.formatter_class = argparse.ArgumentDefaultsHelpFormatter


def run(args):
    from eomc.runtime.simulate import simulate
    extra = {} if args.formulation == "kane" else {"formulation": args.formulation}
    model = cli_common.load_model(args.model, **extra)
    x0 = cli_common.initial_state(model, cli_common.parse_assignments(args.x0, "x0"))
    params = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    res = simulate(model, x0, (args.t0, args.t_final), p=params, method=args.method,
                   rtol=args.rtol, atol=args.atol, dt=args.dt, max_steps=args.max_steps,
                   n_points=None if args.dt else args.points, project=args.project,
                   baumgarte=args.baumgarte)
    s = res.stats
    print(f"{model.name}: {res.method} t=[{args.t0:g}, {args.t_final:g}]: {s['steps']} steps "
          f"({s['rejected']} rejected), {s['nfev']} rhs, {s['njev']} jacobian, {s['nlu']} LU")
    for name, values in res.outputs.items():
        print(f"  {name}: start {values[0]:.10g}, end {values[-1]:.10g}, "
              f"change {values[-1] - values[0]:.3g}")
    if res.constraint_residual is not None:
        print(f"  constraint residual: max {res.constraint_residual.max():.3g}")
    if args.output:
        print(f"wrote {res.to_csv(args.output)}")
    if args.plot:
        print(f"wrote {res.plot(args.plot)}")
    return 0
