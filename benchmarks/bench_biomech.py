"""SymPy's Biomechanical Model Example (examples/biomechanical_arm.py): eomc against the
tutorial's own route, SymPy KanesMethod + lambdify + scipy's solve_ivp.

Measured, contestants interleaved round by round:

1. model -> something that simulates, cold: `eomc build` in a fresh process with a fresh
   cache (derivation, C generation, gcc), against a fresh process that runs the same file
   with sympy.physics.mechanics and lambdifies (mass_matrix, forcing, dadt) as the
   tutorial does.  CPU time of the child (python start and imports included on both sides).
2. 3 s of the tutorial's second run (biceps excited at 80 % from 0.5 s to 1.5 s):
   - the tutorial's call: solve_ivp(RK45, its default rtol=1e-3, atol=1e-6) with eval_rhs
     (lambdified M, f, dadt; numpy.linalg.solve) and eval_r;
   - eomc simulate, DOPRI5 at the same tolerances, the same eval_r called per stage;
   - both again at DOP853 rtol=atol=1e-8, run in three segments of constant excitation
     (no integrator steps across the switches; eomc then never calls Python).
   Thread CPU time, median of --repeat runs.  The final-state difference between the two
   1e-8 runs, and of each against a 1e-12 segmented eomc reference, says both compute the
   same motion.

    python3 benchmarks/bench_biomech.py [--repeat 5] [--no-write]
"""
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import (environment_header, fmt, format_table, median_iqr, parse_args,  # noqa: E402
                    peer_versions, pin_to_one_core, write_results)

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "biomechanical_arm.py"
SEGMENTS = [((0.0, 0.5), [0.0, 0.0]), ((0.5, 1.5), [0.8, 0.0]), ((1.5, 3.0), [0.0, 0.0])]

SYMPY_CHILD = r'''
import sys, time
t0 = time.process_time()
import numpy as np, sympy as sm
src = open(sys.argv[1]).read().replace("import eomc.mechanics as me", "import sympy.physics.mechanics as me")
ns = {"__name__": "arm"}
exec(compile(src, sys.argv[1], "exec"), ns)
kane = ns["kane"]
f = sm.lambdify((kane.q, kane.u, ns["a"], ns["e"], list(ns["parameters"])),
                (kane.mass_matrix, kane.forcing, ns["dadt"]), cse=True)
x = np.zeros(10)
f(x[:4], x[4:8], x[8:], [0.0, 0.0], np.ones(19))     # one call, as the tutorial does
'''


def eval_r(t):
    return np.array([0.0, 0.0]) if t < 0.5 or t > 1.5 else np.array([0.8, 0.0])


def child_cpu(cmd, env=None):
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode:
        raise RuntimeError(proc.stderr[-3000:])
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cold_eomc(outdir):
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_bm_"))
    return child_cpu([sys.executable, "-m", "eomc", "build", str(EXAMPLE), "-o", str(outdir), "-q"], env)


def cold_sympy(script):
    return child_cpu([sys.executable, str(script), str(EXAMPLE)])


def sympy_rhs():
    import sympy as sm
    src = EXAMPLE.read_text().replace("import eomc.mechanics as me", "import sympy.physics.mechanics as me")
    ns = {"__name__": "arm"}
    exec(compile(src, str(EXAMPLE), "exec"), ns)
    kane, p = ns["kane"], ns["parameters"]
    eval_diffeq = sm.lambdify((kane.q, kane.u, ns["a"], ns["e"], list(p)),
                              (kane.mass_matrix, kane.forcing, ns["dadt"]), cse=True)
    p_vals = np.array(list(p.values()))

    def eval_rhs(t, x, r, p):          # the tutorial's function
        q, u, a = x[0:4], x[4:8], x[8:10]
        e = r(t)
        m, f, ad = eval_diffeq(q, u, a, e, p)
        ud = np.linalg.solve(m, f).squeeze()
        return np.hstack((u, ud, ad.squeeze()))
    return eval_rhs, p_vals


def run_scipy(eval_rhs, p_vals, x0, method, tol, segmented):
    from scipy.integrate import solve_ivp
    rtol, atol = tol
    calls = [0]
    if not segmented:
        def fun(t, x):
            calls[0] += 1
            return eval_rhs(t, x, eval_r, p_vals)
        t0 = time.thread_time()
        sol = solve_ivp(fun, (0.0, 3.0), x0, method=method, rtol=rtol, atol=atol)
        return time.thread_time() - t0, sol.y[:, -1], calls[0]
    x = np.array(x0)
    t0 = time.thread_time()
    for span, e in SEGMENTS:
        e = np.array(e)

        def fun(t, xx, e=e):
            calls[0] += 1
            return eval_rhs(t, xx, lambda _t: e, p_vals)
        sol = solve_ivp(fun, span, x, method=method, rtol=rtol, atol=atol)
        x = sol.y[:, -1]
    return time.thread_time() - t0, x, calls[0]


