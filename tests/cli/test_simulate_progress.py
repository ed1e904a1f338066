"""`eomc simulate` with stderr not a terminal (a log, CI): a long run prints sparse plain
progress lines -- when both ~10 % of the span and a few seconds have passed -- and a
short run, or -q, prints none.  The integration is one C call followed from a thread
(runtime/progress.py); here the thresholds are lowered so that a run of a fraction of a
second shows them."""
import re

import pytest

from eomc.cli import main
from eomc.runtime import progress
from helpers import model_files

LINE = re.compile(r"^eomc simulate pend: t = (\S+) of \[0, (\S+)\] \((\d+) %\), (\d+) steps, \d+ s$")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("progress")
    model = model_files.write(folder, model_files.PENDULUM, "p")
    assert main(["build", str(model), "-o", str(folder / "out"), "-q", "--cache-dir",
                 str(folder / "cache")]) == 0
    return folder / "out"


def _simulate(built, *extra):
    # tight tolerances over a long span: a few hundred thousand steps, a fraction of a second
    return main(["simulate", str(built), "--t-final", "3000", "--rtol", "1e-13", "--atol", "1e-13",
                 "--points", "3", "--max-steps", "100000000", *extra])


def test_a_long_run_prints_sparse_increasing_lines_ending_at_the_end(built, capsys, monkeypatch):
    capsys.readouterr()
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.0)
    monkeypatch.setattr(progress, "POLL_S", 0.002)
    assert _simulate(built) == 0
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.startswith("eomc simulate pend:")]
    assert lines, captured.err
    parsed = [LINE.match(line) for line in lines]
    assert all(parsed), lines
    shares = [int(m.group(3)) for m in parsed]
    times = [float(m.group(1)) for m in parsed]
    assert shares[-1] == 100 and times[-1] == 3000.0, lines     # the last line: the end
    assert shares == sorted(shares) and times == sorted(times)
    # every ~10 % at most: consecutive lines (but the closing one) are >= 10 points apart
    assert all(b - a >= 9 for a, b in zip(shares[:-2], shares[1:-1])), shares
    assert len(lines) <= 12
    steps_total = int(re.search(r"(\d+) steps \(", captured.out).group(1))
    assert int(parsed[-1].group(4)) == steps_total         # read from the integrator's own stats


def test_quiet_or_a_short_run_prints_none(built, capsys, monkeypatch):
    capsys.readouterr()
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.0)
    monkeypatch.setattr(progress, "POLL_S", 0.002)
    assert _simulate(built, "-q") == 0
    assert "eomc simulate pend:" not in capsys.readouterr().err
    monkeypatch.undo()                     # the real thresholds: a sub-second run says nothing
    assert _simulate(built) == 0
    assert "eomc simulate pend:" not in capsys.readouterr().err


def test_lines_need_both_a_tenth_of_the_span_and_the_seconds():
    """The rule itself, on a scripted clock (no thread, no timing)."""
    import io
    stream, now = io.StringIO(), [0.0]
    follower = progress._Follower("run", stream, False, lambda: now[0])
    follower.begin(0.0, 10.0)
    # (t reached, wall s): t=1 at 0.5 s: too soon; t=2 at 6 s: 20 % and 6 s -> a line; t=2.5 at
    # 11 s: only 5 % more; t=5 at 12 s: 30 % more and 6 s -> a line; t=5.5 at 30 s: 5 % more;
    # t=9 at 31 s -> a line; then the end
    for t, wall in [(1.0, 0.5), (2.0, 6.0), (2.5, 11.0), (5.0, 12.0), (5.5, 30.0), (9.0, 31.0)]:
        now[0] = wall
        follower.poll(t, int(100 * t))
    follower.end(10.0, 1000)
    lines = stream.getvalue().splitlines()
    assert [line.split(" t = ")[1].split(" of")[0] for line in lines] == ["2", "5", "9", "10"], lines
    assert lines[0] == "run: t = 2 of [0, 10] (20 %), 200 steps, 6 s"
    quiet = io.StringIO()                 # a run that never printed does not print its end either
    follower = progress._Follower("run", quiet, False, lambda: 0.0)
    follower.begin(0.0, 10.0)
    follower.poll(9.0, 9)
    follower.end(10.0, 10)
    assert quiet.getvalue() == ""
