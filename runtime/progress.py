"""Progress on stderr for long steps: a live ticker or a bar on a terminal, sparse plain
lines for an integration whose stderr is a log.

Why: deriving, generating and compiling a big model (the bicycle: a minute
or more) or running a report grid used to leave the terminal blank.  A
stage of unknown length gets a *ticker* (its name, the seconds so far and
what it is doing now, redrawn twice a second from a thread); a loop of known
length gets a *bar*.  Both are drawn by tqdm, and both are off when the
stream is not a terminal (logs and pipes keep the plain stage lines) or when
the caller says so (``-q``).

An integration is one C call, so it is followed from a thread (:func:`integration`):
the integrators write the time they have reached into their stats as they step
(runtime/c/eomc_integrators.c), which the thread reads while the call runs
without the GIL.  On a terminal it draws a bar over the time span; in a log (CI,
a notebook's captured stderr, ``2> run.log``) it prints a plain line only when
both LINE_FRACTION of the span and LINE_SECONDS of wall time have passed since
the last one -- whichever is rarer -- so a short run prints nothing and a long
one about ten lines.  A command of many runs (`eomc check`: references, each
method; G1's took 388 s in silence before, s27) names each run (:func:`stage`) in
its lines, or in its ticker's live line on a terminal.
"""
import threading
import time
from contextlib import contextmanager

__all__ = ["ticker", "bar", "is_terminal", "integration", "follow_integration", "stage"]

REFRESH_S = 0.5
LINE_FRACTION = 0.1     # plain lines: at least this much more of the time span ...
LINE_SECONDS = 5.0      # ... and at least this many seconds of wall time since the last one
POLL_S = 0.25


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

    def __init__(self, label, stream, delay=0.0):
        # delay > 0: nothing is drawn before that many seconds (a quiet build that turns long)
        self._shown_after = time.monotonic() + delay
        self._bar = _tqdm()(total=None, desc=label, file=stream, leave=False, delay=delay,
                            bar_format="{desc} {elapsed}{postfix}", mininterval=REFRESH_S)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="eomc-progress", daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.wait(REFRESH_S):
            if time.monotonic() >= self._shown_after:
                self._bar.refresh()

    def note(self, text):
        """What the stage is doing now (e.g. the compiler pass), shown after the time."""
        self._bar.set_postfix_str(text, refresh=time.monotonic() >= self._shown_after)

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


def ticker(label, stream, enabled=True, delay=0.0):
    """A live 'label 0:12 postfix' line for a step of unknown length (use as a context manager);
    ``delay``: drawn only once the step has lasted that many seconds."""
    if not enabled or not is_terminal(stream) or _tqdm() is None:
        return _Off()
    return _Ticker(label, stream, delay)


def bar(total, label, stream, enabled=True, unit="run"):
    """A progress bar over ``total`` items; ``update(1, text)`` after each."""
    if not enabled or total < 2 or not is_terminal(stream) or _tqdm() is None:
        return _Off()
    return _Bar(total, label, stream, unit)


_current = threading.local()     # the integration() the calling thread is inside, if any


