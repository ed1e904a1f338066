"""eomc sweep: a cases CSV in, one row per case out (CSV or parquet), on processes or a Dask scheduler."""
import csv

import numpy as np
import pytest

from helpers import osc_model
from eomc.cli import main
from eomc.compiler.build import build
from eomc.runtime.batch import simulate_many
from eomc.runtime.loader import load


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "worker-cache"))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.fixture
def cases_csv(tmp_path):
    path = tmp_path / "cases.csv"
    path.write_text("case,q,k,F\nsoft,0.1,4,0\nstiff,0.2,9,1\npushed,0.3,5,-1\n\n")
    return path


def _expected(built):
    X0 = np.array([[0.1, 0.0], [0.2, 0.0], [0.3, 0.0]])
    P = np.array([[2.0, 0.5, 4.0], [2.0, 0.5, 9.0], [2.0, 0.5, 5.0]])
    return simulate_many(load(built.directory), X0, (0, 1.5), p=P, r=np.array([[0.0], [1.0], [-1.0]]),
                         progress=False)


def _read(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_sweep_on_local_processes_writes_final_states(built, cases_csv, tmp_path, capsys):
    out = tmp_path / "results.csv"
    assert main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1.5",
                 "-o", str(out), "--workers", "2", "--quiet"]) == 0
    rows, ref = _read(out), _expected(built)
    assert [r["case"] for r in rows] == ["soft", "stiff", "pushed"]
    assert list(rows[0]) == ["case", "q", "k", "F", "status", "t_final", "final_q", "final_u",
                             "final_energy", "message"]
    got = np.array([[float(r["final_q"]), float(r["final_u"])] for r in rows])
    np.testing.assert_array_equal(got, ref.x[:, -1])          # repr() round-trips: bit for bit
    assert [float(r["final_energy"]) for r in rows] == ref["energy"][:, -1].tolist()
    assert {r["status"] for r in rows} == {"0"} and {r["t_final"] for r in rows} == {"1.5"}
    assert "osc: 3 cases on 2 local processes, 0 failed; wrote" in capsys.readouterr().out


def test_sweep_on_a_dask_scheduler_writes_parquet(built, cases_csv, tmp_path):
    import distributed
    import pyarrow.parquet
    out = tmp_path / "results.parquet"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        assert main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1.5",
                     "-o", str(out), "--scheduler", cluster.scheduler_address, "--quiet"]) == 0
    table = pyarrow.parquet.read_table(out).to_pydict()
    assert table["case"] == ["soft", "stiff", "pushed"] and table["k"] == [4.0, 9.0, 5.0]
    assert table["final_q"] == _expected(built).x[:, -1, 0].tolist()


def test_failed_cases_are_rows_with_a_message(built, tmp_path, capsys):
    cases = tmp_path / "cases.csv"
    cases.write_text("m,q\n2,0.1\n0,0.1\n")                    # m = 0: singular mass matrix
    out = tmp_path / "r.csv"
    assert main(["sweep", str(built.directory), "--cases", str(cases), "--t-final", "1", "-o", str(out),
                 "--workers", "1", "--quiet"]) == 0
    rows = _read(out)
    assert [r["status"] for r in rows][0] == "0" and rows[1]["status"] != "0"
    assert "singular" in rows[1]["message"] and rows[0]["message"] == ""
    assert "1 failed" in capsys.readouterr().out


@pytest.mark.parametrize("text,args,match", [
    ("q,k\n0.1,four\n", [], r"cases.csv:2: column 'k': 'four' is not a number"),
    ("q,k\n0.1\n", [], r"cases.csv:2: 1 values for 2 columns"),
    ("q,stiffness\n0.1,2\n", [], "'stiffness' is not a state, parameter or input of osc"),
    ("q\n", [], "expected a header row"),
    ("q\n0.1\n", ["-o", "r.txt"], r"-o r.txt: write .csv or .parquet"),
    ("q\n0.1\n", ["--workers", "0"], "--workers must be at least 1"),
])
def test_bad_input_is_one_line(built, tmp_path, capsys, monkeypatch, text, args, match):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cases.csv").write_text(text)
    argv = ["sweep", str(built.directory), "--cases", "cases.csv", "--t-final", "1", "-o", "r.csv"]
    assert main(argv + args) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err and err.count("\n") == 1


