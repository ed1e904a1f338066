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
match its key, or lists a file that is missing or whose sha256 differs from
the recorded one is a miss and is rebuilt (a damaged entry with a warning).

A reader *holds* an entry while it copies or loads it: a shared flock on the
key's lock, which ``cache clear``/``prune`` (exclusive, non-blocking) respect,
so an entry in use is never removed under a reader.  A build's temporary
directory is named by its key; one whose key lock is free belongs to a build
that died (kill -9) and is removed by the next build, prune or clear.
"""
import contextlib
import json
import os
import re
import shutil
import tempfile
import time
import warnings
from pathlib import Path

from eomc.runtime.errors import EomcError, EomcWarning
# the layout, keys and manifests are shared with the runtime's SymPy-free publisher (travel.py)
from eomc.runtime.store import (CACHE_SCHEMA, MANIFEST, cache_root, disk_error, entry_path, hash_key,
                                sha256_file, write_manifest)

__all__ = ["CACHE_SCHEMA", "cache_root", "hash_key", "sha256_file", "lookup", "get_or_build", "discard",
           "touch", "try_locked", "hold", "reclaim_tmp", "entry_files", "BadEntry", "CacheWarning"]


try:  # POSIX advisory locks; elsewhere builds still publish atomically.
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None


class CacheWarning(EomcWarning):
    """A damaged cache entry was found (and is rebuilt)."""


class BadEntry(EomcError):
    """A cache entry vanished or changed while it was being used; callers rebuild it."""


def _not_writable(root, exc, doing):
    return EomcError(f"cannot {doing}: the build cache at {root} is not writable "
                     f"({exc.strerror or exc}); set EOMC_CACHE_DIR to a writable directory")


def _damage(entry, key):
    """None when the entry is whole, else why not: "absent", or the first damaged file.

    Whole means: the manifest matches the key and every listed file has its
    recorded size *and* sha256 (a same-size edit or corruption is caught).
    """
    try:
        manifest = json.loads((entry / MANIFEST).read_text())
    except FileNotFoundError:
        return "manifest.json is missing" if entry.is_dir() else "absent"
    except (OSError, ValueError):
        return "manifest.json is unreadable"
    try:
        if manifest.get("key") != key or manifest.get("schema") != CACHE_SCHEMA:
            return "manifest.json does not match the entry"
        for name, info in manifest["files"].items():
            path = entry / name
            if path.stat().st_size != info["size"] or sha256_file(path) != info["sha256"]:
                return f"{name} differs from the file that was built"
        return None
    except FileNotFoundError as exc:
        return f"{Path(exc.filename or '?').name} is missing"
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return "manifest.json is malformed"


def _valid(entry, key):
    """True when the entry is whole (see :func:`_damage`)."""
    return _damage(entry, key) is None


def _warn_damaged(entry, why):
    warnings.warn(f"the build cache entry {entry} was damaged ({why}); rebuilding it", CacheWarning,
                  stacklevel=3)


def entry_files(entry):
    """{file name: sha256} of a published entry, from its manifest (BadEntry when it is gone)."""
    try:
        manifest = json.loads((Path(entry) / MANIFEST).read_text())
        return {name: info["sha256"] for name, info in manifest["files"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        raise BadEntry(f"the build cache entry {entry} vanished or changed while in use") from None


def touch(entry):
    """Record a use: the manifest's mtime is the entry's last use (pruning drops the
    least recently used first).  Best effort: a read-only cache still works."""
    try:
        os.utime(Path(entry) / MANIFEST)
    except OSError:
        pass


def lookup(root, kind, key, hold_in=None):
    """The published entry for ``key`` when it is whole, else None (a damaged one: with a warning).

    With ``hold_in`` (a contextlib.ExitStack) the entry stays held until the stack closes.
    """
    entry = entry_path(root, kind, key)
    with contextlib.ExitStack() as held:
        held.enter_context(hold(root, key))
        why = _damage(entry, key)
        if why is not None:
            if why != "absent":
                _warn_damaged(entry, why)
            return None
        touch(entry)
        if hold_in is not None:
            hold_in.enter_context(held.pop_all())
        return entry


def _open_lock(path, mode="a+"):
    """The key's lock file (a seam for tests of unwritable caches)."""
    return open(path, mode)


@contextlib.contextmanager
def hold(root, key):
    """A shared lock on ``key`` while its entry is read: prune and clear leave it alone.

    Blocks only while the entry is being (re)built.  On a read-only cache it
    holds what it can (nobody can remove entries there anyway).
    """
    path = root / "locks" / f"{key}.lock"
    try:
        fh = _open_lock(path)
    except OSError:
        try:
            fh = _open_lock(path, "r")
        except OSError:
            yield
            return
    with fh:
        if fcntl is not None:
            fcntl.flock(fh.fileno(), fcntl.LOCK_SH)
        yield


