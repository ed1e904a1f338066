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
