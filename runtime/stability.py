"""Stability checks on a user's model (``eomc check``; issue 4 §6).

Why: a compiled model can be right and still be hard to integrate -- stiff,
near a singular configuration, badly scaled, or drifting over long horizons.
``check_model`` runs a fixed list of checks from one start state; each states
what is expected and what was measured, so the user learns which method and
tolerance to trust before running long studies.  numpy + the C integrators
only (no SymPy, no scipy).
"""
from dataclasses import dataclass

import numpy as np

from eomc.runtime.errors import EomcError

from .check_references import apart as ref_apart
from .check_references import run_references
from .progress import stage
from .simulate import simulate

__all__ = ["Check", "check_model", "format_checks", "outcome", "default_methods", "COND_WARN", "GLOBAL_FACTOR",
           "MISSED_FACTOR", "EXIT_INCONCLUSIVE", "STIFF_AT", "EXPLICIT"]

COND_WARN = 1e8          # cond(M) above this: accelerations lose ~8 digits
FD_TOL = 1e-5            # Jacobian vs central differences, relative
GLOBAL_FACTOR = 1000     # global error allowed, in units of the local tolerance
# Beyond this many tolerances a run fails its check even when the motion amplifies errors
# and tighter tolerances converge: the method did not deliver the asked accuracy by orders
# of magnitude over this horizon (issue 29: DOPRI5 at 6.5e5 x tolerance had passed).
MISSED_FACTOR = 100 * GLOBAL_FACTOR
# The two references' (rtol, atol) divisors: the looser one 100x tighter in rtol, the
# reference itself 1000x in rtol and 10x in atol -- tied to the checked tolerance, not a
# fixed 1e-12.  Their difference measures how far the reference can be trusted (it must stay
# within AGREE x tolerance: a tenth of what a method is allowed).  atol shrinks less than
# rtol because an atol below the noise of a state at rest costs without telling anything:
# Go2 resting on 124 contact points takes 70 000 Radau steps per simulated second at atol
# 1e-12 (the old reference stopped at 2e6 steps at t = 6.5 s of 10), 2 500 at 1e-11.
REF_TOLS = ((100, 1), (1000, 10))
REF_FINEST = 1e-13
# The references are trusted while they agree to this many tolerances (a tenth of what a
# method is allowed); later output times measure the problem's conditioning, not a method.
AGREE = GLOBAL_FACTOR / 10
MIN_WINDOW = 5          # output times (of 201) the references must agree on to judge a method
# max |Re lambda| at x0 times t_final above this: the stiffness check calls the model stiff, and
# an explicit method that then stops as stiff (its own detector: h|lambda| stays above its
# stability bound) is reported "[stiff]", not
# FAIL -- the check had said so (first hour s21: `eomc check talos_reduced.urdf`, 9.1e5, exited 1
# with "11 of 13" because dopri5/dop853 stopped at h|lambda| ~ 3-6, which a new user read as "the
# model failed").  A stopped implicit or default method, or an explicit one on a model below
# this, still fails its check.
STIFF_AT = 1e3
EXPLICIT = ("dopri5", "dop853")
STIFF_STOP = 7      # "the problem looks stiff for an explicit method" (cdef.STATUS_NAMES)


@dataclass
class Check:
    """One check: what was expected, what was measured, and whether it held."""
    name: str
    expected: str
    measured: str
    passed: bool
    # neither passed nor failed: the check could not be made (a reference that cannot be
    # computed; references that disagree from the start); `eomc check` exits INCONCLUSIVE
    inconclusive: bool = False
    # neither passed nor failed: an explicit method stopped on a model the stiffness check
    # calls stiff (STIFF_AT) -- expected, so not a failed check
    stiff: bool = False
    # the reference check's: the time the two references part, where they stopped and after which
    # nothing is judged (None: they agree over the whole span); the summary line says it
    judged_until: float = None


def _try(fn):
    try:
        return fn(), None
    except (EomcError, ValueError) as exc:
        return None, str(exc)


