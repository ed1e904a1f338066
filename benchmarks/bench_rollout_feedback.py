"""Issue 31 item 2: eomc.rollout with feedback, and with contacts under adaptive methods, beside
the scalar paths that did the same before (a Python loop over simulate).

Feedback: examples/cartpole_lqr.py (1 input), NROLL rows from 0.1-0.3 rad off upright, RK4 at
dt = 0.01 over 2 s.  Each row gets a gain schedule on a 21-point grid (the LQR gain scaled by a
row-dependent smooth factor: what an iLQR or MPPI solver hands over, K_k along x_k) and a
feed-forward sequence on the same grid.  Contestants, one C thread each:
  open loop   rollout(r=(t_grid, u)) -- the same rows without feedback (what feedback costs)
  K schedule  rollout(r=..., K=(t_grid, Ks), x_ref=refs) -- the feedback in C, per row
  K constant  rollout(K=Ks[:, 0], x_ref=refs[:, 0])
  simulate K  a Python loop over simulate(K=(t_grid, Ks[i]), x_ref=refs[i]) (the scalar path)
  simulate r(t, x)  a Python loop over simulate(r=controller) -- the same law in Python, called
                    from C at every stage (the slow path; PY_ROWS rows, scaled to NROLL)
Contacts: the thrown ball of tests/runtime/test_rollout.py (MJCF sphere on a plane: lands,
bounces, slides, spins) 0.4 s, BALL_ROWS rows, bdf and radau at rtol 1e-6 (rollout now ends
their steps at touch-down and lift-off per row, as simulate): rollout(threads=1) vs a loop over
simulate.  Rows agree bit for bit (checked here on every row, and in tests/).

Times: thread CPU time of the calling thread (rollout with threads=1 runs there), contestants
interleaved repeat by repeat, medians of REPEAT, pinned to one core (taskset -c 0).

    taskset -c 0 python benchmarks/bench_rollout_feedback.py
"""
import os
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
NROLL, PY_ROWS, BALL_ROWS, REPEAT = 256, 16, 16, 5


