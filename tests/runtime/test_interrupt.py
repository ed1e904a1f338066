"""An exception or Ctrl-C stops the integrator at once (reliability report 2026-11-r3, N5).

The callable's failure used to look like a non-finite value to the C loop, which shrank the
step and called the callable again: the run went on to t_final (720 more calls) and Ctrl-C
landed 22-35 s late.  Now a failed callable returns EOMC_ABORTED (no retry, no further
call), and a SIGINT during a long C run without callbacks stops it within one model
evaluation (runtime/native.py arms eomc_interrupt_arm for the C call).
"""
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from helpers import osc_model
from eomc.compiler.build import build
from eomc.runtime.loader import load

METHODS = ("rk4", "dopri5", "dop853", "radau")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="module")
def osc(built):
    return load(built.directory)


def _raises_once_at(t_raise, exc):
    calls = {"after": 0, "raised": False}

    def r(t):
        if calls["raised"]:
            calls["after"] += 1
        elif t > t_raise:
            calls["raised"] = True
            raise exc
        return 0.5
    return r, calls


@pytest.mark.parametrize("method", METHODS)
def test_an_exception_in_the_callable_stops_the_run_at_once(osc, method):
    r, calls = _raises_once_at(0.5, RuntimeError("sensor lost"))
    kw = {"dt": 1e-3} if method == "rk4" else {}
    with pytest.raises(ValueError, match=r"r\(t\) raised RuntimeError at t=0\.5.*sensor lost"):
        osc.simulate([1.0, 0.0], (0, 30), r=r, method=method, **kw)
    assert calls["raised"] and calls["after"] == 0  # never called again after it raised


@pytest.mark.parametrize("exc", [KeyboardInterrupt, SystemExit])
def test_keyboard_interrupt_in_the_callable_propagates_at_once(osc, exc):
    r, calls = _raises_once_at(0.5, exc())
    with pytest.raises(exc):
        osc.simulate([1.0, 0.0], (0, 1e4), r=r, max_steps=10 ** 9)
    assert calls["raised"] and calls["after"] == 0    # at once: r is called every step, and never again after it raised


def test_a_callable_with_state_that_raises_stops_radau_too(osc):
    seen = []

    def r(t, x):
        seen.append(t)
        if t > 0.2:
            raise ArithmeticError("controller fault")
        return [0.0]
    with pytest.raises(ValueError, match="controller fault"):
        osc.simulate([1.0, 0.0], (0, 5), r=r, method="radau")
    assert sum(t > 0.2 for t in seen) == 1


CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    # as in an interactive session: a child of a background job (`cmd &` in a script, as CI
    # may be started) inherits SIGINT ignored, and then Ctrl-C reaches no one by design
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from eomc.runtime.loader import load
    model = load(sys.argv[1])
    calls = {"n": 0}
    def slow(t):
        calls["n"] += 1
        time.sleep(0.01)
        return 0.5
    kind = sys.argv[2]
    kw = dict(r=slow) if kind == "callable" else dict(max_steps=10 ** 12, n_points=2, p=[2.0, 0.0, 8.0])
    threading.Timer(0.5, lambda: (globals().__setitem__("sent", time.perf_counter()),
                                  os.kill(os.getpid(), signal.SIGINT))).start()
    try:
        model.simulate([1.0, 0.0], (0, 1e9), **kw)
        print("finished")
    except KeyboardInterrupt:
        print(f"interrupted {time.perf_counter() - sent:.3f} {calls['n']}")
    # a later run in the same process is not stopped by that old signal
    model.simulate([1.0, 0.0], (0, 1.0))
    print("later run ok")
