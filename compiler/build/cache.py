"""Content-addressed build cache: key -> directory of artifacts plus manifest.json.

Layout under the root (``$EOMC_CACHE_DIR/v1`` or ``~/.cache/eomc/v1``)::

    <kind>/<key[:2]>/<key>/     published entries (read-only once published)
    locks/<key>.lock            one flock per key, never deleted
    tmp/                        builds in progress (same filesystem as entries)
    failed/<name>-<key[:12]>/   sources of a failed compile, kept for the user

Why this shape: a build writes into ``tmp/`` and is published with one
``os.replace``, so readers see either nothing or a whole entry.  The per-key
lock makes N processes building the same model do the work once; the others
wait and then find the entry.  An entry whose manifest is missing, does not
match its key or lists a missing or resized file is a miss and is rebuilt.
"""
import contextlib
import hashlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

from eomc.runtime.errors import EomcError

__all__ = ["CACHE_SCHEMA", "cache_root", "hash_key", "sha256_file", "lookup", "get_or_build", "discard",
           "touch", "try_locked"]

CACHE_SCHEMA = 1
MANIFEST = "manifest.json"

try:  # POSIX advisory locks; elsewhere builds still publish atomically.
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


def hash_key(parts):
    """sha256 of a JSON-able description of everything that changes the artifact."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def sha256_file(path):
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _entry(root, kind, key):
    return root / kind / key[:2] / key


def _valid(entry, key):
    """True when the entry is whole: manifest matches the key and every listed file has its size."""
    try:
        manifest = json.loads((entry / MANIFEST).read_text())
        if manifest.get("key") != key or manifest.get("schema") != CACHE_SCHEMA:
            return False
        return all((entry / name).stat().st_size == info["size"]
                   for name, info in manifest["files"].items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def touch(entry):
    """Record a use: the manifest's mtime is the entry's last use (pruning drops the
    least recently used first).  Best effort: a read-only cache still works."""
    try:
        os.utime(Path(entry) / MANIFEST)
    except OSError:
        pass


def lookup(root, kind, key):
    """The published entry for ``key`` when it is whole, else None."""
    entry = _entry(root, kind, key)
    if not _valid(entry, key):
        return None
    touch(entry)
    return entry


@contextlib.contextmanager
def try_locked(root, key):
    """Yield True holding the key's lock, or False at once when someone else holds it."""
    path = root / "locks" / f"{key}.lock"
    with open(path, "a+") as fh:
        if fcntl is None:
            yield True
            return
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


@contextlib.contextmanager
def _locked(root, key):
    path = root / "locks" / f"{key}.lock"
    with open(path, "a+") as fh:
        if fcntl is not None:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fcntl is not None:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def _write_manifest(directory, key, kind, inputs):
    files = {}
    for path in sorted(directory.iterdir()):
        if path.is_file() and path.name != MANIFEST:
            files[path.name] = {"size": path.stat().st_size, "sha256": sha256_file(path)}
    manifest = {"schema": CACHE_SCHEMA, "kind": kind, "key": key, "created": time.time(),
                "inputs": inputs, "files": files}
    (directory / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True, default=str))


def discard(root, entry):
    """Move a (corrupt) entry out of the way atomically, then delete it."""
    entry = Path(entry)
    if not entry.exists():
        return
    trash = Path(tempfile.mkdtemp(prefix="trash-", dir=root / "tmp"))
    try:
        os.replace(entry, trash / "entry")
    except OSError:
        pass
    shutil.rmtree(trash, ignore_errors=True)


def get_or_build(root, kind, key, build, inputs, force=False):
    """Return (entry, hit).  ``build(tmpdir)`` writes the artifacts; it runs under the key's lock.

    ``force`` discards a published entry first (used when an entry looked whole
    but failed to load).  ``build`` may raise; the temp dir is then removed and
    the error propagates (it keeps any source it wants the user to see).
    """
    entry = _entry(root, kind, key)
    if not force and _valid(entry, key):
        touch(entry)
        return entry, True
    with _locked(root, key):
        if not force and _valid(entry, key):
            touch(entry)
            return entry, True
        tmp = Path(tempfile.mkdtemp(prefix=f"{key[:12]}-", dir=root / "tmp"))
        try:
            build(tmp)
            _write_manifest(tmp, key, kind, inputs)
            discard(root, entry)
            entry.parent.mkdir(parents=True, exist_ok=True)
            os.replace(tmp, entry)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return entry, False
