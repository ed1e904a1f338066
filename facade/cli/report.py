"""``eomc report MODEL``: error against run time over a grid of methods and tolerances.

MODEL is a model file (``.py``: compiled first, SymPy imported only then) or
a built model directory / ``NAME.json`` (``eomc.load``: no SymPy).  Writes
OUTDIR/report.csv, report.png and report.md (see eomc.runtime.report for what
each column means) and prints the table and the recommendation; progress goes
to stderr.  Each run may take --row-budget seconds of CPU time (60 by default): one that
takes longer is stopped and shown as cut (where, after how long), never recommended, and its
method's tighter tolerances are not run (s34: G1's report with no flags ran 41 min).

Exit status 0; 3 (inconclusive, as `eomc check`) when the reference cannot be computed (it
says where, why and what to change) or its two computations part within the first output
times (no error can be measured); 1 on other errors.
"""
import sys
from pathlib import Path

from eomc.errors import ModelError

from . import common as cli_common

__all__ = ["configure", "run", "CONTACT_METHODS"]

# first hour s23: gymnasium's hopper with no flags ran rk4, dopri5 and dop853 at 8 tolerances
# each; 21 of its 40 runs stopped (stiff, or rk4 without DOPRI5's step count), as `eomc check`
# already knows (stability.default_methods leaves them out on contacts)
CONTACT_METHODS = ("bdf", "radau")


def configure(parser):
    from eomc.runtime.report import DEFAULT_METHODS, DEFAULT_TARGET, DEFAULT_TOLERANCES, ROW_BUDGET_S
    cli_common.add_model_arguments(parser)
    cli_common.add_formulation_argument(parser)
    parser.add_argument("--t-final", type=float, default=10.0, help="end of the time span")
    parser.add_argument("--t0", type=float, default=0.0, help="start of the time span")
    parser.add_argument("--methods", nargs="+", default=None,
                        help=f"integration methods (space or comma separated; default {' '.join(DEFAULT_METHODS)}, "
                             f"on a model with ground contacts {' '.join(CONTACT_METHODS)}: the explicit ones "
                             f"stop there as stiff)")
    parser.add_argument("--tolerances", nargs="+", type=float, default=list(DEFAULT_TOLERANCES),
                        help="tolerances (rtol = atol); rk4's dt follows DOPRI5's step count")
    parser.add_argument("--target", type=float, default=DEFAULT_TARGET,
                        help="accuracy target: max scaled RMS error relative to each state's size")
    parser.add_argument("-o", "--output", metavar="OUTDIR",
                        help="directory for report.csv/.png/.md (default: report_NAME)")
    parser.add_argument("--repeats", type=int, default=3, help="timing samples per run (median)")
    parser.add_argument("--points", type=int, default=201, help="output times the error is measured at")
    parser.add_argument("--reference-tol", type=float, default=None,
                        help="rtol = atol of the reference (default: tied to the finest --tolerances, rtol "
                             "1000x and atol 10x tighter, as eomc check's references)")
    parser.add_argument("--row-budget", type=float, default=ROW_BUDGET_S, metavar="SECONDS",
                        help=f"CPU time a run may take (default {ROW_BUDGET_S:g} s): a run that takes longer is "
                             f"stopped and shown as cut (where, and after how long), and its method's tighter "
                             f"tolerances are not run; 0: no limit")
    parser.add_argument("--threads", type=int, default=None,
                        help="methods run at once, each on a thread of its own (default: one per core "
                             "this process may use)")
    parser.add_argument("--reference-check", default="auto",
                        choices=("auto", "scipy", "radau", "dop853-half", "none"),
                        help="second computation the reference is checked against")


def _command(args, methods):
    """The eomc report command line that reproduces this report (for report.md)."""
    parts = ["eomc report", str(args.model), f"--t-final {args.t_final:g}",
             "--methods " + " ".join(methods),
             "--tolerances " + " ".join(f"{t:g}" for t in args.tolerances),
             f"--target {args.target:g}", f"--repeats {args.repeats}"]
    from eomc.runtime.report import ROW_BUDGET_S
    if args.row_budget != ROW_BUDGET_S:
        parts.append(f"--row-budget {args.row_budget:g}")
    if args.t0:
        parts.insert(2, f"--t0 {args.t0:g}")
    if args.x0:
        parts.append("--x0 " + " ".join(args.x0))
    if args.param:
        parts.append("--param " + " ".join(args.param))
    return " ".join(parts)


def run(args):
    from eomc.runtime.report import work_precision
    if args.output and Path(args.output).exists() and not Path(args.output).is_dir():
        raise ValueError(f"-o {args.output} is a file; give a directory for report.csv/.png/.md")
    model = cli_common.load_model(args.model, args.quiet, **cli_common.model_options(args),
                                  **cli_common.read_checks(args),   # --param, from the one reading
                                  # the default methods (DEFAULT_METHODS, CONTACT_METHODS) read no NAME_implicit
                                  methods=("auto",) if args.methods is None else
                                  tuple(m for text in args.methods for m in text.split(",") if m))
    if args.methods is None:
        from eomc.runtime.report import DEFAULT_METHODS
        from eomc.runtime.switching import find_switches
        contacts = find_switches(model).contacts and model.c_model.jac_x != model.ffi.NULL
        args.methods = list(CONTACT_METHODS if contacts else DEFAULT_METHODS)
        if contacts and not args.quiet:
            print(f"eomc report: {model.name} has ground contacts: comparing {' and '.join(CONTACT_METHODS)} "
                  f"(rk4, dopri5 and dop853 stop there as stiff; --methods runs them anyway)", file=sys.stderr)
    methods = [m for text in args.methods for m in text.split(",") if m]
    given = cli_common.parse_assignments(args.x0, "x0")
    x0 = cli_common.initial_state(model, given)
    p = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    # only when it is so (first hour s27: gymnasium's half_cheetah.xml has an initial_state, its
    # qpos0, all zeros, and was said to have none; s33: Solo12, whose start the note above had
    # just lifted onto the ground, was said to start at x = 0)
    if getattr(model, "initial_state", None) is None and not given and not args.quiet:
        moved = [f"{n} = {v:.6g}" for n, v in x0.items() if v]
        at = "x = 0" + (f" but {', '.join(moved[:6])}{' ...' if len(moved) > 6 else ''}" if moved else "")
        print(f"eomc report: {model.name} has no initial_state and no --x0 was given: "
              f"starting from rest at {at}", file=sys.stderr)
    from eomc.errors import SimulationError
    from eomc.runtime.stability import EXIT_INCONCLUSIVE
    try:
        report = work_precision(model, x0, (args.t0, args.t_final), p=p, methods=methods,
                                tolerances=args.tolerances, repeats=args.repeats,
                                progress=not args.quiet, n_points=args.points,
                                reference_tol=args.reference_tol,
                                reference_check=args.reference_check, target=args.target,
                                row_budget=args.row_budget, threads=args.threads)
    except SimulationError as exc:
        if "the reference solution failed" not in str(exc):
            raise
        print(f"eomc report: inconclusive (exit status {EXIT_INCONCLUSIVE}): {model.name}: {exc}: no "
              f"reference to measure the runs against. Report a shorter span (--t-final), or a "
              f"looser grid (the reference is tied to the finest --tolerances), or give "
              f"--reference-tol", file=sys.stderr)
        return EXIT_INCONCLUSIVE
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
    if report.inconclusive:
        print(f"eomc report: inconclusive (exit status {EXIT_INCONCLUSIVE})", file=sys.stderr)
        return EXIT_INCONCLUSIVE
    return 0