@contextlib.contextmanager
def try_locked(root, key):
    """Yield True holding the key's lock, or False at once when someone else holds it."""
    path = root / "locks" / f"{key}.lock"
    try:
        fh = _open_lock(path)
    except OSError as exc:
        raise _not_writable(root, exc, "change the build cache") from None
    with fh:
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


def _lock_exclusive(root, key):
    """The key's lock file, held exclusively (the caller closes it to release)."""
    path = root / "locks" / f"{key}.lock"
    try:
        fh = _open_lock(path)
    except OSError as exc:
        raise _not_writable(root, exc, "build") from None
    if fcntl is not None:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
    return fh


_KEYED_TMP = re.compile(r"([0-9a-f]{64})-")
_TRASH = re.compile(r"trash-(\d+)-")
_ABANDONED_TRASH_SECONDS = 60


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def reclaim_tmp(root, now=None, held=()):
    """Remove temporary directories of builds that died (kill -9, power loss).

    A build's directory is named ``<key>-*`` and exists only while the build
    holds the key's lock, so a free lock means its owner is gone; so does a
    directory of a key in ``held``, whose lock the caller holds (and has not yet
    made its own directory).  ``trash-<pid>-*`` (an entry being deleted) is
    reclaimed when its process is gone.  Returns the paths removed.
    """
    tmp = Path(root) / "tmp"
    now = time.time() if now is None else now
    removed = []
    try:
        listed = list(tmp.iterdir())
    except OSError:
        return removed
    for path in listed:
        keyed, trash = _KEYED_TMP.match(path.name), _TRASH.match(path.name)
        try:
            if keyed and keyed.group(1) in held:
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
            elif keyed:
                with try_locked(root, keyed.group(1)) as free:
                    if free:
                        shutil.rmtree(path, ignore_errors=True)
                        removed.append(path)
            elif (trash and not _pid_alive(int(trash.group(1)))
                  and now - path.stat().st_mtime > _ABANDONED_TRASH_SECONDS):
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
        except (OSError, EomcError):
            pass
    return removed


def discard(root, entry):
    """Move a (corrupt) entry out of the way atomically, then delete it."""
    entry = Path(entry)
    if not entry.exists():
        return
    trash = Path(tempfile.mkdtemp(prefix=f"trash-{os.getpid()}-", dir=root / "tmp"))
    try:
        os.replace(entry, trash / "entry")
    except OSError:
        pass
    shutil.rmtree(trash, ignore_errors=True)


def get_or_build(root, kind, key, build, inputs, force=False, hold_in=None):
    """Return (entry, hit).  ``build(tmpdir)`` writes the artifacts; it runs under the key's lock.

    ``force`` discards a published entry first (used when an entry looked whole
    but failed to load).  ``build`` may raise; the temp dir is then removed and
    the error propagates (it keeps any source it wants the user to see).
    With ``hold_in`` (a contextlib.ExitStack) the entry is returned held (see
    :func:`hold`) until that stack closes; without it, it may be pruned at any time.
    A damaged entry (a file whose sha256 changed) is rebuilt with a CacheWarning.
    """
    entry = entry_path(root, kind, key)
    if not force:
        found = lookup(root, kind, key, hold_in)
        if found is not None:
            return found, True
    fh = _lock_exclusive(root, key)
    try:
        why = None if force else _damage(entry, key)
        if why is None and not force:
            touch(entry)
        else:
            reclaim_tmp(root, held=(key,))
            try:
                tmp = Path(tempfile.mkdtemp(prefix=f"{key}-", dir=root / "tmp"))
            except OSError as exc:
                raise _not_writable(root, exc, "build") from None
            try:
                try:
                    build(tmp)
                    write_manifest(tmp, key, kind, inputs)
                except OSError as exc:  # a full disk mid-build: one clear line (report r3, N10)
                    raise disk_error(exc, f"build into the cache at {root}") from None
                discard(root, entry)
                entry.parent.mkdir(parents=True, exist_ok=True)
                os.replace(tmp, entry)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        if hold_in is not None and fcntl is not None:
            # keep the entry: exclusive -> shared (not atomic on Linux; a prune that slips
            # in between makes the caller see BadEntry, which is a miss like any other)
            fcntl.flock(fh.fileno(), fcntl.LOCK_SH)
            hold_in.callback(fh.close)
            fh = None
    finally:
        if fh is not None:
            fh.close()
    return entry, why is None and not force
