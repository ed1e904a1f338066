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