def _cart():
    import eomc
    from scipy.linalg import solve_continuous_are
    m = eomc.compile(str(ROOT / "examples" / "cartpole_lqr.py"), progress=False)
    up = np.array([0.0, np.pi, 0.0, 0.0])
    A, B = m.linearize(0.0, up)
    K = B.T @ solve_continuous_are(A, B, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    rng = np.random.default_rng(0)
    X0 = up + np.column_stack([rng.uniform(-0.2, 0.2, NROLL), rng.uniform(-0.3, 0.3, NROLL) * 0.5 + 0.05,
                               np.zeros(NROLL), np.zeros(NROLL)])
    t_grid = np.linspace(0.0, 2.0, 21)
    scale = 1.0 + 0.3 * np.sin(np.arange(NROLL)[:, None] + 2.0 * t_grid[None, :])
    Ks = np.ascontiguousarray(K[None, None] * scale[:, :, None, None])
    refs = np.ascontiguousarray(np.broadcast_to(up, (NROLL, t_grid.size, 4)))
    u = np.ascontiguousarray(0.2 * np.cos(t_grid)[None, :, None] * rng.uniform(-1, 1, (NROLL, 1, 1)))
    return m, X0, t_grid, Ks, refs, u


def _controller(t_grid, Ks, refs, u):
    def r(t, x):
        if t <= t_grid[0] or t >= t_grid[-1]:
            j = 0 if t <= t_grid[0] else -1
            return u[j] + Ks[j] @ (refs[j] - x)
        lo = int(np.searchsorted(t_grid, t, side="right")) - 1
        w = (t - t_grid[lo]) / (t_grid[lo + 1] - t_grid[lo])
        return ((1 - w) * u[lo] + w * u[lo + 1]
                + ((1 - w) * Ks[lo] + w * Ks[lo + 1]) @ ((1 - w) * refs[lo] + w * refs[lo + 1] - x))
    return r


def _cpu(f):
    t0 = time.thread_time()
    out = f()
    return time.thread_time() - t0, out


def feedback_table():
    from eomc.runtime.rollout import rollout
    from eomc.runtime.simulate import simulate
    m, X0, t_grid, Ks, refs, u = _cart()
    kw = dict(method="rk4", dt=0.01, steps=200, threads=1, events=False)
    sim = dict(method="rk4", dt=0.01, events=False, t_eval=[2.0])
    contestants = {
        "open loop (no feedback)": (NROLL, lambda: rollout(m, X0, r=(t_grid, u), **kw)),
        "K schedule per row (C)": (NROLL, lambda: rollout(m, X0, r=(t_grid, u), K=(t_grid, Ks), x_ref=refs, **kw)),
        "K constant per row (C)": (NROLL, lambda: rollout(m, X0, r=(t_grid, u), K=Ks[:, 0], x_ref=refs[:, 0], **kw)),
        "loop of simulate(K schedule)": (NROLL, lambda: [simulate(m, X0[i], (0, 2.0), r=(t_grid, u[i]),
                                                                  K=(t_grid, Ks[i]), x_ref=refs[i], **sim)
                                                         for i in range(NROLL)]),
        "loop of simulate(r=Python controller)": (PY_ROWS, lambda: [
            simulate(m, X0[i], (0, 2.0), r=_controller(t_grid, Ks[i], refs[i], u[i]), **sim) for i in range(PY_ROWS)]),
    }
    times = {k: [] for k in contestants}
    outs = {}
    for _ in range(REPEAT):
        for name, (rows, f) in contestants.items():
            dt, outs[name] = _cpu(f)
            times[name].append(dt / rows)
    fb = outs["K schedule per row (C)"]
    for i, one in enumerate(outs["loop of simulate(K schedule)"]):
        assert np.array_equal(one.x_final, fb.x[i]), i
    py_dev = max(np.abs(one.x_final - fb.x[i]).max() for i, one in enumerate(outs["loop of simulate(r=Python controller)"]))
    base = statistics.median(times["K schedule per row (C)"])
    rows = []
    for name, ts in times.items():
        med = statistics.median(ts)
        rows.append([name, contestants[name][0], med * 1e6, 1.0 / med, med / base])
    return rows, py_dev


def ball_table():
    from eomc.runtime.rollout import rollout
    from eomc.runtime.simulate import simulate
    from eomc.runtime.switching import PhysicsWarning
    from runtime.test_rollout import thrown_ball
    m, x0 = thrown_ball(Path(tempfile.mkdtemp(prefix="bench_rollout_feedback_")), "ball_bench")
    x0 = x0[:BALL_ROWS]
    rows = []
    for method in ("bdf", "radau"):
        kw = dict(method=method, rtol=1e-6, atol=1e-8, raise_on_failure=False)
        ts = {"rollout": [], "simulate loop": []}
        for _ in range(REPEAT):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", PhysicsWarning)
                a, res = _cpu(lambda: rollout(m, x0, t_final=0.4, threads=1, **kw))
                b, ones = _cpu(lambda: [simulate(m, x0[i], (0, 0.4), t_eval=[0.4], **kw) for i in range(BALL_ROWS)])
            ts["rollout"].append(a / BALL_ROWS)
            ts["simulate loop"].append(b / BALL_ROWS)
        assert all(np.array_equal(res.x[i], ones[i].x_final) for i in range(BALL_ROWS))
        r, s = statistics.median(ts["rollout"]), statistics.median(ts["simulate loop"])
        rows.append([method, BALL_ROWS, r * 1e6, s * 1e6, s / r, int(res.ok.sum())])
    return rows


def main():
    os.environ.setdefault("EOMC_CACHE_DIR", tempfile.mkdtemp(prefix="bench_rollout_feedback_cache_"))
    core = sorted(os.sched_getaffinity(0))
    fb_rows, py_dev = feedback_table()
    ball_rows = ball_table()
    text = environment_header("eomc.rollout with feedback and with contacts under adaptive methods (issue 31 item 2)",
                              args=True, notes=[f"cores: {core} (taskset), rollout threads=1, thread CPU time",
                                                f"REPEAT={REPEAT}, medians; contestants interleaved"])
    text += ("\n## Feedback: cart-pole, RK4 dt = 0.01 over 2 s, per row\n\n"
             + format_table(["contestant", "rows", "us per row", "rows/s", "vs K schedule in C"], fb_rows)
             + f"\n\nThe loop of simulate(K schedule) equals the rollout bit for bit on all {NROLL} rows; the "
               f"Python controller (same law, numpy arithmetic) is within {py_dev:.2g} of it.\n")
    text += ("\n## Contacts with adaptive methods: thrown ball, 0.4 s, rtol 1e-6, per row\n\n"
             + format_table(["method", "rows", "rollout us/row", "simulate loop us/row", "loop / rollout",
                             "rows ok"], ball_rows)
             + "\n\nEvery row equals simulate's final state bit for bit (same steps, same switching).\n")
    print(text)
    write_results("rollout_feedback", text, keep_notes=True)


if __name__ == "__main__":
    main()
