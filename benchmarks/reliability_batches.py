"""Rerun of the round-3 reliability and first-hour cases about batches, sweeps, events, inputs and
consistent states (issue 24: N2, N3, N11, N12, N13, N14 of reliability-2026-11-r3.md and the
first-hour items 4, 7, 8, 9 of first-hour-2026-11-r3.md).

Every attempt prints one line ``case | outcome | detail`` with outcome one of
  clear error  -- one ValueError/EomcError (API) or one ``eomc CMD: error:`` line (CLI) naming the cause
  correct      -- the answer equals its reference (simulate() of the same case, consistent_state, ...)
  silent wrong -- an answer that differs from its reference, or a bad input accepted
  traceback    -- another exception, a Traceback on stderr, or an error that does not say what is wrong
  hang         -- no answer within the attempt's timeout
Models are built into a temporary directory with a private EOMC_CACHE_DIR; CLI attempts run as
subprocesses (``python -m eomc``) with timeouts.  Usage: ``python benchmarks/reliability_batches.py``
(about 2-3 minutes on a quiet 2-core machine; add ``--no-dask-kill`` to skip the two attempts that
start and kill a Dask scheduler and worker; ``--write`` also writes the lines to
``benchmarks/results/reliability_batches.md``).
"""
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PY = sys.executable
WORK = Path(tempfile.mkdtemp(prefix="eomc-r3-batch-"))
os.environ["EOMC_CACHE_DIR"] = str(WORK / "cache")
COUNTS = {}

import eomc  # noqa: E402
from eomc.errors import EomcError  # noqa: E402
from eomc.runtime.batch import simulate_many  # noqa: E402
from eomc.runtime.simulate import simulate  # noqa: E402

ROW_KEY_MODEL = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
    q1, u = dynamicsymbols("q1 u")
    r = dynamicsymbols("r")
    p, q = sm.symbols("p q")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q1 * N.x)
    P.set_vel(N, u * N.x)
    system = KanesMethod(N, q_ind=[q1], u_ind=[u], kd_eqs=[q1.diff() - u])
    system.kanes_equations([Particle("b", P, q)], [(P, (-p * q1 + r) * N.x)])
    parameters = {p: 2.0, q: 1.0}
    inputs = [r]
    initial_state = {q1: 1.0, u: 0.0}
    ''')

EVENTS_MODEL = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
    q, u = dynamicsymbols("q u")
    F = dynamicsymbols("F")
    m, l, g = sm.symbols("m l g", positive=True)
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q, N.z])
    A.set_ang_vel(N, u * N.z)
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", -l * A.y)
    P.v2pt_theory(O, N, A)
    system = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
    system.kanes_equations([Particle("bob", P, m)], [(P, -m * g * N.y + F * A.x)])
    parameters = {m: 1.0, l: 1.0, g: 9.81}
    inputs = [F]
    initial_state = {q: 1.0, u: 0.0}
    outputs = {"angle": q, "speed": u, "nanout": sm.sqrt(q - 5)}
    EVENTS
    ''')


LINES = []


def say(text):
    LINES.append(text)
    print(text, flush=True)


def line(case, outcome, detail):
    COUNTS[outcome] = COUNTS.get(outcome, 0) + 1
    detail = " ".join(str(detail).replace(str(WORK) + "/", "").split()).replace("|", "/")
    say(f"{case} | {outcome} | {detail[:400]}")


