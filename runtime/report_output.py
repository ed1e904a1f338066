"""What a WorkPrecisionReport writes: CSV, text table, work-precision PNG, Markdown summary.

Why a separate module: runtime/report.py measures, this one presents.  The
plot imports matplotlib lazily (Agg backend), so measuring never needs it.
"""
import csv
import math
from pathlib import Path

import numpy as np

from .files import atomic_path

# The report's columns and default error target: defined here, with the
# writers that use them, so that this module does not import report.py back.
DEFAULT_TARGET = 1e-6
COLUMNS = ("method", "tolerance", "rtol", "atol", "dt", "status", "error", "wall_time_s",
           "wall_time_min_s", "cpu_time_s", "samples",
           "steps", "accepted", "rejected", "nfev", "njev", "nlu", "cost", "energy_drift",
           "constraint_residual", "message")

__all__ = ["write_csv", "table_text", "plot_report", "summary_markdown", "recommendation", "usage",
           "is_cut", "CUT_STATUS"]

CUT_STATUS = 9           # EOMC_ABORTED: what a run stopped through eomc_options.stop ends with


def is_cut(row):
    """Whether a row's run was stopped at the report's row budget (runtime/report.py)."""
    return row["status"] == CUT_STATUS and str(row.get("message") or "").startswith("cut:")


def _after_cut(row):
    """A row not run because a looser tolerance of its method was cut at the row budget."""
    message = str(row.get("message") or "")
    return message.startswith("not run") and ("cut at the row budget" in message
                                               or "x the row budget" in message)

EXPLICIT = ("rk4", "dopri5", "dop853")
ONCE_S = 0.2             # a first call this long (thread CPU s) is the row's only timing sample
SWEEP_BUDGETS = 3        # row budgets a method's runs may use together (runtime/report.py)
MANY_REJECTIONS = 0.25    # rejected / steps above this: reported (a symptom only with others)
FLAT_STEPS = 1.5         # explicit steps growing less than this over >= 3 decades: stability-limited
CONSERVED = 1e-8          # reference energy drift below this: the model conserves energy


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def write_csv(report, path):
    path = Path(path)
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for row in report.rows:
            w.writerow([_cell(row[c]) for c in COLUMNS])
    return path


def _fmt(value, spec=".2e"):
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return format(value, spec)


def _setting(row):
    return f"dt={row['dt']:.3g}" if row["method"] == "rk4" and row["dt"] else f"{row['tolerance']:.0e}"


def _table_rows(report):
    head = ["method", "tol/dt", "error", "CPU [ms]", "steps", "rejected", "nfev", "cost [rhs]"]
    if report.has_energy:
        head.append("energy drift")
    if report.has_constraints:
        head.append("constraint res.")
    body = []
    for r in report.rows:
        ms = r.get("cpu_time_s", r["wall_time_s"]) * 1e3 if r["status"] == 0 else None
        cells = [r["method"], _setting(r), _fmt(r["error"]) if r["status"] == 0 else _not_ok(r),
                 _fmt(ms, ".3g"), _fmt(r["steps"], "d"), _fmt(r["rejected"], "d"), _fmt(r["nfev"], "d"),
                 _fmt(r.get("cost") if r["status"] == 0 else None, ".0f")]
        if report.has_energy:
            cells.append(_fmt(r["energy_drift"]))
        if report.has_constraints:
            cells.append(_fmt(r["constraint_residual"]))
        body.append(cells)
    return head, body


def _not_ok(row):
    """The error cell of a row without one: cut (where), not run, or FAILED."""
    if is_cut(row):
        return f"cut t={row['cut_at']:.3g}" if row.get("cut_at") is not None else "cut"
    return "not run" if str(row.get("message") or "").startswith("not run") else "FAILED"


def table_text(report):
    head, body = _table_rows(report)
    widths = [max(len(str(c)) for c in col) for col in zip(head, *body)]
    line = lambda cells: "  ".join(str(c).rjust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(head), line(["-" * w for w in widths])] + [line(b) for b in body])


def _markdown_table(report):
    head, body = _table_rows(report)
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(c) for c in b) + " |" for b in body]
    return "\n".join(out)


def usage(row):
    """The simulate() keywords that reproduce a row."""
    if row["method"] == "rk4":
        return f'method="rk4", dt={row["dt"]:.4g}'
    return f'method="{row["method"]}", rtol={row["tolerance"]:.0e}, atol={row["tolerance"]:.0e}'