def _finite_at_start(model, x0, p):
    f, err = _try(lambda: model.rhs(0.0, x0, p))
    ok = err is None and np.all(np.isfinite(f))
    return Check("rhs at x0", "finite derivative", err or f"max |xdot| = {np.max(np.abs(f)):.3g}", ok)


def _jacobian_vs_fd(model, x0, p):
    if model.c_model.jac_x == model.ffi.NULL:
        return Check("jacobian", "generated jac_x", "not generated (radau unavailable)", False)
    J, err = _try(lambda: model.jacobian(0.0, x0, p))
    if err:
        return Check("jacobian", "finite", err, False)
    # Per column the closest of the central and the two one-sided differences: a start on a
    # kink of a law (a joint at its push-only limit, gymnasium's hopper at qpos0) has no
    # derivative there, and jac_x is one of the one-sided ones (the central one was 1.5e-2 off).
    # A column that misses at the first step is tried at 10x and 100x smaller ones: at a point
    # where a law's curvature jumps (a quadratic drag c|v|v at v = 0: every difference is off by
    # c h there, dm_control's swimmer.xml at rest 3e-4 with the right jac_x = 0) the miss shrinks
    # with the step; a wrong jac_x misses at every step.
    # A law whose force grows like depth**1.5 from a contact's onset (dm_control's walker.xml at
    # qpos0: four capsule ends at depth 0) has slope 0 there, which jac_x gives, but its differences
    # approach it only like sqrt(h) (1.2e4 at h = 1e-6, 1.2e3 at 1e-8: the check failed 1.48e+01).
    # So the differences at four steps are also extrapolated to h -> 0 (Richardson's, with the order
    # they show, from steps 1-3 and from 2-4): a right jac_x is their limit, within the two limits'
    # spread (row by row), a wrong one stays off it.
    f0 = np.asarray(model.rhs(0.0, x0, p), dtype=float)
    scale = max(1.0, np.max(np.abs(J)))
    worst, onsets = 0.0, []
    for j in range(model.nx):
        miss, seen = np.inf, []
        for shrink in (1.0, 0.1, 0.01):
            h = 1e-6 * max(1.0, abs(x0[j])) * shrink
            e = np.zeros(model.nx)
            e[j] = h
            up, down = np.asarray(model.rhs(0.0, x0 + e, p)), np.asarray(model.rhs(0.0, x0 - e, p))
            seen.append(((up - down) / (2 * h), (up - f0) / h, (f0 - down) / h))
            miss = min(miss, min(np.max(np.abs(J[:, j] - d)) for d in seen[-1]))
            if miss / scale < FD_TOL:
                break
        else:   # a 4th step: the limits from steps 1-3 and 2-4 differ by the extrapolation's error
            h = 1e-9 * max(1.0, abs(x0[j]))
            e = np.zeros(model.nx)
            e[j] = h
            up, down = np.asarray(model.rhs(0.0, x0 + e, p)), np.asarray(model.rhs(0.0, x0 - e, p))
            seen.append(((up - down) / (2 * h), (up - f0) / h, (f0 - down) / h))
            # row by row, the best converged of the three (the smallest spread): off its 2-4 limit
            # by more than twice the spread of its two limits
            lim = np.array([[_extrapolated(*ds[:3]), _extrapolated(*ds[1:])] for ds in zip(*seen)])
            spread = np.abs(lim[:, 0] - lim[:, 1])
            best = np.argmin(spread, axis=0)
            rows = np.arange(model.nx)
            off = np.max(np.abs(J[:, j] - lim[best, 1, rows]) - 2 * spread[best, rows])
            if off < FD_TOL * scale:
                onsets.append(j)
            miss = 0.0 if off < FD_TOL * scale else min(miss, off)
        worst = max(worst, miss)
    rel = worst / scale
    at_onset = (f"; {len(onsets)} column{'s' if len(onsets) > 1 else ''} ({model.state_names[onsets[0]]}"
                f"{', ...' if len(onsets) > 1 else ''}) at a law's onset: the limit of their differences"
                if onsets else "")
    return Check("jacobian", f"jac_x = central differences of rhs, or one-sided ones on a kink, at a step of 1e-6 or, "
                 f"where a law's curvature jumps, 1e-7 or 1e-8 (rel. < {FD_TOL:g}); at a law's onset (a "
                 f"contact at depth 0) the differences' limit, extrapolated from 4 steps (rel. < {FD_TOL:g} beyond its spread)",
                 f"rel. difference {rel:.2e}{at_onset}", rel < FD_TOL)