""")


@pytest.mark.parametrize("kind", ["callable", "plain C run"])
def test_ctrl_c_lands_within_a_tenth_of_a_second(built, kind, tmp_path):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    proc = subprocess.run([sys.executable, str(script), str(built.directory), kind.split()[0]],
                          capture_output=True, text=True, timeout=60)
    lines = proc.stdout.split("\n")
    assert lines[0].startswith("interrupted"), proc.stdout + proc.stderr
    latency = float(lines[0].split()[1])
    assert latency < 0.1, lines[0]
    assert lines[1] == "later run ok", proc.stdout + proc.stderr


TERM_CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    class Terminated(BaseException):
        pass
    def on_term(signum, frame):     # as the command line's: SIGTERM unwinds like Ctrl-C
        raise Terminated()
    signal.signal(signal.SIGTERM, on_term)
    import eomc.runtime.simulate as sim
    from eomc.runtime.loader import load
    model = load(sys.argv[1])
    started, real = threading.Event(), sim.follow_integration
    def following(*args, **kwargs):     # the C loop is about to start
        started.set()
        return real(*args, **kwargs)
    sim.follow_integration = following
    def send():
        started.wait()
        time.sleep(0.3)
        globals()["sent"] = time.perf_counter()
        os.kill(os.getpid(), signal.SIGTERM)
    threading.Thread(target=send, daemon=True).start()
    try:
        model.simulate([1.0, 0.0], (0, 1e9), max_steps=10 ** 12, n_points=10 ** 6 + 1, p=[2.0, 0.0, 8.0])
        print("finished")
    except Terminated as stop:
        res = stop.partial_result
        print(f"terminated {time.perf_counter() - sent:.3f} {res.status} {len(res.t)} {res.t[-1] < res.t_final}")
""")


def test_sigterm_with_a_handler_stops_the_c_loop_and_keeps_the_rows(built, tmp_path):
    """s27: SIGTERM reached the program's handler only when the C call returned (a killed `eomc
    check` went on for minutes); now it stops the loop as Ctrl-C does, and the exception carries
    the rows computed so far (status 9)."""
    script = tmp_path / "child.py"
    script.write_text(TERM_CHILD)
    proc = subprocess.run([sys.executable, str(script), str(built.directory)], capture_output=True,
                          text=True, timeout=60)
    words = proc.stdout.split()
    assert words[:1] == ["terminated"], proc.stdout + proc.stderr
    assert float(words[1]) < 0.1 and words[2] == "9" and int(words[3]) >= 1 and words[4] == "True", words


def test_sigint_handler_is_python_s_again_after_a_run(osc):
    before = signal.getsignal(signal.SIGINT)
    osc.simulate([1.0, 0.0], (0, 1.0))
    assert signal.getsignal(signal.SIGINT) is before
    assert np.isfinite(osc.simulate([1.0, 0.0], (0, 1.0)).x_final).all()


ROLLOUT_TERM_CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    import numpy as np
    class Terminated(BaseException):
        pass
    def on_term(signum, frame):     # as the command line's: SIGTERM unwinds like Ctrl-C
        raise Terminated()
    signal.signal(signal.SIGTERM, on_term)
    import eomc
    from eomc.runtime.loader import load
    kind, where = sys.argv[1], sys.argv[2]
    if kind in ("adaptive", "extras"):  # the oscillator: 64 rows of ~10 s each (dop853 to t = 1e5)
        model = load(where)
        X0 = np.tile([1.0, 0.0], (64, 1))
        # "extras": method="auto" runs the rows through eomc_rollout_ex (runtime/rollout_extras.py)
        kw = dict(method="dop853" if kind == "adaptive" else "auto", t_final=1e5, max_steps=10 ** 12,
                  p=[2.0, 0.0, 8.0])
    else:                           # the cart in lanes: 512 rows of RK4, blocks of 64, ~10 s in all
        from eomc.compiler.driver import compile as compile_model
        model = compile_model(sys.argv[3], "rl_cart", functions=("rhs", "rhs_batch"), cache_dir=where,
                              progress=False)
        X0 = np.full((512, model.nx), 0.1)
        kw = dict(method="rk4", dt=1e-3, t_final=100.0, lanes=True)
    import eomc.runtime.rollout as ro
    started = threading.Event()
    def starting(real):                 # the C rollout is about to start (not the Python before it)
        def call(*args, **kwargs):
            started.set()
            return real(*args, **kwargs)
        return call
    ro._run_rows, ro._rollout_lanes = starting(ro._run_rows), starting(ro._rollout_lanes)
    import eomc.runtime.rollout_extras as rx
    rx.integrator_library = starting(rx.integrator_library)     # armed just before its C call
    def send():
        started.wait()
        time.sleep(0.3)
        globals()["sent"] = time.perf_counter()
        os.kill(os.getpid(), signal.SIGTERM)
    threading.Thread(target=send, daemon=True).start()
    try:
        eomc.rollout(model, X0, threads=2, **kw)
        print("finished")
    except Terminated as stop:
        res = getattr(stop, "partial_result", None)
        print("terminated", f"{time.perf_counter() - sent:.3f}", "none" if res is None else
              f"{len(res.status)} {int(np.sum(res.status == 9))} {int(np.sum((res.status != 0) & (res.status != 9)))} "
              f"{int(np.all(np.isnan(res.x[res.steps == 0])) and np.all(np.isfinite(res.x[res.status == 0])))}")
