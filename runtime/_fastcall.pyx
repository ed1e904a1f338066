# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Calls into ANY model through its ``const eomc_model *``, compiled once with eomc.

Why this exists: a call through cffi costs ~3-5 us of Python per rhs, several
times the C work of a small model; the per-model Cython backend is ~0.6 us but
takes 10-25 s to build per model.  The struct's function pointers have the same
signature for every model, so one extension, built at install time (setup.py),
can call any model's C directly and check the common call in C.

:class:`FastCalls` takes the struct's address (``int(ffi.cast("uintptr_t",
c_model))``) and, per function, the runtime's *checked* Python method.  The
fast path handles only the commonest call -- a real scalar t and float64,
aligned, native-byte-order, C-contiguous 1-D arrays of the right lengths
(p and r may be None: the defaults / zero inputs).  Anything else, a function
the model lacks, or a nonzero status is handed to the checked method, which
converts the arguments or raises the proper ``ValueError`` /
``SimulationError`` / ``ModelError``.  Both paths run the same C function on
the same numbers, so their results are bit-identical.

The GIL is released around the C call only for functions the caller marks as
expensive (``nogil`` names): for a tiny model, releasing and re-acquiring the
GIL costs a measurable share of the call and, with another busy Python
thread, re-acquiring can wait a whole switch interval.
"""
from cpython.float cimport PyFloat_AS_DOUBLE, PyFloat_Check
from cpython.mem cimport PyMem_Free, PyMem_Malloc
from libc.stdint cimport uintptr_t

cimport numpy as cnp

cnp.import_array()

__all__ = ["FastCalls", "ABI_VERSION"]

cdef extern from "eomc_model.h":
    int EOMC_ABI_VERSION
    ctypedef int (*eomc_rhs_fn)(double t, const double *x, const double *p, const double *r,
                                double *out, double *work) noexcept nogil
    ctypedef int (*eomc_mat_fn)(double t, const double *x, const double *p, const double *r,
                                double *out, double *work) noexcept nogil
    ctypedef struct eomc_model:
        int abi_version
        int nq, nu, nx
        int nparam, ninput
        size_t work_size
        eomc_rhs_fn rhs
        eomc_mat_fn jac_x
        eomc_mat_fn mass_matrix
        eomc_rhs_fn forcing

ABI_VERSION = EOMC_ABI_VERSION

cdef enum:
    STACK_WORK = 512   # doubles of scratch kept on the C stack (4 KiB); more is malloc'd per call


cdef inline bint _vector(object a, Py_ssize_t n, const double **data):
    """True (and *data set, NULL when n == 0) for a well-behaved float64 1-D array of length n."""
    cdef cnp.ndarray arr
    if not cnp.PyArray_Check(a):
        return False
    arr = <cnp.ndarray>a
    if (cnp.PyArray_TYPE(arr) != cnp.NPY_DOUBLE or cnp.PyArray_NDIM(arr) != 1
            or cnp.PyArray_DIM(arr, 0) != n or not cnp.PyArray_IS_C_CONTIGUOUS(arr)
            or not cnp.PyArray_ISBEHAVED_RO(arr)):   # aligned and in native byte order
        return False
    data[0] = NULL if n == 0 else <const double *>cnp.PyArray_DATA(arr)
    return True


cdef inline bint _time(object t, double *value):
    """True (and *value set) for a Python float (or subclass, e.g. numpy.float64) or int."""
    if PyFloat_Check(t):
        value[0] = PyFloat_AS_DOUBLE(t)
        return True
    if type(t) is int:
        try:
            value[0] = <double>t
        except OverflowError:
            return False
        return True
    return False


cdef class FastCalls:
    """rhs / jacobian / mass_matrix / forcing of one model, with the common call checked in C.

    ``FastCalls(address, p_default, r_zero, checked, nogil=(), keepalive=None)``:
    address of the model's ``eomc_model`` struct; the default parameters and the
    zero inputs (float64 arrays, held here); ``checked``, a mapping from the
    method names to the validating Python methods used for everything the fast
    path does not take; ``nogil``, the method names whose C call releases the
    GIL; ``keepalive``, any object that must outlive this one (the library).
    """
    cdef const eomc_model *model
    cdef object p_default, r_zero, keepalive
    cdef object checked_rhs, checked_jacobian, checked_mass_matrix, checked_forcing
    cdef const double *p_ptr
    cdef const double *r_ptr
    cdef Py_ssize_t nx, nu, nparam, ninput
    cdef size_t work_size
    cdef bint nogil_rhs, nogil_jacobian, nogil_mass_matrix, nogil_forcing

    def __init__(self, uintptr_t address, p_default, r_zero, checked, nogil=(), keepalive=None):
        if address == 0:
            raise ValueError("FastCalls: NULL eomc_model pointer")
        self.model = <const eomc_model *>address
        if self.model.abi_version != EOMC_ABI_VERSION:
            raise ValueError(f"FastCalls: model ABI {self.model.abi_version}, this eomc reads {EOMC_ABI_VERSION}")
        self.nx, self.nu = self.model.nx, self.model.nu
        self.nparam, self.ninput = self.model.nparam, self.model.ninput
        self.work_size = self.model.work_size
        if not _vector(p_default, self.nparam, &self.p_ptr):
            raise ValueError(f"FastCalls: p_default must be a float64 C-contiguous array of shape ({self.nparam},)")
        if not _vector(r_zero, self.ninput, &self.r_ptr):
            raise ValueError(f"FastCalls: r_zero must be a float64 C-contiguous array of shape ({self.ninput},)")
        self.p_default, self.r_zero, self.keepalive = p_default, r_zero, keepalive
        self.checked_rhs = checked["rhs"]
        self.checked_jacobian = checked["jacobian"]
        self.checked_mass_matrix = checked["mass_matrix"]
        self.checked_forcing = checked["forcing"]
        nogil = frozenset(nogil)
        unknown = nogil - {"rhs", "jacobian", "mass_matrix", "forcing"}
        if unknown:
            raise ValueError(f"FastCalls: nogil names unknown methods {sorted(unknown)}")
        self.nogil_rhs, self.nogil_jacobian = "rhs" in nogil, "jacobian" in nogil
        self.nogil_mass_matrix, self.nogil_forcing = "mass_matrix" in nogil, "forcing" in nogil

    @property
    def nogil(self):
        """Names of the methods whose C call releases the GIL."""
        flags = (self.nogil_rhs, self.nogil_jacobian, self.nogil_mass_matrix, self.nogil_forcing)
        return tuple(fn for fn, flag in zip(("rhs", "jacobian", "mass_matrix", "forcing"), flags) if flag)

    cdef object _call(self, eomc_rhs_fn fn, bint release, int nd, Py_ssize_t rows, Py_ssize_t cols,
                      object t, object x, object p, object r):
        """A new array (rows,) or (rows, cols) from fn, or None: the caller takes the checked path."""
        cdef double tt
        cdef const double *xp
        cdef const double *pp = self.p_ptr
        cdef const double *rp = self.r_ptr
        cdef double stack_work[STACK_WORK]
        cdef double *work = stack_work
        cdef cnp.npy_intp dims[2]
        cdef double *op
        cdef int status
        if fn == NULL or not _time(t, &tt) or not _vector(x, self.nx, &xp):
            return None
        if p is not None and not _vector(p, self.nparam, &pp):
            return None
        if r is not None and (self.ninput == 0 or not _vector(r, self.ninput, &rp)):
            return None   # the checked path accepts an empty r for an input-free model
        dims[0], dims[1] = rows, cols
        out = cnp.PyArray_EMPTY(nd, dims, cnp.NPY_DOUBLE, 0)
        op = <double *>cnp.PyArray_DATA(<cnp.ndarray>out)
        if self.work_size > STACK_WORK:
            work = <double *>PyMem_Malloc(self.work_size * sizeof(double))
            if work == NULL:
                raise MemoryError()
        if release:
            with nogil:
                status = fn(tt, xp, pp, rp, op, work)
        else:
            status = fn(tt, xp, pp, rp, op, work)
        if work != stack_work:
            PyMem_Free(work)
        return None if status else out

    def rhs(self, t, x, p=None, r=None):
        """State derivative xdot = f(t, x, p, r), shape (nx,)."""
        out = self._call(self.model.rhs, self.nogil_rhs, 1, self.nx, 0, t, x, p, r)
        return self.checked_rhs(t, x, p, r) if out is None else out

    def jacobian(self, t, x, p=None, r=None):
        """d rhs / d x, shape (nx, nx)."""
        out = self._call(<eomc_rhs_fn>self.model.jac_x, self.nogil_jacobian, 2, self.nx, self.nx, t, x, p, r)
        return self.checked_jacobian(t, x, p, r) if out is None else out

    def mass_matrix(self, t, x, p=None, r=None):
        """M(q), shape (nu, nu)."""
        out = self._call(<eomc_rhs_fn>self.model.mass_matrix, self.nogil_mass_matrix, 2, self.nu, self.nu,
                         t, x, p, r)
        return self.checked_mass_matrix(t, x, p, r) if out is None else out

    def forcing(self, t, x, p=None, r=None):
        """f(q, u, t) of M u' = f, shape (nu,)."""
        out = self._call(self.model.forcing, self.nogil_forcing, 1, self.nu, 0, t, x, p, r)
        return self.checked_forcing(t, x, p, r) if out is None else out
