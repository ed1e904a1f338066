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