def _extrapolated(d1, d2, d3):
    """The limit h -> 0 of differences d1, d2, d3 at steps h, h/10, h/100, row by row: where they
    converge geometrically (each decade closer by a factor 10**a, 0.18 <= a <= 2.3: a law's order
    at a kink or onset), Richardson's extrapolation with that order; elsewhere d3."""
    a, b = d1 - d2, d2 - d3
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(b != 0, a / b, 0.0)
        ok = (r >= 1.5) & (r <= 200.0)
        return np.where(ok, d3 - b / np.where(ok, r - 1.0, 1.0), d3)


def _stiffness(model, x0, p, t_final):
    if model.c_model.jac_x == model.ffi.NULL:
        return None
    lam = np.linalg.eigvals(model.jacobian(0.0, x0, p))
    fast = np.max(np.abs(lam.real)) if lam.size else 0.0
    stiff = fast * t_final > STIFF_AT
    return Check("stiffness at x0", f"informational: max |Re lambda| * t_final > {STIFF_AT:g} means stiff "
                 f"(explicit methods stop or crawl there; the default auto goes on with radau)",
                 f"max |Re lambda| = {fast:.3g}, times t_final = {fast * t_final:.3g}" +
                 (": stiff" if stiff else ": not stiff"), True)


def _is_stiff(check):
    return check is not None and check.measured.endswith(": stiff")


def _run(model, x0, p, t_final, t_eval, method, rtol, atol, max_steps):
    """One checked run, named in `eomc check`'s progress (runtime/progress.stage: inside the
    caller's stage, e.g. "reference: radau at rtol=1e-10, atol=1e-12")."""
    with stage(f"{method} at rtol={rtol:g}, atol={atol:g}"):
        return simulate(model, x0, (0.0, t_final), p=p, method=method, rtol=rtol, atol=atol,
                        t_eval=t_eval, max_steps=max_steps, raise_on_failure=False)


def _reference_method(model):
    """(implicit, method) of the references: dop853 (cheapest at tight tolerances), and radau
    from the start on ground contacts (as method="auto"; a dop853 pair whose looser run proves
    stiff is run again with radau, check_references.run_references): on gymnasium's ant DOP853
    at 1e-12 ended 2.4e-3 away from Radau at 1e-10, 1e-11 and 1e-12 (which agree to 2e-9):
    across the contacts' friction and push-only limits an explicit reference is not the tight
    one."""
    from .switching import find_switches
    implicit = model.c_model.jac_x != model.ffi.NULL
    return implicit, "radau" if implicit and find_switches(model).contacts else "dop853"


def _unreachable(what, method, tol, ref, t_final, rtol):
    """The inconclusive check of a reference that stopped: where, why, and what to do."""
    reached = float(ref.t[-1]) if ref.t.size else 0.0
    shorter = f"--t-final {reached:.3g} (it reached t = {reached:.6g})" if reached > 0 else "a shorter --t-final"
    return Check("reference", f"{what} ({method} at rtol={tol[0]:g}, atol={tol[1]:g}) reaches "
                 f"t_final={t_final:g}",
                 f"{ref.message}: no reference to measure the methods against, so their accuracy is "
                 f"not judged. Check {shorter}, or a looser --rtol (at {rtol * 10:g} the references "
                 f"run at {tol[0] * 10:g}), or allow more steps (--max-steps; the references take "
                 f"10x)", False, inconclusive=True)