def plot_report(report, path, target_error=None):
    """Error vs thread CPU time, log-log, one line per method, points labelled by tolerance
    (CPU time: a loaded machine's wall times put a tighter tolerance left of a looser one)."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    target = DEFAULT_TARGET if target_error is None else float(target_error)
    fig, ax = plt.subplots(figsize=(8.5, 6))
    markers = dict(rk4="s", dopri5="o", dop853="^", bdf="v", radau="D")
    for method in report.methods:
        rows = [r for r in report.ok_rows() if r["method"] == method]
        if not rows:
            why = "not run" if method in report.skipped else "no successful run"
            ax.plot([], [], ls="none", marker=markers.get(method, "o"), mfc="none",
                    color="0.5", label=f"{method} ({why})")
            continue
        rows.sort(key=lambda r: -r["tolerance"])
        x = [r.get("cpu_time_s", r["wall_time_s"]) for r in rows]
        y = [max(r["error"], 1e-17) for r in rows]
        label = method + (" (dt from DOPRI5 step count)" if method == "rk4" else "")
        (line,) = ax.loglog(x, y, marker=markers.get(method, "o"), label=label)
        for xi, yi, r in zip(x, y, rows):
            ax.annotate(f"{r['tolerance']:.0e}", (xi, yi), textcoords="offset points",
                        xytext=(5, 3), fontsize=7, color=line.get_color())
    ax.axhline(target, color="0.3", ls="--", lw=1, label=f"target error {target:.0e}")
    agree = report.reference.agreement
    if np.isfinite(agree) and agree > 0:
        ax.axhspan(1e-17, agree, color="0.85", zorder=0,
                   label=f"below reference agreement ({agree:.1e})")
    ok = [r["error"] for r in report.ok_rows()]
    if ok:
        ax.set_ylim(max(min(ok), 1e-17) / 5, max(max(ok), target) * 5)
    t0, t1 = report.t_span
    ax.set_xlabel("CPU time of one integration [s] (thread time, median of repeats)")
    ax.set_ylabel("error vs reference [max over output times of scaled RMS, relative]")
    ax.set_title(f"{report.model_name}: work-precision, t in [{t0:g}, {t1:g}]\n"
                 f"points labelled by tolerance (rtol = atol); lower-left is better", fontsize=11)
    ax.grid(True, which="both", alpha=0.3)
    # plain numbers (0.03, 0.04) at the ticks matplotlib labels: its 3x10^-2 and 4x10^-2 ran into
    # each other over a decade and a half (first hour s27: A1's report, 0.016 to 0.49 s)
    ax.xaxis.set_major_formatter(_plain_log_formatter())
    ax.xaxis.set_minor_formatter(_plain_log_formatter())
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    _fit_labels(fig, ax)
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=path.suffix[1:] or "png")
    plt.close(fig)
    return path


def _plain_log_formatter():
    """matplotlib's LogFormatter (which ticks get a label) printing each value with %g."""
    from matplotlib.ticker import LogFormatter

    class Plain(LogFormatter):
        def _num_to_string(self, x, vmin, vmax):
            return f"{x:g}"
    return Plain(labelOnlyBase=False)


def _fit_labels(fig, ax, rounds=3):
    """Widen the (log) x range until every point label ends inside the axes: the rightmost
    point's label, drawn to its right, ran past the edge and was cut (first hour s26)."""
    for _ in range(rounds):
        if not ax.texts:
            return
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        box = ax.get_window_extent(renderer)
        right = max(t.get_window_extent(renderer).x1 for t in ax.texts)
        if right <= box.x1 - 2:
            return
        lo, hi = ax.get_xlim()
        ax.set_xlim(lo, hi * (hi / lo) ** ((right - box.x1 + 6) / box.width))


def cpu_ms(row):
    """A row's thread CPU time in ms (wall time for a CSV written before it was measured)."""
    value = row.get("cpu_time_s")
    return 1e3 * (value if value is not None and np.isfinite(value) else row["wall_time_s"])


