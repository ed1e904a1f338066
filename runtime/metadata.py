"""What a built directory's NAME.json may say, checked before and after the library is opened.

NAME.json is a plain file next to the library; anyone (or any tool, or a bad
disk) can change it.  So the loader trusts it as little as possible:

- before anything is opened (:func:`check_json`): it must be a JSON object of
  the right types; ``build.library`` and ``build.extension`` must be bare file
  names (no directory part), so only a file *inside* the directory is ever
  opened -- a library's constructors run as soon as it is opened; the cffi
  declarations are rebuilt from the function list (never parsed from the JSON),
  and a ``cdef`` that says anything else is refused.
- after the library is opened (:func:`from_library`): sizes, the model's name,
  state/parameter/input/output names and parameter defaults are read from the
  library's own ``eomc_model`` struct -- what the C code was compiled with --
  and a NAME.json that disagrees is refused.  Only the facts the struct does
  not carry (initial_state, op_counts, sparsity, and the notes on how the model was
  formulated: formulation_note, tree_notes) come from the JSON, type-checked.

Every inconsistency is a LoadError that says to rebuild the model.
"""
import numbers
import re

from eomc.runtime.errors import ModelError

from .cdef import ABI_VERSION, CONST_SPLIT, model_function_cdef

__all__ = ["LoadError", "check_json", "from_library", "SIZES", "FUNCTIONS"]

SIZES = ("abi_version", "nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol", "nvel", "work_size")
STRUCT_FUNCTIONS = ("rhs", "jac_x", "jac_r", "mass_matrix", "forcing", "outputs", "constraints",
                    "constraints_jac")
EXPORTED_FUNCTIONS = ("inverse_dynamics", "linearize", "events", "poses", "jac_p", "regressor", "jvp", "jvp_more",
                      "jac_id", "vjp", "hvp", "hess_id", "implicit", "rhs_batch", "jac_x_batch",
                      "outputs_batch", "implicit_batch", "energy")
FUNCTIONS = STRUCT_FUNCTIONS + EXPORTED_FUNCTIONS
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


class LoadError(ModelError, OSError):
    """A build directory is incomplete, stale, inconsistent or was built for another ABI."""


def _bad(path, what):
    return LoadError(f"{path}: {what}; rebuild the model (eomc build)")


def _bare_file_name(path, value, what):
    if (not isinstance(value, str) or not value or value in (".", "..") or "/" in value or "\\" in value
            or "\0" in value):
        raise _bad(path, f"{what} must be a file name inside the model's directory, not {value!r}")
    return value


def _integer(path, data, field):
    value = data.get(field)
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise _bad(path, f"{field} must be a non-negative integer, not {value!r}")
    return value


def const_split(path, data):
    """The functions whose constant outputs NAME.json says are apart ("const_outputs": {function:
    count}; runtime/cdef.CONST_SPLIT), checked."""
    split = data.get("const_outputs") or {}
    if not isinstance(split, dict) or any(f not in CONST_SPLIT or not isinstance(n, int) or n < 1
                                          for f, n in split.items()):
        raise _bad(path, f"const_outputs must map {', '.join(CONST_SPLIT)} to a count; got {split!r}")
    return tuple(split)


def tree_lu(path, data):
    """Whether NAME.json says the library has NAME_tree_lu ("tree_lu": true; runtime/cdef.TREE_LU), checked."""
    flag = data.get("tree_lu", False)
    if not isinstance(flag, bool):
        raise _bad(path, f"tree_lu must be true or false; got {flag!r}")
    return flag


