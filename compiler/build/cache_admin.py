"""What the build cache holds, and taking it back: sizes, ages, pruning.

Why this exists: every distinct model, parameter folding, flag set and eomc
version is a new cache entry, and nothing else ever deletes one.  Entries
record their last use (the manifest's mtime, refreshed on every hit by
:func:`eomc.compiler.build.cache.touch`), so pruning can drop the least
recently used first.  A new entry triggers :func:`auto_prune` when the cache
grows past ``$EOMC_CACHE_MAX_SIZE`` (default 2 GiB; ``0`` turns it off).

Removal is safe with other processes at work: an entry whose per-key lock is
held (a build in progress, or a reader holding it while it copies or loads it) is skipped, and an entry is moved aside with one
``os.replace`` before it is deleted, so readers see it whole or not at all.
A process that already loaded a library keeps it: unlinking a mapped file
does not unmap it.
"""
import json
import os
import re
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from eomc.runtime.errors import EomcError

from .cache import MANIFEST, discard, reclaim_tmp, try_locked

__all__ = ["CacheEntry", "entries", "usage", "prune", "clear", "auto_prune", "parse_size",
           "parse_age", "format_size", "DEFAULT_MAX_SIZE"]

DEFAULT_MAX_SIZE = 2 * 1024 ** 3
STALE_TMP_SECONDS = 24 * 3600      # builds in progress are minutes old at most
_RESERVED = {"locks", "tmp", "failed"}


@dataclass(frozen=True)
class CacheEntry:
    kind: str           # "models", "generated", ...
    key: str
    path: Path
    size: int           # bytes on disk
    last_used: float    # seconds since the epoch
    name: str           # the model's name, when the manifest says


def _tree_size(path):
    total = 0
    for dirpath, _, files in os.walk(path):
        for f in files:
            try:
                total += os.lstat(os.path.join(dirpath, f)).st_size
            except OSError:
                pass
    return total


def _name_of(manifest):
    inputs = manifest.get("inputs") or {}
    name = inputs.get("name") if isinstance(inputs, dict) else None
    if not name:
        libs = [f for f in manifest.get("files", {}) if f.startswith("lib") and f.endswith(".so")]
        name = libs[0][3:-3] if libs else ""
    return str(name)


def entries(root):
    """Every entry under ``root`` (published ones, whole or not), oldest use first."""
    root = Path(root)
    found = []
    for kind_dir in sorted(p for p in root.iterdir() if p.is_dir() and p.name not in _RESERVED):
        for entry in sorted(kind_dir.glob("*/*")):
            if not entry.is_dir():
                continue
            manifest_path = entry / MANIFEST
            try:
                manifest = json.loads(manifest_path.read_text())
                last_used = manifest_path.stat().st_mtime
            except (OSError, ValueError):
                try:
                    manifest, last_used = {}, entry.stat().st_mtime
                except OSError:     # removed meanwhile by another process
                    continue
            found.append(CacheEntry(kind_dir.name, entry.name, entry, _tree_size(entry), last_used,
                                    _name_of(manifest) if isinstance(manifest, dict) else ""))
    return sorted(found, key=lambda e: (e.last_used, e.kind, e.key))


def usage(root):
    """{"entries": [...], "by_kind": {kind: (count, bytes)}, "failed": bytes, "tmp": bytes, "total": bytes}."""
    root = Path(root)
    listed = entries(root)
    by_kind = {}
    for e in listed:
        count, size = by_kind.get(e.kind, (0, 0))
        by_kind[e.kind] = (count + 1, size + e.size)
    failed = _tree_size(root / "failed") if (root / "failed").exists() else 0
    tmp = _tree_size(root / "tmp") if (root / "tmp").exists() else 0
    return {"entries": listed, "by_kind": by_kind, "failed": failed, "tmp": tmp,
            "total": sum(e.size for e in listed) + failed + tmp}


def _remove(root, entry):
    """Discard one entry unless a build holds its lock; True when it is gone."""
    with try_locked(root, entry.key) as got:
        if not got:
            return False
        discard(root, entry.path)
    return not entry.path.exists()


