"""``eomc check MODEL --t-final T``: stability checks on a user's model (issue 4 §6).

Runs eomc.runtime.stability.check_model from the model's initial state (or
--x0) and prints each check with what was expected and what was measured.
Exit status 1 when a check failed, so it can gate CI (an explicit method that stops on a
model the stiffness check calls stiff is "[stiff]", expected, not a failure); 3 (EXIT_INCONCLUSIVE) when none
failed but one could not be made (a reference that cannot be computed says why and what to
change): a CI gate can tell a wrong method from a problem too stiff to check at that span.
"""

from . import common as cli_common

__all__ = ["configure", "run"]


def configure(parser):
    cli_common.add_model_arguments(parser)
    cli_common.add_formulation_argument(parser)
    parser.add_argument("--t-final", type=float, default=10.0, metavar="T", help="horizon")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance to check")
    parser.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance to check")
    parser.add_argument("--max-steps", type=int, default=200000, metavar="N",
                        help="steps each checked method may take (the references: 10 N); a reference that "
                             "stops leaves the accuracy checks inconclusive (exit status 3)")
    parser.add_argument("--methods", default=None,
                        help="methods to check, comma-separated (default: auto and every method that "
                             "applies: dopri5, dop853, bdf, radau; on a model with ground contacts auto and "
                             "the implicit method(s) auto takes at --rtol: bdf and radau at rtol >= 1e-7, "
                             "radau below)")


def run(args):
    import sys
    from eomc.runtime.progress import integration, ticker
    from eomc.runtime.stability import EXIT_INCONCLUSIVE, check_model, format_checks, outcome
    model = cli_common.load_model(args.model, args.quiet, **cli_common.model_options(args),
                                  **cli_common.read_checks(args),   # --param, from the one reading
                                  methods=_methods(args.methods))
    x0 = cli_common.initial_state(model, cli_common.parse_assignments(args.x0, "x0"))
    p = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    import warnings
    from eomc.runtime.switching import PhysicsWarning
    # a long run (G1's references: 388 s in silence, s27) says how far it got: in the live line on a
    # terminal, in a line every ~10 % of its span and >= 5 s in a log (runtime/progress.py); -q: nothing
    with ticker(f"eomc check {model.name}", sys.stderr, not args.quiet) as live, \
            integration(f"eomc check {model.name}", sys.stderr, not args.quiet, ticker=live), \
            warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("default")
        checks = check_model(model, [x0[n] for n in model.state_names], args.t_final, p=p,
                             rtol=args.rtol, atol=args.atol, max_steps=args.max_steps,
                             methods=None if args.methods is None
                             else tuple(m for m in args.methods.split(",") if m))
    for w in seen:      # printed as they were, on stderr
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    physics = {str(w.message) for w in seen if issubclass(w.category, PhysicsWarning)}
    print(f"eomc check {model.name}: t_final={args.t_final:g}, rtol={args.rtol:g}, "
          f"atol={args.atol:g}")
    print(format_checks(checks))
    if physics:
        # first hour s21: dm_control's manipulator (a ball through the pommel) and romeo (wrists
        # past their limits) warned on stderr, then read "10 of 10 checks passed"
        print(f"eomc check: the runs gave {len(physics)} physics warning{'s' if len(physics) > 1 else ''} "
              f"(on stderr: limits, contacts, energy): the checks above judge the integration, not the "
              f"model's laws")
    from eomc.runtime.diagnose import no_ground
    falling = no_ground(model, p=p, t_span=(0.0, args.t_final))
    if falling:
        # first hour s25: solo12 --floating-base checked a 490 m fall into the void and said nothing
        warnings.warn(falling, PhysicsWarning, stacklevel=1)
    still = _at_rest(model, x0, p, args.t_final)
    if still:
        # first hour s24: SymPy's multi-dof holonomic example (JointsMethod) at its zero start read
        # "10 of 10 checks passed" with every method "0 x tolerance, 8 steps": nothing was tested
        print(f"eomc check: nothing moved: the start is an equilibrium (rhs = 0 there), so the runs stayed at "
              f"their start and the accuracy checks compared nothing; give --x0 to start elsewhere, e.g. "
              f"--x0 {still}=0.1")
    verdict = outcome(checks)
    if verdict == "inconclusive":
        print(f"eomc check: inconclusive (exit status {EXIT_INCONCLUSIVE}): no method failed, but a "
              f"check could not be made; the lines marked INCONCLUSIVE say why and what to change")
    return {"passed": 0, "failed": 1, "inconclusive": EXIT_INCONCLUSIVE}[verdict]


def _methods(given):
    """The methods this check runs, as load_model takes them: the default ones (auto, the
    explicit ones, bdf, radau: stability.default_methods) read no NAME_implicit."""
    return ("auto",) if given is None else tuple(m for m in given.split(",") if m)


def _at_rest(model, x0, p, t_final):
    """When the start is an equilibrium (rhs exactly 0 there, at t = 0, t_final / 2 and t_final: a
    time-varying force would show), the name of a state whose change starts a motion, else None."""
    import numpy as np
    x = np.array([x0[n] for n in model.state_names], dtype=float)
    try:
        if any(np.any(np.asarray(model.rhs(t, x, p=p)) != 0) for t in (0.0, 0.5 * t_final, t_final)):
            return None
    except Exception:       # noqa: BLE001 -- the checks above already said what failed
        return None
    from eomc.runtime.diagnose import leaving_state
    return leaving_state(model, x, p)
