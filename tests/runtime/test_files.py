"""Output files (trajectory CSV, plots, report tables) are written beside the target and
renamed: a failure midway keeps the previous file whole and leaves no temporary behind."""
import os
import stat
import threading

import numpy as np
import pytest

from eomc.runtime.files import atomic_path
from eomc.runtime.result import SimulationResult


def test_a_completed_write_replaces_the_target(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp != target
        tmp.write_text("new\n")
    assert target.read_text() == "new\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_a_failed_write_keeps_the_previous_file(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError, match="midway"):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("midway")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_trajectory_csv_is_not_half_written(tmp_path, monkeypatch):
    """`eomc simulate -o` writes through SimulationResult.to_csv."""
    res = SimulationResult.__new__(SimulationResult)
    target = tmp_path / "traj.csv"
    target.write_text("previous trajectory\n")
    monkeypatch.setattr(SimulationResult, "columns", lambda self: (["t", "q"], np.ones((3, 2))))

    def broken_savetxt(fname, *args, **kwargs):
        with open(fname, "w") as fh:
            fh.write("t,q\n1,")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savetxt", broken_savetxt)
    with pytest.raises(OSError, match="disk full"):
        res.to_csv(target)
    assert target.read_text() == "previous trajectory\n"
    assert [p.name for p in tmp_path.iterdir()] == ["traj.csv"]
    monkeypatch.undo()
    monkeypatch.setattr(SimulationResult, "columns", lambda self: (["t", "q"], np.ones((3, 2))))
    assert res.to_csv(target) == target
    assert target.read_text().splitlines()[0] == "t,q"


def test_a_named_pipe_is_written_in_place_not_renamed_over(tmp_path):
    """`eomc simulate -o /dev/null` (or a named pipe, /dev/stdout) replaced the device with a
    regular file (the rename): a target that is no file is written in place and stays what it was.
    (A FIFO stands for /dev/null here: a test must not risk the machine's /dev/null.)"""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    with atomic_path(fifo) as tmp:
        assert tmp == fifo
        tmp.write_text("t,q\n0,1\n")
    reader.join(timeout=10)
    assert got == ["t,q\n0,1\n"]
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


def test_a_symbolic_link_is_followed_and_kept(tmp_path):
    """The file a link points to is replaced; the link stays a link (the rename used to put a
    regular file in the link's place)."""
    (tmp_path / "data").mkdir()
    real = tmp_path / "data" / "traj.csv"
    real.write_text("old\n")
    link = tmp_path / "traj.csv"
    link.symlink_to(real)
    with atomic_path(link) as tmp:
        tmp.write_text("new\n")
    assert link.is_symlink() and real.read_text() == "new\n"
    assert sorted(p.name for p in (tmp_path / "data").iterdir()) == ["traj.csv"]