def _stopped(method, res, stiff):
    """The check of a method that stopped: FAIL, or "[stiff]" for an explicit method that
    stopped as stiff on a model the stiffness check calls stiff (out of steps still fails:
    the detector stops a crawling explicit run long before 200 000 steps)."""
    if not (stiff and method in EXPLICIT and res.status == STIFF_STOP):
        return Check(f"{method} accuracy", "reaches t_final", res.message, False)
    why = res.message.split("; state ")[0].split(": ", 1)[-1]      # no model name, no state
    return Check(f"{method} accuracy", "reaches t_final, or stops as an explicit method does on a "
                 "stiff model", f"{why} (expected: the stiffness check calls the model stiff; use the "
                 "default or an implicit method)", False, stiff=True)


def _accuracy(model, x0, p, t_final, rtol, atol, methods, max_steps, stiff=False):
    """Each method at (rtol, atol) against a reference (REF_TOLS[1] tighter), itself measured
    against a second, looser one (REF_TOLS[0]); returns checks and runs.

    Why two references: their difference says how far the reference can be trusted, and on
    a motion that amplifies differences (a collapse onto many contacts, a chaotic pendulum)
    from when on no tight run can tell a right method from a wrong one.  A method is judged
    where the references agree to AGREE x tolerance (a tenth of what the method is allowed);
    past that time its difference from them would measure the problem's conditioning: the two
    run at once, compared as they go, and stop there (check_references.py; G1's parted at
    t = 1.15 of 10), and the check says up to when it judged and why, instead of failing the
    method.  A method still runs to t_final (one that stops fails).  A reference that stops (too stiff or too
    long at its tolerance: Go2 resting on 124 contact points at rtol 1e-12) leaves the
    accuracy checks inconclusive, with what to change."""
    t_eval = np.linspace(0.0, t_final, 201)
    tols = [(max(rtol / fr, REF_FINEST), max(atol / fa, 1e-15)) for fr, fa in REF_TOLS]
    implicit, method = _reference_method(model)
    refs = run_references(model, x0, p, t_final, t_eval, method, tols, rtol, atol, max_steps * 10,
                          AGREE, implicit)
    ref_method, loose, ref = refs.method, refs.loose, refs.tight
    if refs.failed is not None:   # e.g. a singular configuration or too many steps: say where and why
        tol = tols[0] if refs.failed is loose else tols[1]
        return [_unreachable("reference", ref_method, tol, refs.failed, t_final, rtol)], {"reference": loose}
    apart = ref_apart(loose.x[:refs.rows], ref.x[:refs.rows], rtol, atol)   # per output time, in tolerances
    parted = refs.parted is not None
    h = refs.parted if parted else refs.rows     # the references agree on the first h output times
    refs_text = (f"{ref_method} at rtol={tols[1][0]:g} (agreeing with rtol={tols[0][0]:g} to "
                 f"{np.max(apart[:h]) if h else 0.0:.3g} x tolerance{f' until t={t_eval[h]:.4g}' if parted else ''})")
    checks = [Check("reference", f"two references ({ref_method} at rtol={tols[0][0]:g} and "
                    f"{tols[1][0]:g}) agree to {AGREE:g} x tolerance over [0, t_final]",
                    _horizon_text(apart, t_eval, h, parted) + _stopped_text(ref), True,
                    judged_until=float(t_eval[h]) if parted else None)]
    if h < MIN_WINDOW:
        checks.append(Check("accuracy", f"the references agree long enough to judge a method "
                            f"({MIN_WINDOW} output times)", _horizon_text(apart, t_eval, h, parted) +
                            f": too early to judge the methods; check a shorter span (--t-final "
                            f"{t_eval[max(h, 1)]:.3g}: the motion before it diverges)", False,
                            inconclusive=True))
        return checks, {"reference": ref}
    # the convergence runs need only the judged span: [0, the last output time before the parting]
    judged = (t_eval[h - 1], t_eval[:h]) if parted else (t_final, t_eval)
    runs, same = {}, _same_runs(model, rtol, methods)
    finer_runs = _finer_runs(ref_method, loose, tols[0], rtol, atol)
    for method in methods:
        res = runs[same[method]] if same.get(method) in runs else _run(model, x0, p, t_final, t_eval,
                                                                        method, rtol, atol, max_steps)
        runs[method] = res
        if res.status:      # a method that stopped did not do the job: a failed check (or [stiff])
            checks.append(_stopped(method, res, stiff))
            continue
        err_ratio = float(np.max(ref_apart(res.x[:h], ref.x[:h], rtol, atol)))
        passed, how = err_ratio <= GLOBAL_FACTOR, ""
        if not passed and err_ratio <= MISSED_FACTOR:
            # Chaotic or unstable motion amplifies any local error: then the honest test
            # is convergence -- 100x tighter tolerances must cut the error at least 10x.
            key = same["auto"] if method == "auto" and "auto" in same else method   # one run per same run
            if key not in finer_runs:
                with stage("convergence"):
                    finer_runs[key] = (_run(model, x0, p, judged[0], judged[1], method, rtol / 100,
                                            atol / 100, max_steps * 10), "tolerances")
            finer, tighter = finer_runs[key]
            # the looser reference, when it is this run, may have been stopped where the references
            # part: its rows before that are whole
            whole = finer.status == 0 or (getattr(finer, "stopped", False) and len(finer.t) >= h)
            fine_ratio = float(np.max(ref_apart(finer.x[:h], ref.x[:h], rtol, atol))) if whole else np.inf
            passed = fine_ratio <= err_ratio / 10
            how = (f"; the motion amplifies errors, and at 100x tighter {tighter} the error is "
                   f"{fine_ratio:.3g} x tolerance ({'converging' if passed else 'NOT converging'})")
        elif not passed:
            how = f"; more than {MISSED_FACTOR:g} x tolerance: the tolerance was missed by orders of magnitude"
        if parted:
            how += (f"; judged up to t={t_eval[h]:.4g}, where the references part: after it the problem's "
                    f"conditioning, not the method, limits any comparison (the run itself went on to "
                    f"t={float(res.t_final):.4g})")
        if method == "auto" and same.get("auto") in methods:
            # first hour s27: a1 --floating-base --ground printed the same line for auto and radau
            # with nothing saying why
            how += f" (auto runs {same['auto']} here: the {same['auto']} run, judged once)"
        window = f" on [0, {t_eval[h]:.4g}] where the references agree" if parted else ""
        checks.append(Check(f"{method} accuracy", f"error <= {GLOBAL_FACTOR:g} x (atol + rtol |x|) "
                            f"vs {refs_text}{window} (local tolerances add up), or, where the motion "
                            f"amplifies errors (up to {MISSED_FACTOR:g} x), 10x smaller at 100x "
                            f"tighter tolerances",
                            f"{err_ratio:.3g} x tolerance, {res.stats['steps']} steps{how}", passed))
    # cond(M) along the trajectory: the reference's, or where the references stopped where they
    # part, a method's run that reached t_final (the default's first)
    along = next((r for r in runs.values() if r.status == 0), ref) if parted else ref
    return checks, {"reference": along, **runs}


