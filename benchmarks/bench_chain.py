"""Chained frames vs summed angles: what writing a chain the SymPy way costs (issue 8, item 6).

The same n-link pendulum on a cart (tests/helpers/chained_frames.py; the system of
`../shared/reports/performance-2026-11/n_link_cart_rel*.py`) written two ways:

* summed: link k's frame oriented from N by q1 + ... + qk;
* chained: link k's frame oriented from link k-1's by qk (each frame's angular
  velocity given in N, as the report's chained file does).

A second system, "spatial": rigid links turning about z, z, x, x, z, z, x, x, ...,
exercises what a planar chain does not (SymPy's v2pt_theory expands cos(q3 + q4) there).

Per contestant and round, one fresh Python process pinned to one core measures, in
thread CPU time:

* kinematics: frames, points, v2pt_theory (SymPy's own code, called by the model script);
* kanes_equations: eomc's (or SymPy 1.14's) KanesMethod + kanes_equations;
* generate: eomc's pipeline from the formed equations to C for rhs, Kane formulation,
  generation cache off (eomc only);
* and the generated rhs's operation count (adds + muls + divs + calls).

Contestants are interleaved (order rotated every round); a ratio is the median of the
per-round ratios chained / summed.  SymPy runs only up to --sympy-max links.

    python3 benchmarks/bench_chain.py                   # n = 4, 8, 12, 20; 3 rounds
    python3 benchmarks/bench_chain.py --quick
"""
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

_HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE), str(_HERE.parent / "tests")]

from common import environment_header, fmt, format_table, parse_args, write_results  # noqa: E402

DEFAULT_N = [4, 8, 12, 20]
SPATIAL_N = [5, 10]
STYLES = {"summed": "sum", "chained": "chain"}


def _axes(system, n):
    return "z" * n if system == "planar" else ("zzxx" * n)[:n]


def worker(tool, system, style, n):
    """Measure one contestant in this process; print a JSON line."""
    try:
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    from helpers.chained_frames import chain_cart
    if tool == "eomc":
        import eomc.mechanics as mech
        from eomc.compiler.driver import generate
    else:
        import sympy.physics.mechanics as mech
    spent = {}
    original = mech.KanesMethod.kanes_equations

    def timed(self, *a, **k):
        t0 = time.thread_time()
        out = original(self, *a, **k)
        spent["kane"] = time.thread_time() - t0
        return out

    mech.KanesMethod.kanes_equations = timed
    t0 = time.thread_time()
    km = chain_cart(mech, _axes(system, n), STYLES[style], rigid=(system == "spatial"))
    total = time.thread_time() - t0
    out = {"kin": total - spent["kane"], "kane": spent["kane"]}
    if tool == "eomc":
        import warnings
        warnings.simplefilter("ignore")
        t0 = time.thread_time()
        _, gm = generate(km, "c", functions=["rhs"], formulation="kane", use_cache=False,
                         progress=False, inputs=[mech.dynamicsymbols("F")])
        out["gen"] = time.thread_time() - t0
        out["ops"] = sum(gm.metadata["op_counts"]["rhs"].values())
    print(json.dumps(out))