def recommendation(report, target):
    if getattr(report, "inconclusive", None):
        return f"**Inconclusive:** {report.inconclusive}."
    best = report.recommend(target)
    meeting = [r for r in report.ok_rows() if r["error"] <= target]
    if best is None:
        ok = report.ok_rows()
        if not ok:
            return "**No run succeeded**; see the table for the reasons."
        top = min(ok, key=lambda r: r["error"])
        return (f"**No run met the target.** The most accurate was `{usage(top)}` "
                f"(error {top['error']:.2e}, {cpu_ms(top):.3g} ms CPU): add tighter "
                f"tolerances to the grid (`--tolerances`).")
    which = ("the only run that meets the target" if len(meeting) == 1 else
             f"the cheapest of the {len(meeting)} runs that meet the target")
    drift = (f", energy drift {best['energy_drift']:.1e}"
             if best.get("energy_drift") is not None else "")
    text = (f"**Recommendation** (target {target:.0e}): `{usage(best)}` -- error "
            f"{best['error']:.2e}, cost {best['cost']:.0f} rhs-equivalents ({best['steps']} steps, "
            f"{best['nfev']} rhs evaluations{drift}; {cpu_ms(best):.3g} ms CPU); {which}.")
    others = sorted((r for r in meeting if r is not best), key=cost_key)
    if others:
        nxt = others[0]
        text += (f" Runner-up: `{usage(nxt)}` (error {nxt['error']:.2e}, cost {nxt['cost']:.0f}, "
                 f"{cpu_ms(nxt):.3g} ms CPU).")
    return text + " " + how_chosen(report)


def cost_key(row):
    """Deterministic ranking: counted work, then error, then the row's settings (never wall time)."""
    return (row["cost"], row["error"], row["method"], -(row["tolerance"] or 0.0))


def how_chosen(report):
    """One sentence on how the recommendation was made, so a reader can trust (and redo) it."""
    jac, lu = report.cost_weights
    source = ("the model's operation counts" if report.cost_from_op_counts else
              "a rhs assumed to cost nx^2 operations (the model has no operation counts)")
    return (f"Runs are ranked by counted work, not by wall time, so the same command always "
            f"recommends the same run: cost = rhs evaluations + {jac:.3g} x Jacobians + {lu:.3g} x "
            f"LU factorizations, in rhs-equivalents from {source}; times are shown for "
            f"information as thread CPU time (median of the repeats; the CSV has wall times too), "
            f"which the machine's load disturbs far less than wall time.")


def _reference_notes(report, target):
    ref = report.reference
    notes = [ref.describe() + "."]
    finest = min(report.tolerances)
    if ref.check_method == "none":
        notes.append("**Warning:** the reference was not checked; errors are only as good as it is.")
    elif not (ref.agreement <= 0.1 * finest):
        notes.append(f"**Warning:** the two references agree only to {ref.agreement:.1e}, which is "
                     f"not well below the finest tolerance {finest:.0e}: errors below "
                     f"~{10 * ref.agreement:.0e} are not resolved by this reference.")
    window = getattr(report, "window", None)
    if window is not None and 0 < window < ref.t.size and not getattr(report, "inconclusive", None):
        apart = ref.agreement_t[window:]
        stopped = getattr(ref, "check_stopped_at", None)
        differ = (f"there they differ by {float(np.nanmax(apart)):.1e}, and the check was stopped "
                  f"(at t = {stopped:.4g})" if stopped is not None else
                  f"after it they differ by up to {float(np.nanmax(apart)):.1e}")
        notes.append(f"**Errors are measured on t in [{ref.t[0]:g}, {ref.t[window]:.4g}]**, where the "
                     f"reference's two computations agree to {report.window_level:.1e} (a tenth of the "
                     f"target); {differ}: the "
                     f"motion amplifies their differences, so there the problem's conditioning, not a "
                     f"method, limits the comparison (not judged).")
    elif ref.check_method != "none" and not (ref.agreement <= 0.1 * target):
        notes.append(f"**Warning:** the reference is not 10x more accurate than the target "
                     f"{target:.0e}; the recommendation above is not reliable (tighten "
                     f"--reference-tol or shorten the time span).")
    return notes


def _short(report, message):
    """A failure message without the model-name prefix and the trailing state dump."""
    message = (message or "").split("; state ")[0].replace("; use method='radau'", "")
    prefix = f"{report.model_name}: "
    return message[len(prefix):] if message.startswith(prefix) else message


MISSED_FACTOR = 1e5    # error beyond this many tolerances: the run missed it by orders of magnitude