def _finer_runs(ref_method, loose, loose_tol, rtol, atol):
    """{method: (run, what is tighter)}: the convergence runs check already has.  The looser
    reference is the reference method at 100x tighter rtol (atol unchanged): for that method
    (and auto where it runs it) it is the convergence run, so it is not integrated a third
    time -- G1's no-flag check ran Radau at (1e-10, 1e-12) for 23 s CPU for auto and again
    for radau, next to the reference at (1e-10, 1e-10).  The verdict keeps its meaning: the
    same method at 100x tighter rtol must be 10x closer to the reference (a smaller atol only
    tightens it further)."""
    if loose_tol != (rtol / 100, atol):
        return {}          # rtol below REF_FINEST x 100: the references are clipped, not 100x
    return {ref_method: (loose, f"rtol (the looser reference, atol={atol:g})")}


def _same_runs(model, rtol, methods):
    """{method: an equal method}: "auto" where it runs one listed method from start to end (on
    a contact model below BDF_FINEST auto is radau with radau's own settings), so check runs it
    once -- G1's no-flag check ran Radau twice over 10 s of 232 contact points (~37 s CPU)."""
    from .simulate import auto_method
    if "auto" not in methods:
        return {}
    first, may_switch = auto_method(model, rtol)
    return {"auto": first, first: "auto"} if not may_switch and first in methods else {}


