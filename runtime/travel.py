"""Models that travel: a loaded Model pickles by content and comes back on any worker.

Why: parameter studies and Monte Carlo runs go to other processes and other
machines (``eomc.sweep``, Dask, multiprocessing), and a Model wraps a
dlopen'ed library, which pickle cannot carry.  So a Model pickles as what it
was built from: its cache key, name, metadata (NAME.json), C source and
headers, and the library's bytes with a platform tag.  Unpickling
(``arrive``) on a worker takes the first of:

(a) the key is already in the worker's build cache -> load that entry;
(b) the worker's platform matches the tag -> publish the shipped library under
    the same key (``store.publish``: atomic, one lock per key), then load;
(c) otherwise -> compile the shipped C with the worker's C compiler (``$CC``,
    cc, gcc or clang) into an entry keyed by the shipped key, the platform,
    the compiler and its command line, then load.

A library built for an instruction set the worker's CPU lacks (the default build adds
-mavx2 on AVX2 machines; runtime/cpu.py) skips (a) and (b) and is compiled in (c)
without those flags.

A worker never re-derives a model: it needs numpy, cffi and (for (c)) a C
compiler, not SymPy.  Each payload carries a sha256 over all of its content;
a payload that does not match it is refused (``TravelError``).  That catches
truncated, corrupted and edited pickles; it is no defence against a forged
one -- unpickling runs code by design, so only unpickle what you trust.

A process restores each (key, content) once and then hands out the same
Model (it is thread-safe), so tasks that each carry the model cost a hash
check, not a load.  This module does not import the loader (which imports
it): ``arrive`` gets the load function from ``loader.restore``.
"""
import json
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import threading
from pathlib import Path

from eomc.runtime.errors import CompileError, CompilerNotFoundError, EomcError, ModelError

from . import store
from .cpu import missing_isa

__all__ = ["TravelError", "pack", "arrive", "platform_tag", "FORMAT", "RUNTIME_FILES"]

FORMAT = 1
_FIELDS = ("eomc_travel", "name", "key", "platform", "abi_version", "library_name", "files", "library",
           "digest")
_COMPILERS = ("cc", "gcc", "clang")
# the shipped C beside a model's own NAME.c/.h/.json in its build directory (compiler/build/builder.py)
RUNTIME_FILES = ("eomc_model.h", "eomc_integrators.h", "eomc_batch.h", "eomc_batch.c")
_KEY = re.compile(r"[0-9a-f]{64}")   # a sha256: the entry's directory name in the cache
_RESTORED = {}                 # (key, digest) -> Model restored in this process
_LOCK = threading.Lock()


class TravelError(ModelError):
    """A pickled model is not whole: wrong format, or its content does not match its hash."""


def platform_tag():
    """Where a shipped library runs: OS, machine and C library, e.g. 'linux-x86_64-glibc2.36'."""
    libc, version = platform.libc_ver()
    return f"{sys.platform}-{platform.machine()}-{libc}{version}"


def _digest(payload):
    """sha256 over every field of a payload but the digest itself."""
    head = {k: payload[k] for k in _FIELDS if k not in ("files", "library", "digest")}
    head["files"] = {n: store.sha256_bytes(t.encode()) for n, t in sorted(payload["files"].items())}
    head["library"] = store.sha256_bytes(payload["library"])
    return store.hash_key(head)


def pack(model):
    """The payload a Model pickles to (a dict of plain values); made once per Model."""
    cached = model.__dict__.get("_travel_payload")
    if cached is not None:
        return cached
    data = dict(model.metadata)
    build = dict(data.get("build") or {})
    # read when the model was loaded (loader._Snapshot), so a cache entry or directory removed
    # since (`eomc cache clear`, a prune) does not stop the model travelling (report r3, N6)
    snapshot = model.__dict__.get("_travel_files") or _read_directory(model)
    library, library_name = snapshot["library"], snapshot["library_name"]
    key = build.get("key") or store.sha256_bytes(library)
    texts = [f"{model.name}.json", f"{model.name}.c", f"{model.name}.h", *RUNTIME_FILES]
    files = {n: snapshot["files"][n] for n in texts if n in snapshot["files"]}
    if build.get("backend", "cffi") != "cffi":
        # a Cython extension is tied to one Python; the library it wraps travels and loads with cffi
        build.update(backend="cffi", extension=None)
        data["build"] = build
        files[model.name + ".json"] = json.dumps(data, indent=1, sort_keys=True)
        key = store.hash_key({"travelled": key, "backend": "cffi"})
    payload = {"eomc_travel": FORMAT, "name": model.name, "key": key, "platform": platform_tag(),
               "abi_version": data.get("abi_version"), "library_name": library_name,
               "files": files, "library": library}
    payload["digest"] = _digest(payload)
    model.__dict__["_travel_payload"] = payload
    return payload


