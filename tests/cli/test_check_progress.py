"""`eomc check` says how far its long runs got (s27: G1's check ran 388 s in silence, its
references the longest part): in a log, the plain lines of runtime/progress.py, each naming the
run (which reference, which method, its tolerances); on a terminal, the ticker's live line."""
import re
import threading
import time

import pytest

from eomc.cli import main
from eomc.runtime import check_references, progress, stability
from helpers import model_files

LINE = re.compile(r"^eomc check pend: (.+): t = (\S+) of \[0, 300\] \((\d+) %\), (\d+) steps, \d+ s$")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("check_progress")
    model = model_files.write(folder, model_files.PENDULUM, "p")
    assert main(["build", str(model), "-o", str(folder / "out"), "-q", "--cache-dir",
                 str(folder / "cache")]) == 0
    return folder / "out"


def test_each_long_run_of_a_check_prints_lines_naming_it(built, capsys, monkeypatch):
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.0)
    monkeypatch.setattr(progress, "POLL_S", 0.002)
    # the references stop where they part (t = 105 of 300 here, s31): held together, they run to
    # t_final, long enough for lines (tests/runtime/test_check_references.py: the lines of a stop)
    monkeypatch.setattr(stability, "AGREE", 1e12)
    # the pendulum's references take milliseconds: a poll may never see them mid-run, and a run
    # no poll saw print nothing (right for a short run; ci31b failed on it, 1 in 3 after
    # test_check_references). Their comparison waits here until the follower printed a line.
    printed = threading.Event()
    poll, watch = progress._Follower.poll, check_references._watch

    def poll_noting(self, t, steps):
        poll(self, t, steps)
        if self.lines:
            printed.set()

    def watch_after_a_line(*args):
        printed.wait(60)
        return watch(*args)
    monkeypatch.setattr(progress._Follower, "poll", poll_noting)
    monkeypatch.setattr(check_references, "_watch", watch_after_a_line)
    capsys.readouterr()
    main(["check", str(built), "--t-final", "300", "--methods", "dop853"])
    err = capsys.readouterr().err
    parsed = [LINE.match(line) for line in err.splitlines() if line.startswith("eomc check pend: ")]
    assert parsed and all(parsed), err
    runs = {m.group(1) for m in parsed}
    # the references at 100x and 1000x tighter rtol (atol 1x, 10x), run at once (one line for
    # both, the tighter's time and steps: s31), and the method's own run (it may end before a
    # poll sees it)
    refs = "references: dop853 at rtol=1e-10 and 1e-11, compared as they go"
    named = {refs, "dop853 at rtol=1e-08, atol=1e-10"}
    assert refs in runs and runs <= named, runs
    for run in runs:       # each run's lines rise to its end
        shares = [int(m.group(3)) for m in parsed if m.group(1) == run]
        assert shares == sorted(shares) and shares[-1] == 100, (run, shares)
    capsys.readouterr()
    main(["check", str(built), "--t-final", "300", "--methods", "dop853", "-q"])
    assert "eomc check pend: " not in capsys.readouterr().err


def test_on_a_terminal_the_tickers_live_line_shows_the_run():
    notes = []

    class Live:
        active = True

        def note(self, text):
            notes.append(text)
    import io
    with progress.integration("eomc check pend", io.StringIO(), ticker=Live()), \
            progress.stage("reference: radau at rtol=1e-10, atol=1e-12"):
        read = iter([(0.5, 10), (1.0, 20)] + [(2.0, 40)] * 100)
        progress.follow_integration(lambda: next(read), 0.0, 2.0, lambda: __import__("time").sleep(0.6))
    assert notes and notes[0].startswith("reference: radau at rtol=1e-10, atol=1e-12: t=0.5 of 2 (25 %), 10 steps")


def test_the_reports_reference_prints_lines_naming_it(built, capsys, monkeypatch, tmp_path):
    """`eomc report`'s reference (DOP853 at 1e-13, then its check) printed nothing in a log until
    it ended (first hour s33: G1's took minutes, 113 s its DOP853 alone): its lines now say how far
    it got, as check's and simulate's do."""
    monkeypatch.setattr(progress, "LINE_SECONDS", 0.0)
    monkeypatch.setattr(progress, "POLL_S", 0.0005)
    # the pendulum's runs take milliseconds: under load (ci40: its check, stopped at t = 991 of
    # 3000, printed no line) the polling thread may not run before a run ends, and a run no poll
    # saw prints nothing (right for a short run).  Each followed run's end waits here until its
    # follower printed a line: the poll then reads the run's last state, so its lines still rise
    # to where it ended
    run = progress._Follower.run

    def run_until_a_line(self, read, t0, t1, call, resume=False):
        def held():
            try:
                return call()
            finally:
                deadline = time.monotonic() + 30
                while not self.lines and time.monotonic() < deadline:
                    time.sleep(0.001)
        return run(self, read, t0, t1, held, resume)
    monkeypatch.setattr(progress._Follower, "run", run_until_a_line)
    capsys.readouterr()
    # the reference is tied to the finest tolerance (1e-6 here); over 3000 s the pendulum's runs part
    # (exit 3, inconclusive): the lines are what is tested.  The check stops where the two differ by
    # more than a tenth of the target (s34): its lines rise to there
    assert main(["report", str(built), "--t-final", "3000", "--methods", "dop853", "--tolerances", "1e-3",
                 "--repeats", "1", "--reference-check", "dop853-half", "--target", "1",
                 "-o", str(tmp_path / "rep")]) in (0, 3)
    err = capsys.readouterr().err
    line = re.compile(r"^eomc report: reference(: its check, dop853 at rtol=5e-07)?: t = (\S+) of \[0, 3000\] "
                      r"\((\d+) %\), (\d+) steps, \d+ s$")
    parsed = [line.match(text) for text in err.splitlines() if text.startswith("eomc report: reference")
              and " t = " in text]
    assert parsed and all(parsed), err
    primary = [int(m.group(3)) for m in parsed if not m.group(1)]
    check = [int(m.group(3)) for m in parsed if m.group(1)]
    for shares in (primary, check):     # each run's lines rise to its end
        assert shares and shares == sorted(shares), err
    assert primary[-1] == 100, err
    stopped = re.search(r"its check stopped at t=(\S+), past where the two part", err)
    last = float([m.group(2) for m in parsed if m.group(1)][-1])
    assert last == 3000 if stopped is None else abs(last - float(stopped.group(1))) <= 1e-3 * last, err
