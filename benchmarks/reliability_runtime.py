"""Rerun of the runtime findings N1, N4, N5, N6, N9 and N10 of the reliability report r3
(shared/reports/reliability-2026-11-r3.md, issue 24), one line per attempt:

    case | outcome | detail

outcome: "clear error" (an EomcError/ValueError or a one-line `eomc CMD: error:` that names
the problem), "correct" (checked against the expected answer), "silent wrong", "traceback"
(an unexpected exception, or a CLI run whose stderr holds "Traceback"), "hang" (no answer in
the case's timeout), "skipped" (needs root for a small tmpfs).

Each attempt runs in its own child Python (or CLI process) in a temporary directory with a
private EOMC_CACHE_DIR, so nothing touches the user's cache.  Usage:
``python benchmarks/reliability_runtime.py [--rounds N] [--out FILE]``; the table is also
written to benchmarks/results/reliability_runtime.md with the load and versions.
"""
import argparse
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PY = sys.executable
EOMC = [PY, "-m", "eomc"]

SPRING = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
    q, u = dynamicsymbols("q u")
    F = dynamicsymbols("F")
    m, k = sm.symbols("m k")
    N = ReferenceFrame("N")
    O = Point("O"); O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x); P.set_vel(N, u * N.x)
    system = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
    LOAD = -k * q + F
    system.kanes_equations([Particle("p", P, m)], [(P, LOAD * N.x)])
    parameters = {m: 1.0, k: 2.0}
    inputs = [F]
    initial_state = {q: 1.0, u: 0.0}
    ''')
CUBIC = SPRING.replace("LOAD = -k * q + F", "LOAD = -k * q**3 + F")

PRELUDE = textwrap.dedent('''\
    import json, os, sys, time, pickle, shutil, subprocess
    import numpy as np
    import eomc
    from eomc.errors import EomcError
    def result(outcome, detail):
        print("RESULT " + outcome + " | " + " ".join(str(detail).split())[:300])
        sys.stdout.flush()
    ''')

MIXED_TREE = textwrap.dedent('''\
    import sympy as sm
    import eomc.mechanics as em
    def mixed_tree():
        ground = em.RigidBody("ground")
        s = em.System.from_newtonian(ground)
        a = em.RigidBody("a", mass=sm.Symbol("ma"))
        a.inertia = (em.inertia(a.frame, 1, 2, 3, 0.1, 0.2, 0.3), a.masscenter)
        b = em.RigidBody("b", mass=sm.Symbol("mb"))
        b.inertia = (em.inertia(b.frame, 2, 1, 2.5), b.masscenter)
        c = em.RigidBody("c", mass=1)
        c.inertia = (em.inertia(c.frame, 1, 1, 1), c.masscenter)
        qa, ua = em.dynamicsymbols("qa1:4"), em.dynamicsymbols("ua1:4")
        qb, ub = em.dynamicsymbols("qb ub")
        qc, uc = em.dynamicsymbols("qc uc")
        s.add_joints(em.SphericalJoint("S", ground, a, qa, ua, parent_point=0.1 * ground.x, child_point=-0.5 * a.z),
                     em.PrismaticJoint("P", a, b, qb, ub, parent_point=0.5 * a.z, joint_axis=a.x),
                     em.PinJoint("R", a, c, qc, uc, parent_point=0.3 * a.y, child_point=-0.2 * c.x,
                                 joint_axis=a.y + a.z))
        s.apply_uniform_gravity(-9.81 * ground.z)
        return s
    ''')


class Run:
    def __init__(self, work):
        self.work = Path(work)
        self.env = dict(os.environ, EOMC_CACHE_DIR=str(self.work / "cache"), PYTHONUNBUFFERED="1")
        self.rows = []

    def record(self, case, outcome, detail):
        line = f"{case} | {outcome} | {detail}"
        print(line, flush=True)
        self.rows.append(line)

    def python(self, case, body, timeout=300, env=None):
        """Run PRELUDE + body in a child; its RESULT line is the outcome."""
        script = self.work / "case.py"
        script.write_text(PRELUDE + textwrap.dedent(body))
        try:
            proc = subprocess.run([PY, str(script)], cwd=self.work, env=env or self.env, capture_output=True,
                                  text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return self.record(case, "hang", f"no answer in {timeout} s")
        lines = [ln[7:] for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
        if not lines:
            tail = (proc.stderr.strip().splitlines() or ["(no output)"])[-1]
            return self.record(case, "traceback", tail[:300])
        for ln in lines:
            outcome, _, detail = ln.partition(" | ")
            self.record(case, outcome, detail)

    def cli(self, args, env=None, timeout=300, cwd=None):
        return subprocess.run([*EOMC, *args], cwd=cwd or self.work, env=env or self.env, capture_output=True,
                              text=True, timeout=timeout)


def cli_outcome(proc, wanted):
    err = proc.stderr.strip()
    if "Traceback" in err:
        return "traceback", err.splitlines()[-1][:300]
    if proc.returncode and err.count("\n") == 0 and err.startswith("eomc") and wanted in err:
        return "clear error", err[:300]
    return "silent wrong" if proc.returncode == 0 else "traceback", (err or proc.stdout)[:300]


# ---------------------------------------------------------------- N1

def n1(run):
    (run.work / "m.py").write_text(SPRING)
    run.python("N1 compile twice into one output_dir (edit between)", f'''
        open("m.py", "w").write({SPRING!r})
        x = np.array([2.0, 0.0])
        m1 = eomc.compile("m.py", output_dir="out", progress=False)
        open("m.py", "w").write({CUBIC!r})
        m2 = eomc.compile("m.py", output_dir="out", progress=False)
        a, b = m2.rhs(0, x, r=[0])[1], eomc.load("out").rhs(0, x, r=[0])[1]
        old = m1.rhs(0, x, r=[0])[1]
        ok = a == -16.0 and b == -16.0 and old == -4.0
        result("correct" if ok else "silent wrong", f"new model {{a}}, load('out') {{b}} (want -16); first model {{old}} (want -4)")
    ''')
    (run.work / "lin.py").write_text(SPRING)
    (run.work / "cub.py").write_text(CUBIC)
    run.python("N1 load('out') after `eomc build -o out` in another process", '''
        x = np.array([2.0, 0.0])
        build = lambda f: subprocess.run([sys.executable, "-m", "eomc", "build", "-q", f, "-o", "out2",
                                          "--name", "spring"], check=True, capture_output=True)
        build("lin.py")
        first = eomc.load("out2").rhs(0, x, r=[0])[1]
        build("cub.py")
        second = eomc.load("out2").rhs(0, x, r=[0])[1]
        build("lin.py")
        third = eomc.load("out2").rhs(0, x, r=[0])[1]
        ok = (first, second, third) == (-4.0, -16.0, -4.0)
        result("correct" if ok else "silent wrong", f"loads gave {first}, {second}, {third} (want -4, -16, -4)")
    ''')
    run.python("N1 Cython backend: second build of one name in one process", f'''
        x = np.array([2.0, 0.0])
        open("m.py", "w").write({SPRING!r})
        m1 = eomc.compile("m.py", output_dir="cy", backend="cython", progress=False)
        first = m1.rhs(0, x, r=[0])[1]
        open("m.py", "w").write({CUBIC!r})
        try:
            m2 = eomc.compile("m.py", output_dir="cy", backend="cython", progress=False)
            v = m2.rhs(0, x, r=[0])[1]
            result("correct" if v == -16.0 else "silent wrong", f"second build's rhs {{v}} (want -16)")
        except EomcError as exc:
            ok = "backend='cffi'" in str(exc)
            result("clear error" if ok else "traceback", exc)
        v = eomc.load("cy", backend="cffi").rhs(0, x, r=[0])[1]
        result("correct" if v == -16.0 else "silent wrong", f"then load('cy', backend='cffi'): {{v}} (want -16)")
    ''', timeout=600)


# ---------------------------------------------------------------- N4

def n4(run, rounds):
    mixed = bad = 0
    for i in range(rounds):
        a = subprocess.Popen([*EOMC, "build", "-q", "lin.py", "-o", "shared", "--name", "spring"], cwd=run.work,
                             env=run.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        b = run.cli(["build", "-q", "cub.py", "-o", "shared", "--name", "spring"])
        a_err = a.communicate(timeout=300)[1]
        if a.returncode or b.returncode:
            bad += 1
            run.record(f"N4 round {i + 1}: two concurrent `eomc build -o shared --name spring`",
                       "traceback" if "Traceback" in a_err + b.stderr else "clear error",
                       (a_err + b.stderr).strip()[:300])
            continue
        check = subprocess.run([PY, "-c", textwrap.dedent('''
            import hashlib, json, sys
            import numpy as np, eomc
            listing = json.load(open("shared/.eomc-files-spring.json"))["files"]
            off = [n for n, d in listing.items() if hashlib.sha256(open("shared/" + n, "rb").read()).hexdigest() != d]
            c = open("shared/spring.c").read()
            v = eomc.load("shared").rhs(0, np.array([2.0, 0.0]), r=[0])[1]
            cubic = "pow" in c or "q*q" in c.replace(" ", "") or "x[0]*x[0]" in c.replace(" ", "")
            print(json.dumps({"off": off, "rhs": v, "c_cubic": cubic}))
        ''')], cwd=run.work, env=run.env, capture_output=True, text=True, timeout=300)
        try:
            import json
            info = json.loads(check.stdout.strip().splitlines()[-1])
        except (ValueError, IndexError):
            mixed += 1
            run.record(f"N4 round {i + 1}", "clear error" if "LoadError" in check.stderr else "traceback",
                       (check.stderr.strip().splitlines() or ["?"])[-1][:300])
            continue
        consistent = not info["off"] and (info["rhs"] == -16.0) == info["c_cubic"]
        mixed += not consistent
        run.record(f"N4 round {i + 1}: two concurrent `eomc build -o shared --name spring`",
                   "correct" if consistent else "silent wrong",
                   f"files off their listing: {info['off'] or 'none'}; library rhs {info['rhs']}, "
                   f"C cubic: {info['c_cubic']}")
    return mixed, bad


# ---------------------------------------------------------------- N5

def n5(run):
    body = '''
        m = eomc.compile("lin.py", output_dir="s5", progress=False)
        calls = {"n": 0, "after": 0, "raised": False}
        def r(t):
            calls["n"] += 1
            if calls["raised"]:
                calls["after"] += 1
            elif t > 0.5:
                calls["raised"] = True
                raise RuntimeError("boom")
            return 0.5
        t0 = time.perf_counter()
        try:
            m.simulate([1.0, 0.0], (0, 30), r=r)
            result("silent wrong", "the run finished")
        except ValueError as exc:
            dt = time.perf_counter() - t0
            ok = calls["after"] == 0
            result("clear error" if ok else "silent wrong",
                   f"{exc} -- raised after {dt:.3f} s, {calls['after']} calls after it raised")
    '''
    run.python("N5 r(t) raises once at t=0.5 over (0, 30)", body)
    sig = '''
        import signal, threading
        m = eomc.load("s5")
        calls = {"n": 0}
        def r(t):
            calls["n"] += 1
            time.sleep(0.01)
            return 0.5
        KIND
        sent = {}
        def fire():
            sent["t"] = time.perf_counter()
            os.kill(os.getpid(), signal.SIGINT)
        threading.Timer(DELAY, fire).start()
        try:
            m.simulate([1.0, 0.0], SPAN, **kw)
            result("silent wrong", "the run finished")
        except KeyboardInterrupt:
            lat = time.perf_counter() - sent["t"]
            result("correct" if lat < 0.1 else "silent wrong",
                   f"KeyboardInterrupt {lat * 1000:.1f} ms after SIGINT ({calls['n']} calls of r)")
    '''
    run.python("N5 Ctrl-C (SIGINT at 3 s) inside a slow r(t) over (0, 150)",
               sig.replace("KIND", "kw = dict(r=r)").replace("DELAY", "3.0").replace("SPAN", "(0, 150)"))
    run.python("N5 Ctrl-C (SIGINT at 1 s) during a long C run without callbacks",
               sig.replace("KIND", "kw = dict(max_steps=10**12, n_points=2, r=[0.0])")
               .replace("DELAY", "1.0").replace("SPAN", "(0, 1e9)"))


# ---------------------------------------------------------------- N6

def n6(run):
    dp = ROOT / "examples" / "double_pendulum.py"
    run.python("N6 pickle.dumps(model) after `eomc cache clear`", f'''
        m = eomc.compile({str(dp)!r}, progress=False)
        subprocess.run([sys.executable, "-m", "eomc", "cache", "clear"], check=True, capture_output=True)
        gone = not m.directory.exists()
        try:
            back = pickle.loads(pickle.dumps(m))
            x = np.array(m.initial_state)
            same = np.array_equal(back.rhs(0, x), m.rhs(0, x))
            result("correct" if same else "silent wrong", f"entry removed: {{gone}}; unpickled rhs equal: {{same}}")
        except EomcError as exc:
            result("clear error", exc)
    ''')
    run.python("N6 eomc.sweep(map=ProcessPoolExecutor(2)) after `eomc cache clear`", f'''
        from concurrent.futures import ProcessPoolExecutor
        m = eomc.compile({str(dp)!r}, progress=False)
        subprocess.run([sys.executable, "-m", "eomc", "cache", "clear"], check=True, capture_output=True)
        cases = [{{"q1": 0.1 * i}} for i in range(1, 5)]
        with ProcessPoolExecutor(2) as pool:
            far = eomc.sweep(m, cases, (0, 1), map=pool, progress=False)
        here = eomc.sweep(m, cases, (0, 1), progress=False)
        same = np.array_equal(far.x, here.x)
        result("correct" if same else "silent wrong", f"4 cases on 2 processes equal to here: {{same}}")
    ''')


# ---------------------------------------------------------------- N9

def n9(run):
    run.python("N9 recursive rhs at SphericalJoint gimbal lock", MIXED_TREE + textwrap.dedent('''
        from eomc.errors import SimulationError
        m = eomc.compile(mixed_tree(), "mixed", formulation="recursive", progress=False,
                         parameters={"ma": 2.0, "mb": 1.5}, functions=["rhs", "mass_matrix", "forcing"])
        for label, q2 in (("pi/2", np.pi / 2), ("pi/2+1e-14", np.pi / 2 + 1e-14),
                          ("pi/2-1e-9", np.pi / 2 - 1e-9), ("pi/2+1e-9", np.pi / 2 + 1e-9),
                          ("pi/2-1e-6", np.pi / 2 - 1e-6), ("pi/2-1e-3", np.pi / 2 - 1e-3)):
            x = np.zeros(m.nx); x[1] = q2; x[m.nq:] = 0.3
            try:
                ud = m.rhs(0, x)[m.nq:]
                M, f = m.mass_matrix(0, x), m.forcing(0, x)
                res = np.linalg.norm(M @ ud - f) / (np.linalg.norm(M) * max(1, np.linalg.norm(f)))
                cond = np.linalg.cond(M)
                singular = cond > 1e15
                result("silent wrong" if singular else "correct",
                       f"q2={label}: status 0, cond(M)={cond:.1e}, |u'|max={np.max(np.abs(ud)):.3g}, residual {res:.1e}")
            except SimulationError as exc:
                ok = "nothing resists motion along" in str(exc)
                result("clear error" if ok else "traceback", f"q2={label}: " + str(exc).split("; ", 1)[-1])
    '''), timeout=600)


# ---------------------------------------------------------------- N10

def _tmpfs(path, size="200k"):
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        return False
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)]).returncode == 0


def _fill(path):
    try:
        with open(path / "filler", "ab") as fh:
            while True:
                fh.write(b"\0" * 4096)
                fh.flush()
    except OSError:
        pass


def n10(run):
    run.python("N10 a same-size edit in a worker's cache entry on unpickling", '''
        import copy, eomc.runtime.travel as travel
        from eomc.runtime import store
        m = eomc.compile("lin.py", progress=False)
        blob = pickle.dumps(m)
        worker = os.path.abspath("worker-cache")
        os.environ["EOMC_CACHE_DIR"] = worker
        first = pickle.loads(blob)
        entry = store.entry_path(store.cache_root(), "models", first.metadata["build"]["key"])
        path = entry / f"{first.name}.json"
        text = path.read_text()
        edited = text.replace('"initial_state": [\\n  1.0,', '"initial_state": [\\n  7.0,')
        assert edited != text and len(edited) == len(text)
        path.write_text(edited)
        travel._RESTORED.clear()
        again = pickle.loads(blob)
        ok = list(again.initial_state) == [1.0, 0.0]
        result("correct" if ok else "silent wrong",
               f"after the edit: initial_state {again.initial_state.tolist()}, arrival {again.arrival!r}")
    ''')
    full = run.work / "full"
    if not _tmpfs(full):
        for case in ("unpickling into a full cache", "cold build with a full cache",
                     "`eomc build -o` on a full disk"):
            run.record(f"N10 {case}", "skipped", "needs root for a 200 KB tmpfs")
        return
    try:
        env = dict(run.env, EOMC_CACHE_DIR=str(full / "cache"))
        (full / "cache" / "v1" / "tmp").mkdir(parents=True)
        (full / "cache" / "v1" / "locks").mkdir(parents=True)
        _fill(full)
        run.python("N10 unpickling into a full cache", '''
            m = eomc.compile("lin.py", progress=False)
            blob = pickle.dumps(m)
            os.environ["EOMC_CACHE_DIR"] = sys.argv[1] if len(sys.argv) > 1 else os.environ["FULL_CACHE"]
            try:
                back = pickle.loads(blob)
                result("correct", f"loaded ({back.arrival})")
            except EomcError as exc:
                ok = "full" in str(exc) and "\\n" not in str(exc)
                result("clear error" if ok else "traceback", exc)
        ''', env=dict(run.env, FULL_CACHE=str(full / "cache")))
        proc = run.cli(["build", "-q", "cub.py", "--name", "cold_full", "-o", "cold_out"], env=env)
        outcome, detail = cli_outcome(proc, "full")
        run.record("N10 cold `eomc build` with a full cache", outcome, detail)
        os.remove(full / "filler")
        subprocess.run(["rm", "-rf", str(full / "cache")])
        _fill(full)
        # the build cache is elsewhere (warm: lin.py was built above); only DIR is on the full disk
        proc = run.cli(["build", "-q", "lin.py", "-o", str(full / "dir")])
        outcome, detail = cli_outcome(proc, "full")
        left = sorted(p.name for p in (full / "dir").iterdir()) if (full / "dir").exists() else []
        run.record("N10 `eomc build -o` on a full disk", outcome, f"{detail}; DIR holds {left or 'nothing'}")
    finally:
        subprocess.run(["umount", str(full)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=10, help="N4 rounds (the report ran 20)")
    ap.add_argument("--out", default=str(HERE / "results" / "reliability_runtime.md"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="eomc-r3-") as work:
        run = Run(work)
        started = time.time()
        n1(run)
        n4(run, args.rounds)
        n5(run)
        n6(run)
        n9(run)
        n10(run)
        took = time.time() - started
    import eomc
    from collections import Counter
    counts = Counter(line.split(" | ")[1] for line in run.rows)
    head = [f"# Reliability report r3: rerun of N1, N4, N5, N6, N9, N10 ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})",
            "", f"eomc {eomc.__version__}, Python {platform.python_version()}, {platform.platform()}; "
            f"load average (1 min) at the end: {os.getloadavg()[0]:.2f}; {took:.0f} s; N4 rounds: {args.rounds}.",
            "", "Totals: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())), "",
            "```", "case | outcome | detail"]
    Path(args.out).write_text("\n".join(head + run.rows + ["```", ""]))
    print("\nTotals: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