def _stopped_text(ref):
    """"; every run ends at t=..., where the terminal event NAME fired ..." when one did, else "".
    Why: examples/cartpole_lqr.py's pole falls at t = 0.55 and its "fallen" event ends each run
    there; `eomc check` said t_final=10 and nothing of it, its checks covering 0.55 s (first hour s28)."""
    stop = getattr(ref, "event_stop", None)
    if not stop or not len(ref.t):
        return ""
    times = (getattr(ref, "t_events", None) or {}).get(stop)
    end = float(times[-1]) if times is not None and len(times) else float(ref.t[-1])  # not the last output time
    return (f"; every run ends at t={end:.4g}, where the terminal event {stop} fired: the checks "
            f"cover [0, {end:.4g}], not [0, t_final]")


def _horizon_text(apart, t_eval, h, parted):
    if not parted:
        return f"they differ by at most {np.max(apart) if apart.size else 0.0:.3g} x tolerance"
    return (f"they agree to {np.max(apart[:h]) if h else 0.0:.3g} x tolerance until t={t_eval[h]:.4g}, where "
            f"they differ by {apart[h]:.3g} x: the motion amplifies the references' own small differences "
            f"beyond what a method is allowed (the problem's conditioning), so both stopped there and "
            f"nothing after it is judged")


def _conditioning(model, res, p):
    if model.c_model.mass_matrix == model.ffi.NULL or res is None:
        return None
    if res.t.size == 0:
        return None
    conds = np.array([np.linalg.cond(model.mass_matrix(t, x, p)) for t, x in zip(res.t, res.x)])
    i = int(np.argmax(conds))
    # the coordinates only: M depends on them, not on the speeds (first hour s23: the humanoid's
    # line ran to 70 values, half of them speeds)
    state = ", ".join(f"{n}={v:.4g}" for n, v in zip(model.state_names[:model.nq], res.x[i]))
    return Check("mass matrix conditioning", f"cond(M) < {COND_WARN:g} along the trajectory",
                 f"max cond(M) = {conds[i]:.3g} at t={res.t[i]:.6g} ({state})", conds[i] < COND_WARN)


def _drift(runs, name="energy"):
    out = []
    for method, res in runs.items():
        if method == "reference" or name not in res.outputs or res.status:
            continue
        e = res.outputs[name]
        rel = abs(e[-1] - e[0]) / max(np.max(np.abs(e)), 1e-300)   # e(0) may be 0
        out.append(Check(f"{method} {name} drift", "informational (conserved only without "
                         "damping and inputs)", f"change {rel:.3g} of max |{name}|", True))
    return out


def _constraints(model, x0, p, t_final, rtol, atol):
    if model.nhol + model.nvel == 0 or model.c_model.constraints == model.ffi.NULL:
        return []
    with stage(f"constraint drift: auto at rtol={rtol:g}, atol={atol:g}"):
        free = simulate(model, x0, (0.0, t_final), p=p, rtol=rtol, atol=atol, raise_on_failure=False)
    with stage(f"constraint drift: auto at rtol={rtol:g}, atol={atol:g}, projected"):
        proj = simulate(model, x0, (0.0, t_final), p=p, rtol=rtol, atol=atol, project=True,
                        raise_on_failure=False)
    ok = proj.status == 0 and proj.stats["max_residual"] < 1e-10
    return [Check("constraint drift", "project=True keeps residuals < 1e-10 at steps",
                  f"free: max {np.max(free.constraint_residual):.3g}; projected: "
                  f"{proj.stats['max_residual']:.3g}", ok)]


