"""Body–body pairs of random, long and flat shapes near contact against MuJoCo's ``mj_geomDistance``.

Why: the pair tests (tests/compiler/contact/test_solid_pairs.py) place fixed shapes of moderate
proportions; session 40 found that long or flat shapes broke three routines that passed them
(ellipsoid–ellipsoid, capsule–ellipsoid, box–ellipsoid: forces while 19 cm apart, bodies passing
through each other).  This is the audit that found them, kept as a table so that each routine's
accuracy on shapes nobody tuned it for is on record.

For every pair of kinds (sphere, capsule, ellipsoid, cylinder, box; cylinder–ellipsoid is not
modelled) and CASES random cases: each shape's sizes 1-8 cm, one of them stretched 2-8x in half
the cases; random orientations and direction; the offset set by bisection on mj_geomDistance so
that MuJoCo's distance is a random target in [-2 mm, 2 cm].  eomc's distance is the deepest of the
pair's contact points (pairs.scheme, evaluated in SymPy with numbers).  Early: eomc's distance
below MuJoCo's by more than 1e-6 m (a force before touching, or deeper than MuJoCo's penetration);
late: above by more than 1e-6 m (some pairs are late by design: rim and sample points, see
docs/contact.md's table).

    python benchmarks/bench_pair_shapes.py [--cases 60] [--seed 0]   # writes results/pair_shapes.md
"""
import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

KINDS = ["sphere", "capsule", "ellipsoid", "cylinder", "box"]
NAMED = {2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box"}


def placed(m, d, g):
    R = np.array(d.geom_xmat[g]).reshape(3, 3)
    return {"kind": NAMED[int(m.geom_type[g])], "centre": [float(x) for x in d.geom_xpos[g]],
            "axes": [[float(x) for x in R[:, k]] for k in range(3)], "size": [float(x) for x in m.geom_size[g]]}


def eomc_distance(a, b):
    from eomc.compiler.contact.pairs import pair_parts, scheme
    return -max(float(scheme(a, b, part, 0.0, lambda e: e)[2]) for part in pair_parts(a["kind"], b["kind"]))


def sizes(kind, rng):
    s = rng.uniform(0.01, 0.08, 3)
    if rng.uniform() < 0.5:
        s[rng.integers(3)] *= rng.uniform(2, 8)
    return {"sphere": s[:1], "capsule": s[:2], "cylinder": s[:2], "ellipsoid": s, "box": s}[kind]


def audit(ka, kb, cases, rng):
    import mujoco
    compared, early, late, worst_early, worst_late = 0, 0, 0, 0.0, 0.0
    for _ in range(cases):
        sa, sb = sizes(ka, rng), sizes(kb, rng)
        xml = ('<mujoco><option gravity="0 0 0"/><worldbody>'
               f'<body><freejoint/><geom type="{ka}" size="{" ".join(map(str, sa))}"/></body>'
               f'<body><freejoint/><geom type="{kb}" size="{" ".join(map(str, sb))}"/></body>'
               '</worldbody></mujoco>')
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        fromto = np.zeros(6)
        for j in range(2):
            q = rng.normal(size=4)
            d.qpos[7 * j + 3:7 * j + 7] = q / np.linalg.norm(q)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        target, lo, hi = rng.uniform(-0.002, 0.02), 0.0, float(m.geom_rbound[0] + m.geom_rbound[1]) + 0.05
        for _ in range(40):
            d.qpos[7:10] = (lo + hi) / 2 * u
            mujoco.mj_kinematics(m, d)
            above = mujoco.mj_geomDistance(m, d, 0, 1, 10.0, fromto) > target
            lo, hi = (lo, (lo + hi) / 2) if above else ((lo + hi) / 2, hi)
        d.qpos[7:10] = hi * u
        mujoco.mj_kinematics(m, d)
        dist = mujoco.mj_geomDistance(m, d, 0, 1, 10.0, fromto)
        if abs(dist - target) > 1e-3:        # bisection left the window (MuJoCo's solver at a kink)
            continue
        mine = eomc_distance(placed(m, d, 0), placed(m, d, 1))
        compared += 1
        if mine < dist - 1e-6:
            early, worst_early = early + 1, max(worst_early, dist - mine)
        if mine > dist + 1e-6:
            late, worst_late = late + 1, max(worst_late, mine - dist)
    return compared, early, worst_early, late, worst_late


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    rows = []
    for ka, kb in itertools.combinations_with_replacement(KINDS, 2):
        if {ka, kb} == {"cylinder", "ellipsoid"}:
            continue
        t0 = time.process_time()
        n, early, we, late, wl = audit(ka, kb, args.cases, rng)
        rows.append([f"{ka}–{kb}", n, early, f"{we:.2g}" if early else "-", late, f"{wl:.2g}" if late else "-",
                     f"{time.process_time() - t0:.0f}"])
        print(rows[-1], flush=True)
    import mujoco
    text = "\n".join([
        environment_header("Pairs of random long and flat shapes near contact vs mj_geomDistance", args,
                           notes=[f"MuJoCo {mujoco.__version__}; {args.cases} cases a pair of kinds, seed {args.seed}; "
                                  "sizes 1-8 cm, one stretched 2-8x in half the cases; MuJoCo's distance -2 mm to 2 cm"]),
        format_table(["pair", "compared", "early", "worst early (m)", "late", "worst late (m)", "CPU s"], rows), ""])
    print(text)
    if not args.no_write:
        write_results("pair_shapes", text, keep_notes=True)


if __name__ == "__main__":
    main()
