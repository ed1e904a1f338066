"""Find and publish build-cache entries from the runtime: no SymPy, no eomc.compiler.

Why this module exists: a model unpickled on a worker (``travel.py``) must put
the library it carries into the worker's build cache, and a worker needs
numpy, cffi and a C compiler -- not the compiler package.  It follows the
layout and protocol of ``eomc.compiler.build.cache`` exactly, so an entry
published here is a hit there and the other way round
(``tests/runtime/test_pickle.py`` checks both directions):

- entries at ``<root>/<kind>/<key[:2]>/<key>/`` with a ``manifest.json`` that
  names the key, the cache schema and every file's size and sha256;
- one ``flock`` per key at ``<root>/locks/<key>.lock``, so N workers receiving
  the same model publish it once;
- work happens in ``<root>/tmp/`` and is published with one ``os.replace``,
  so a reader sees either nothing or a whole entry.
"""
import contextlib
import errno
import hashlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from eomc.runtime.errors import EomcError

__all__ = ["CACHE_SCHEMA", "MANIFEST", "cache_root", "hash_key", "sha256_bytes", "sha256_file",
           "entry_path", "write_manifest", "find", "publish", "directory_lock", "disk_error"]

CACHE_SCHEMA = 1          # eomc.compiler.build.cache uses this one (and the functions below)
MANIFEST = "manifest.json"

try:  # POSIX advisory locks; elsewhere entries still publish atomically.
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None


def cache_root(cache_dir=None):
    """The versioned cache root: ``cache_dir`` or $EOMC_CACHE_DIR or ~/.cache/eomc, plus /v1."""
    base = cache_dir or os.environ.get("EOMC_CACHE_DIR")
    if not base:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        base = os.path.join(xdg, "eomc")
    root = Path(base).expanduser().resolve() / f"v{CACHE_SCHEMA}"
    try:
        for sub in ("tmp", "locks"):
            (root / sub).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise EomcError(f"cannot use the build cache at {root} ({exc.strerror or exc}); "
                        f"set EOMC_CACHE_DIR to a writable directory") from None
    return root


def disk_error(exc, doing, hint="free some space (e.g. `eomc cache prune`) or set EOMC_CACHE_DIR elsewhere"):
    """One clear EomcError for a write that failed: ``cannot <doing>: <why>``.

    Why: a full disk (ENOSPC, EDQUOT) raised deep inside a copy is otherwise a
    traceback (``shutil.Error`` holds a list of per-file failures); the user needs
    to know which place is full or not writable, and nothing more.
    """
    if isinstance(exc, shutil.Error) and exc.args and isinstance(exc.args[0], list):
        why = exc.args[0][0][2] if exc.args[0] else str(exc)
        full = "No space left" in str(why) or "quota" in str(why).lower()
        reason = str(why)
    else:
        full = getattr(exc, "errno", None) in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC))
        reason = exc.strerror or str(exc)
    if full:
        return EomcError(f"cannot {doing}: the file system is full ({reason}); {hint}")
    where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
    return EomcError(f"cannot {doing}: {reason}{where}")


def hash_key(parts):
    """sha256 of a JSON-able description (the same function as the compiler's cache keys)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def sha256_bytes(data):
    return hashlib.sha256(data).hexdigest()


def sha256_file(path):
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def entry_path(root, kind, key):
    return root / kind / key[:2] / key


def find(root, kind, key, verify=()):
    """The published entry for ``key`` when it is whole, else None.

    Whole means what it means to the compiler's cache: the manifest names this key
    and schema, and every listed file has its recorded size *and* sha256 -- a
    same-size edit (an ``initial_state`` 1.0 -> 7.0 in NAME.json) is a miss, not
    served (reliability report r3, N10).  ``verify`` must name listed files (the
    library): an entry whose manifest does not list them is not whole either.
    """
    entry = entry_path(root, kind, key)
    try:
        manifest = json.loads((entry / MANIFEST).read_text())
        if manifest.get("key") != key or manifest.get("schema") != CACHE_SCHEMA:
            return None
        files = manifest["files"]
        if any(name not in files for name in verify):
            return None
        for name, info in files.items():
            path = entry / name
            if path.stat().st_size != info["size"] or sha256_file(path) != info["sha256"]:
                return None
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    with contextlib.suppress(OSError):  # a use: pruning drops the least recently used first
        os.utime(entry / MANIFEST)
    return entry


@contextlib.contextmanager
def directory_lock(directory, exclusive):
    """A flock on ``directory`` itself: ``eomc build -o`` publishes a model's files holding it
    exclusively, the loader reads them holding it shared, so a load never sees half of one
    build and half of another.  Best effort where a directory cannot be opened or locked."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        yield
        return
    try:
        if fcntl is not None:
            with contextlib.suppress(OSError):
                fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def _locked(root, key):
    try:
        fh = open(root / "locks" / f"{key}.lock", "a+")
    except OSError as exc:
        raise disk_error(exc, f"lock an entry of the build cache at {root}") from None
    with fh:
        if fcntl is not None:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fcntl is not None:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def write_manifest(directory, key, kind, inputs):
    """The entry's manifest.json: key, kind, schema and every file's size and sha256."""
    files = {}
    for path in sorted(directory.iterdir()):
        if path.is_file() and path.name != MANIFEST:
            files[path.name] = {"size": path.stat().st_size, "sha256": sha256_file(path)}
    manifest = {"schema": CACHE_SCHEMA, "kind": kind, "key": key, "created": time.time(),
                "inputs": inputs, "files": files}
    (directory / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True, default=str))


def publish(root, kind, key, write, inputs, verify=()):
    """(entry, published): ``write(tmpdir)`` fills a new entry, under the key's lock.

    Another process that published the key first wins: its entry is returned
    and ``write`` never runs (``published`` is False).  A stale or corrupt
    entry is moved aside and replaced.
    """
    with _locked(root, key):
        found = find(root, kind, key, verify)
        if found is not None:
            return found, False
        entry = entry_path(root, kind, key)
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f"{key}-", dir=root / "tmp"))  # reclaimable (cache.reclaim_tmp)
        except OSError as exc:
            raise disk_error(exc, f"write into the build cache at {root}") from None
        try:
            try:
                write(tmp)
                write_manifest(tmp, key, kind, inputs)
            except OSError as exc:
                raise disk_error(exc, f"write into the build cache at {root}") from None
            if entry.exists():
                trash = Path(tempfile.mkdtemp(prefix=f"trash-{os.getpid()}-", dir=root / "tmp"))
                with contextlib.suppress(OSError):
                    os.replace(entry, trash / "entry")
                shutil.rmtree(trash, ignore_errors=True)
            entry.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp, entry)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return entry, True