def default_methods(model, rtol=None):
    """The methods ``eomc check`` runs when none are named: the default ("auto") and every
    method that applies -- explicit ones only for a model without ground contacts, where
    they are the right tool (on contacts they stop as stiff, which is not news); bdf and radau
    where the model has jac_x.  On a contact model bdf is listed at the tolerances where auto
    takes it (rtol >= simulate.BDF_FINEST): below, auto is radau, and BDF there misses by orders
    of magnitude what Radau meets (Go2 falling 1 s at 1e-8: 1.07e5 x tolerance against 1.03e3
    x; G1: 3.6e5 x) -- `--methods bdf` still checks it."""
    from .simulate import BDF_FINEST
    from .switching import find_switches
    implicit = model.c_model.jac_x != model.ffi.NULL
    if find_switches(model).contacts and implicit:
        if rtol is not None and rtol < BDF_FINEST:
            return ("auto", "radau")              # what auto runs here (simulate.auto_method)
        return ("auto", "bdf", "radau")           # auto takes bdf here
    return ("auto", "dopri5", "dop853") + (("bdf", "radau") if implicit else ())


def check_model(model, x0=None, t_final=10.0, p=None, rtol=1e-8, atol=1e-10,
                methods=None, max_steps=200000):
    """Run the checks from x0 (default: the model's initial_state) over [0, t_final].

    A method that stops, or misses its tolerance by more than MISSED_FACTOR, fails its check --
    but an explicit method that stops as stiff on a model the stiffness check calls stiff is
    marked ``stiff`` (expected; not a failure).
    A check that cannot be made is ``inconclusive`` (see :func:`outcome`): the accuracy checks
    when the reference cannot be computed (it says why and what to change) or when the two
    references disagree from the start (the problem's conditioning, not the methods)."""
    if methods is None:
        methods = default_methods(model, rtol)
    if x0 is None:
        from .start import start_or_default
        x0 = start_or_default(model, None)
    x0 = np.asarray([x0[n] for n in model.state_names] if isinstance(x0, dict) else x0, float)
    p = model.param_defaults if p is None else np.asarray(p, float)
    if model.c_model.jac_x == model.ffi.NULL:
        methods = tuple(m for m in methods if m not in ("radau", "bdf"))
    checks = [_finite_at_start(model, x0, p)]
    if not checks[0].passed:
        return checks
    stiffness = _stiffness(model, x0, p, t_final)
    checks += [c for c in (_jacobian_vs_fd(model, x0, p), stiffness) if c]
    acc, runs = _accuracy(model, x0, p, t_final, rtol, atol, methods, max_steps, _is_stiff(stiffness))
    checks += acc
    cond = _conditioning(model, runs.get("reference"), p)
    checks += ([cond] if cond else []) + _drift(runs) + _constraints(model, x0, p, t_final, rtol,
                                                                      atol)
    return checks


def outcome(checks):
    """"passed", "failed" (a check failed) or "inconclusive" (none failed, but one could not
    be made: `eomc check` exits EXIT_INCONCLUSIVE, not 1, so a CI gate can tell a method
    that is wrong from a reference that could not be computed)."""
    if any(not c.passed and not c.inconclusive and not c.stiff for c in checks):
        return "failed"
    return "inconclusive" if any(c.inconclusive for c in checks) else "passed"


EXIT_INCONCLUSIVE = 3    # `eomc check`: 0 passed, 1 a check failed, 2 bad arguments, 3 inconclusive


def format_checks(checks):
    """A plain-text table: status, name, expected, measured."""
    lines = []
    for c in checks:
        tag = "INCONCLUSIVE" if c.inconclusive else "stiff" if c.stiff else "ok" if c.passed else "FAIL"
        lines.append(f"[{tag:>4}] {c.name}: {c.measured}")
        lines.append(f"       expected: {c.expected}")
    passed = sum(c.passed for c in checks)
    unsure = sum(c.inconclusive for c in checks)
    stiff = [c.name.split()[0] for c in checks if c.stiff]
    until = next((c.judged_until for c in checks if c.judged_until is not None), None)
    lines.append(f"{passed} of {len(checks)} checks passed" + (
        f"; accuracy judged on [0, {until:.4g}] only, where the references part (the reference line says why)"
        if until is not None else "") + (
        f", {len(stiff)} stiff ({' and '.join(stiff)} stopped as explicit methods do on a stiff model: "
        f"expected, not failures)" if stiff else "") + (
        f", {unsure} inconclusive (could not be made; see why above)" if unsure else ""))
    return "\n".join(lines)
