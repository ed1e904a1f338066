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
