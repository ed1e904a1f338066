"""Work-precision through contact, 1 s: eomc's default (method="auto": BDF here) and Radau against scipy's
LSODA and BDF on eomc's own compiled rhs and jac_x.

    python benchmarks/bench_contact_wp.py [--models solo12,hopper,ant] [--tols 1e-2,...,1e-8]

Models: Solo12 standing (examples/quadruped_stand.py: four foot spheres, joint PD K (x_ref - x)
evaluated in C for eomc and in NumPy for scipy, the Jacobian jac_x - jac_r K), gymnasium's
hopper and ant dropped from qpos0 with zero control (their ground contacts from the file,
as in bench_fixedstep.py).  Every contestant at rtol = atol = tol; eomc's default also at
--eomc-only-tols (1e-1, 3e-2: rows marked "curve only"), which only extend its curve for the
equal-error comparison below.
eomc is timed as a user calls it: ``model.simulate(x0, (0, 1), t_eval=[1], rtol=tol,
atol=tol)`` (its Python side, checks and verdict included); scipy ``solve_ivp(...,
method="LSODA"/"BDF", jac=...)``.  Error: max abs over the coordinates q at t = 1 against
eomc's Radau at rtol = atol = 1e-11.  Thread CPU time, contestants interleaved (order
rotated per repeat), median of --repeat runs; pinned to one core.

At equal error (the target's wording: "no slower at equal or better error"): each peer's
row is set against eomc's default at the peer's own error, eomc's time there read off its
work-precision curve -- the rows not beaten by a faster, more accurate row of the same
contestant, interpolated linearly in log(error)-log(time).  Outside eomc's range of errors
there is no interpolation: a peer less accurate than eomc's loosest row is compared with that
row (eomc would be at most as slow there: the ratio is a lower bound, marked >=); a peer more
accurate than eomc's most accurate row gets no ratio ("beyond").
"""
import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "examples"))
from common import environment_header, pin_to_one_core, write_results  # noqa: E402

TOLS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)


def solo12(cache_dir):
    import quadruped_stand as qs
    model = qs.build(cache_dir=cache_dir)
    x0, K, x_ref = qs.stance(model)
    return model, x0, dict(K=K, x_ref=x_ref)


def gym(name, cache_dir):
    import mujoco
    import bench_fixedstep as fs
    base = mujoco.MjModel.from_xml_path(str(fs.gym_xml(name)))
    model = fs.eomc_model(name, cache_dir)
    return model, fs.eomc_start(model, base), {}


def scipy_problem(model, fb):
    """(fun, jac) over the compiled functions; with feedback r = K (x_ref - x)."""
    K, x_ref = fb.get("K"), fb.get("x_ref")
    if K is None:
        def fun(t, x):
            return np.array(model.rhs(t, x), dtype=float)

        def jac(t, x):
            return np.array(model.jacobian(t, x), dtype=float)
        return fun, jac

    def fun(t, x):
        return np.array(model.rhs(t, x, r=K @ (x_ref - x)), dtype=float)

    def jac(t, x):
        r = K @ (x_ref - x)
        return model.jacobian(t, x, r=r) - model.input_jacobian(t, x, r=r) @ K
    return fun, jac


NOTES_MARK = "<!-- hand-written notes below: kept by bench_contact_wp.py when it rewrites this file -->"


def frontier(points):
    """(error, time) pairs of one contestant, most accurate first, without the rows a faster
    and at least as accurate row of the same contestant beats (error non-finite: dropped)."""
    pts = sorted((e, t) for e, t in points if np.isfinite(e) and e > 0)
    keep = []
    for e, t in pts:
        if not keep or t < keep[-1][1]:
            keep.append((e, t))
    return keep


