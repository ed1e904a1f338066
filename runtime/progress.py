"""Progress on stderr for long steps: a live ticker or a bar, only on a terminal.

Why: deriving, generating and compiling a big model (the bicycle: a minute
or more) or running a report grid used to leave the terminal blank.  A
stage of unknown length gets a *ticker* (its name, the seconds so far and
what it is doing now, redrawn twice a second from a thread); a loop of known
length gets a *bar*.  Both are drawn by tqdm, and both are off when the
stream is not a terminal (logs and pipes keep the plain stage lines) or when
the caller says so (``-q``).
"""
import threading

__all__ = ["ticker", "bar", "is_terminal"]

REFRESH_S = 0.5


def is_terminal(stream):
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class _Off:
    """What ticker()/bar() return when there is nothing to draw: every call does nothing."""

    active = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def note(self, text):
        pass

    def write(self, line):
        """A whole line above the live one (without garbling it)."""

    def update(self, n=1, text=None):
        pass

    def close(self):
        pass


def _tqdm():
    try:
        from tqdm import tqdm
    except ImportError:  # a source tree without it: plain stage lines only
        return None
    return tqdm


class _Ticker(_Off):
    active = True

    def __init__(self, label, stream):
        self._bar = _tqdm()(total=None, desc=label, file=stream, leave=False,
                            bar_format="{desc} {elapsed}{postfix}", mininterval=REFRESH_S)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="eomc-progress", daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.wait(REFRESH_S):
            self._bar.refresh()

    def note(self, text):
        """What the stage is doing now (e.g. the compiler pass), shown after the time."""
        self._bar.set_postfix_str(text, refresh=True)

    def write(self, line):
        self._bar.write(line, file=self._bar.fp)

    def close(self):
        if not self._stop.is_set():
            self._stop.set()
            self._thread.join()
            self._bar.close()


class _Bar(_Off):
    active = True

    def __init__(self, total, label, stream, unit):
        self._bar = _tqdm()(total=total, desc=label, file=stream, leave=False, unit=unit)

    def update(self, n=1, text=None):
        if text is not None:
            self._bar.set_postfix_str(text, refresh=False)
        self._bar.update(n)

    def write(self, line):
        self._bar.write(line, file=self._bar.fp)

    def close(self):
        self._bar.close()


def ticker(label, stream, enabled=True):
    """A live 'label 0:12 postfix' line for a step of unknown length (use as a context manager)."""
    if not enabled or not is_terminal(stream) or _tqdm() is None:
        return _Off()
    return _Ticker(label, stream)


def bar(total, label, stream, enabled=True, unit="run"):
    """A progress bar over ``total`` items; ``update(1, text)`` after each."""
    if not enabled or total < 2 or not is_terminal(stream) or _tqdm() is None:
        return _Off()
    return _Bar(total, label, stream, unit)
