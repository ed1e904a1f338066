"""Writing a user's output file (a trajectory CSV, a plot, a results table) so that a
failure midway never leaves a half-written file in its place.

The content goes to a temporary file beside the target (same directory, so the
final ``os.replace`` is an atomic rename on one file system) and only a complete
file is renamed over the target; on any error the temporary file is removed and a
previous file of that name is left whole.
"""
import os
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path"]


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success rename it to ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.eomc-tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