def time_at_error(front, err):
    """(time, how): the contestant's time at error err on its frontier; how is "" (read off
    the curve), ">=" (err looser than its loosest row: that row's time, an upper bound on its
    time, so a ratio peer / it is a lower bound) or "beyond" (err tighter than its tightest)."""
    if not front or not np.isfinite(err) or err <= 0:
        return np.nan, "beyond"
    if err < front[0][0]:
        return np.nan, "beyond"
    if err >= front[-1][0]:
        return front[-1][1], ">=" if err > front[-1][0] else ""
    for (e0, t0), (e1, t1) in zip(front, front[1:]):
        if e0 <= err <= e1:
            w = (np.log(err) - np.log(e0)) / (np.log(e1) - np.log(e0)) if e1 > e0 else 0.0
            return float(np.exp(np.log(t0) + w * (np.log(t1) - np.log(t0)))), ""
    return np.nan, "beyond"


def equal_error_table(rows):
    """Markdown: per model and peer row, eomc default's time at that row's error."""
    out = ["| model | peer | peer rtol | peer error | peer ms | eomc default ms at that error | peer ms / eomc ms |",
           "|---|---|--:|--:|--:|--:|--:|"]
    for name in dict.fromkeys(r[0] for r in rows):
        mine = [r for r in rows if r[0] == name]
        front = frontier([(r[3], r[4]) for r in mine if r[2] == "eomc auto (default)"])
        for peer in ("scipy LSODA", "scipy BDF"):
            for r in (r for r in mine if r[2] == peer):
                t, how = time_at_error(front, r[3])
                ratio = "beyond" if how == "beyond" else f"{how}{r[4] / t:.2f}"
                et = "" if how == "beyond" else f"{how.replace('>=', '<=')}{t:.2f}"
                out.append(f"| {name} | {peer} | {r[1]:.0e} | {r[3]:.2e} | {r[4]:.2f} | {et} | {ratio} |")
    return out


def same_rtol_table(rows):
    """Markdown: LSODA's and scipy BDF's time / eomc default's at each rtol."""
    names = list(dict.fromkeys(r[0] for r in rows))
    tols = list(dict.fromkeys(r[1] for r in rows))
    get = {(r[0], r[1], r[2]): r for r in rows}
    out = ["| rtol | " + " | ".join(f"{n} LSODA / eomc | {n} scipy BDF / eomc" for n in names) + " |",
           "|--:|" + "--:|" * (2 * len(names))]
    for tol in tols:
        cells = []
        for n in names:
            base = get.get((n, tol, "eomc auto (default)"))
            for peer in ("scipy LSODA", "scipy BDF"):
                r = get.get((n, tol, peer))
                cells.append(f"{r[4] / base[4]:.2f}" if r and base else "")
        out.append(f"| {tol:.0e} | " + " | ".join(cells) + " |")
    return out


