"""A stand-in C compiler that never finishes on its own, for tests of killed and interrupted builds.

It answers ``--version`` like a compiler; any other call starts a long child (as
``cc`` starts ``cc1``), writes the child's pid to ``child.pid`` and waits for it.
"""
import os
import textwrap
import time

__all__ = ["slow_compiler", "wait_for_pid", "alive"]


def slow_compiler(directory):
    """Write the script into ``directory``; returns (script path, path of child.pid)."""
    script, pidfile = directory / "slowcc", directory / "child.pid"
    script.write_text(textwrap.dedent(f'''\
        #!/bin/sh
        if [ "$1" = "--version" ]; then echo "slowcc 1.0"; exit 0; fi
        sleep 60 &
        echo $! > {pidfile}
        wait
        '''))
    script.chmod(0o755)
    return script, pidfile


def wait_for_pid(path, seconds=120):
    """The pid written to ``path``, once it is there."""
    end = time.time() + seconds
    while time.time() < end:
        if path.exists() and path.read_text().strip():
            return int(path.read_text())
        time.sleep(0.05)
    raise AssertionError(f"{path} did not appear within {seconds} s")


def alive(pid):
    """True while ``pid`` runs (a zombie waiting to be reaped counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:  # pragma: no cover (no /proc)
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True
