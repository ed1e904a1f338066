"""-q on a terminal: silent for short stages, a live line once a stage turns long (a 5000-link
robot builds for many minutes; silence looked like a hang)."""
import io
import time

import pytest

from eomc.compiler.driver import Progress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def _run(progress, seconds):
    with progress.stage("generate"):
        time.sleep(seconds)


def test_quiet_shows_a_long_stage_on_a_terminal(monkeypatch):
    pytest.importorskip("tqdm")
    monkeypatch.setattr(Progress, "QUIET_LIVE_AFTER", 0.2)
    short, long_ = _Terminal(), _Terminal()
    _run(Progress("quiet", short), 0.0)
    _run(Progress("quiet", long_), 1.5)
    assert short.getvalue().strip() == ""
    assert "eomc: generate" in long_.getvalue()
    assert "0.0" not in short.getvalue()


def test_python_progress_false_stays_silent(monkeypatch):
    monkeypatch.setattr(Progress, "QUIET_LIVE_AFTER", 0.2)
    out = _Terminal()
    _run(Progress(False, out), 1.5)
    assert out.getvalue() == ""


def test_a_log_gets_a_line_only_for_a_long_stage(monkeypatch):
    """stderr a log (not a terminal), progress left to its default: a stage still running after
    LOG_AFTER seconds says so and then its time; a short stage, progress=False and -q say nothing
    (firsthour, session 20: `eomc simulate go2.urdf --floating-base --ground 2> run.log` built for
    minutes with the log empty)."""
    monkeypatch.setattr(Progress, "LOG_AFTER", 0.1)
    short, long_, off, quiet = io.StringIO(), io.StringIO(), io.StringIO(), io.StringIO()
    _run(Progress(None, short), 0.0)
    _run(Progress(None, long_), 0.5)
    _run(Progress(False, off), 0.5)
    _run(Progress("quiet", quiet), 0.5)
    assert short.getvalue() == "" and off.getvalue() == "" and quiet.getvalue() == ""
    lines = long_.getvalue().splitlines()
    assert lines[0] == "eomc: generate ... (still running after 0.1 s)", lines
    assert lines[1].startswith("eomc: generate") and lines[1].endswith(" s") and len(lines) == 2, lines


def _long_stage_log(monkeypatch, enabled, seconds=1.0, passes=()):
    monkeypatch.setattr(Progress, "LOG_AFTER", 0.1)
    monkeypatch.setattr(Progress, "LOG_EVERY", 0.25)
    log = io.StringIO()
    progress = Progress(enabled, log)
    with progress.stage("generate"):
        time.sleep(0.2)
        for name in passes:
            progress.pass_done(name, 0.0)
        time.sleep(seconds - 0.2)
    return log.getvalue().splitlines()


def test_a_long_stage_in_a_log_gets_a_line_every_interval(monkeypatch):
    """A log does not go silent after the first 'still running' line (firsthour5, session 24:
    dm_control's dog and humanoid_CMU generated for minutes with one line): one more line every
    LOG_EVERY seconds, each with the seconds so far, and no more than that (no spinner)."""
    lines = _long_stage_log(monkeypatch, None, seconds=1.0)
    running = [line for line in lines if "still running" in line]
    assert running[0] == "eomc: generate ... (still running after 0.1 s)", lines
    # 0.1 s, then every 0.25 s up to 1.0 s: 4 lines (a loaded machine may lose the last one)
    assert 3 <= len(running) <= 4, lines
    assert all(line.startswith("eomc: generate ... (still running after ") for line in running)
    assert lines[-1].startswith("eomc: generate ") and lines[-1].endswith(" s"), lines


def test_later_log_lines_say_which_pass_the_stage_is_past(monkeypatch):
    lines = _long_stage_log(monkeypatch, None, seconds=0.8, passes=("cse", "contacts"))
    later = [line for line in lines if "still running" in line][1:]
    assert later and all(line.endswith("s, 2 passes done, the last contact laws)")
                         for line in later), lines


def test_progress_on_in_a_log_also_reports_a_long_stage(monkeypatch):
    """`eomc build 2> build.log` asks for progress (True): its stage and pass lines come only as
    they end, so a long stage got no line at all while it ran."""
    lines = _long_stage_log(monkeypatch, True, seconds=0.5)
    assert lines[0] == "eomc: generate ...", lines
    assert lines[1] == "eomc: generate ... (still running after 0.1 s)", lines
    quiet = _long_stage_log(monkeypatch, "quiet", seconds=0.5)
    off = _long_stage_log(monkeypatch, False, seconds=0.5)
    assert quiet == [] and off == []


def test_later_log_lines_say_what_a_long_step_is_at_now(monkeypatch):
    """dm_control's dog (session 41) spent over ten minutes inlining its body-body contacts with rolling
    friction while every line said "26 passes done, the last dropping unused code": a step that notes
    what it is at (passes.timing.doing) is named on the next line, until the next pass ends."""
    from eomc.compiler.driver import Progress
    from eomc.compiler.passes.timing import doing, reporting
    monkeypatch.setattr(Progress, "LOG_AFTER", 0.1)
    monkeypatch.setattr(Progress, "LOG_EVERY", 0.25)
    log = io.StringIO()
    progress = Progress(None, log)
    with progress.stage("generate"), reporting(progress.pass_done, progress.now_doing):
        progress.pass_done("cse", 0.0)
        doing("inlining body-body contact 3 of 9 (foot_L-ball)")
        time.sleep(0.45)
        progress.pass_done("contacts", 0.0)
        time.sleep(0.3)
    running = [line for line in log.getvalue().splitlines() if "still running" in line]
    now = [line for line in running if line.endswith("1 passes done, the last common subexpressions; now inlining "
                                                      "body-body contact 3 of 9 (foot_L-ball))")]
    assert now, running
    assert running[-1].endswith("2 passes done, the last contact laws)"), running    # the note ended with its step
    doing("heard by nobody")        # no stage listening: nothing happens
