"""Load a built model: ``load(directory_or_path, name=None)`` -> :class:`~eomc.runtime.model.Model`.

The default backend is cffi in ABI mode (``ffi.dlopen``): loading needs no
extension module to be compiled, so going from generated C to a loaded model
costs one C compile and a dlopen -- the fastest model-to-loaded-module path.
Per-call speed does not suffer: the common calls (rhs, jacobian, mass_matrix,
forcing) go through ``eomc.runtime._fastcall``, one Cython extension built
when eomc is installed, which calls any model through its ``eomc_model``
struct.  The Cython backend (``backend="cython"``) builds a per-model
extension instead; it remains for users who want a self-contained module.

Only numpy and cffi are imported here -- never SymPy or eomc.compiler -- so a
built model runs where only the runtime is installed.  What NAME.json may say is
checked by ``metadata.py``: only a library inside the directory is opened, and
sizes, names and defaults are the library's own.

What a load reads is read once, at load time (:class:`_Snapshot`): the library's
bytes and the model's texts.  Three things rest on that snapshot:

- No stale library (reliability report r3, N1).  ``dlopen`` of a path the process
  has already opened returns the library mapped then, even when the file was
  rebuilt since (``eomc.compile(..., output_dir="out")`` twice in a notebook).
  So the cffi backend opens every library from a uniquely named private copy of
  the snapshot (``<cache>/tmp/trash-<pid>-load-*``, removed right after the
  dlopen -- the mapping outlives the file, and a process killed in between leaves
  a directory that the cache reclaims).  The same copy keeps a loaded model alive
  when another process rewrites its files in place (round 4: ``cp`` over an
  exported ``libNAME.so`` killed the process using it with SIGBUS).
- One consistent set (N4).  An exported directory lists what eomc wrote in
  ``.eomc-files-NAME.json``; the snapshot must match it file by file, and it is
  taken under a shared lock on the directory that ``eomc build -o`` holds
  exclusively while it publishes, so a load never mixes two builds.
- Travel (N6).  A Model pickles from the snapshot, so removing its cache entry
  (``eomc cache clear``/prune) or its directory later does not stop it pickling.
"""
import contextlib
import copyreg
import importlib.machinery
import importlib.util
import json
import os
import shutil
import tempfile
import threading
from pathlib import Path

import cffi

from .cpu import ISA_FLAGS, missing_isa
from .cdef import BATCH_CDEF, MODEL_CDEF, model_function_cdef
from .integrators_api import INTEGRATOR_CDEF
from .metadata import EXPORTED_FUNCTIONS, LoadError, check_json, const_split, from_library, tree_lu
from .float32 import FLOAT32_TARGET, Float32Model
from .model import Model
from .native import integrator_library
from . import store
from .errors import EomcError
from .travel import RUNTIME_FILES, arrive, pack

__all__ = ["load", "find_model_json", "LoadError", "restore"]


def find_model_json(dir_or_path, name=None):
    """The NAME.json describing the model at ``dir_or_path`` (a directory, NAME.json or libNAME.so)."""
    path = Path(dir_or_path)
    if path.is_file():
        if path.suffix == ".json":
            return path
        stem = path.name.split(".")[0]
        stem = stem[3:] if stem.startswith("lib") else stem
        return path.parent / f"{name or stem}.json"
    if not path.is_dir():
        raise LoadError(f"{path}: no such model directory or file")
    if name:
        found = path / f"{name}.json"
        if not found.is_file():
            raise LoadError(f"{path}: no model named {name!r} (expected {found.name})")
        return found
    candidates = sorted(p for p in path.glob("*.json")
                        if p.name != "manifest.json" and (path / f"lib{p.stem}.so").exists())
    if len(candidates) != 1:
        names = ", ".join(p.stem for p in candidates) or "none"
        raise LoadError(f"{path}: expected one built model, found {names}; pass name=")
    return candidates[0]


def _parse_json(path, text):
    """NAME.json, checked (runtime/metadata.py) before any library is opened."""
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise LoadError(f"{path}: cannot read model metadata ({exc}); rebuild the model") from None
    check_json(path, data)
    return data