""")


@pytest.mark.parametrize("kind", ["adaptive", "lanes", "extras"])
def test_sigterm_stops_every_rollout_thread_and_keeps_the_rows(built, kind, tmp_path):
    """s29: a rollout's C threads went on taking rows after SIGTERM (or Ctrl-C): only the rows in
    flight stopped, and the program's handler ran when every row was done (25 s here on the
    adaptive rows, 9 s on the lanes).  Now no thread takes a row after the signal, the lanes' blocks
    stop at their next step, and the exception carries every row as a RolloutResult, those not run
    to the end status 9, those never started NaN (0 steps), those finished as they ended.  The
    rows with feedback, events or method="auto" (rollout_extras) kept none until s30."""
    script = tmp_path / "child.py"
    script.write_text(ROLLOUT_TERM_CHILD)
    where = str(built.directory) if kind != "lanes" else str(tmp_path / "cache")
    cart = Path(__file__).resolve().parents[2] / "examples" / "cart_pole_system.py"
    proc = subprocess.run([sys.executable, str(script), kind, where, str(cart)], capture_output=True, text=True,
                          timeout=120)
    words = proc.stdout.split()
    assert words[:1] == ["terminated"], proc.stdout + proc.stderr
    assert float(words[1]) < 1.0, words              # the whole rollout: 10 s
    n, stopped, other, nan_where_not_run = map(int, words[2:6])
    assert n == (512 if kind == "lanes" else 64) and stopped >= 1 and other == 0 and nan_where_not_run, words


@pytest.mark.parametrize("kind", ["simulate", "rollout", "rollout with events"])
def test_a_signal_between_the_arm_and_the_c_run_stops_it(osc, kind, monkeypatch):
    """CI, session 41: a Ctrl-C 0.5 s into docs/sweeps.md's million-row rollout was lost, and the rows
    ran to their end (156 s).  The signal came after the arm but before the C run read the signal
    count, so the run took it for an older one; Python raises KeyboardInterrupt only as the C call
    returns.  Now the run counts from the arm (eomc_options.interrupt_base).  Here the signal is
    sent right after the arm, to a Python handler that only records it: the run must stop at its
    first evaluation (before: it ran to its end with status 0)."""
    from eomc.runtime import native
    import eomc
    real = native._Interruptible._arm

    def arm_then_signal(self):
        base = real(self)
        os.kill(os.getpid(), signal.SIGINT)
        return base
    seen = []
    previous = signal.signal(signal.SIGINT, lambda *args: seen.append(args[0]))
    try:
        monkeypatch.setattr(native._Interruptible, "_arm", arm_then_signal)
        if kind == "simulate":
            res = osc.simulate([1.0, 0.0], (0, 100.0), method="dop853", raise_on_failure=False)
            status, steps = [res.status], [len(res.t)]
        else:
            extra = {"method": "auto"} if kind == "rollout with events" else {"method": "dop853"}
            res = eomc.rollout(osc, np.tile([1.0, 0.0], (8, 1)), t_final=100.0, threads=2,
                               raise_on_failure=False, **extra)
            status, steps = list(res.status), list(res.steps)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert seen, "the signal was not sent"
    assert all(s == 9 for s in status), (status, steps)