def _run_notes(report):
    """Methods that could not run on this model, runs that failed (other than stiffness) and
    runs that missed their tolerance by orders of magnitude (failed too: issue 29)."""
    notes = [f"{m} not run: {why}" for m, why in report.skipped.items()]
    notes += _cut_notes(report)
    # one line per method and reason, its settings listed (first hour s23: gymnasium's hopper
    # had seven lines of "rk4 at 1e-04 failed: not run: DOPRI5 failed ...", one per tolerance,
    # which pushed the notes after them past the ten kept)
    same = {}
    for r in report.rows:
        if r["status"] != 0 and not (r["method"] in EXPLICIT and r["status"] in (6, 7)) \
                and not is_cut(r) and not _after_cut(r):
            same.setdefault((r["method"], _short(report, r["message"])), []).append(_setting(r))
    for (method, why), settings in same.items():
        notes.append(f"{method} at {', '.join(settings)} failed: {why}")
    missed = [r for r in report.ok_rows() if r["method"] != "rk4"
              and r["error"] > MISSED_FACTOR * r["tolerance"]]
    if missed:
        notes.append("FAILED, tolerance missed by orders of magnitude (error > 1e5 x tolerance): "
                     + "; ".join(f"{r['method']} at {_setting(r)} (error {r['error']:.2g})" for r in missed[:6]))
    stopped = [r for r in report.rows if r["status"] != 0 and not is_cut(r) and not _after_cut(r)]
    if stopped:
        notes.append(f"FAILED, stopped: {len(stopped)} of {len(report.rows)} runs "
                     f"({', '.join(sorted({r['method'] for r in stopped}))}); they are never recommended")
    return notes[:10]


def _cut_notes(report):
    """The runs stopped at the row budget, where, and what was not run after them."""
    cut = [r for r in report.rows if is_cut(r)]
    swept = {}
    for r in report.rows:
        if _after_cut(r) and "x the row budget" in r["message"]:
            swept.setdefault(r["method"], []).append(_setting(r))
    if not cut and not swept:
        return []
    notes = [f"{m} at {', '.join(settings)} not run: its runs at looser tolerances used "
             f"{SWEEP_BUDGETS} row budgets of CPU time together (`--row-budget`)"
             for m, settings in swept.items()]
    if not cut:
        return notes
    t1 = report.t_span[1]
    budget = getattr(report, "row_budget", None)
    clock = getattr(report, "budget_clock", "CPU")
    parts = []
    for r in cut:
        skipped = [_setting(s) for s in report.rows if s["method"] == r["method"] and _after_cut(s)]
        error = (f", error {r['error']:.2e} on the judged times it covered" if r["error"] is not None
                 and np.isfinite(r["error"]) else "")
        parts.append(f"{r['method']} at {_setting(r)} (stopped at t = {r.get('cut_at', float('nan')):.4g} "
                     f"of {t1:g}, {r['steps']} steps{error})"
                     + (f", so {r['method']} at {', '.join(skipped)} was not run" if skipped else ""))
    limit = f"{budget:g} s of {clock} time per run" if budget else "the row budget"
    return [f"CUT at the row budget ({limit}; `--row-budget` sets it, 0 for none): "
            + "; ".join(parts) + ". A cut run is never recommended; its tighter tolerances take "
            f"longer still."] + notes


def _energy_notes(report):
    if not report.has_energy:
        return []
    d_ref = report.reference_energy_drift()
    if d_ref is None or d_ref > CONSERVED:
        return [f"Energy is not conserved by the model itself (reference drift {_fmt(d_ref)}: "
                f"forcing, damping or inputs), so the drift column measures physics, not error."]
    parts = []
    for method in report.methods:
        rows = [r for r in report.ok_rows() if r["method"] == method and r["energy_drift"] is not None]
        if rows:
            lo, hi = rows[0], rows[-1]
            parts.append(f"{method} {lo['energy_drift']:.1e} ({_setting(lo)}) -> "
                         f"{hi['energy_drift']:.1e} ({_setting(hi)})")
    return [f"Energy: the reference conserves it to {d_ref:.1e} (relative). None of these methods "
            f"is symplectic: drift follows the accuracy (loosest -> tightest): "
            + "; ".join(parts) + "."]


