"""The bouncing-sphere property grid (issue 29), all of it: right or loud, never silently wrong.

    python benchmarks/bench_bounce_grid.py [--bare]

A 1 kg sphere (tests/compiler/contact/sphere_model.py) dropped from 0.5 m with 1 m/s sideways,
1.2 s, for k = 1e3 ... 1e12, c = 0 / 0.05 / 2, mu = 0 / 0.5, DOPRI5 / DOP853 / Radau / BDF / auto
at rtol 1e-3, 1e-4, 1e-6, 1e-8 (atol = rtol/1000).  Each case is judged by
tests/compiler/contact/bounce_grid.py: "right" (energy never above its start by more than
the stated tolerance; first bounce height equal to a 1-D reference of the same normal law,
scipy DOP853 at 1e-12), "loud" (non-zero status or a PhysicsWarning) or "SILENT" (status 0 and
wrong).  --bare also runs every case with switching=False (the methods as they were before the
switching points, with the verdicts still on) to show what the switching points fix.
Writes benchmarks/results/bounce_grid.md (+ .csv).  CPU time is not the point here.
"""
import argparse
import itertools
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "compiler" / "contact"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bounce_grid as bg  # noqa: E402
from common import environment_header, format_table, write_results  # noqa: E402

METHODS = ("dopri5", "dop853", "radau", "bdf", "auto")   # every adaptive method simulate has
RTOLS = (1e-3, 1e-4, 1e-6, 1e-8)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bare", action="store_true", help="also run without the switching points")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        model = bg.build(cache)
        rows, silent = [], []
        switching = (True, False) if args.bare else (True,)
        t0 = time.process_time()
        for sw, k, (cname, c), mu, method, rtol in itertools.product(
                switching, bg.STIFFNESS, bg.DAMPING.items(), bg.FRICTION, METHODS, RTOLS):
            verdict, detail = bg.run_case(model, k, c, mu, method, rtol, switching=sw)
            rows.append((sw, k, cname, mu, method, rtol, verdict, detail))
            if verdict == "SILENT":
                silent.append(rows[-1])
            print(f"{'switching' if sw else 'bare':9s} k={k:.0e} c={cname:5s} mu={mu} {method:6s} "
                  f"rtol={rtol:g}: {verdict} {detail}", flush=True)
        cpu = time.process_time() - t0
    out = [environment_header("Bouncing-sphere property grid (issue 29)", args,
                              notes=[f"{len(rows)} runs in {cpu:.0f} s CPU"]), ""]
    out.append("A 1 kg sphere of radius 0.1 m dropped from 0.5 m with 1 m/s sideways for 1.2 s. "
               "right: energy kept to the tolerance and the first bounce as the law predicts "
               "(1-D reference, scipy DOP853 at 1e-12); loud: a failed status or a PhysicsWarning "
               "(a contact penetrating more than half its radius, created energy); SILENT: status 0 "
               "and wrong physics.  Cases per verdict:\n")
    for sw in switching:
        head = ["method"] + [f"rtol {r:g}" for r in RTOLS]
        table = []
        for method in METHODS:
            cells = []
            for rtol in RTOLS:
                v = [r[6] for r in rows if r[0] == sw and r[4] == method and r[5] == rtol]
                cells.append(f"{v.count('right')} right / {v.count('loud')} loud / {v.count('SILENT')} SILENT")
            table.append([method] + cells)
        out.append(f"### {'with the switching points (the default)' if sw else 'bare (switching=False)'}\n")
        out.append(format_table(head, table))
        out.append("")
        bad = [r for r in silent if r[0] == sw]
        out.append(f"Silent: {len(bad)} of {sum(r[0] == sw for r in rows)}.\n")
        for r in bad:
            out.append(f"- k={r[1]:g} c={r[2]} mu={r[3]} {r[4]} rtol={r[5]:g}: {r[7]}")
        out.append("")
    loud_why = {}
    for r in rows:
        if r[0] and r[6] == "loud":
            key = ("status 7 (stiff, explicit method)" if r[7].startswith("status 7")
                   else "status 20 (created energy)" if r[7].startswith("status 20")
                   else "penetration warning" if "penetrated" in r[7] else r[7][:60])
            loud_why[key] = loud_why.get(key, 0) + 1
    out.append("Why the loud runs (with switching): " + "; ".join(f"{k}: {v}" for k, v in sorted(loud_why.items())))
    paths = write_results("bounce_grid", "\n".join(out), keep_notes=True,
                          csv_rows=[(int(r[0]), r[1], r[2], r[3], r[4], r[5], r[6], r[7]) for r in rows],
                          csv_headers=["switching", "k", "c", "mu", "method", "rtol", "verdict", "detail"])
    print("\n".join(str(p) for p in paths))
    return 1 if any(r[0] for r in silent) else 0


if __name__ == "__main__":
    sys.exit(main())