def _stale_tmp(root, now):
    """Leftovers of builds that died (a crash, kill -9): at once when their key's lock
    is free (see cache.reclaim_tmp), otherwise after a day."""
    reclaim_tmp(root, now)
    tmp = root / "tmp"
    if not tmp.exists():
        return
    for path in tmp.iterdir():
        try:
            if now - path.stat().st_mtime > STALE_TMP_SECONDS:
                shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink()
        except OSError:
            pass


def prune(root, max_size=None, older_than=None, dry_run=False, now=None, keep=()):
    """Remove entries unused for ``older_than`` seconds, then least recently used ones
    until the entries fit in ``max_size`` bytes.  Entries whose key is in ``keep`` stay.
    Returns the entries removed (or, with ``dry_run``, that would be)."""
    root = Path(root)
    now = time.time() if now is None else now
    listed = [e for e in entries(root) if e.key not in keep]
    doomed = [e for e in listed if older_than is not None and now - e.last_used > older_than]
    if max_size is not None:
        kept = [e for e in listed if e not in doomed]
        total = sum(e.size for e in kept)
        for e in kept:              # oldest use first
            if total <= max_size:
                break
            doomed.append(e)
            total -= e.size
    if dry_run:
        return doomed
    _stale_tmp(root, now)
    return [e for e in doomed if _remove(root, e)]


def clear(root):
    """Remove every entry and every kept failed build; returns the bytes freed."""
    root = Path(root)
    before = usage(root)["total"]
    for e in entries(root):
        _remove(root, e)
    shutil.rmtree(root / "failed", ignore_errors=True)
    _stale_tmp(root, time.time())     # a build in progress keeps its fresh tmp directory
    return before - usage(root)["total"]


def max_size_from_env():
    """``$EOMC_CACHE_MAX_SIZE`` in bytes (None: no limit); EomcError when it is not a size."""
    text = os.environ.get("EOMC_CACHE_MAX_SIZE")
    if text is None or not text.strip():
        return DEFAULT_MAX_SIZE
    try:
        size = parse_size(text)
    except ValueError:
        raise EomcError(f"EOMC_CACHE_MAX_SIZE={text!r} is not a size; use e.g. 500M or 2G "
                        f"(0 turns automatic pruning off), or unset it for the default 2G") from None
    return None if size == 0 else size


def auto_prune(root, keep=()):
    """After a new entry: keep the cache under $EOMC_CACHE_MAX_SIZE, dropping the least
    recently used entries down to 80% of it (so not every build prunes).  The keys in
    ``keep`` (the entries just built) stay even if they alone are over the limit."""
    limit = max_size_from_env()
    if limit is None:
        return []
    listed = entries(root)
    if sum(e.size for e in listed) <= limit:
        return []
    return prune(root, max_size=int(0.8 * limit), keep=keep)


_SIZE_UNITS = {"": 1, "b": 1, "k": 1024, "kb": 1024, "kib": 1024, "m": 1024 ** 2, "mb": 1024 ** 2,
               "mib": 1024 ** 2, "g": 1024 ** 3, "gb": 1024 ** 3, "gib": 1024 ** 3}
_AGE_UNITS = {"s": 1, "m": 60, "min": 60, "h": 3600, "d": 86400, "w": 7 * 86400}


def parse_size(text):
    """'500M', '2G', '1.5GiB', '0' -> bytes (binary units)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([a-zA-Z]*)\s*", str(text))
    unit = m.group(2).lower() if m else None
    if not m or unit not in _SIZE_UNITS:
        raise ValueError(f"not a size: {text!r} (examples: 500M, 2G, 1.5GiB)")
    return int(float(m.group(1)) * _SIZE_UNITS[unit])


def parse_age(text):
    """'30d', '12h', '90min', '2w' -> seconds."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([a-zA-Z]+)\s*", str(text))
    unit = m.group(2).lower() if m else None
    if not m or unit not in _AGE_UNITS:
        raise ValueError(f"not an age: {text!r} (examples: 30d, 12h, 90min, 2w)")
    return float(m.group(1)) * _AGE_UNITS[unit]


def format_size(n):
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"  # pragma: no cover
