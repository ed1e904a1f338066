"""Two builds of the same model (two library directories) in one process: their rhs and jac_x
agreement at 20 perturbed states, then rhs and jac_x time (thread CPU, Python call included,
medians of interleaved rounds).  benchmarks/results/spin_table.md.

Usage: python benchmarks/spin_table_ab.py NEW_DIR OLD_DIR
"""
import sys, time, numpy as np, eomc
a = eomc.load(sys.argv[1]); b = eomc.load(sys.argv[2])
rng = np.random.default_rng(0)
p = np.array(a.param_defaults, float)
assert list(a.param_names) == list(b.param_names) and list(a.state_names) == list(b.state_names)
x0 = a.initial_state.copy()
S = list(a.state_names)
# the ball's q_ball_root_x/y/z onto the quadruped's q_root_x/y/z where the file has both (its pairs near)
ball = [(k, S.index(n.replace("ball_root", "root"))) for k, n in enumerate(S)
        if n in ("q_ball_root_x", "q_ball_root_y", "q_ball_root_z") and n.replace("ball_root", "root") in S]
err_f = err_j = 0
for i in range(20):
    x = x0 + 0.05 * rng.standard_normal(a.nx)     # the file's initial state, perturbed
    for k, j in ball:
        x[k] = x0[j]
    x[list(a.quaternions)] = 1.0
    fa, fb = a.rhs(0, x, p), b.rhs(0, x, p)
    err_f = max(err_f, np.abs(fa - fb).max() / max(1, np.abs(fb).max()))
    Ja, Jb = a.jacobian(0, x, p), b.jacobian(0, x, p)
    err_j = max(err_j, np.abs(Ja - Jb).max() / max(1, np.abs(Jb).max()))
print("rel diff rhs %.1e jac_x %.1e" % (err_f, err_j))
x = x0.copy()
def med(f, n=2000):
    ts = []
    for r in range(7):
        t0 = time.thread_time()
        for _ in range(n): f()
        ts.append((time.thread_time() - t0) / n)
    return np.median(ts) * 1e9
for name, fa, fb in (("rhs", lambda: a.rhs(0, x, p), lambda: b.rhs(0, x, p)),
                     ("jac_x", lambda: a.jacobian(0, x, p), lambda: b.jacobian(0, x, p))):
    ra, rb = [], []
    for r in range(5):
        ra.append(med(fa, 300)); rb.append(med(fb, 300))
    print(f"{name}: after {np.median(ra):.0f} ns, before {np.median(rb):.0f} ns (Python call included)")