def _read_directory(model):
    """The snapshot of a Model made without the loader (its files, read now)."""
    directory = Path(model.directory)
    texts = [f"{model.name}.json", f"{model.name}.c", f"{model.name}.h", *RUNTIME_FILES]
    try:
        return {"files": {n: (directory / n).read_text() for n in texts if (directory / n).is_file()},
                "library": Path(model.library_path).read_bytes(), "library_name": Path(model.library_path).name}
    except OSError as exc:
        raise TravelError(f"cannot pickle model {model.name!r}: its files in {directory} are gone "
                          f"({exc.strerror or exc}); load it again") from None


def _check(payload):
    if not isinstance(payload, dict) or payload.get("eomc_travel") != FORMAT \
            or any(k not in payload for k in _FIELDS):
        got = payload.get("eomc_travel") if isinstance(payload, dict) else type(payload).__name__
        raise TravelError(f"this pickle does not hold an eomc model in travel format {FORMAT} "
                          f"(got {got!r}); pickle and unpickle with the same eomc version")
    try:
        digest = _digest(payload)
    except (TypeError, AttributeError, ValueError) as exc:
        raise TravelError(f"the pickled model {payload['name']!r} is malformed ({exc}); refusing to load it") \
            from None
    if digest != payload["digest"]:
        raise TravelError(f"the pickled model {payload['name']!r} (key {str(payload['key'])[:12]}) is "
                          f"corrupt or was altered: its content hashes to {digest[:12]}, the pickle "
                          f"says {str(payload['digest'])[:12]}; refusing to load it")
    name = payload["name"]
    if not (isinstance(payload["key"], str) and _KEY.fullmatch(payload["key"])):
        raise TravelError(f"the pickled model {name!r} has a malformed cache key; refusing to load it")
    for n in [*payload["files"], payload["library_name"]]:
        if not isinstance(n, str) or os.path.basename(n) != n or n.startswith("."):
            raise TravelError(f"the pickled model {name!r} names a file {n!r} outside its directory; "
                              f"refusing to load it")
    if f"{name}.json" not in payload["files"]:
        raise TravelError(f"the pickled model {name!r} has no {name}.json; refusing to load it")


def _write_sources(payload):
    def write(tmp):
        for n, text in payload["files"].items():
            (tmp / n).write_text(text)
    return write


def _compiler():
    """(argv prefix, version line) of the worker's C compiler: $CC, else cc, gcc, clang."""
    cc = os.environ.get("CC")
    argv = shlex.split(cc) if cc else next(([c] for c in _COMPILERS if shutil.which(c)), None)
    if not argv or shutil.which(argv[-1]) is None:
        raise CompilerNotFoundError(
            f"this worker has no C compiler ({'CC=' + repr(cc) if cc else 'no cc, gcc or clang on PATH'}) "
            f"and the pickled model was built for another platform, so its library cannot be used "
            f"here; install a C compiler on the worker or set CC")
    try:
        out = subprocess.run([argv[-1], "--version"], capture_output=True, text=True, timeout=60)
        version = (out.stdout or out.stderr).strip().splitlines()[0]
    except (OSError, subprocess.SubprocessError, IndexError):
        version = "unknown"
    return argv, version


def _shipped_flags(payload):
    """The C flags the shipped library was built with (from its NAME.json)."""
    try:
        data = json.loads(payload["files"][f"{payload['name']}.json"])
        return list((data.get("build") or {}).get("cflags") or [])
    except (ValueError, TypeError, AttributeError):
        return []