class _Follower:
    """Follows one C integration from a thread: ``run`` polls ``read()`` -> (t, steps).

    ``note``: a ticker's note (its live line, `eomc check`'s on a terminal) shows how far the run
    got, instead of a bar of its own."""

    def __init__(self, label, stream, live, clock, note=None):
        self.label, self.stream, self.live, self.clock, self.note = label, stream, live, clock, note
        self.lines = 0
        self._bar = None
        self.what = None

    def begin(self, t0, t1, resume=False):
        """``resume``: the same run goes on in a second call (method="auto" after it switched to
        Radau): the span, the clock and the last line's place carry on."""
        self.t0, self.t1 = t0, t1
        if not (resume and hasattr(self, "start")):
            self.start = self.clock()
            self.frac, self.wall = 0.0, self.start
            self.lines = 0
            self.what = getattr(_current, "stage", None)    # read here, on the caller's thread
        self.shown = 0
        if self.live and self.note is None:
            self._bar = _tqdm()(total=100, desc=self.label, file=self.stream, leave=False, unit="%",
                                bar_format="{desc} {percentage:3.0f}%|{bar}| {elapsed}{postfix}")

    def _line(self, t, steps):
        span = self.t1 - self.t0
        share = 100.0 * (t - self.t0) / span if span else 100.0
        what = f"{self.label}: {self.what}" if self.what else self.label
        print(f"{what}: t = {t:.6g} of [{self.t0:.6g}, {self.t1:.6g}] ({share:.0f} %), "
              f"{steps} steps, {self.clock() - self.start:.0f} s", file=self.stream, flush=True)
        self.lines += 1

    def poll(self, t, steps):
        """The integrator reached ``t`` after ``steps`` steps: redraw the bar, or print a line
        if LINE_FRACTION of the span and LINE_SECONDS have passed since the last one."""
        span = (self.t1 - self.t0) or 1.0
        frac = min(max((t - self.t0) / span, 0.0), 1.0)
        if self.note is not None:
            self.note(f"{self.what + ': ' if self.what else ''}t={t:.4g} of {self.t1:.4g} "
                      f"({100 * frac:.0f} %), {steps} steps")
            return
        if self._bar is not None:
            shown = int(100 * frac)
            if shown > self.shown:
                self._bar.update(shown - self.shown)
                self.shown = shown
            self._bar.set_postfix_str(f"t={t:.4g}, {steps} steps", refresh=True)
            return
        now = self.clock()
        if frac - self.frac >= LINE_FRACTION and now - self.wall >= LINE_SECONDS:
            self._line(t, steps)
            self.frac, self.wall = frac, now

    def end(self, t, steps):
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self.lines:                   # a long run said how far it got: say where it ended
            self._line(t, steps)

    def run(self, read, t0, t1, call, resume=False):
        """``call()`` (the C call) while a thread polls how far ``read()`` says it got."""
        stop = threading.Event()
        self.begin(t0, t1, resume)

        def watch():
            while not stop.wait(POLL_S):
                self.poll(*read())
        thread = threading.Thread(target=watch, name="eomc-integration-progress", daemon=True)
        thread.start()
        try:
            return call()
        finally:
            stop.set()
            thread.join()
            self.end(*read())


@contextmanager
def integration(label, stream, enabled=True, clock=time.monotonic, ticker=None):
    """Integrations run inside this block (on this thread) report progress on ``stream``: a bar
    on a terminal, sparse plain lines otherwise (module docstring); nothing when not
    ``enabled`` (``-q``).  The integrator's caller hands each C call to
    :func:`follow_integration`.  ``ticker``: a live :func:`ticker` already drawn for the whole
    command (`eomc check`: many runs), whose note then says how far each run got instead of a
    bar per run; lines name the run :func:`stage` says it is."""
    previous = getattr(_current, "follower", None)
    live = is_terminal(stream)
    if ticker is not None and ticker.active:
        _current.follower = _Follower(label, stream, False, clock, note=ticker.note) if enabled else None
    else:
        _current.follower = (_Follower(label, stream, live and _tqdm() is not None, clock)
                             if enabled and (not live or _tqdm() is not None) else None)
    try:
        yield _current.follower
    finally:
        _current.follower = previous


@contextmanager
def stage(what):
    """The integrations inside this block are ``what`` (`eomc check`'s "reference: radau at
    rtol=1e-10, atol=1e-12"): an enclosing :func:`integration`'s lines and note name it.  Inside
    another stage it is a part of that one: "reference", then "radau at ...", read as above."""
    previous = getattr(_current, "stage", None)
    _current.stage = f"{previous}: {what}" if previous else what
    try:
        yield
    finally:
        _current.stage = previous


def follow_integration(read, t0, t1, call, resume=False):
    """``call()``, followed by the enclosing :func:`integration` if there is one (else just
    the call).  ``read()`` -> (time reached, steps taken), read from another thread while
    ``call`` runs: it must be safe for that (a look at the integrator's stats struct).
    ``resume``: this call continues the previous one's run over the same span [t0, t1] (its
    lines and clock go on)."""
    follower = getattr(_current, "follower", None)
    if follower is None:
        return call()
    return follower.run(read, t0, t1, call, resume)
