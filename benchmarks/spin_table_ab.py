"""Two builds of the same model (two library directories) in one process: their rhs and jac_x
agreement at 20 perturbed states, then rhs and jac_x time (thread CPU, Python call included,
medians of interleaved rounds).  benchmarks/results/spin_table.md.

Usage: python benchmarks/spin_table_ab.py NEW_DIR OLD_DIR
"""
import sys, time, numpy as np, eomc
a = eomc.load(sys.argv[1]); b = eomc.load(sys.argv[2])
rng = np.random.default_rng(0)
p = np.array(a.param_defaults, float); pb = np.array(b.param_defaults, float)
assert list(a.param_names) == list(b.param_names) and list(a.state_names) == list(b.state_names)
x0 = a.initial_state.copy()
# states near the ball: put the ball at the quadruped's body, random speeds
S = list(a.state_names)
err_f = err_j = 0
for i in range(20):
    x = x0 + 0.05 * rng.standard_normal(a.nx)
    for k, n in enumerate(S):
        if n.startswith("q_ball_root") and n[-1] in "xyz" and "q" not in n[-2:]:
            x[k] = x0[S.index(n.replace("ball_root", "root"))] if n.replace("ball_root","root") in S else x[k]
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
