"""Writing a user's output file (a trajectory CSV, a plot, a results table) so that a
failure midway never leaves a half-written file in its place.

The content goes to a temporary file beside the target (same directory, so the
final ``os.replace`` is an atomic rename on one file system) and only a complete
file is renamed over the target; on any error the temporary file is removed and a
previous file of that name is left whole.
"""
import os
import stat
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path"]


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    A target that exists and is no file -- a device (``/dev/null``, ``/dev/stdout``), a named pipe,
    a socket -- is yielded itself and written in place: a rename would put a regular file where the
    device was (``eomc simulate -o /dev/null``, benchmarks/bench_startup.py's own command, replaced
    the machine's /dev/null with a file in session 28, and a test run beside it failed opening it).
    A symbolic link is followed: the file it points to is replaced and the link is kept."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = 0
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) or stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
        yield path
        return
    if path.is_symlink():
        path = Path(os.path.realpath(path))
    tmp = path.with_name(f".{path.name}.eomc-tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