def _read_bytes(path):
    """(bytes, identity) of one file, identity = (device, inode, size, mtime) of what was read."""
    with open(path, "rb") as fh:
        st = os.fstat(fh.fileno())
        return fh.read(), (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _identity(path):
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


class _Snapshot:
    """What one load read from the model's directory: NAME.json, the library and the texts.

    ``texts`` (file name -> bytes) are what a Model pickles with (runtime/travel.py);
    ``library``/``extension`` are (path, bytes, sha256, identity).
    """

    def __init__(self, json_path):
        self.json_path = json_path
        self.directory = json_path.parent.resolve()
        try:
            raw, _ = _read_bytes(json_path)
        except OSError as exc:
            raise LoadError(f"{json_path}: cannot read model metadata ({exc.strerror or exc}); "
                            f"rebuild the model") from None
        self.data = _parse_json(json_path, raw.decode("utf-8", "replace"))
        self.name = self.data["name"]
        self.texts = {f"{self.name}.json": raw}
        build = self.data.get("build") or {}
        self.library = self._binary(self.directory / build.get("library", f"lib{self.name}.so"))
        for fname in (f"{self.name}.c", f"{self.name}.h", *RUNTIME_FILES):
            with contextlib.suppress(OSError):
                self.texts[fname] = _read_bytes(self.directory / fname)[0]
        extension = build.get("extension")
        self.extension = None
        if extension and (self.directory / extension).is_file():
            self.extension = self._binary(self.directory / extension)
        self._check_written_list()

    def _binary(self, path):
        try:
            blob, ident = _read_bytes(path)
        except OSError as exc:
            raise LoadError(f"cannot load model {self.name!r} from {path}: {exc.strerror or exc}") from None
        return path, blob, store.sha256_bytes(blob), ident

    def _check_written_list(self):
        """The files must be the set ``eomc build -o`` wrote together (N4), when it left a list."""
        listing = self.directory / f".eomc-files-{self.name}.json"
        try:
            recorded = json.loads(listing.read_text())["files"]
            recorded = {str(k): str(v) for k, v in recorded.items()}
        except FileNotFoundError:
            return
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise LoadError(f"{listing}: cannot read the list of files eomc wrote ({exc}); "
                            f"rebuild the model") from None
        ours = {n: store.sha256_bytes(b) for n, b in self.texts.items()}
        for path, _, digest, _ in filter(None, (self.library, self.extension)):
            ours[path.name] = digest
        for fname, digest in sorted(ours.items()):
            if fname in recorded and recorded[fname] != digest:
                raise LoadError(f"{self.directory / fname} is not the file eomc built with the rest of "
                                f"model {self.name!r} (its sha256 differs from {listing.name}): another "
                                f"build wrote into {self.directory} meanwhile, or the file was edited; "
                                f"rebuild the model")

    def travel_files(self):
        """What runtime/travel.py packs: texts as str, the library's bytes and its file name."""
        texts = {n: b.decode("utf-8", "replace") for n, b in self.texts.items()}
        return {"files": texts, "library": self.library[1], "library_name": self.library[0].name}


# Every library this process opened by path -> sha256 of the bytes mapped under it ("?" when
# unknown: the file changed while it was being opened).  See the module docstring (N1).
_MAPPED = {}
_MAPPED_LOCK = threading.Lock()
# Cython extensions find libNAME.so by its bare name, which the dynamic loader binds once per
# process: NAME -> sha256 of the libNAME.so the first extension of that name bound.
_BOUND_BY_NAME = {}


def _claim(path, digest):
    """True when ``path`` may be opened as is: the process never mapped other bytes under it."""
    keys = {str(path), os.path.realpath(path)}
    with _MAPPED_LOCK:
        if any(_MAPPED.get(k, digest) != digest for k in keys):
            return False
        for k in keys:
            _MAPPED[k] = digest
    return True


def _taint(path):
    with _MAPPED_LOCK:
        for k in {str(path), os.path.realpath(path)}:
            _MAPPED[k] = "?"


@contextlib.contextmanager
def _private_copies(files):
    """A new directory holding ``files`` ({name: bytes}); removed when the block ends.

    It lives in the build cache's tmp/ (where libraries are known to be executable),
    named like the cache's trash so a process killed inside the block leaves nothing
    that the next build, prune or clear does not reclaim.
    """
    try:
        base = store.cache_root() / "tmp"
    except EomcError:
        base = Path(tempfile.gettempdir())
    private = None
    try:
        private = Path(tempfile.mkdtemp(prefix=f"trash-{os.getpid()}-load-", dir=base))
        for fname, blob in files.items():
            (private / fname).write_bytes(blob)
    except OSError as exc:
        if private is not None:
            shutil.rmtree(private, ignore_errors=True)
        raise LoadError(f"cannot load the model: its library is opened from a private copy (so that "
                        f"another process rewriting the file cannot crash this one), and the copy could "
                        f"not be written in {base} ({exc.strerror or exc}); free space there or set "
                        f"EOMC_CACHE_DIR to a writable folder") from None
    try:
        yield private
    finally:
        shutil.rmtree(private, ignore_errors=True)


_BASE = []
_BASE_LOCK = threading.Lock()


def _base_ffi():
    """One FFI per process for the ABI types, the batch helper and the integrators.

    Parsing these declarations is most of a load's cost, so it happens once;
    each model adds only its own few declarations in an FFI that includes
    this one (types are shared, so its ``eomc_model *`` passes to the
    integrators).
    """
    with _BASE_LOCK:
        if not _BASE:
            ffi = cffi.FFI()
            ffi.cdef(MODEL_CDEF + BATCH_CDEF + INTEGRATOR_CDEF)
            # Build every struct type here, in the FFI that lives as long as the process.
            # cffi marks a struct declaration "completed" once, but shares the built type only
            # through a weak cache: if a model's own FFI built it first and that FFI was then
            # collected (a load that failed its checks), the next model got a new, never
            # completed -- opaque -- `eomc_model` and every later load in the process failed.
            typedefs, structs, unions = ffi.list_types()
            for decl in typedefs + [f"struct {n}" for n in structs] + [f"union {n}" for n in unions]:
                ffi.typeof(decl)
            _BASE.append(ffi)
    return _BASE[0]


def _dlopen(ffi, model_ffi, path, name, functions):
    lib = ffi.dlopen(str(path))
    model_lib = model_ffi.dlopen(str(path))
    c_model = getattr(model_lib, f"{name}_model")()
    for fn in EXPORTED_FUNCTIONS:
        if fn in functions:
            getattr(model_lib, f"{name}_{fn}")
    return lib, model_lib, c_model


def _open_cffi(snap):
    """(ffi, lib, model_lib, c_model, library): ``lib`` has the batch helper, ``model_lib`` NAME_*.

    The declarations come from the function list (checked), never from text in NAME.json,
    and the library is the bare file name NAME.json gives, inside the directory -- opened
    from a private copy of the bytes read at load time (see the module docstring).
    """
    name, data = snap.name, snap.data
    ffi = _base_ffi()
    model_ffi = cffi.FFI()
    model_ffi.include(ffi)
    functions = data.get("functions", ())
    model_ffi.cdef(model_function_cdef(name, functions, const_split(snap.json_path, data),
                                    tree_lu(snap.json_path, data)))
    library, blob, _, _ = snap.library
    try:
        # always from a private copy of the bytes read at load time: the dynamic loader maps
        # the file it opens, so another process rewriting that file in place (`cp` over an
        # exported libNAME.so, a sync tool) would kill this one with SIGBUS at its next call;
        # nobody else knows the copy's path, and the mapping outlives its removal
        with _private_copies({library.name: blob}) as private:
            lib, model_lib, c_model = _dlopen(ffi, model_ffi, private / library.name, name, functions)
    except (OSError, AttributeError) as exc:
        if isinstance(exc, LoadError):
            raise
        raise LoadError(f"cannot load model {name!r} from {library}: {exc}") from None
    return ffi, lib, model_lib, c_model, library


def _import_extension(path):
    module_name = path.name.split(".")[0]
    loader = importlib.machinery.ExtensionFileLoader(module_name, str(path))
    spec = importlib.util.spec_from_file_location(module_name, path, loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def _open_extension(snap):
    """The Cython extension, bound to the very library bytes the snapshot holds.

    The extension links libNAME.so by its bare name, and the dynamic loader binds a
    bare name once per process: a second, different libNAME.so can never be bound to
    a Cython extension in the same process, so that is refused rather than run stale.
    """
    name = snap.name
    if snap.extension is None:
        raise LoadError(f"{snap.directory}: model {name!r} was not built with the Cython backend "
                        f"(rebuild with backend='cython')")
    path, blob, digest, ident = snap.extension
    library, lib_blob, lib_digest, _ = snap.library
    with _MAPPED_LOCK:
        bound = _BOUND_BY_NAME.setdefault(name, lib_digest)
    if bound != lib_digest:
        raise LoadError(f"cannot load model {name!r} with the Cython backend: this process already runs "
                        f"another build of a model named {name!r} through Cython, and its library is "
                        f"bound by name once per process; load it with backend='cffi', build it under "
                        f"another name, or restart Python")
    if _claim(path, digest):
        module = _import_extension(path)
        if _identity(path) == ident:
            return module
        _taint(path)
    with _private_copies({path.name: blob, library.name: lib_blob}) as private:
        return _import_extension(private / path.name)


def _check_cpu(snap):
    """Refuse a library built for an instruction set this CPU lacks (runtime/cpu.py): it would
    die of SIGILL at its first call."""
    flags = (snap.data.get("build") or {}).get("cflags") or []
    missing = missing_isa(flags)
    if missing:
        raise LoadError(f"model {snap.name!r} in {snap.directory} was built for a CPU with "
                        f"{', '.join(ISA_FLAGS[f].upper() for f in missing)} (C flags {' '.join(flags)}), "
                        f"which this CPU lacks; rebuild it on this machine, or build it with "
                        f"`eomc build --portable` (portable=True) to run it on other machines")


def load(dir_or_path, name=None, backend=None):
    """Load the model built in ``dir_or_path``; ``backend`` is "cffi" or "cython" (default: as built).

    A c99-f32 build loads as a :class:`~.float32.Float32Model` (its float functions, for
    comparison with double; it does not simulate)."""
    json_path = find_model_json(dir_or_path, name)
    # shared: `eomc build -o` publishes a directory's files under the exclusive lock (N4)
    with store.directory_lock(json_path.parent, exclusive=False):
        snap = _Snapshot(json_path)
        _check_cpu(snap)
        if snap.data.get("target", "c99-f64") == FLOAT32_TARGET:   # firmware C: no eomc_model struct
            if backend not in (None, "cffi"):
                raise LoadError(f"model {snap.name!r} is built for {FLOAT32_TARGET}: it loads through cffi only")
            library, blob, digest, _ = snap.library
            if _claim(library, digest):
                return Float32Model(library, snap.data, snap.directory)
            with _private_copies({library.name: blob}) as private:   # stale mapping (N1)
                return Float32Model(private / library.name, snap.data, snap.directory)
        ffi, lib, model_lib, c_model, library = _open_cffi(snap)
        data = from_library(json_path, snap.data, c_model, ffi, library)
        backend = backend or data.get("build", {}).get("backend", "cffi")
        if backend not in ("cffi", "cython"):
            raise ValueError(f"unknown backend {backend!r}; choose cffi or cython")
        extension = _open_extension(snap) if backend == "cython" else None
    model = Model(ffi=ffi, lib=lib, c_model=c_model, metadata=data, directory=snap.directory,
                  library_path=library, extension=extension, model_lib=model_lib,
                  integrators=integrator_library(ffi))
    model.__dict__["_travel_files"] = snap.travel_files()
    return model


def restore(payload):
    """Unpickle a Model that pickled by content (runtime/travel.py): cache hit, shipped library or compile."""
    return arrive(payload, lambda directory, name: load(directory, name, backend="cffi"))


# Every Model comes from this module, so pickling is registered here: a Model pickles by
# content (travel.pack) and unpickles through restore() -- on any worker, without SymPy.
copyreg.pickle(Model, lambda model: (restore, (pack(model),)))
