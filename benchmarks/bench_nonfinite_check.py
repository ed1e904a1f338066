"""A/B of formulations.select.nonfinite (the nan/inf check of every formed row before C is
printed): the old four ``expr.has(bad)`` walks vs the one deduplicated walk, on the Kane rows
(kinematics, mass matrix, forcing) of a URDF robot, in one process, SymPy's cache cleared before
every timed call (has() is cached: only a first call costs), thread CPU time, median of 3.

    cd /tmp && taskset -c 1 python /path/to/benchmarks/bench_nonfinite_check.py [robot.urdf]

Session 24, so101 (example-robot-data, 48 rows), core 1, load ~10 on 2 cores:
old 3.195 s CPU (3.211 3.172 3.195), new 0.017 s (0.017 0.016 0.017): 189x.
"""
import statistics, sys, time
import sympy as sm
from eomc.compiler.model.spec import read_model, spec_of
from eomc.compiler.formulations import select
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import robots_dir  # noqa: E402
URDF = str(robots_dir() / "so_arm_description/urdf/so101.urdf")
path = sys.argv[1] if len(sys.argv) > 1 else URDF
read = read_model(path, None, poses=True)
spec = spec_of(read, formulation="kane")
f = spec.formed
rows = list(f.kinematics) + [e for i in range(f.dynamics_matrix.rows) for e in f.dynamics_matrix.row(i)] + list(f.dynamics_rhs)
rows += list((spec.outputs or {}).values()) + list((spec.events or {}).values())
print("rows", len(rows), "outputs", list(spec.outputs or {}), "events", list(spec.events or {}))
def old(expr):
    expr = sm.sympify(expr)
    for bad in select._NONFINITE:
        if expr.has(bad):
            return bad
    return None
new = select.nonfinite
from sympy.core.cache import clear_cache
assert [old(e) for e in rows] == [new(e) for e in rows]
ta, tb = [], []
for r in range(3):
    for fn, acc in ((old, ta), (new, tb)) if r % 2 == 0 else ((new, tb), (old, ta)):
        clear_cache(); t = time.thread_time(); [fn(e) for e in rows]; acc.append(time.thread_time() - t)
print("old has x4  : median %.3f s CPU  (%s)" % (statistics.median(ta), " ".join("%.3f" % x for x in ta)))
print("new one walk: median %.3f s CPU  (%s)" % (statistics.median(tb), " ".join("%.3f" % x for x in tb)))
print("ratio %.1fx" % (statistics.median(ta) / statistics.median(tb)))