def kept_notes():
    """The hand-written part of the results file this script rewrites (after NOTES_MARK; in
    a file from before the mark, from its first hand-written section on)."""
    path = HERE / "results" / "contact_wp.md"
    if not path.exists():
        return ""
    text = path.read_text()
    if NOTES_MARK in text:
        return text.split(NOTES_MARK, 1)[1].lstrip("\n")
    i = text.find("\n## What the table says")
    return text[i + 1:] if i >= 0 else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="solo12,hopper,ant")
    parser.add_argument("--tols", default=",".join(f"{t:g}" for t in TOLS))
    parser.add_argument("--eomc-only-tols", default="1e-1,3e-2",
                        help="looser tolerances run for eomc's default alone: they extend its "
                             "work-precision curve to the errors the peers reach at 1e-2 / 1e-3, "
                             "for the equal-error comparison")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cache-dir", default=None)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    from scipy.integrate import solve_ivp
    import scipy
    core = pin_to_one_core()
    only = [float(t) for t in args.eomc_only_tols.split(",") if t]
    tols = only + [float(t) for t in args.tols.split(",")]
    warnings.simplefilter("ignore")
    rows = []
    for name in args.models.split(","):
        model, x0, fb = solo12(args.cache_dir) if name == "solo12" else gym(name, args.cache_dir)
        nq = model.nq
        ref = model.simulate(x0, (0, 1.0), method="radau", rtol=1e-11, atol=1e-11, t_eval=[1.0],
                             max_steps=10 ** 7, **fb)
        q_ref = ref.x[-1][:nq]
        fun, jac = scipy_problem(model, fb)
        print(f"{name}: nx={model.nx}, reference status {ref.status}, nfev {ref.stats['nfev']}", flush=True)
        for tol in tols:
            def eomc_run(method, tol=tol):
                res = model.simulate(x0, (0, 1.0), method=method, rtol=tol, atol=tol, t_eval=[1.0],
                                     max_steps=10 ** 6, raise_on_failure=False, **fb)
                err = np.abs(res.x[-1][:nq] - q_ref).max() if res.status == 0 else np.nan
                return err, res.stats["nfev"], res.status, getattr(res, "method", method)

            def scipy_run(method, tol=tol):
                sol = solve_ivp(fun, (0, 1.0), x0, method=method, rtol=tol, atol=tol, jac=jac,
                                t_eval=[1.0])
                err = np.abs(sol.y[:nq, -1] - q_ref).max() if sol.status == 0 else np.nan
                return err, sol.nfev, sol.status, method

            contestants = {"eomc auto (default)": lambda: eomc_run("auto"),
                           "eomc radau": lambda: eomc_run("radau"),
                           "scipy LSODA": lambda: scipy_run("LSODA"),
                           "scipy BDF": lambda: scipy_run("BDF")}
            if tol in only:
                contestants = {"eomc auto (default)": contestants["eomc auto (default)"]}
            times = {k: [] for k in contestants}
            out = {}
            order = list(contestants)
            for rep in range(args.repeat):
                k = rep % len(order)
                for label in order[k:] + order[:k]:
                    t0 = time.thread_time()
                    out[label] = contestants[label]()
                    times[label].append(time.thread_time() - t0)
            base_t = float(np.median(times["eomc auto (default)"]))
            for label in order:
                err, nfev, status, used = out[label]
                t = float(np.median(times[label]))
                rows.append((name, tol, label, err, t * 1e3, t / base_t, nfev, status, used))
                print(f"  {tol:7.0e} {label:22s} err {err:9.2e}  {t * 1e3:9.2f} ms  x{t / base_t:5.2f}"
                      f"  nfev {nfev} status {status} ({used})", flush=True)
    head = environment_header("Work-precision through contact, 1 s: eomc vs scipy LSODA / BDF", args,
                              notes=[f"pinned to core {core}; scipy {scipy.__version__}; "
                                     f"{args.repeat} interleaved repeats, median thread CPU"])
    rows_only = [r for r in rows if r[1] not in only]
    table = ["| model | rtol = atol | contestant | method | error (max abs q, t = 1) | CPU ms | time / eomc default | rhs calls | status |",
             "|---|--:|---|---|--:|--:|--:|--:|--:|"]
    for name, tol, label, err, ms, ratio, nfev, status, used in rows:
        if tol in only:
            label += " (curve only)"
        table.append(f"| {name} | {tol:.0e} | {label} | {used} | {err:.2e} | {ms:.2f} | {ratio:.2f} | {nfev} | {status} |")
    same = same_rtol_table(rows_only)
    equal = equal_error_table(rows)
    text = (head + "\n" + __doc__.split("\n\n", 2)[2] + "\n\n" + "\n".join(table) + "\n\n"
            "### At the same rtol: the peer's time / eomc default's time (this run)\n\n"
            + "\n".join(same) + "\n\n"
            "### At equal error: the peer's time / eomc default's time at the peer's error (this run)\n\n"
            + "\n".join(equal) + "\n\n" + NOTES_MARK + "\n\n" + kept_notes())
    print("\n".join(table + [""] + same + [""] + equal))
    if not args.no_write:
        write_results("contact_wp", text)


if __name__ == "__main__":
    main()
