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
"""
import copyreg
import importlib.machinery
import importlib.util
import json
import threading
from pathlib import Path

import cffi

from .cdef import BATCH_CDEF, MODEL_CDEF, model_function_cdef
from .integrators_api import INTEGRATOR_CDEF
from .metadata import EXPORTED_FUNCTIONS, LoadError, check_json, from_library
from .model import Model
from .native import integrator_library
from .travel import arrive, pack

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


def _read_json(path):
    """NAME.json, checked (runtime/metadata.py) before any library is opened."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise LoadError(f"{path}: cannot read model metadata ({exc}); rebuild the model") from None
    check_json(path, data)
    return data


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


def _open_cffi(directory, data):
    """(ffi, lib, model_lib, c_model, library): ``lib`` has the batch helper, ``model_lib`` NAME_*.

    The declarations come from the function list (checked), never from text in NAME.json,
    and the library is the bare file name NAME.json gives, inside ``directory``.
    """
    name = data["name"]
    ffi = _base_ffi()
    model_ffi = cffi.FFI()
    model_ffi.include(ffi)
    functions = data.get("functions", ())
    model_ffi.cdef(model_function_cdef(name, functions))
    library = directory / data.get("build", {}).get("library", f"lib{name}.so")
    try:
        lib = ffi.dlopen(str(library))
        model_lib = model_ffi.dlopen(str(library))
        c_model = getattr(model_lib, f"{name}_model")()
        for fn in EXPORTED_FUNCTIONS:
            if fn in functions:
                getattr(model_lib, f"{name}_{fn}")
    except (OSError, AttributeError) as exc:
        raise LoadError(f"cannot load model {name!r} from {library}: {exc}") from None
    return ffi, lib, model_lib, c_model, library


def _open_extension(directory, data):
    filename = data.get("build", {}).get("extension")
    if not filename or not (directory / filename).is_file():
        raise LoadError(f"{directory}: model {data['name']!r} was not built with the Cython backend "
                        f"(rebuild with backend='cython')")
    module_name = filename.split(".")[0]
    loader = importlib.machinery.ExtensionFileLoader(module_name, str(directory / filename))
    spec = importlib.util.spec_from_file_location(module_name, directory / filename, loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def load(dir_or_path, name=None, backend=None):
    """Load the model built in ``dir_or_path``; ``backend`` is "cffi" or "cython" (default: as built)."""
    json_path = find_model_json(dir_or_path, name)
    directory = json_path.parent.resolve()
    data = _read_json(json_path)
    ffi, lib, model_lib, c_model, library = _open_cffi(directory, data)
    data = from_library(json_path, data, c_model, ffi, library)
    backend = backend or data.get("build", {}).get("backend", "cffi")
    if backend not in ("cffi", "cython"):
        raise ValueError(f"unknown backend {backend!r}; choose cffi or cython")
    extension = _open_extension(directory, data) if backend == "cython" else None
    return Model(ffi=ffi, lib=lib, c_model=c_model, metadata=data, directory=directory,
                 library_path=library, extension=extension, model_lib=model_lib,
                 integrators=integrator_library(ffi))


def restore(payload):
    """Unpickle a Model that pickled by content (runtime/travel.py): cache hit, shipped library or compile."""
    return arrive(payload, lambda directory, name: load(directory, name, backend="cffi"))


# Every Model comes from this module, so pickling is registered here: a Model pickles by
# content (travel.pack) and unpickles through restore() -- on any worker, without SymPy.
copyreg.pickle(Model, lambda model: (restore, (pack(model),)))