def _compile_here(payload, root):
    """Case (c): the shipped C, compiled by this worker's compiler, as a cache entry."""
    name = payload["name"]
    data = json.loads(payload["files"][f"{name}.json"])
    flags = list((data.get("build") or {}).get("cflags") or ["-O2", "-fPIC", "-std=c99"])
    # built for the sender's CPU (e.g. -mavx2): compile for this one, without what it lacks
    dropped = missing_isa(flags)
    flags = [f for f in flags if f not in dropped]
    sources = [f"{name}.c"] + [n for n in RUNTIME_FILES if n.endswith(".c") and n in payload["files"]]
    link = ["-Wl,-Bsymbolic"] if sys.platform.startswith("linux") else []
    argv, version = _compiler()
    command = [*argv, *flags, "-shared", "-o", payload["library_name"], *sources, "-lm", *link]
    key = store.hash_key({"compiled_from": payload["key"], "platform": platform_tag(),
                          "compiler": version, "argv": command[len(argv):]})

    def write(tmp):
        _write_sources(payload)(tmp)
        if dropped:     # NAME.json says what this library was built with (the loader reads it)
            data["build"]["cflags"] = flags
            (tmp / f"{name}.json").write_text(json.dumps(data, indent=1, sort_keys=True))
        proc = subprocess.run(command, cwd=tmp, capture_output=True, text=True)
        if proc.returncode:
            raise CompileError(f"compiling the pickled model {name!r} on this worker failed "
                               f"(exit status {proc.returncode})\ncommand: {shlex.join(command)}\n"
                               f"{(proc.stderr or proc.stdout).strip()}")

    inputs = {"compiled_from": payload["key"], "shipped_platform": payload["platform"],
              "platform": platform_tag(), "compiler": version, "argv": command[len(argv):]}
    found = store.find(root, "models", key, verify=(payload["library_name"],))
    return found or store.publish(root, "models", key, write, inputs, verify=(payload["library_name"],))[0]


def _shipped_library(payload, root):
    """Case (b): the shipped library published under its own key."""
    def write(tmp):
        _write_sources(payload)(tmp)
        (tmp / payload["library_name"]).write_bytes(payload["library"])
    inputs = {"shipped": True, "platform": payload["platform"]}
    return store.publish(root, "models", payload["key"], write, inputs, verify=(payload["library_name"],))[0]


def arrive(payload, load):
    """The Model a payload describes, in this process; ``load(directory, name)`` opens an entry.

    Sets ``model.arrival`` to how it came: "cache" (a), "library" (b) or "compiled" (c).
    """
    _check(payload)
    memo = (payload["key"], payload["digest"])
    with _LOCK:
        model = _RESTORED.get(memo)
    if model is not None:
        return model
    name, root, lib = payload["name"], store.cache_root(), payload["library_name"]
    failures = []
    # a library built for an instruction set this CPU lacks (runtime/cpu.py) is neither looked
    # up nor unpacked here: only compiled, for this CPU
    runs_here = not missing_isa(_shipped_flags(payload))
    steps = [("cache", lambda: store.find(root, "models", payload["key"], verify=(lib,)))] if runs_here else []
    if payload["platform"] == platform_tag() and runs_here:
        steps.append(("library", lambda: _shipped_library(payload, root)))
    steps.append(("compiled", lambda: _compile_here(payload, root)))
    for arrival, step in steps:
        try:
            entry = step()
        except (TravelError, CompileError, CompilerNotFoundError):
            raise
        except EomcError as exc:  # e.g. a full or read-only cache: one clear line, no traceback
            raise TravelError(f"cannot unpickle model {name!r} here: {exc}") from None
        if entry is None:
            continue
        try:
            model = load(entry, name)
        except (ModelError, OSError) as exc:  # e.g. a library the loader refuses: try the next way
            failures.append(f"{arrival}: {exc}")
            continue
        model.arrival = arrival
        model.__dict__["_travel_payload"] = payload
        with _LOCK:
            return _RESTORED.setdefault(memo, model)
    raise TravelError(f"the pickled model {name!r} could not be loaded here: " + "; ".join(failures))
