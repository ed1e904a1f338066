"""The loaded model: numpy in, numpy out, every argument checked before any C runs.

A :class:`Model` wraps one built library.  Each method validates shapes and
dtypes (raising ``ValueError`` that names the argument and the expected
shape), fills in defaults (``p=None`` -> the model's default parameters,
``r=None`` -> zero inputs), calls the C function through the backend's
*kernels* and turns a nonzero status into an error that says what failed,
when and where (``eomc.runtime.errors.SimulationError``).

Kernels are plain callables taking float64 numpy arrays (or None for an
absent argument) and returning the C status; the cffi backend builds them
over ``ffi.from_buffer``, the Cython backend is the extension module itself.
"""
import numbers
import threading
from pathlib import Path

import numpy as np

from eomc.runtime.errors import ModelError, SimulationError

from .cdef import STATUS_NAMES
from .diagnose import SINGULAR_STATUS, singular_direction
from .metadata import EXPORTED_FUNCTIONS, STRUCT_FUNCTIONS
from .names import index_of, model_name

try:  # built once with eomc (setup.py); a source tree without it uses the cffi fast path
    from ._fastcall import FastCalls as _FastCalls
except ImportError:
    _FastCalls = None

__all__ = ["Model"]

_F64 = np.dtype(np.float64)
_BAD_ARGUMENT = 4   # EOMC_BAD_ARGUMENT (runtime/c/eomc_model.h): a batch function refused its arguments

_FAST_METHODS = {"rhs": "rhs", "jacobian": "jac_x", "mass_matrix": "mass_matrix", "forcing": "forcing"}
# _fastcall releases the GIL only around a C function of at least this many operations
# (metadata op_counts): releasing and re-taking it costs ~0.1-0.2 us, a quarter of a small
# model's whole call, and buys threads nothing when the C takes well under a microsecond.
_NOGIL_MIN_OPS = 10_000


def _cffi_backend(ffi, lib, model_lib, c_model, name, functions):
    """(prepare, kernels) over the C function pointers, called through cffi (ABI mode).

    ``prepare`` turns a float64 array that is reused across calls (parameters,
    inputs, work) into the pointer the kernels take, so a call with default
    parameters converts only x and the output.
    """
    frombuf, null = ffi.from_buffer, ffi.NULL

    def prepare(a):
        return null if a is None or a.size == 0 else frombuf("double[]", a)

    def vector_kernel(fp):
        return lambda t, x, p, r, out, work: fp(t, frombuf("double[]", x), p, r, prepare(out), work)

    kernels = {}
    for fn in STRUCT_FUNCTIONS:
        fp = getattr(c_model, fn)
        if fp != null:
            kernels[fn] = vector_kernel(fp)
    if "inverse_dynamics" in functions:
        kernels["inverse_dynamics"] = _inverse_dynamics_kernel(getattr(model_lib, f"{name}_inverse_dynamics"),
                                                               prepare)
    if "linearize" in functions:
        kernels["linearize"] = _linearize_kernel(getattr(model_lib, f"{name}_linearize"), prepare)
    if "regressor" in functions:   # (t, x, udot, p, r, out, work), as inverse_dynamics
        kernels["regressor"] = _inverse_dynamics_kernel(getattr(model_lib, f"{name}_regressor"), prepare)
    if "jac_id" in functions:      # (t, x, udot, p, r, out, work), as inverse_dynamics
        kernels["jac_id"] = _inverse_dynamics_kernel(getattr(model_lib, f"{name}_jac_id"), prepare)
    if "jvp" in functions:
        fp_jvp = getattr(model_lib, f"{name}_jvp")
        kernels["jvp"] = lambda t, x, p, r, k, dirs, xdot, out, work: fp_jvp(
            t, frombuf("double[]", x), p, r, k, prepare(dirs), prepare(xdot), prepare(out), work)
    if "hess_id" in functions:     # (t, x, udot, p, r, out, work), as inverse_dynamics
        kernels["hess_id"] = _inverse_dynamics_kernel(getattr(model_lib, f"{name}_hess_id"), prepare)
    if "vjp" in functions:
        fp_vjp = getattr(model_lib, f"{name}_vjp")
        kernels["vjp"] = lambda t, x, p, r, lam, xdot, gx, gp, work: fp_vjp(
            t, frombuf("double[]", x), p, r, prepare(lam), prepare(xdot), prepare(gx), prepare(gp), work)
    if "hvp" in functions:
        fp_hvp = getattr(model_lib, f"{name}_hvp")
        kernels["hvp"] = lambda t, x, p, r, lam, v, out, work: fp_hvp(
            t, frombuf("double[]", x), p, r, prepare(lam), prepare(v), prepare(out), work)
    if "jac_p" in functions:     # exported, not in the eomc_model struct (ABI unchanged)
        kernels["jac_p"] = vector_kernel(getattr(model_lib, f"{name}_jac_p"))
    for fn in ("rhs_batch", "jac_x_batch", "outputs_batch", "implicit_batch"):   # SoA states in SIMD lanes (compiler/emit/batch.py)
        if fn in functions:
            kernels[fn] = (lambda fp: lambda n, t, X, p, R, XD, status, work: fp(
                n, t, frombuf("double[]", X), p, prepare(R), frombuf("double[]", XD), frombuf("int[]", status),
                work))(getattr(model_lib, f"{name}_{fn}"))
    if "rhs" in kernels:
        many = lib.eomc_rhs_many

        def rhs_many(n, t, t_stride, X, p, R, r_stride, XD, work):
            row = ffi.new("size_t *")
            status = many(c_model, n, prepare(t), t_stride, prepare(X), p, R, r_stride,
                          prepare(XD), work, row)
            return status, int(row[0])
        kernels["rhs_many"] = rhs_many
    return prepare, kernels