def _flat_step_counts(report):
    """Explicit methods whose step count barely grows over >= 3 decades of tolerance.

    Accuracy-limited steps grow like tol**(-1/order); a count that stays flat
    means the step is limited by stability instead: the signature of stiffness.
    """
    out = []
    for method in ("dopri5", "dop853"):
        rows = [r for r in report.ok_rows() if r["method"] == method]
        if len(rows) < 2 or rows[0]["tolerance"] / rows[-1]["tolerance"] < 1e3:
            continue
        if rows[-1]["accepted"] < FLAT_STEPS * rows[0]["accepted"]:
            out.append(f"{method} takes {rows[0]['accepted']} steps at {_setting(rows[0])} and "
                       f"still {rows[-1]['accepted']} at {_setting(rows[-1])} (step limited by "
                       f"stability, not accuracy)")
    return out


def _stiffness_notes(report):
    """Strong symptoms (explicit runs stopped, flat step counts, Radau needing far fewer
    steps) decide; a high rejection rate alone is only reported, not called stiffness."""
    strong = [f"{_short(report, r['message'])} ({_setting(r)})" for r in report.rows
              if r["method"] in EXPLICIT and r["status"] in (6, 7)]
    strong += _flat_step_counts(report)
    by = {(r["method"], r["tolerance"]): r for r in report.ok_rows()}
    for tol in report.tolerances:
        rad = by.get(("radau", tol))
        exp = [by[(m, tol)]["accepted"] for m in ("dopri5", "dop853") if (m, tol) in by]
        if rad and exp and rad["accepted"] * 5 < min(exp):
            strong.append(f"at {tol:.0e} radau needs {rad['accepted']} steps against "
                          f"{min(exp)} for the best explicit method")
    rejecting = [r for r in report.ok_rows() if r["method"] in EXPLICIT and r["steps"]
                 and r["rejected"] / r["steps"] > MANY_REJECTIONS]
    worst = max(rejecting, key=lambda r: r["rejected"] / r["steps"]) if rejecting else None
    reject = (f"{worst['method']} rejects up to {worst['rejected'] / worst['steps']:.0%} of its "
              f"steps ({worst['rejected']} of {worst['steps']} at {_setting(worst)})") if worst else ""
    if strong:
        extra = [reject] if reject else []
        return ['Stiffness symptoms -- prefer method="radau": ' + "; ".join((strong + extra)[:6]) + "."]
    if reject:
        return [f"Stiffness: no symptoms (no explicit run stopped, explicit step counts grow "
                f"with the tolerance as accuracy demands); {reject}, which is step-size control "
                f"on a fast-changing solution, not stiffness."]
    return ["Stiffness: no symptoms (no explicit run stopped, step counts grow with the "
            f"tolerance, none rejected more than {MANY_REJECTIONS:.0%} of its steps)."]


def _constraint_notes(report):
    if not report.has_constraints:
        return []
    ref = report.reference.constraint_residual
    rows = [r for r in report.ok_rows() if r["constraint_residual"] is not None]
    worst = max(rows, key=lambda r: r["constraint_residual"]) if rows else None
    text = f"Constraints: reference residual {_fmt(None if ref is None else float(np.max(ref)))}"
    if worst:
        text += f"; worst run {worst['method']} at {_setting(worst)}: {worst['constraint_residual']:.1e}"
    return [text + " (max |constraint| along the trajectory; `project=True` removes the drift)."]


def summary_markdown(report, target):
    target = float(target)
    t0, t1 = report.t_span
    lines = [f"# Work-precision report: {report.model_name}", "",
             f"Integration over t in [{t0:g}, {t1:g}]; the error is measured at "
             f"{report.n_points} equally spaced times: at each time the RMS over states of "
             f"(x - x_ref) / (largest |x_ref| of that state along the trajectory), and the "
             f"maximum over times is reported. Target {target:.0e} therefore means about "
             f"{-math.log10(target):.0f} correct digits of every state, relative to its size, "
             f"at every output time. Adaptive methods run with rtol = atol = tolerance; RK4's "
             f"step is the span over DOPRI5's accepted steps at that tolerance. Wall time is "
             f"the median of the C integration call (a run of {ONCE_S:g} s of CPU time or more: "
             f"its one call).", "",
             recommendation(report, target), ""]
    notes = (_reference_notes(report, target) + _run_notes(report) + _energy_notes(report)
             + _constraint_notes(report) + _stiffness_notes(report))
    for note in notes:
        lines += [f"- {note}"]
    lines += ["", _markdown_table(report), ""]
    return "\n".join(lines)