def test_a_failed_write_leaves_the_previous_results_untouched(tmp_path, monkeypatch):
    """-o results.csv is written beside the target and renamed: a failure midway keeps the
    old file whole and leaves no temporary behind."""
    from eomc.cli import sweep as cli_sweep

    target = tmp_path / "results.csv"
    target.write_text("previous results\n")

    class Broken:
        def __init__(self, fh):
            self.fh = fh

        def writerow(self, row):
            self.fh.write("half,")

        def writerows(self, rows):
            raise OSError("disk full")

    monkeypatch.setattr(cli_sweep.csv, "writer", Broken)
    with pytest.raises(OSError, match="disk full"):
        cli_sweep._write(target, {"case": [0, 1], "q1": [0.5, 0.25]})
    assert target.read_text() == "previous results\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]


# ---- issue 24: events in the table, output checked first, CSV lines, Dask failures ---------------
import errno  # noqa: E402
import socket  # noqa: E402
import threading  # noqa: E402
from pathlib import Path  # noqa: E402

CARTPOLE = str(Path(__file__).resolve().parents[2] / "examples" / "cartpole_lqr.py")


@pytest.fixture(scope="module")
def cartpole_dir(tmp_path_factory):
    import eomc
    model = eomc.compile(CARTPOLE, output_dir=str(tmp_path_factory.mktemp("cartpole")), progress=False)
    return model


def test_terminal_event_cases_report_the_event_state(cartpole_dir, tmp_path, capsys):
    """N2: examples/cartpole_lqr.py's `fallen` stops each case; final_* = simulate()'s x_final."""
    from eomc.runtime.simulate import simulate
    cases = tmp_path / "cases.csv"
    cases.write_text("th\n3.0\n2.9\n2.5\n")
    out = tmp_path / "out.csv"
    assert main(["sweep", str(Path(cartpole_dir.library_path).parent), "--cases", str(cases),
                 "--t-final", "10", "-o", str(out), "-q", "--workers", "1"]) == 0
    rows = _read(out)
    for row, th in zip(rows, (3.0, 2.9, 2.5)):
        x0 = dict(zip(cartpole_dir.state_names, cartpole_dir.initial_state), th=th)
        single = simulate(cartpole_dir, x0, (0, 10))
        got = [float(row[f"final_{n}"]) for n in cartpole_dir.state_names]
        assert got == single.x_final.tolist() and float(row["t_final"]) == single.t_final
        assert row["event_stop"] == "fallen" and row["events_fallen"] == "1"
        assert float(row["first_fallen"]) == single.t_events["fallen"][0]
        assert float(row["final_bob_height"]) == pytest.approx(-0.6 * np.cos(single.x_final[1]), abs=1e-15)


@pytest.fixture
def no_sweep(monkeypatch):
    """Any attempt to run the sweep fails the test: the output must be refused before."""
    import eomc.runtime.sweep as runtime_sweep

    def refuse(*args, **kwargs):
        raise AssertionError("the sweep ran although its output cannot be written")
    monkeypatch.setattr(runtime_sweep, "sweep", refuse)