def check_json(path, data):
    """Check NAME.json before anything is opened; returns (name, library file name, functions)."""
    if not isinstance(data, dict):
        raise _bad(path, "not a model description (expected a JSON object)")
    if data.get("abi_version") != ABI_VERSION:
        raise LoadError(f"{path}: built for model ABI {data.get('abi_version')}, this eomc reads "
                        f"ABI {ABI_VERSION}; rebuild the model")
    name = data.get("name")
    if not isinstance(name, str) or not _IDENTIFIER.match(name):
        raise _bad(path, f"the model name must be a C identifier, not {name!r}")
    for field in SIZES:
        _integer(path, data, field)
    build = data.get("build", {})
    if not isinstance(build, dict):
        raise _bad(path, f"'build' must be an object, not {build!r}")
    library = _bare_file_name(path, build.get("library", f"lib{name}.so"), "build.library")
    if build.get("extension") is not None:
        extension = _bare_file_name(path, build["extension"], "build.extension")
        if extension.split(".")[0] != f"{name}_cy":
            raise _bad(path, f"build.extension must be the model's own {name}_cy module, not {extension!r}")
    functions = data.get("functions", ())
    if not isinstance(functions, list) or any(f not in FUNCTIONS for f in functions):
        raise _bad(path, f"functions must be a list of {', '.join(FUNCTIONS)}; got {functions!r}")
    target = data.get("target", "c99-f64")
    if target not in ("c99-f64", "c99-f32"):
        raise _bad(path, f"target must be c99-f64 or c99-f32, not {target!r}")
    cdef = data.get("cdef")
    if cdef is not None and target == "c99-f64":   # a c99-f32 load declares its own (runtime/float32.py)
        expected = set(model_function_cdef(name, functions, const_split(path, data),
                                         tree_lu(path, data)).split("\n")) - {""}
        if not isinstance(cdef, str) or {line.strip() for line in cdef.split("\n")} - {""} != expected:
            raise _bad(path, "its C declarations (cdef) do not match the functions it lists")
    for field in ("state_names", "param_names", "input_names", "output_names", "param_defaults"):
        if not isinstance(data.get(field), list):
            raise _bad(path, f"{field} must be a list, not {data.get(field)!r}")
    return name, library, tuple(functions)


def _strings(ffi, array, n, library, field):
    if not n:
        return []
    if array == ffi.NULL or any(array[i] == ffi.NULL for i in range(n)):
        raise LoadError(f"{library}: the library lists no {field}; rebuild the model")
    return [ffi.string(array[i]).decode() for i in range(n)]


def _real_list(path, value, n, field):
    if (not isinstance(value, list) or len(value) != n
            or any(not isinstance(v, numbers.Real) or isinstance(v, bool) for v in value)):
        raise _bad(path, f"{field} must be a list of {n} numbers, not {value!r}")
    return [float(v) for v in value]


def from_library(path, data, c_model, ffi, library):
    """The metadata the Model uses: sizes, names and defaults from the library's struct
    (NAME.json must agree), the rest from NAME.json after type checks."""
    meta = dict(data)
    for field in SIZES:
        value = int(getattr(c_model, field))
        if value != data[field]:
            raise LoadError(f"{library}: {field} is {value} in the library but {data[field]} in its "
                            f"metadata; rebuild the model")
        meta[field] = value
    name = ffi.string(c_model.name).decode()
    if name != data["name"]:
        raise LoadError(f"{library}: library is model {name!r}, metadata says {data['name']!r}; "
                        f"rebuild the model")
    nx, nparam, ninput, noutput = meta["nx"], meta["nparam"], meta["ninput"], meta["noutput"]
    from_struct = {
        "state_names": _strings(ffi, c_model.state_names, nx, library, "state_names"),
        "param_names": _strings(ffi, c_model.param_names, nparam, library, "param_names"),
        "input_names": _strings(ffi, c_model.input_names, ninput, library, "input_names"),
        "output_names": _strings(ffi, c_model.output_names, noutput, library, "output_names"),
        "param_defaults": [],
    }
    if nparam:
        if c_model.param_defaults == ffi.NULL:
            raise LoadError(f"{library}: the library lists no param_defaults; rebuild the model")
        from_struct["param_defaults"] = [float(c_model.param_defaults[i]) for i in range(nparam)]
    for field, value in from_struct.items():
        if data[field] != value:
            raise LoadError(f"{library}: {field} is {value} in the library but {data[field]} in "
                            f"{path.name}; rebuild the model")
        meta[field] = value
    if data.get("initial_state") is not None:
        meta["initial_state"] = _real_list(path, data["initial_state"], nx, "initial_state")
    for field in ("formulation_note",):   # shown to users (eomc inspect): text, if anything
        if data.get(field) is not None and not isinstance(data[field], str):
            raise _bad(path, f"{field} must be a string, not {data[field]!r}")
    notes = data.get("tree_notes")   # the System -> tree reader's fallbacks (compiler/tree/recognize.py)
    if notes is not None and (not isinstance(notes, list) or any(not isinstance(n, str) for n in notes)):
        raise _bad(path, f"tree_notes must be a list of strings, not {notes!r}")
    ops = data.get("op_counts", {})
    if not isinstance(ops, dict) or any(
            not isinstance(c, dict) or any(not isinstance(v, int) or isinstance(v, bool) for v in c.values())
            for c in ops.values()):
        raise _bad(path, "op_counts must map each function to integer operation counts")
    return meta
