"""runtime/progress.py: a live ticker / bar on a terminal, nothing otherwise (pipes, logs, -q)."""
import io
import time

from eomc.runtime.progress import bar, ticker


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_ticker_draws_label_time_and_note_on_a_terminal_and_clears_itself():
    stream = Terminal()
    with ticker("eomc: compile", stream) as live:
        assert live.active
        live.note("after Jacobians")
        live.write("eomc:   Jacobians   1.000 s")
        time.sleep(0.05)
    text = stream.getvalue()
    assert "eomc: compile 00:00" in text and "after Jacobians" in text
    assert "eomc:   Jacobians   1.000 s\n" in text
    assert text.endswith("\r")              # the live line is erased (leave=False)


def test_bar_counts_to_total():
    stream = Terminal()
    live = bar(4, "eomc report", stream)
    for i in range(4):
        time.sleep(0.12)                    # tqdm redraws at most every 0.1 s
        live.update(1, f"row {i}")
    live.close()
    assert "4/4" in stream.getvalue() and "row 3" in stream.getvalue()


def test_nothing_is_drawn_off_a_terminal_or_when_quiet():
    plain = io.StringIO()
    for live in (ticker("x", plain), bar(5, "x", plain), ticker("x", Terminal(), enabled=False),
                 bar(5, "x", Terminal(), enabled=False)):
        assert not live.active
        live.note("n")
        live.update(1, "t")
        live.write("line")
        live.close()
    assert plain.getvalue() == ""


def test_driver_stages_use_the_ticker_on_a_terminal():
    from eomc.compiler.driver import Progress
    stream = Terminal()
    progress = Progress(True, stream)
    with progress.stage("derive"):
        progress.pass_done("cse", 0.5)
    text = stream.getvalue()
    assert "eomc: derive 00:00" in text                       # the live line
    assert "eomc:   common subexpressions" in text and " 0.500 s\n" in text
    assert "eomc: derive ..." not in text                      # no duplicate start line
    assert text.rstrip().splitlines()[-1].strip("\r ").startswith("eomc: derive ")
    off = io.StringIO()
    quiet = Progress(False, off)
    with quiet.stage("derive"):
        quiet.pass_done("cse", 0.5)
    assert off.getvalue() == ""