def run_eomc(model, x0, method, tol, segmented):
    rtol, atol = tol
    if not segmented:
        t0 = time.thread_time()
        res = model.simulate(x0, (0.0, 3.0), r=eval_r, method=method, rtol=rtol, atol=atol,
                             t_eval=[0.0, 3.0])
        return time.thread_time() - t0, res.x[-1], res.stats["nfev"]
    x, nfev = np.array(x0), 0
    t0 = time.thread_time()
    for span, e in SEGMENTS:
        res = model.simulate(x, span, r=e, method=method, rtol=rtol, atol=atol, t_eval=list(span))
        x, nfev = res.x[-1], nfev + res.stats["nfev"]
    return time.thread_time() - t0, x, nfev


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], default_n=[10], default_repeat=5, argv=argv)
    import eomc
    rounds = max(2, min(args.repeat, 3))
    tmp = Path(tempfile.mkdtemp(prefix="bench_biomech_"))
    script = tmp / "sympy_child.py"
    script.write_text(SYMPY_CHILD)
    cold = {"eomc build (derive, generate C, gcc)": [], "SymPy KanesMethod + lambdify": []}
    for k in range(rounds):
        order = list(cold) if k % 2 == 0 else list(reversed(list(cold)))
        for name in order:
            cold[name].append(cold_eomc(tmp / f"out{k}") if name.startswith("eomc") else cold_sympy(script))

    model = eomc.compile(EXAMPLE, cache_dir=tmp / "cache")
    eval_rhs, p_vals = sympy_rhs()
    x0 = model.initial_state.copy()
    pin_to_one_core()
    ref = run_eomc(model, x0, "dop853", (1e-12, 1e-12), True)[1]
    cases = [("tutorial: RK45 rtol=1e-3 atol=1e-6, eval_r per call", ("rk45", "dopri5"), (1e-3, 1e-6), False),
             ("DOP853 rtol=atol=1e-8, 3 constant-excitation segments", ("DOP853", "dop853"), (1e-8, 1e-8), True)]
    rows, csv_rows, finals = [], [], {}
    for label, (sm_method, eo_method), tol, seg in cases:
        samples = {"SymPy + solve_ivp": [], "eomc simulate": []}
        info = {}
        for k in range(args.repeat):
            order = list(samples) if k % 2 == 0 else list(reversed(list(samples)))
            for name in order:
                if name.startswith("SymPy"):
                    cpu, xf, calls = run_scipy(eval_rhs, p_vals, x0, sm_method.upper(), tol, seg)
                else:
                    cpu, xf, calls = run_eomc(model, x0, eo_method, tol, seg)
                samples[name].append(cpu)
                info[name] = (xf, calls)
        sym_med = median_iqr(samples["SymPy + solve_ivp"])[0]
        for name, s in samples.items():
            med, q1, q3 = median_iqr(s)
            xf, calls = info[name]
            err = float(np.max(np.abs(xf - ref)))
            finals[label, name] = xf
            rows.append([label, name, fmt(med * 1e3), fmt((q3 - q1) * 1e3), calls, fmt(err),
                         fmt(sym_med / med)])
            csv_rows.append([label, name, med, q3 - q1, calls, err])
    agree = {label: float(np.max(np.abs(finals[label, "SymPy + solve_ivp"] - finals[label, "eomc simulate"])))
             for label, *_ in cases}
    cold_rows = []
    sym_cold = median_iqr(cold["SymPy KanesMethod + lambdify"])[0]
    for name, s in cold.items():
        med, q1, q3 = median_iqr(s)
        cold_rows.append([name, fmt(med), fmt(q3 - q1), fmt(sym_cold / med)])

    text = environment_header(
        "SymPy's Biomechanical Model Example: eomc vs SymPy + lambdify + solve_ivp (issue 22)", args,
        notes=[f"peers: {', '.join(peer_versions(['scipy', 'sympy']))}",
               f"cold: CPU s of a fresh child process (python start and imports included on both sides), "
               f"median of {rounds}, interleaved",
               f"simulation: thread CPU time (time.thread_time), pinned to one core, median of "
               f"{args.repeat}, contestants interleaved; eomc's model loaded from the cache first",
               "final error: max |x(3 s) - reference|, the reference eomc DOP853 rtol=atol=1e-12 in the "
               "three constant-excitation segments",
               *[f"{label}: max |x_eomc(3 s) - x_SymPy(3 s)| = {v:.3g}" for label, v in agree.items()],
               "rhs calls: solve_ivp's calls of fun; eomc's nfev from the result's stats",
               "RK45 and DOPRI5 are the same Dormand-Prince 5(4) pair; step-size controllers differ in "
               "detail, so call counts and errors differ a little"])
    text += "\n## Model to simulator, cold\n\n"
    text += format_table(["route", "CPU [s]", "IQR [s]", "SymPy / this"], cold_rows)
    text += "\n\n## 3 s of the biceps run\n\n"
    text += format_table(["case", "tool", "CPU [ms]", "IQR [ms]", "rhs calls", "final error",
                          "SymPy / this"], rows)
    print(text)
    if not args.no_write:
        for p in write_results("biomech", text, csv_rows,
                               ["case", "tool", "cpu_s", "iqr_s", "rhs_calls", "final_error"]):
            print("wrote", p)


if __name__ == "__main__":
    main()