def _run(tool, system, style, n, timeout):
    env = {**os.environ, "EOMC_CACHE_DIR": os.environ.get("EOMC_CACHE_DIR", "/tmp/eomc-bench-chain")}
    cmd = [sys.executable, __file__, "--worker", tool, system, style, str(n)]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return None
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _median(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def measure(system, n, rounds, tools, timeout):
    """{(tool, style): [sample dicts]} and per-round ratios, contestants interleaved."""
    contestants = [(t, s) for t in tools for s in STYLES]
    samples = {c: [] for c in contestants}
    for r in range(rounds):
        k = r % len(contestants)
        for c in contestants[k:] + contestants[:k]:
            samples[c].append(_run(c[0], system, c[1], n, timeout))
    return samples


def _derive(s, tool):
    """The formulation's share: kanes_equations (+ eomc's generation to C)."""
    return s["kane"] + s.get("gen", 0.0) if s else None


def _total(s, tool):
    return s["kin"] + _derive(s, tool) if s else None


def rows_for(system, n, samples):
    rows = []
    for tool in ("eomc", "sympy"):
        if (tool, "summed") not in samples:
            continue
        a, b = samples[tool, "summed"], samples[tool, "chained"]
        pairs = [(x, y) for x, y in zip(a, b) if x and y]
        if not pairs:
            rows.append([system, n, tool] + ["timeout"] * 11)
            continue
        med = lambda key, xs: _median([key(s, tool) for s in xs])  # noqa: E731
        r_tot = _median([_total(y, tool) / _total(x, tool) for x, y in pairs])
        r_der = _median([_derive(y, tool) / _derive(x, tool) for x, y in pairs])
        ops_a, ops_b = (_median([s.get("ops") for s in xs if s]) for xs in (a, b))
        rows.append([system, n, "eomc" if tool == "eomc" else "SymPy 1.14",
                     med(lambda s, t: s["kin"], a), med(_derive, a), med(_total, a),
                     med(lambda s, t: s["kin"], b), med(_derive, b), med(_total, b),
                     r_der, r_tot,
                     None if ops_a is None else int(ops_a), None if ops_b is None else int(ops_b),
                     None if not ops_a else ops_b / ops_a])
    return rows


HEADERS = ["system", "n", "tool",
           "summed: kinematics s", "summed: derivation s", "summed: total s",
           "chained: kinematics s", "chained: derivation s", "chained: total s",
           "derivation chained/summed", "total chained/summed",
           "rhs ops summed", "rhs ops chained", "ops chained/summed"]


def main(argv=None):
    if argv is None and len(sys.argv) > 1 and sys.argv[1] == "--worker":
        tool, system, style, n = sys.argv[2:6]
        worker(tool, system, style, int(n))
        return 0

    def extra(p):
        p.add_argument("--sympy-max", type=int, default=12,
                       help="largest n run with SymPy 1.14 (default 12)")
        p.add_argument("--timeout", type=float, default=900,
                       help="seconds one contestant may take before it is recorded as a timeout")
        p.add_argument("--spatial-n", type=lambda s: [int(v) for v in s.split(",") if v],
                       default=None, help="link counts of the spatial rigid chain (default 5,10)")
    args = parse_args("Chained frames vs summed angles", DEFAULT_N, default_repeat=3,
                      argv=argv, extra=extra)
    spatial = args.spatial_n if args.spatial_n is not None else (SPATIAL_N[:1] if args.quick
                                                                 else SPATIAL_N)
    rows = []
    for system, ns in (("planar", args.n), ("spatial", spatial)):
        for n in ns:
            tools = ["eomc"] + (["sympy"] if n <= args.sympy_max else [])
            rounds = args.repeat if n <= 12 else max(1, min(args.repeat, 2))
            samples = measure(system, n, rounds, tools, args.timeout)
            for row in rows_for(system, n, samples):
                rows.append(row)
                print(" | ".join(fmt(c) for c in row), flush=True)
    table = format_table(HEADERS, rows)
    print(table)
    if not args.no_write:
        notes = [
            "system 'planar': the report's n-link cart (point masses, pins about z); 'spatial': "
            "rigid links about z, z, x, x, z, z, x, x, ... (tests/helpers/chained_frames.py)",
            "times are thread CPU seconds of one fresh process per contestant and round, pinned "
            "to one core; medians over rounds (n = 20: at most 2 rounds); ratios are medians of "
            "per-round ratios",
            "kinematics = frames, points and v2pt_theory: SymPy's own code, run by the model "
            "script for both tools; derivation = kanes_equations, plus for eomc the generation "
            "of C for rhs (Kane formulation, generation cache off); total = both",
            "rhs ops = adds + muls + divs + calls of the generated rhs (eomc only)",
            f"SymPy 1.14 runs up to n = {args.sympy_max}",
        ]
        text = environment_header("Chained frames vs summed angles (issue 8, item 6)", args, notes)
        write_results("chain", text + "\n" + table + "\n", csv_rows=rows, csv_headers=HEADERS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