@pytest.mark.parametrize("target,message", [
    ("missing/r.csv", "the directory missing does not exist"),
    ("adir.csv", "adir.csv is a directory"),
])
def test_an_output_that_cannot_be_written_fails_before_the_sweep(built, cases_csv, tmp_path, capsys,
                                                                 monkeypatch, no_sweep, target, message):
    """N3: -o into a missing directory or onto a directory: one error line before any work."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir.csv").mkdir()
    assert main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1",
                 "-o", target, "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("eomc sweep: error: -o ") and message in err and err.count("\n") == 1


def test_a_read_only_directory_fails_before_the_sweep(built, cases_csv, tmp_path, capsys, monkeypatch,
                                                      no_sweep):
    """N3: a read-only mount (which root's os.access does not see) is found by creating a probe file;
    the failure of that creation is simulated here, as the tester's bind mount cannot be made in CI."""
    import tempfile

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")
    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    (tmp_path / "prev.csv").write_text("previous\n")
    assert main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1",
                 "-o", str(tmp_path / "prev.csv"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "cannot write in" in err and "Read-only file system" in err and err.count("\n") == 1
    assert (tmp_path / "prev.csv").read_text() == "previous\n"


def test_a_bad_cell_names_its_csv_line(built, tmp_path, capsys):
    """N13: inf at line 352 (case 350) with chunks of 100 is reported at line 352."""
    lines = ["m,q"] + ["2,0.1"] * 400
    lines[351] = "inf,0.1"               # file line 352
    cases = tmp_path / "cases.csv"
    cases.write_text("\n".join(lines) + "\n")
    assert main(["sweep", str(built.directory), "--cases", str(cases), "--t-final", "1", "-o",
                 str(tmp_path / "r.csv"), "--chunk-size", "100", "-q", "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert f"{cases}:352: osc: p (parameters) is not finite for m" in err and err.count("\n") == 1


@pytest.mark.parametrize("text,args,match", [
    ("q,x0\n0.1,1\n0.2,2\n", [], "'x0' is not a state, parameter or input of osc"),
    ("q\n0.1\n", ["--chunk-size", "0"], "--chunk-size must be a positive number of cases; got 0"),
])
def test_row_keys_and_chunk_size_zero_are_errors(built, tmp_path, capsys, monkeypatch, text, args, match):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cases.csv").write_text(text)
    assert main(["sweep", str(built.directory), "--cases", "cases.csv", "--t-final", "1", "-o", "r.csv",
                 "-q"] + args) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1


def test_an_excel_bom_is_not_part_of_the_first_name(built, tmp_path):
    cases = tmp_path / "cases.csv"
    cases.write_bytes("\ufeffq,k\r\n0.1,4\r\n".encode("utf-8"))
    out = tmp_path / "r.csv"
    assert main(["sweep", str(built.directory), "--cases", str(cases), "--t-final", "1", "-o", str(out),
                 "-q", "--workers", "1"]) == 0
    assert list(_read(out)[0])[:2] == ["q", "k"]


@pytest.fixture
def not_dask():
    """A TCP server that answers with bytes that are not Dask's protocol."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    stop = threading.Event()

    def serve():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            try:
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n" * 64)
            except OSError:
                pass
            conn.close()
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    server.close()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("where", ["refused", "not_dask"])
def test_dask_connection_failures_are_one_line(built, cases_csv, tmp_path, capsys, request, where):
    """N11: nothing listening, or something that is not Dask: one error line within the timeout."""
    import time
    address = (f"tcp://127.0.0.1:{_free_port()}" if where == "refused"
               else request.getfixturevalue("not_dask"))
    start = time.perf_counter()
    rc = main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1",
               "-o", str(tmp_path / "r.csv"), "--scheduler", address, "--connect-timeout", "2", "-q"])
    err = capsys.readouterr().err
    assert rc == 1 and err.startswith(f"eomc sweep: error: cannot connect to a Dask scheduler at {address}")
    assert err.count("\n") == 1 and time.perf_counter() - start < 30


def test_a_scheduler_without_workers_is_one_line(built, cases_csv, tmp_path, capsys):
    import distributed
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        rc = main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1",
                   "-o", str(tmp_path / "r.csv"), "--scheduler", cluster.scheduler_address,
                   "--connect-timeout", "1", "-q"])
    err = capsys.readouterr().err
    assert rc == 1 and "has no workers" in err and err.count("\n") == 1


def test_a_lost_cluster_is_one_error(monkeypatch):
    """N11: a worker or the scheduler lost mid-sweep surfaces as Dask's exceptions; they become
    one EomcError (the mechanism; killing a real cluster is in benchmarks/reliability_batches.py)."""
    from distributed.client import FutureCancelledError

    from eomc.cli import sweep as cli_sweep
    failure = cli_sweep._cluster_failure(FutureCancelledError("run_chunk-1", reason="already forgotten"),
                                         "tcp://h:8786")
    assert "the Dask cluster at tcp://h:8786 failed during the sweep" in str(failure)
    assert cli_sweep._cluster_failure(ValueError("mine"), "tcp://h:8786") is None


def test_parquet_without_pyarrow_names_the_extra(built, cases_csv, tmp_path, monkeypatch, capsys):
    """README's `eomc sweep ... -o results.parquet` after the quick start's `.[plot]` said "pip
    install pyarrow" where every other missing package names its extra (first hour s28): it names
    eomc[dask] (which brings pyarrow), pyarrow alone, and .csv, before any case runs."""
    import sys
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    assert main(["sweep", str(built.directory), "--cases", str(cases_csv), "--t-final", "1",
                 "-o", str(tmp_path / "r.parquet")]) != 0
    err = capsys.readouterr().err
    assert ('writing .parquet needs pyarrow, which is not installed: pip install "eomc[dask]" (from a clone of '
            'eomc: pip install ".[dask]"), or pyarrow alone; or write .csv') in err, err
    assert not (tmp_path / "r.parquet").exists()


def test_sigterm_stops_the_local_workers_at_once(built, tmp_path):
    """s29: SIGTERM (a scheduler's, `kill`'s) reaches the command only; its pool's shutdown then
    waited for every running chunk and the queued ones (82 s for 20,000 double-pendulum cases of
    200 s).  Now the workers are killed and nothing queued starts: the command exits 143 within
    seconds (800 oscillator cases of 2e4 s on 2 workers: ~60 s of work)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    cases = tmp_path / "long.csv"
    cases.write_text("q,k,c\n" + "".join(f"{0.1 + i * 1e-4},8,0\n" for i in range(800)))
    proc = subprocess.Popen([sys.executable, "-m", "eomc", "sweep", str(built.directory), "--cases", str(cases),
                             "--t-final", "2e4", "-o", str(tmp_path / "out.csv"), "--workers", "2"],
                            stderr=subprocess.PIPE, text=True, env=dict(os.environ))
    try:
        line = proc.stderr.readline()
        assert line.startswith("sweep: 800 cases in"), line
        time.sleep(2.0)                                 # the workers are in their first chunks
        sent = time.perf_counter()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=120)
        took = time.perf_counter() - sent
    finally:
        proc.kill()
    rest = proc.stderr.read()
    assert code == 143 and "terminated" in rest, (code, rest)
    assert took < 10.0, took
    assert not (tmp_path / "out.csv").exists()


def test_a_stopped_sweep_writes_the_chunks_that_came_back_marked_partial(built, tmp_path):
    """s29: a sweep stopped by SIGTERM (or Ctrl-C) wrote nothing, however many chunks had come back.
    Now -o gets every case: those of the finished chunks as they ended, the others status 9 with
    a "not run" message, the CSV's last line "# partial: ..." (written under a temporary name and
    renamed), and stderr says so; the exit status is still 143.  Here the first two chunks of 50
    (a soft spring: few steps) come back at once, the others (~4 s each) are stopped."""
    import signal
    import subprocess
    import sys
    cases = tmp_path / "long.csv"
    cases.write_text("q,k,c\n" + "".join(f"{0.1 + i * 1e-4},{8e-6 if i < 100 else 8},0\n" for i in range(800)))
    out = tmp_path / "out.csv"
    proc = subprocess.Popen([sys.executable, "-m", "eomc", "sweep", str(built.directory), "--cases", str(cases),
                             "--t-final", "2e4", "-o", str(out), "--workers", "2", "--chunk-size", "50"],
                            stderr=subprocess.PIPE, text=True)
    try:
        seen = []
        while not any(line.startswith("sweep: 100/800 cases") for line in seen):
            seen.append(proc.stderr.readline())
            assert seen[-1], seen
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=120)
    finally:
        proc.kill()
    rest = proc.stderr.read()
    assert code == 143 and "terminated" in rest, (code, rest)
    assert f"wrote the 100 of 800 cases whose chunks had finished to {out}, marked partial" in rest, rest
    lines = out.read_text().splitlines()
    assert lines[-1].startswith("# partial: the sweep was stopped; 100 of 800 cases ran"), lines[-1]
    rows = list(csv.DictReader(lines[:-1]))
    assert len(rows) == 800 and [r["status"] for r in rows] == ["0"] * 100 + ["9"] * 700
    assert all(np.isfinite(float(r["final_q"])) for r in rows[:100])
    assert all(r["final_q"] == "nan" and r["message"].startswith("not run") for r in rows[100:])
    assert not list(tmp_path.glob(".out.csv.eomc-tmp-*"))