def attempt(case, fn, expect=None):
    """Run fn(); it returns (outcome, detail).  An error is 'clear error' when it is a
    ValueError/EomcError containing ``expect`` (when given), else 'traceback'."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            outcome, detail = fn()
    except (EomcError, ValueError) as exc:
        msg = f"{type(exc).__name__}: {exc}"
        if expect is not None and expect not in str(exc):
            line(case, "traceback", f"unexpected error: {msg}")
        else:
            line(case, "clear error", msg)
        return
    except Exception as exc:       # noqa: BLE001 -- the point is to see it
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        line(case, "traceback", f"{type(exc).__name__}: {exc} [{Path(tb.filename).name}:{tb.lineno}]")
        return
    line(case, outcome, detail)


def refused(case, fn, expect):
    """An attempt that must be refused: returning normally is a silent wrong answer."""
    attempt(case, lambda: ("silent wrong", f"accepted: {fn()!r}"[:200]), expect)


def cli(case, args, expect_rc=None, expect=None, timeout=300, judge=None, cwd=None):
    """One eomc command; a one-line `eomc CMD: error:` containing ``expect`` is a clear error."""
    start = time.perf_counter()
    try:
        run = subprocess.run([PY, "-m", "eomc", *args], capture_output=True, text=True, timeout=timeout,
                             cwd=cwd or WORK, env=os.environ)
    except subprocess.TimeoutExpired:
        line(case, "hang", f"no answer in {timeout} s")
        return None
    took = time.perf_counter() - start
    err = run.stderr.strip()
    errors = [ln for ln in err.splitlines() if ": error:" in ln]
    if "Traceback" in err or run.returncode < 0:
        line(case, "traceback", f"rc={run.returncode} {took:.1f}s: {err.splitlines()[-1] if err else ''}")
    elif judge is not None:
        outcome, detail = judge(run)
        line(case, outcome, f"rc={run.returncode} {took:.1f}s: {detail}")
    elif run.returncode != 0 and len(errors) == 1 and (expect is None or expect in errors[0]):
        line(case, "clear error", f"rc={run.returncode} {took:.1f}s: {errors[0]}")
    elif run.returncode != 0:
        line(case, "traceback", f"rc={run.returncode} {took:.1f}s: unclear: {err[-300:]}")
    else:
        line(case, "silent wrong", f"rc=0 {took:.1f}s: accepted: {run.stdout.strip()[-200:]}")
    return run


def same(a, b):
    return np.array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float), equal_nan=True)


# ---- models -------------------------------------------------------------------------------------
def build_models():
    models = {}
    models["cartpole"] = eomc.compile(str(EXAMPLES / "cartpole_lqr.py"), output_dir=str(WORK / "cartpole"),
                                      progress=False)
    models["fourbar"] = eomc.compile(str(EXAMPLES / "four_bar_system.py"), output_dir=str(WORK / "fourbar"),
                                     progress=False)
    (WORK / "rowkeys.py").write_text(ROW_KEY_MODEL)
    models["rowkeys"] = eomc.compile(str(WORK / "rowkeys.py"), output_dir=str(WORK / "rowkeys"),
                                     progress=False)
    for name, events in (("ev_nan_always", 'events = {"bad": sm.sqrt(q - 5)}'),
                         ("ev_nan_sometimes", 'events = {"bad": sm.log(q + 0.5)}'),
                         ("ev_plain", 'events = {"zero": q}')):
        (WORK / f"{name}.py").write_text(EVENTS_MODEL.replace("EVENTS", events))
        models[name] = eomc.compile(str(WORK / f"{name}.py"), progress=False)
    models["dp"] = eomc.compile(str(EXAMPLES / "double_pendulum.py"), output_dir=str(WORK / "dp"),
                                progress=False)
    return models


def cartpole_start(m, th):
    return dict(zip(m.state_names, m.initial_state), th=th)


# ---- N2 -----------------------------------------------------------------------------------------
def n2(models):
    m = models["cartpole"]
    ths = [3.0, 2.9, 2.5]
    singles = [simulate(m, cartpole_start(m, th), (0, 10)) for th in ths]

    def many():
        X0 = np.array([list(cartpole_start(m, th).values()) for th in ths])
        b = simulate_many(m, X0, (0, 10), progress=False)
        ok = all(same(b.x_final[i], s.x_final) and b.t_final[i] == s.t_final and b.event_stop[i] == s.event_stop
                 and same(b.t_events[i]["fallen"], s.t_events["fallen"]) for i, s in enumerate(singles))
        return ("correct" if ok else "silent wrong",
                f"x_final/t_final/event_stop/t_events equal simulate(): {ok}; status {b.status.tolist()}")
    attempt("N2 simulate_many cartpole (terminal 'fallen') vs simulate", many)

    def final():
        r = eomc.sweep(m, {"th": ths}, (0, 10), reduce="final", progress=False)
        ok = all(same(r.x[i, 0], s.x_final) and r.t_final[i] == s.t_final for i, s in enumerate(singles))
        return ("correct" if ok else "silent wrong", f"final rows = simulate().x_final: {ok}; "
                f"any NaN: {bool(np.isnan(r.x).any())}; event_stop {r.event_stop}")
    attempt("N2 eomc.sweep reduce='final' cartpole vs simulate", final)

    def reduce_f():
        v = eomc.sweep(m, {"th": ths}, (0, 10), reduce=lambda r: (r.t_final, r.x_final[0], r.event_stop,
                                                                    r.t_events["fallen"][0]), progress=False)
        ok = all(tuple(v.values[i]) == (s.t_final, s.x_final[0], s.event_stop, s.t_events["fallen"][0])
                 for i, s in enumerate(singles))
        return ("correct" if ok else "silent wrong", f"f sees t_final, x_final, event_stop, t_events as simulate(): {ok}")
    attempt("N2 eomc.sweep reduce=f sees simulate()'s result", reduce_f)

    def events_kept():
        X0 = np.array([list(cartpole_start(m, th).values()) for th in ths])
        b = simulate_many(m, X0, (0, 3), progress=False, events={"fallen": {"terminal": False}})
        s = simulate(m, X0[0], (0, 3), events={"fallen": {"terminal": False}})
        ok = b.t_events is not None and same(b.t_events[0]["fallen"], s.t_events["fallen"])
        return ("correct" if ok else "silent wrong", f"events= records kept: {ok}")
    attempt("N2 simulate_many events= (3 cases) keeps the records", events_kept)

    cases = WORK / "cp_cases.csv"
    cases.write_text("th\n3.0\n2.9\n2.5\n")

    def judge(run):
        import csv
        rows = list(csv.DictReader(open(WORK / "cp_out.csv")))
        ok = all([float(r[f"final_{n}"]) for n in m.state_names] == s.x_final.tolist()
                 and r["event_stop"] == "fallen" for r, s in zip(rows, singles))
        return ("correct" if ok else "silent wrong", f"final_* = simulate().x_final, event_stop column: {ok}")
    cli("N2 eomc sweep examples/cartpole_lqr.py 3 cases", ["sweep", str(EXAMPLES / "cartpole_lqr.py"), "--cases",
        str(cases), "--t-final", "10", "-o", str(WORK / "cp_out.csv"), "-q", "--workers", "1"], judge=judge)


# ---- N3 -----------------------------------------------------------------------------------------
def n3(models):
    cases = WORK / "long.csv"
    cases.write_text("q1,q2\n" + "".join(f"{1 + i * 1e-4},0.5\n" for i in range(400)))
    base = ["sweep", str(WORK / "dp"), "--cases", str(cases), "--t-final", "50", "-q", "--workers", "1"]
    (WORK / "adir.csv").mkdir(exist_ok=True)
    cli("N3 eomc sweep -o missing/r.csv", base + ["-o", "missing/r.csv"], expect="does not exist")
    cli("N3 eomc sweep -o adir.csv (a directory)", base + ["-o", "adir.csv"], expect="is a directory")
    ro = WORK / "rodir"
    ro.mkdir(exist_ok=True)
    (ro / "prev.csv").write_text("previous\n")
    if os.geteuid() == 0 and shutil.which("unshare"):
        # root ignores file modes: a read-only bind mount in a private mount namespace, as the report did
        script = (f"mount --bind {ro} {ro} && mount -o remount,bind,ro {ro} && "
                  f"{PY} -m eomc " + " ".join(base + ["-o", str(ro / "prev.csv")]))
        start = time.perf_counter()
        run = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True, text=True, timeout=300,
                             cwd=WORK, env=os.environ)
        took = time.perf_counter() - start
        err = run.stderr.strip()
        kept = (ro / "prev.csv").read_text() == "previous\n"
        if "mount" in err and "eomc" not in err:
            line("N3 eomc sweep -o in a read-only directory", "clear error", f"(mount failed here: {err[:80]})")
        elif "Traceback" in err:
            line("N3 eomc sweep -o in a read-only directory", "traceback", err.splitlines()[-1])
        else:
            line("N3 eomc sweep -o in a read-only directory", "clear error" if run.returncode and kept else
                 "silent wrong", f"rc={run.returncode} {took:.1f}s previous kept={kept}: {err}")
    else:
        os.chmod(ro, 0o555)
        cli("N3 eomc sweep -o in a read-only directory", base + ["-o", str(ro / "prev.csv")], expect="write")
        os.chmod(ro, 0o755)
    cli("N3 eomc simulate -o missing/t.csv", ["simulate", str(WORK / "dp"), "--t-final", "1", "-o", "missing/t.csv"],
        expect="does not exist")


# ---- N11 ----------------------------------------------------------------------------------------
@contextlib.contextmanager
def not_dask_server():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    stop = threading.Event()

    def serve():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            with contextlib.suppress(OSError):
                conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n" * 100)
            conn.close()
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        server.close()


def _start(args):
    return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=os.environ,
                            start_new_session=True)


def _port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def n11(models, kill=True):
    cases = WORK / "dp_cases.csv"
    cases.write_text("q1,q2\n0.1,0.2\n0.3,0.4\n")
    base = ["sweep", str(WORK / "dp"), "--cases", str(cases), "--t-final", "1", "-o", str(WORK / "dask.csv"), "-q"]
    cli("N11 --scheduler tcp://127.0.0.1:1 (refused)", base + ["--scheduler", "tcp://127.0.0.1:1",
        "--connect-timeout", "3"], expect="cannot connect")
    with not_dask_server() as address:
        cli("N11 --scheduler at a non-Dask server", base + ["--scheduler", address, "--connect-timeout", "3"],
            expect="cannot connect")
    cli("N11 --scheduler http://127.0.0.1:9 (wrong scheme)", base + ["--scheduler", "http://127.0.0.1:9"],
        expect="scheme")
    port = _port()
    scheduler = _start([PY, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                        "--dashboard-address", ":0"])
    try:
        time.sleep(4)
        cli("N11 --scheduler with no workers", base + ["--scheduler", f"tcp://127.0.0.1:{port}",
            "--connect-timeout", "3"], expect="no workers")
        if not kill:
            return
        long_cases = WORK / "dp_long.csv"
        long_cases.write_text("q1,q2\n" + "".join(f"{1 + i * 1e-4},0.5\n" for i in range(400)))
        worker = _start([PY, "-m", "distributed.cli.dask_worker", f"tcp://127.0.0.1:{port}", "--nworkers", "1",
                         "--nthreads", "1", "--no-dashboard"])
        time.sleep(4)
        run_args = ["sweep", str(WORK / "dp"), "--cases", str(long_cases), "--t-final", "400", "-o",
                    str(WORK / "dask_long.csv"), "-q", "--scheduler", f"tcp://127.0.0.1:{port}", "--chunk-size", "10",
                    "--max-steps", "10000000"]
        sweep = subprocess.Popen([PY, "-m", "eomc", *run_args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 text=True, env=os.environ, cwd=WORK)
        time.sleep(6)
        os.killpg(worker.pid, signal.SIGKILL)
        _wait_line("N11 the only Dask worker killed mid-sweep", sweep, 120)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(scheduler.pid, signal.SIGKILL)
    if not kill:
        return
    port = _port()
    scheduler = _start([PY, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                        "--dashboard-address", ":0"])
    time.sleep(4)
    worker = _start([PY, "-m", "distributed.cli.dask_worker", f"tcp://127.0.0.1:{port}", "--nworkers", "1",
                     "--nthreads", "1", "--no-dashboard"])
    try:
        time.sleep(4)
        run_args[run_args.index("--scheduler") + 1] = f"tcp://127.0.0.1:{port}"
        sweep = subprocess.Popen([PY, "-m", "eomc", *run_args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 text=True, env=os.environ, cwd=WORK)
        time.sleep(6)
        os.killpg(scheduler.pid, signal.SIGKILL)
        _wait_line("N11 the Dask scheduler killed mid-sweep", sweep, 120)
    finally:
        for proc in (worker, scheduler):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)


def _wait_line(case, proc, timeout):
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        line(case, "hang", f"no answer {timeout} s after the kill")
        return
    err = err.strip()
    errors = [ln for ln in err.splitlines() if ": error:" in ln]
    if "Traceback" in err:
        line(case, "traceback", err.splitlines()[-1])
    elif proc.returncode and len(errors) == 1 and len(err.splitlines()) == 1:
        line(case, "clear error", f"rc={proc.returncode}: {errors[0]}")
    elif proc.returncode == 0:
        line(case, "correct", f"rc=0 (Dask recovered): {out.strip()[-150:]}")
    else:
        line(case, "traceback", f"rc={proc.returncode}: {err[-200:]}")


# ---- N12 ----------------------------------------------------------------------------------------
def n12(models):
    m = models["cartpole"]

    def huge():
        start = time.perf_counter()
        try:
            simulate_many(m, np.tile(m.initial_state, (10 ** 6, 1)), (0, 1e-9), progress=False)
        except ValueError as exc:
            return "clear error", f"{time.perf_counter() - start:.1f}s: {exc}"
        return "silent wrong", "10**6 cases x 1001 rows accepted"
    attempt("N12 simulate_many 10**6 cases x 1001 rows", huge)
    refused("N12 max_events=10**10", lambda: simulate(m, m.initial_state, (0, 1), max_events=10 ** 10),
            "max_events")

    def peak():
        import tracemalloc
        n = 20000
        th = np.linspace(3.0, 3.2, n)
        tracemalloc.start()
        try:
            eomc.sweep(m, {"th": th}, (0, 0.5), reduce="final", progress=False, chunk_size=n)
            got = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        whole = n * 1001 * 5 * 8
        return ("correct" if got < whole / 10 else "silent wrong",
                f"peak {got / 2 ** 20:.1f} MiB for {n} cases in one chunk; whole trajectories would be "
                f"{whole / 2 ** 20:.0f} MiB")
    attempt("N12 sweep reduce='final' memory per chunk (tracemalloc)", peak)


# ---- N13 ----------------------------------------------------------------------------------------
def n13(models):
    rk = models["rowkeys"]

    def named():
        res = eomc.sweep(rk, {"p": [1.0, 5.0], "q": [1.0, 1.1]}, (0, 1), reduce="final", progress=False)
        want = [simulate(rk, None, (0, 1), p={"p": p, "q": q}).x_final for p, q in ((1, 1), (5, 1.1))]
        ok = all(same(res.x_final[i], w) for i, w in enumerate(want))
        return "correct" if ok else "silent wrong", f"parameter named p swept per case = simulate(p=...): {ok}"
    attempt("N13 API sweep: parameter named 'p', 2 rows (= nparam)", named)
    (WORK / "p2.csv").write_text("p,q\n1,1\n5,1.1\n")

    def judge_p(run):
        import csv
        rows = list(csv.DictReader(open(WORK / "p2_out.csv")))
        want = [simulate(rk, None, (0, 1), p={"p": p, "q": q}).x_final[0] for p, q in ((1, 1), (5, 1.1))]
        ok = [float(r["final_q1"]) for r in rows] == want
        return "correct" if ok else "silent wrong", f"final_q1 = simulate(p per case): {ok}"
    cli("N13 eomc sweep: CSV column 'p' (a parameter named p)", ["sweep", str(WORK / "rowkeys"), "--cases",
        str(WORK / "p2.csv"), "--t-final", "1", "-o", str(WORK / "p2_out.csv"), "-q", "--workers", "1"],
        judge=judge_p)
    (WORK / "r2.csv").write_text("r,q1\n0.5,0.1\n1.0,0.2\n")

    def judge_r(run):
        import csv
        rows = list(csv.DictReader(open(WORK / "r2_out.csv")))
        want = [simulate(rk, {"q1": q1}, (0, 1), r=[r]).x_final[0] for r, q1 in ((0.5, 0.1), (1.0, 0.2))]
        ok = [float(row["final_q1"]) for row in rows] == want
        return "correct" if ok else "silent wrong", f"input named r swept per case: {ok}"
    cli("N13 eomc sweep: CSV column 'r' (an input named r)", ["sweep", str(WORK / "rowkeys"), "--cases",
        str(WORK / "r2.csv"), "--t-final", "1", "-o", str(WORK / "r2_out.csv"), "-q", "--workers", "1"],
        judge=judge_r)
    (WORK / "x0col.csv").write_text("q1,x0\n0.1,1\n0.2,2\n0.3,3\n0.4,4\n")
    cli("N13 eomc sweep: CSV column 'x0' beside q1", ["sweep", str(WORK / "dp"), "--cases", str(WORK / "x0col.csv"),
        "--t-final", "1", "-o", str(WORK / "x0.csv"), "-q"], expect="'x0' is not a state")
    big = ["q1,m2"] + ["1,1"] * 400
    big[351] = "1,inf"
    (WORK / "inf352.csv").write_text("\n".join(big) + "\n")
    cli("N13 inf parameter at CSV line 352, --chunk-size 100", ["sweep", str(WORK / "dp"), "--cases",
        str(WORK / "inf352.csv"), "--t-final", "1", "-o", str(WORK / "i.csv"), "--chunk-size", "100", "-q"],
        expect="inf352.csv:352:")
    (WORK / "nan1.csv").write_text("q1,q2\nnan,1\n1,1\n")
    cli("N13 NaN state in row 1", ["sweep", str(WORK / "dp"), "--cases", str(WORK / "nan1.csv"), "--t-final", "1",
        "-o", str(WORK / "n.csv"), "-q"], expect="nan1.csv:2:")
    (WORK / "bom.csv").write_bytes("\ufeffq1,q2\r\n0.1,0.2\r\n".encode())

    def judge_bom(run):
        head = open(WORK / "bom_out.csv").readline()
        ok = run.returncode == 0 and head.startswith("q1,")
        return "correct" if ok else "silent wrong", f"header {head.strip()[:40]!r}"
    cli("N13 Excel CSV with a BOM", ["sweep", str(WORK / "dp"), "--cases", str(WORK / "bom.csv"), "--t-final", "1",
        "-o", str(WORK / "bom_out.csv"), "-q", "--workers", "1"], judge=judge_bom)
    cli("N13 --chunk-size 0", ["sweep", str(WORK / "dp"), "--cases", str(WORK / "nan1.csv").replace("nan1", "bom"),
        "--t-final", "1", "-o", str(WORK / "c0.csv"), "--chunk-size", "0", "-q"], expect="--chunk-size")
    refused("N13 eomc.sweep(m, {'q1': []})", lambda: eomc.sweep(models["dp"], {"q1": []}, (0, 1), progress=False),
            "no cases")
    fb = models["fourbar"]

    def consistent():
        res = eomc.sweep(fb, {"q1": [-1.0, -0.9]}, (0, 0.5), consistent=True, reduce="final", progress=False)
        want = [simulate(fb, {"q1": v}, (0, 0.5), consistent=True).x_final for v in (-1.0, -0.9)]
        ok = all(same(res.x_final[i], w) for i, w in enumerate(want))
        return "correct" if ok else "silent wrong", f"= simulate(consistent=True): {ok}"
    attempt("N13 eomc.sweep(..., consistent=True) four-bar", consistent)


# ---- N14 ----------------------------------------------------------------------------------------
def n14(models):
    def names(model, x0, events, want):
        def run():
            try:
                model.simulate(x0, (0, 1), events=events)
            except EomcError as exc:
                ok = want in str(exc)
                return ("clear error" if ok else "traceback", f"{'' if ok else 'does not name ' + want + ': '}{exc}")
            return "silent wrong", "ran"
        return run
    attempt("N14 NaN event always", names(models["ev_nan_always"], [1.0, 0.0], None, "event function bad"))
    attempt("N14 NaN event mid-run (log(q + 0.5))", names(models["ev_nan_sometimes"], [1.0, 0.0], None,
                                                          "event function bad"))
    attempt("N14 outputs as events while another output is NaN", names(models["ev_plain"], [1.0, 0.0], ["angle"],
                                                                      "nanout"))
    attempt("N14 NaN output not an event", names(models["ev_plain"], [1.0, 0.0], False, "nanout"))
    fb = models["fourbar"]

    def same_start():
        start = {"q1": 0.3, "u1": 1.0}
        a = fb.simulate(start, (0, 0.1), consistent=True).x[0]
        b = fb.consistent_state(start)
        return ("correct" if same(a, b) else "silent wrong", f"simulate(dict, consistent=True) start = "
                f"consistent_state(dict): {same(a, b)}")
    attempt("N14 four-bar {'q1': 0.3, 'u1': 1.0}: simulate(consistent=True) vs consistent_state", same_start)
    for kw in (dict(tol=-1), dict(tol=float("nan")), dict(max_iter=-1), dict(max_iter=2.5)):
        refused(f"N14 consistent_state {kw}", lambda kw=kw: fb.consistent_state({"q1": 0.3}, **kw),
                "must be")

    def many_consistent():
        X0 = np.tile(fb.initial_state, (2, 1))
        X0[:, 0] = [-1.0, -0.9]
        b = simulate_many(fb, X0, (0, 0.1), consistent=True, progress=False, n_points=2)
        ok = all(same(b.x[i, 0], fb.consistent_state(X0[i])) for i in range(2))
        return "correct" if ok else "silent wrong", f"starts = consistent_state: {ok}"
    attempt("N14 simulate_many(consistent=True)", many_consistent)
    cp = models["cartpole"]
    K = np.ones((1, 4))
    refused("N14 K with an imaginary part", lambda: cp.simulate(cp.initial_state, (0, 1), r=[0.0], K=K + 5j),
            "K must hold real numbers")
    refused("N14 x_ref with an imaginary part", lambda: cp.simulate(cp.initial_state, (0, 1), r=[0.0], K=K,
                                                                    x_ref=np.zeros(4) + 1j), "x_ref")
    refused("N14 K of strings", lambda: cp.simulate(cp.initial_state, (0, 1), r=[0.0], K=[["a"] * 4]), "K")
    refused("N14 input table of strings", lambda: cp.simulate(cp.initial_state, (0, 1),
                                                              r=([0.0, 1.0], ["a", "b"])), "r=(t_grid, values)")
    refused("N14 r as a 4-tuple", lambda: cp.simulate(cp.initial_state, (0, 1), r=([0.0, 1.0], [0.0, 1.0], "cubic",
                                                                                   1)), "tuple of 4")


# ---- first hour ---------------------------------------------------------------------------------
def first_hour(models):
    fh = Path("/work/shared/reports/first-hour-2026-11-r3")
    folder = WORK / "fh"
    folder.mkdir(exist_ok=True)
    for name in ("ball.py", "ball_R_in_output.py", "slider_crank.py"):
        if (fh / name).exists():
            shutil.copy(fh / name, folder / name)
    if (folder / "ball.py").exists():     # the report's ball with its radius R in the impact event
        text = (folder / "ball.py").read_text()
        text = text.replace("m, c, g = symbols('m c g'", "m, c, g, R = symbols('m c g R'")
        text = text.replace("parameters = {m: 0.2, c: 0.05, g: 9.81}", "parameters = {m: 0.2, c: 0.05, g: 9.81, R: 0.05}")
        (folder / "ball_R_event.py").write_text(text.replace("'expr': y - 0.05", "'expr': y - R"))
    for name in ("ball_R_in_output.py", "ball_R_event.py"):
        if not (folder / name).exists():
            continue

        def judge(run, name=name):
            ok = run.returncode == 0 and "stopped by event impact" in run.stdout
            return ("correct" if ok else "silent wrong", run.stdout.strip().splitlines()[-1] if run.stdout else
                    run.stderr.strip()[-200:])
        cli(f"first hour #4 a parameter only in an event/output ({name})", ["simulate", str(folder / name),
            "--t-final", "3", "-q"], judge=judge)
    m = models["cartpole"]

    def dict_rule():
        x = m.simulate({"x": 0.1}, (0, 0.01), n_points=2).x[0]
        want = np.array(m.initial_state)
        want[0] = 0.1
        return ("correct" if same(x, want) else "silent wrong", f"dict x0 fills initial_state: {same(x, want)}")
    attempt("first hour #7 dict x0 in Python fills initial_state (as the CLI)", dict_rule)

    def none_start():
        x = m.simulate(None, (0, 0.01), n_points=2).x[0]
        return ("correct" if same(x, m.initial_state) else "silent wrong", "simulate(None) starts at initial_state")
    attempt("first hour #7 simulate(None, ...)", none_start)
    if (folder / "slider_crank.py").exists():
        sc = str(folder / "slider_crank.py")

        def warn_judge(run):
            warn = [ln for ln in run.stderr.splitlines() if "warning" in ln]
            ok = len(warn) == 1 and "--consistent" in warn[0] and "simulate.py" not in run.stderr
            return ("correct" if ok else "silent wrong", warn[0][:200] if warn else run.stderr[-200:])
        cli("first hour #8 the CLI's constraint warning names --consistent, no source line",
            ["simulate", sc, "--t-final", "0.01", "--x0", "q1=0.3", "u1=1", "-q"], judge=warn_judge)

        def keeps(flag):
            def judge(run):
                first = np.loadtxt(WORK / "sc.csv", delimiter=",", skiprows=1)[0]
                ok = run.returncode == 0 and first[1] == 0.3
                return "correct" if ok else "silent wrong", f"q1 at t=0: {first[1]:.6g} (given 0.3)"
            return judge
        for flag in ("--consistent", "--project"):
            cli(f"first hour #8 eomc simulate {flag} --x0 q1=0.3 u1=1 keeps q1", ["simulate", sc, "--t-final", "1",
                "--x0", "q1=0.3", "u1=1", flag, "-o", str(WORK / "sc.csv"), "-q"], judge=keeps(flag))
    # the suite's own warnings and cache: three modules that warned before, with a fresh cache dir
    fresh = WORK / "user-cache"
    env = dict(os.environ, EOMC_CACHE_DIR=str(fresh))
    start = time.perf_counter()
    run = subprocess.run([PY, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/compiler/tree/test_select.py",
                          "tests/runtime/test_fastcall.py", "tests/cli/test_first_hour.py"], capture_output=True,
                         text=True, cwd=ROOT, env=env, timeout=900)
    tail = run.stdout.strip().splitlines()[-1] if run.stdout.strip() else run.stderr[-200:]
    entries = sum(1 for _ in fresh.rglob("*.json")) if fresh.exists() else 0
    noisy = "EomcWarning" in run.stdout
    line("first hour #9 test modules that warned about their own models (select, fastcall, first_hour)",
         "correct" if not noisy and run.returncode == 0 else "silent wrong",
         f"{time.perf_counter() - start:.0f}s: {tail}; EomcWarning in the summary: {noisy}")
    line("first hour #9 the same modules leave nothing in $EOMC_CACHE_DIR",
         "correct" if entries == 0 else "silent wrong", f"{entries} entries written into the given cache dir")


def main():
    kill = "--no-dask-kill" not in sys.argv
    import distributed
    say(f"# eomc reliability rerun, batch items (issue 24); {time.strftime('%Y-%m-%d %H:%M:%S %Z')}; "
        f"load {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} CPUs; eomc {eomc.__version__}, numpy "
        f"{np.__version__}, distributed {distributed.__version__}, python {sys.version.split()[0]}")
    say("")
    say("case | outcome | detail")
    say("---|---|---")
    try:
        models = build_models()
        n2(models)
        n3(models)
        n11(models, kill=kill)
        n12(models)
        n13(models)
        n14(models)
        first_hour(models)
    finally:
        shutil.rmtree(WORK, ignore_errors=True)
    say("")
    say("totals: " + ", ".join(f"{k}: {v}" for k, v in sorted(COUNTS.items())) +
        f"; end load {os.getloadavg()[0]:.2f}")
    if "--write" in sys.argv:
        (ROOT / "benchmarks" / "results" / "reliability_batches.md").write_text("\n".join(LINES) + "\n")
    return 0 if set(COUNTS) <= {"clear error", "correct"} else 1


if __name__ == "__main__":
    sys.exit(main())