def _cffi_fast_rhs(model, fp, frombuf):
    """rhs for the commonest call -- float t, a float64 C-contiguous x, default p and r --
    with the fewest Python steps; everything else (and any nonzero status) goes
    through the validating Model.rhs, which raises the proper error."""
    nx, xshape, checked, empty, ndarray = model.nx, (model.nx,), model._checked_rhs, np.empty, np.ndarray
    p_default, r_default, work = model._default_p, model._default_r, model._work

    def rhs(t, x, p=None, r=None):
        if (p is None and r is None and type(t) is float and type(x) is ndarray and x.dtype is _F64
                and x.shape == xshape and x.flags.c_contiguous):
            out = empty(nx)
            if fp(t, frombuf("double[]", x), p_default, r_default, frombuf("double[]", out), work()[1]) == 0:
                return out
        return checked(t, x, p, r)
    rhs.__doc__ = Model.rhs.__doc__
    return rhs


def _inverse_dynamics_kernel(fp, ptr):
    return lambda t, x, ud, p, r, tau, work: fp(t, ptr(x), ptr(ud), p, r, ptr(tau), work)


def _linearize_kernel(fp, ptr):
    return lambda t, x, p, r, A, B, work: fp(t, ptr(x), p, r, ptr(A), ptr(B), work)


def _extension_backend(module):
    """(prepare, kernels) of a Cython extension: it takes the arrays themselves."""
    names = STRUCT_FUNCTIONS + EXPORTED_FUNCTIONS + ("rhs_many",)
    return (lambda a: a), {fn: getattr(module, fn) for fn in names if hasattr(module, fn)}


