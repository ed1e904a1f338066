"""`eomc simulate` stopped by SIGTERM (a job scheduler, `kill`) or Ctrl-C: the C loop stops at
once and the rows it computed are written, marked as stopped on the CSV's last line (s27: SIGTERM
waited for the whole run -- a killed Talos check went on for minutes -- and a stop lost the rows)."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from eomc.cli import main
from helpers import model_files

CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    # as in an interactive session (a background job inherits SIGINT ignored)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import eomc.runtime.simulate as sim
    from eomc.cli import main
    started, sent = threading.Event(), []
    real = sim.follow_integration
    def following(*args, **kwargs):     # the C loop is about to start
        started.set()
        return real(*args, **kwargs)
    sim.follow_integration = following
    def send():
        started.wait()
        time.sleep(0.3)
        sent.append(time.perf_counter())
        os.kill(os.getpid(), getattr(signal, sys.argv[1]))
    threading.Thread(target=send, daemon=True).start()
    code = main(["simulate", sys.argv[2], "--t-final", "1e9", "--rtol", "1e-13", "--atol", "1e-13",
                 "--max-steps", str(10 ** 12), "-o", sys.argv[3]])
    print("exit", code, f"{time.perf_counter() - sent[0]:.3f}")
""")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stop")
    model = model_files.write(folder, model_files.PENDULUM, "p")
    assert main(["build", str(model), "-o", str(folder / "out"), "-q", "--cache-dir",
                 str(folder / "cache")]) == 0
    return folder / "out"


@pytest.mark.parametrize("sig, status, what", [("SIGTERM", 143, "terminated (SIGTERM)"),
                                               ("SIGINT", 130, "interrupted (SIGINT, Ctrl-C)")])
def test_a_stopped_run_writes_its_rows_marked_as_stopped(built, tmp_path, sig, status, what):
    script, csv = tmp_path / "child.py", tmp_path / "traj.csv"
    script.write_text(CHILD)
    proc = subprocess.run([sys.executable, str(script), sig, str(built), str(csv)],
                          capture_output=True, text=True, timeout=120)
    last = proc.stdout.split("\n")[-2].split()
    assert last[:2] == ["exit", str(status)], proc.stdout + proc.stderr
    assert float(last[2]) < 2.0, last         # the 1e9 s run stopped at once (a loaded machine: 2 s)
    lines = csv.read_text().splitlines()
    assert lines[-1].startswith(f"# incomplete: {what} at t="), lines[-1]
    rows = np.genfromtxt(csv, delimiter=",", names=True, comments="#")
    assert rows.size >= 1 and np.all(np.isfinite(rows["q"]))
    assert f"wrote the {rows.size} rows computed up to t=" in proc.stderr, proc.stderr
    assert f"eomc simulate: {what.split()[0]}" in proc.stderr


SLOW_MODEL = textwrap.dedent("""
    import atexit, pathlib, sys, time
    from eomc.mechanics import *
    here = pathlib.Path(__file__).parent
    atexit.register(lambda: (here / "torn_down").write_text("the interpreter's exit ran"))
    (here / "ready").write_text("deriving")
    time.sleep(120)                      # a long derivation, stopped here
""")


@pytest.mark.parametrize("sig, status", [("SIGTERM", 143), ("SIGINT", 130)])
def test_the_stopped_program_ends_at_once(tmp_path, sig, status):
    """`eomc simulate` stopped while building ends when it says so (first hour s33: it printed
    "terminated" and then lived on 9 s on G1, ~20 s on dm_control's quadruped, freeing the
    build's SymPy graphs in the interpreter's teardown): the program leaves by os._exit once the
    stop has unwound, so the teardown (here an atexit hook, run by it) does not run; main([...])
    called from Python returns as before (the test above)."""
    import os
    import signal
    import time
    (tmp_path / "slow.py").write_text(SLOW_MODEL)
    child = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
             "from eomc.cli import main; sys.argv = ['eomc', 'simulate', 'slow.py', '-o', 'traj.csv']; "
             "sys.exit(main())")
    env = dict(os.environ, EOMC_CACHE_DIR=str(tmp_path / "cache"))
    proc = subprocess.Popen([sys.executable, "-c", child], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (tmp_path / "ready").exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(getattr(signal, sig))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == status, out + err
    assert ("terminated" if sig == "SIGTERM" else "interrupted") in err, err
    assert not (tmp_path / "torn_down").exists()