class Model:
    """A built model (see the module docstring); attributes mirror the C ``eomc_model`` struct."""

    def __init__(self, *, ffi, lib, c_model, metadata, directory, library_path, extension=None,
                 model_lib=None, integrators=None):
        # lib: the batch helper (eomc_rhs_many); model_lib: the model's NAME_* functions;
        # integrators: eomc_integrate & co., built once with eomc (runtime/native.py)
        self.ffi, self.lib, self.c_model = ffi, lib, c_model
        self.integrators = lib if integrators is None else integrators
        self.model_lib = lib if model_lib is None else model_lib
        self.metadata = metadata
        self.name = metadata["name"]
        for size in ("nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol", "nvel", "work_size"):
            setattr(self, size, int(metadata[size]))
        self.nz = self.nx - self.nq - self.nu     # extra first-order states, after q and u in x
        self.state_names = tuple(metadata["state_names"])
        self.param_names = tuple(metadata["param_names"])
        self.input_names = tuple(metadata["input_names"])
        self.output_names = tuple(metadata["output_names"])
        self.param_defaults = np.array(metadata["param_defaults"], dtype=np.float64).reshape(self.nparam)
        self.param_defaults.setflags(write=False)
        # x indices of each unit quaternion's w (a free joint with floating_base="quaternion");
        # the integrators keep them unit
        self.quaternions = tuple(int(i) for i in metadata.get("quaternions", ()))
        x0 = metadata.get("initial_state")
        self.initial_state = None if x0 is None else np.array(x0, dtype=np.float64)
        # the model file's own time step (MJCF <option timestep>): what its author integrates at
        self.timestep = metadata.get("timestep")
        self.directory = Path(directory)
        self.library_path = Path(library_path)
        self.source_path = self.directory / f"{self.name}.c"
        self.header_path = self.directory / f"{self.name}.h"
        self.functions = tuple(metadata.get("functions", ()))
        self.backend = "cffi" if extension is None else "cython"
        self._prepare, self._kernels = (
            _cffi_backend(ffi, lib, self.model_lib, c_model, self.name, self.functions) if extension is None
            else _extension_backend(extension))
        self._zero_inputs = np.zeros(self.ninput)
        self._zero_inputs.setflags(write=False)
        self._default_p = self._prepare(self.param_defaults)
        self._default_r = self._prepare(self._zero_inputs) if self.ninput else self._prepare(None)
        self._tls = threading.local()
        self._xshape = (self.nx,)
        if extension is not None and hasattr(extension, "FastRHS"):
            # the common call checked in C; everything else falls back to Model.rhs
            self.rhs = extension.FastRHS(self._checked_rhs, np.empty, self.param_defaults,
                                         self._zero_inputs, self.nx, self.work_size)
        elif extension is None:
            self._install_fast_calls(ffi, c_model)
        # every generated function under its C name too (NAME_jac_x -> model.jac_x), bound to
        # whatever the fast path installed
        self.jac_x = self.jacobian

    def _install_fast_calls(self, ffi, c_model):
        """The cffi backend's per-call fast path: rhs, jacobian, mass_matrix and forcing through
        eomc.runtime._fastcall (one extension for every model) when it imports, else rhs through
        cffi.  Either way the common call is checked cheaply and everything else falls back to
        the checked methods of this class, which raise the proper errors."""
        if _FastCalls is not None:
            checked = {fn: getattr(self, fn) for fn in _FAST_METHODS}
            ops = self.metadata.get("op_counts") or {}
            nogil = [fn for fn, c_fn in _FAST_METHODS.items()
                     if sum((ops.get(c_fn) or {}).values()) >= _NOGIL_MIN_OPS]
            fast = _FastCalls(int(ffi.cast("uintptr_t", c_model)), self.param_defaults, self._zero_inputs,
                              checked, nogil=nogil, keepalive=(ffi, self.model_lib))
            for fn in _FAST_METHODS:
                setattr(self, fn, getattr(fast, fn))
        elif c_model.rhs != ffi.NULL:
            self.rhs = _cffi_fast_rhs(self, c_model.rhs, ffi.from_buffer)

    def __repr__(self):
        return (f"<eomc Model {self.name!r}: nq={self.nq} nu={self.nu} nparam={self.nparam} "
                f"ninput={self.ninput} backend={self.backend} from {self.library_path}>")

    # ---- argument checking -------------------------------------------------
    def _array(self, value, shape, what, names=()):
        a = np.asarray(value)
        if a.dtype.kind not in "fiu":
            raise ValueError(f"{self.name}: {what} must hold real numbers (float64); got dtype {a.dtype}")
        if a.shape != shape:
            listed = f" [{', '.join(names)}]" if names else ""
            raise ValueError(f"{self.name}: {what} must have shape {shape}{listed}; got shape {a.shape}")
        return np.ascontiguousarray(a, dtype=np.float64)

    def _time(self, t, what="t"):
        if isinstance(t, numbers.Real) and not isinstance(t, (bool, np.bool_)):
            try:
                return float(t)
            except OverflowError:  # an int such as 10**400
                raise ValueError(f"{self.name}: {what} must be a real number that fits a double; "
                                 f"got an integer of about {int(abs(int(t)).bit_length() * 0.30103)} "
                                 f"digits") from None
        a = np.asarray(t)
        if a.ndim == 0 and a.dtype.kind in "fiu":
            return float(a)
        raise ValueError(f"{self.name}: {what} must be a real scalar; got {type(t).__name__} {np.shape(t)}")

    def _named(self, value, names, defaults, what):
        out = np.array(defaults, dtype=np.float64)
        for key, v in value.items():
            out[index_of(key, names, what, self.name)] = self._time(v, f"{what} {model_name(key)}")
        return out

    def _params(self, p):
        """Parameters, prepared for the kernels (p=None: the defaults, no copy)."""
        if p is None:
            return self._default_p
        if isinstance(p, dict):
            return self._prepare(self._named(p, self.param_names, self.param_defaults, "parameter"))
        return self._prepare(self._array(p, (self.nparam,), "p (parameters)", self.param_names))

    def _inputs(self, r):
        """Inputs, prepared for the kernels (r=None: zeros)."""
        if self.ninput == 0:
            if r is not None and np.size(r) != 0:
                raise ValueError(f"{self.name}: this model has no inputs, but r was given")
            return self._default_r
        if r is None:
            return self._default_r
        if isinstance(r, dict):
            return self._prepare(self._named(r, self.input_names, self._zero_inputs, "input"))
        return self._prepare(self._array(r, (self.ninput,), "r (inputs)", self.input_names))

    def _state(self, x):
        if type(x) is np.ndarray and x.dtype is _F64 and x.shape == self._xshape and x.flags.c_contiguous:
            return x  # the common case, checked cheaply
        return self._array(x, self._xshape, "x (state)", self.state_names)

    def _args(self, t, x, p, r):
        t = float(t) if type(t) is float else self._time(t)
        return t, self._state(x), self._params(p), self._inputs(r)

    # ---- calling C -----------------------------------------------------------
    def _work(self):
        """Scratch for the C functions: one buffer per thread keeps calls reentrant."""
        try:
            return self._tls.work
        except AttributeError:
            array = np.empty(max(self.work_size, 1))
            self._tls.work = (array, self._prepare(array))
            return self._tls.work


    def _kernel(self, fn):
        try:
            return self._kernels[fn]
        except KeyError:
            raise self._missing(fn) from None

    def _missing(self, fn):
        """The error for a function this model was built without (rhs_many comes with rhs)."""
        needed = "rhs" if fn == "rhs_many" else fn
        return ModelError(f"model {self.name!r} was built without `{needed}`; rebuild it with "
                          f"functions including {needed!r} (eomc build --outputs ...)")

    def _nonfinite(self, t, x, p, r):
        """'x (state) q1=nan, p (parameters) g=inf' for whatever non-finite values were passed in."""
        found = []
        if not np.isfinite(t):
            found.append(f"t={t}")
        for what, value, names, defaults in (("x (state)", x, self.state_names, None),
                                             ("p (parameters)", p, self.param_names, self.param_defaults),
                                             ("r (inputs)", r, self.input_names, self._zero_inputs)):
            if value is None:
                continue
            try:
                a = (self._named(value, names, defaults, what) if isinstance(value, dict)
                     else np.asarray(value, dtype=np.float64).reshape(-1))
            except (TypeError, ValueError):
                continue
            if a.shape == (len(names),):
                bad = [f"{n}={v}" for n, v in zip(names, a) if not np.isfinite(v)]
                if bad:
                    found.append(f"{what} {', '.join(bad)}")
        return "; ".join(found)

    def _fail(self, fn, status, t, x, row=None, inputs=None):
        nonfinite = self._nonfinite(t, x, *(inputs or (None, None)))
        if nonfinite:  # not the model's fault: say which input was NaN/inf (not "singular mass matrix")
            where = f" (row {row} of X)" if row is not None else ""
            raise SimulationError(f"{self.name}.{fn}: non-finite input{where}: {nonfinite}")
        what = STATUS_NAMES.get(status, f"error status {status}")
        state = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.state_names, x))
        where = f" (row {row} of X)" if row is not None else ""
        why = singular_direction(self, t, x, *(inputs or (None, None))) if status == SINGULAR_STATUS else ""
        raise SimulationError(f"{self.name}.{fn}: {what} at t={t:.6g}, state {state}{where}{why}")

    def _vector_call(self, fn, size, t, x, p, r):
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        kernel = self._kernel(fn)
        out = np.empty(size)
        status = kernel(t, x, p, r, out, self._work()[1])
        if status:
            self._fail(fn, status, t, x, inputs=given)
        return out

    def _matrix_call(self, fn, rows, cols, t, x, p, r):
        return self._vector_call(fn, rows * cols, t, x, p, r).reshape(rows, cols)

    # ---- the model's functions -------------------------------------------------
    def rhs(self, t, x, p=None, r=None):
        """State derivative xdot = f(t, x, p, r), shape (nx,)."""
        if type(x) is list and p is None and r is None:
            # model.rhs(t, [..]) as the README writes it: convert once and take the installed
            # fast path (~1 us) instead of the general checked one (~7 us)
            fast = self.__dict__.get("rhs")
            a = np.asarray(x)
            if fast is not None and a.dtype.kind in "fiu" and a.shape == self._xshape:
                return fast(t, a.astype(np.float64))
        return self._vector_call("rhs", self.nx, t, x, p, r)

    _checked_rhs = rhs

    def rhs_many(self, t, X, p=None, r=None):
        """rhs at every row of X (shape (n, nx)) in one C loop; t scalar or (n,), r (ninput,) or (n, ninput).

        A model built with ``rhs_batch`` evaluates a scalar t through it (several states per
        instruction, :meth:`rhs_batch`)."""
        X = np.asarray(X)
        if X.ndim != 2 or X.shape[1:] != (self.nx,):
            raise ValueError(f"{self.name}: X must have shape (n, {self.nx}) (one state per row); "
                             f"got shape {X.shape}")
        if "rhs_batch" in self._kernels and np.ndim(t) == 0:
            return self.rhs_batch(t, X, p, r)
        n = X.shape[0]
        p_given = p
        X = self._array(X, X.shape, "X (states)")
        if np.ndim(t) == 0:
            times, t_stride = np.array([self._time(t)]), 0
        else:
            times, t_stride = self._array(t, (n,), "t (one time per row of X)"), 1
        p = self._params(p)
        if self.ninput and r is not None and np.ndim(r) == 2:
            R = self._prepare(self._array(r, (n, self.ninput), "r (inputs per row)", self.input_names).reshape(-1))
            r_stride = self.ninput
        else:
            R, r_stride = self._inputs(r), 0
        XD = np.empty((n, self.nx))
        if n == 0:
            return XD
        status, row = self._kernel("rhs_many")(n, times, t_stride, X.reshape(-1), p, R, r_stride,
                                               XD.reshape(-1), self._work()[1])
        if status:
            r_row = r[row] if self.ninput and r is not None and np.ndim(r) == 2 else r
            self._fail("rhs", status, times[row * t_stride], X[row], row, inputs=(p_given, r_row))
        return XD

    def rhs_batch(self, t, X, p=None, r=None):
        """rhs at every row of X (shape (n, nx)) by NAME_rhs_batch: several states per instruction
        (SIMD lanes, ``metadata["rhs_batch"]``), the rows past the last full group of lanes by
        the scalar rhs.  t scalar, p shared, r (ninput,) or (n, ninput).  Agrees with :meth:`rhs`
        bit for bit except through sin and cos, which are within 1 ulp of libm's.

        The C function reads and writes states as columns (structure of arrays), so the result
        is column-major (a transposed view) and a column-major X (``X.T`` of an (nx, n) array)
        is read without a copy; a row-major X costs one transpose.

        Generated on request (``functions`` including "rhs_batch", ``eomc build --outputs
        rhs,rhs_batch,...``)."""
        return self._batch("rhs_batch", t, X, p, r, self.nx).T

    def jac_x_batch(self, t, X, p=None, r=None):
        """jac_x at every row of X (shape (n, nx)) by NAME_jac_x_batch: several states per
        instruction (SIMD lanes, ``metadata["jac_x_batch"]``), the rows past the last full group
        of lanes by the scalar jac_x; returns (n, nx, nx).  t scalar, p shared, r (ninput,) or
        (n, ninput).  Agrees with :meth:`jacobian` bit for bit except through sin and cos (within
        1 ulp of libm's; bit for bit when built with -DEOMC_BATCH_LIBM_TRIG).

        Generated on request (``functions`` including "jac_x_batch")."""
        out = self._batch("jac_x_batch", t, X, p, r, self.nx * self.nx)
        return out.T.reshape(-1, self.nx, self.nx)

    def outputs_batch(self, t, X, p=None, r=None):
        """The outputs at every row of X (shape (n, nx)) by NAME_outputs_batch: several states per
        instruction (SIMD lanes, ``metadata["outputs_batch"]``), the rows past the last full group
        of lanes by the scalar outputs; (n, noutput), each row equal to ``outputs(t, X[i], p, r)``
        bit for bit with -DEOMC_BATCH_LIBM_TRIG, else within the lanes' sin/cos (1 ulp).  p, r as
        rhs_batch (r (n, ninput): one input row per state).  Generated on request (``functions``
        including "outputs_batch")."""
        return self._batch("outputs_batch", t, X, p, r, self.noutput).T

    def implicit_batch(self, t, X, p=None, r=None):
        """NAME_implicit (the fixed-step implicit step's terms, laid out as
        ``metadata["implicit"]["layout"]``) at every row of X by NAME_implicit_batch: several
        states per instruction (SIMD lanes; a contact's depth branch is a mask per lane), the
        rows past the last full group of lanes by the scalar NAME_implicit; (n, size).  Equal
        to NAME_implicit bit for bit with -DEOMC_BATCH_LIBM_TRIG, else within the lanes'
        sin/cos.  Generated on request (``functions`` including "implicit_batch")."""
        return self._batch("implicit_batch", t, X, p, r, self.metadata["implicit"]["layout"]["size"]).T

    def _batch(self, fn, t, X, p, r, nout):
        """(nout, n) from NAME_<fn> (rhs_batch, jac_x_batch) over the rows of X; errors name the
        first failed row."""
        kernel = self._kernels.get(fn)
        if kernel is None:
            if fn in self.functions:
                raise ModelError(f"model {self.name!r}: {fn} is called through the cffi backend; "
                                 f"load it with backend='cffi'")
            raise self._missing(fn)
        X = np.asarray(X)
        if X.ndim != 2 or X.shape[1:] != (self.nx,):
            raise ValueError(f"{self.name}: X must have shape (n, {self.nx}) (one state per row); "
                             f"got shape {X.shape}")
        n = X.shape[0]
        if n >= 2**31:
            raise ValueError(f"{self.name}: {fn} takes at most 2**31 - 1 states per call; got {n}")
        t = self._time(t)
        p_given = p
        if X.dtype != _F64 or not X.T.flags.c_contiguous:   # a column-major X is read as it is
            X = self._array(X, X.shape, "X (states)")
        soa = np.ascontiguousarray(X.T)
        p = self._params(p)
        R = None
        if self.ninput:
            if r is not None and np.ndim(r) == 2 and not isinstance(r, dict):
                R = np.ascontiguousarray(self._array(r, (n, self.ninput), "r (inputs per row)",
                                                     self.input_names).T)
            else:
                one = self._zero_inputs if r is None else (
                    self._named(r, self.input_names, self._zero_inputs, "input") if isinstance(r, dict)
                    else self._array(r, (self.ninput,), "r (inputs)", self.input_names))
                R = np.ascontiguousarray(np.broadcast_to(np.asarray(one)[:, None], (self.ninput, n)))
        elif r is not None and np.size(r) != 0:
            raise ValueError(f"{self.name}: this model has no inputs, but r was given")
        OUT = np.empty((nout, n))
        if n == 0:
            return OUT
        status = np.empty(n, dtype=np.intc)
        worst = kernel(n, t, soa, p, R, OUT, status, self._work()[1])
        if worst:
            if worst == _BAD_ARGUMENT:   # refused before any state: the C wrote no status (batch.py)
                raise self._refused(fn, n, p)
            failed = np.flatnonzero(status)
            if failed.size == 0:
                raise ModelError(f"model {self.name!r}: {fn} returned status {int(worst)} "
                                 f"({STATUS_NAMES.get(int(worst), 'unknown')}) but marked no row of X as "
                                 f"failed (eomc bug: the batch C must write every row's status)")
            row = int(failed[0])
            r_row = r[row] if self.ninput and r is not None and np.ndim(r) == 2 else r
            self._fail(fn, int(status[row]), t, np.asarray(X[row], dtype=np.float64), row,
                       inputs=(p_given, r_row))
        return OUT

    def _refused(self, fn, n, p):
        """The error for NAME_<fn>_batch returning EOMC_BAD_ARGUMENT: it checks its arguments
        before any state (n >= 0, X and the outputs not NULL, p not NULL when the model has
        parameters) and then writes no status, so no row is to blame."""
        null_p = p is None or (self.backend == "cffi" and p == self.ffi.NULL)
        if null_p and self.nparam:
            why = (f"p (parameters) was NULL, and the model has {self.nparam} parameter"
                   f"{'' if self.nparam == 1 else 's'} [{', '.join(self.param_names)}]; pass p=None "
                   f"for the defaults or an array of shape ({self.nparam},)")
        else:
            why = ("it takes n >= 0 states, X and the output array not NULL, and p not NULL when the "
                   "model has parameters")
        return ValueError(f"{self.name}.{fn} refused its arguments (bad argument) and evaluated none "
                          f"of the {n} states: {why}")

    def jacobian(self, t, x, p=None, r=None):
        """d rhs / d x, shape (nx, nx); also ``jac_x``, its C name."""
        return self._matrix_call("jac_x", self.nx, self.nx, t, x, p, r)

    jac_x = jacobian      # the C name (an instance binds it to the fast path, see __init__)

    def input_jacobian(self, t, x, p=None, r=None):
        """d rhs / d r, shape (nx, ninput); also ``jac_r``, its C name."""
        if self.ninput == 0:
            self._args(t, x, p, r)
            return np.empty((self.nx, 0))
        return self._matrix_call("jac_r", self.nx, self.ninput, t, x, p, r)

    def jac_p(self, t, x, r=None, p=None):
        """d rhs / d p, shape (nx, nparam): columns in ``param_names`` order.

        Generated only on request (``functions`` including ``"jac_p"``, ``eomc build
        --outputs ...,jac_p``).  Note the argument order (t, x, r, p), as the issue
        asks; keywords work either way.  A parameter folded into literals
        (``fold_parameters``) has no column.
        """
        if self.nparam == 0:
            self._args(t, x, p, r)
            return np.empty((self.nx, 0))
        return self._matrix_call("jac_p", self.nx, self.nparam, t, x, p, r)

    parameter_jacobian = jac_p

    def mass_matrix(self, t, x, p=None, r=None):
        """M(q), shape (nu, nu)."""
        return self._matrix_call("mass_matrix", self.nu, self.nu, t, x, p, r)

    def forcing(self, t, x, p=None, r=None):
        """f(q, u, t) of M u' = f, shape (nu,)."""
        return self._vector_call("forcing", self.nu, t, x, p, r)

    def outputs(self, t, x, p=None, r=None):
        """The model's named outputs as a dict name -> float."""
        if self.noutput == 0:
            self._args(t, x, p, r)
            return {}
        values = self._vector_call("outputs", self.noutput, t, x, p, r)
        return dict(zip(self.output_names, values.tolist()))

    @property
    def frame_names(self):
        """Frames whose pose, velocity and Jacobian are outputs (built with ``frames=[...]``)."""
        from .frames import frame_names
        return frame_names(self.output_names)

    def frame(self, name, t, x, p=None, r=None):
        """Frame output ``name`` (eomc.runtime.frames.Frame: ``p``, ``R``, ``v``, ``w``, ``J`` in
        world components; ``com``: ``p`` and ``v``) at one state (nx,), or along rows (n, nx)
        with t (n,).  The model must have been built with ``frames=[name]``."""
        from .frames import frame_from_columns, frame_indices
        frame_indices(self.output_names, name)          # a KeyError naming the frames first
        X = np.asarray(x, dtype=np.float64)
        if X.ndim == 2:
            T = np.asarray(t, dtype=np.float64)
            if T.shape != (X.shape[0],):
                raise ValueError(f"frame along rows needs t of shape ({X.shape[0]},), got {T.shape}")
            rows = [self._vector_call("outputs", self.noutput, float(ti), np.ascontiguousarray(xi), p, r)
                    for ti, xi in zip(T, X)]
            return frame_from_columns(self.output_names, np.array(rows).reshape(len(rows), self.noutput),
                                      name)
        return frame_from_columns(self.output_names, self._vector_call("outputs", self.noutput, t, x, p, r),
                                  name)

    def constraints(self, t, x, p=None, r=None):
        """Constraint residuals (nhol holonomic, then nvel velocity-level)."""
        if self.nhol + self.nvel == 0:
            self._args(t, x, p, r)
            return np.empty(0)
        return self._vector_call("constraints", self.nhol + self.nvel, t, x, p, r)

    def constraints_jacobian(self, t, x, p=None, r=None):
        """d constraints / d x, shape (nhol + nvel, nx); also ``constraints_jac``, its C name."""
        if self.nhol + self.nvel == 0:
            self._args(t, x, p, r)
            return np.empty((0, self.nx))
        return self._matrix_call("constraints_jac", self.nhol + self.nvel, self.nx, t, x, p, r)

    def inverse_dynamics(self, t, x, udot, p=None, r=None):
        """Generalized forces tau = M u' - f needed for the accelerations udot, shape (nu,)."""
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        udot = self._array(udot, (self.nu,), "udot (speed derivatives)",
                           self.state_names[self.nq:self.nq + self.nu])
        kernel = self._kernel("inverse_dynamics")
        tau = np.empty(self.nu)
        status = kernel(t, x, udot, p, r, tau, self._work()[1])
        if status:
            if not np.all(np.isfinite(udot)):
                raise SimulationError(f"{self.name}.inverse_dynamics: non-finite input: udot "
                                      f"{', '.join(f'{v}' for v in udot)}")
            self._fail("inverse_dynamics", status, t, x, inputs=given)
        return tau

    def jac_id(self, t, x, udot, p=None, r=None):
        """d tau / d x of inverse dynamics (tau = M u' - f at the given ``udot``), shape (nu, nx):
        columns [:, :nq] are d tau/dq, [:, nq:nq + nu] d tau/du (d tau/du' is the mass matrix).

        On request (``functions`` including "jac_id"), recursive formulation.  Pinocchio's
        ``computeRNEADerivatives`` differentiates along its Lie-group tangent instead of q:
        on a floating base its dtau_dq is ``jac_id[:, :nq] @ K`` with K = dq'/du
        (``jac_x[:nq, nq:nq + nu]``); on joints with one angle each they are the same.
        """
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        udot = self._array(udot, (self.nu,), "udot (speed derivatives)",
                           self.state_names[self.nq:self.nq + self.nu])
        kernel = self._kernel("jac_id")
        out = np.empty((self.nu, self.nx))
        status = kernel(t, x, udot, p, r, out.reshape(-1), self._work()[1])
        if status:
            if not np.all(np.isfinite(udot)):
                raise SimulationError(f"{self.name}.jac_id: non-finite input: udot "
                                      f"{', '.join(f'{v}' for v in udot)}")
            self._fail("jac_id", status, t, x, inputs=given)
        return out

    def jvp(self, t, x, directions, p=None, r=None):
        """(xdot, J·d for each row d of ``directions``): rhs and its directional derivatives
        along k directions in (state, parameter) space without forming J = d rhs/d[x; p].
        ``directions``: (k, nx) (state directions) or (k, nx + nparam).  Both
        formulations, on request (``functions`` including "jvp"); forward sensitivities use it."""
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        kernel = self._kernel("jvp")
        D = np.asarray(directions, dtype=np.float64)
        if D.ndim == 1:
            D = D[None, :]
        if D.ndim == 2 and D.shape[1] == self.nx:
            D = np.hstack([D, np.zeros((D.shape[0], self.nparam))])
        D = self._array(D, (D.shape[0], self.nx + self.nparam), "directions (k rows of nx or nx + nparam)")
        xdot, out = np.empty(self.nx), np.empty((D.shape[0], self.nx))
        status = kernel(t, x, p, r, D.shape[0], D.reshape(-1), xdot, out.reshape(-1), self._work()[1])
        if status:
            self._fail("jvp", status, t, x, inputs=given)
        return xdot, out

    def hess_id(self, t, x, udot, p=None, r=None):
        """∂²τ/∂x² of inverse dynamics at given udot, shape (nu, nx, nx): [i, j, k] =
        ∂²τ_i/∂x_j∂x_k (blocks [:, :nq, :nq] = ∂²τ/∂q², [:, :nq, nq:] = ∂²τ/∂q∂u, ...), by
        forward over reverse on RNEA.  Recursive formulation, on request ("hess_id").
        The C leaves the entries off the tree's support paths (zero for every state) as the
        caller zeroed them, Pinocchio's contract (compiler/tree/second_order.py, ``ZERO``): the
        output is a new zeroed array."""
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        udot = self._array(udot, (self.nu,), "udot (speed derivatives)",
                           self.state_names[self.nq:self.nq + self.nu])
        kernel = self._kernel("hess_id")
        out = np.zeros((self.nu, self.nx, self.nx))
        status = kernel(t, x, udot, p, r, out.reshape(-1), self._work()[1])
        if status:
            self._fail("hess_id", status, t, x, inputs=given)
        return out

    def vjp(self, t, x, lam, p=None, r=None):
        """(xdot, lamᵀ·∂rhs/∂x, lamᵀ·∂rhs/∂p): the vector-Jacobian products with respect to
        the state and every parameter by one reverse sweep (cost a few rhs, whatever nx and
        nparam), what adjoint sensitivities and gradient-based fitting need.  Both
        formulations, on request (``functions`` including "vjp")."""
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        kernel = self._kernel("vjp")
        lam = self._array(lam, (self.nx,), "lam (one weight per state)", self.state_names)
        xdot, gx, gp = np.empty(self.nx), np.empty(self.nx), np.empty(self.nparam)
        status = kernel(t, x, p, r, lam, xdot, gx, gp, self._work()[1])
        if status:
            self._fail("vjp", status, t, x, inputs=given)
        return xdot, gx, gp

    def hvp(self, t, x, lam, v, p=None, r=None):
        """(∂²(lamᵀ·rhs)/∂x²)·v: the directional second derivative of lamᵀ·rhs (what DDP and
        interior-point solvers consume), by forward over reverse mode.  Both formulations,
        on request (``functions`` including "hvp")."""
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        kernel = self._kernel("hvp")
        lam = self._array(lam, (self.nx,), "lam (one weight per state)", self.state_names)
        v = self._array(v, (self.nx,), "v (a state direction)", self.state_names)
        out = np.empty(self.nx)
        status = kernel(t, x, p, r, lam, v, out, self._work()[1])
        if status:
            self._fail("hvp", status, t, x, inputs=given)
        return out

    def regressor(self, q, u, udot, p=None, t=0.0):
        """Y(q, u, u'), shape (nu, 10 * bodies), with inverse dynamics = Y @ pi at zero inputs.

        pi holds 10 numbers per body (``regressor_columns`` names them): mass, first
        moments m·c and the inertia about the body's reference point (its link frame
        for a URDF robot, as Pinocchio's ``computeJointTorqueRegressor``; else its mass
        centre), in Pinocchio's order.  Recursive formulation, on request
        (``functions`` including "regressor").  ``p`` only places the joints (the
        inertial parameters do not enter Y).
        """
        kernel = self._kernel("regressor")
        q = self._array(q, (self.nq,), "q (coordinates)", self.state_names[:self.nq])
        u = self._array(u, (self.nu,), "u (speeds)", self.state_names[self.nq:])
        # extra first-order states (after q and u) do not enter the regressor: zeros
        t, x, pp, r = self._args(t, np.concatenate([q, u, np.zeros(self.nx - self.nq - self.nu)]), p, None)
        udot = self._array(udot, (self.nu,), "udot (speed derivatives)", self.state_names[self.nq:])
        out = np.empty((self.nu, 10 * len(self.metadata.get("regressor_bodies", ()))))
        status = kernel(t, x, udot, pp, r, out.reshape(-1), self._work()[1])
        if status:
            self._fail("regressor", status, t, x, inputs=(p, None))
        return out

    jac_r = input_jacobian
    constraints_jac = constraints_jacobian

    @property
    def regressor_columns(self):
        """Names of the regressor's columns: ``<parameter>_<body>`` (see :meth:`regressor`)."""
        names = self.metadata.get("regressor_parameters", ())
        return tuple(f"{k}_{b}" for b in self.metadata.get("regressor_bodies", ()) for k in names)

    def linearize(self, t, x, p=None, r=None, parameters=False):
        """(A, B) = (d rhs/d x, d rhs/d r) at an operating point; with ``parameters=True``
        (A, B, P), P = d rhs/d p (the model must have been built with jac_p).  Over every
        state: a quaternion's 4 coordinates included, whose length is no motion (a zero
        eigenvalue no physics explains); :meth:`linearize_reduced` and ``eomc linearize``
        report quaternions in their 3-angle tangent chart (eomc.runtime.tangent)."""
        if parameters:
            if self.nparam and "jac_p" not in self._kernels:
                raise self._missing("jac_p")
            A, B = self.linearize(t, x, p, r)
            return A, B, self.jac_p(t, x, r=r, p=p)
        if "linearize" not in self._kernels:
            return self.jacobian(t, x, p, r), self.input_jacobian(t, x, p, r)
        given = (p, r)
        t, x, p, r = self._args(t, x, p, r)
        A, B = np.empty((self.nx, self.nx)), np.empty((self.nx, self.ninput))
        status = self._kernels["linearize"](t, x, p, r, A.reshape(-1), B.reshape(-1), self._work()[1])
        if status:
            self._fail("linearize", status, t, x, inputs=given)
        return A, B

    def linearize_reduced(self, t, x, p=None, r=None, fixed=None):
        """(A, B, states, basis): linearization over the independent states only (the dependent
        ones eliminated through the constraint Jacobian, quaternions in their 3-angle tangent
        chart); see eomc.runtime.reduced and eomc.runtime.tangent."""
        from .reduced import linearize_reduced
        return linearize_reduced(self, t, x, p, r, fixed=fixed)

    def consistent_state(self, x0, t=0.0, p=None, r=None, fixed=None, tol=1e-12, max_iter=50):
        """x0 completed onto the constraints: dependent coordinates by Newton on the
        configuration constraints, dependent speeds from the velocity constraints, the
        others (or the states named in ``fixed``) kept; see eomc.runtime.consistent."""
        from .consistent import consistent_state
        return consistent_state(self, x0, t, p, r, fixed=fixed, tol=tol, max_iter=max_iter)

    def simulate(self, x0, t_span, **kw):
        """Integrate from x0 over t_span; see eomc.runtime.simulate.simulate."""
        from .simulate import check_keywords, simulate
        check_keywords(kw, simulate, skip=3)
        result = simulate(self, x0, t_span, **kw)
        # res.poses() / res.animate() evaluate the model again, with the run's parameters
        result.model, result.p = self, kw.get("p")
        if not callable(kw.get("r")) and not isinstance(kw.get("r"), tuple):
            result.r = kw.get("r")
        return result

    def poses(self, t, x, p=None, r=None):
        """Where the bodies are (eomc.runtime.poses.Poses): each body frame's origin and rotation
        matrix and each named point's position in the world, computed by the generated C
        ``NAME_poses``.  ``x``: one state (nx,) with scalar ``t``, or rows (n, nx) with t (n,)."""
        from .poses import evaluate_poses
        return evaluate_poses(self, t, x, p, r)

    def animate(self, res=None, path=None, **options):
        """A self-contained HTML animation (eomc.runtime.animate) of ``res`` (a SimulationResult;
        default: 10 s from the initial state)."""
        from .animate import animate
        if res is None:
            x0 = self.initial_state if self.initial_state is not None else np.zeros(self.nx)
            res = self.simulate(x0, (0.0, 10.0), n_points=601)
        return animate(res, path, model=self, **options)
