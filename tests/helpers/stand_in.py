"""Hand-written C test models, built with gcc into one .so with the integrators.

Why: the integrator and simulate tests must not depend on the code generator
or the build system, so they run against small C models with known answers
(oscillator, pendulum, stiff chain, Kepler orbit, a constrained ring, and two
failure cases) written directly against runtime/c/eomc_model.h.  The
stand-in object carries the attributes the runtime Model has (preamble,
"Pipeline interfaces"), which is all eomc.runtime.simulate uses.
"""
import functools
import shutil
import subprocess
import tempfile
from pathlib import Path

import cffi
import numpy as np

from eomc.errors import SimulationError
from eomc.runtime.cdef import MODEL_CDEF
from eomc.runtime.integrators_api import INTEGRATOR_CDEF

__all__ = ["MODELS_DIR", "RUNTIME_C", "MODEL_NAMES", "StandInModel", "build_library", "get_model",
           "compile_shared"]

MODELS_DIR = Path(__file__).resolve().parents[1] / "runtime" / "models"  # the stand-in C models
RUNTIME_C = Path(__file__).resolve().parents[2] / "runtime" / "c"  # eomc_model.h, eomc_integrators.c
MODEL_NAMES = ("oscillator", "pendulum", "chain", "kepler", "ring", "blowup", "singular", "sphere",
               "top", "robertson", "vdp", "decay_fail")
SOURCES = ("oscillator.c", "pendulum.c", "chain.c", "kepler.c", "ring.c", "faulty.c", "sphere.c",
           "top.c", "stiff.c")

def compile_shared(out, sources, extra_flags=()):
    """gcc -shared the given C files with the integrators; raises with gcc's output."""
    cmd = ["gcc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-fPIC", "-shared",
           f"-I{RUNTIME_C}", *extra_flags, "-o", str(out), *map(str, sources),
           str(RUNTIME_C / "eomc_integrators.c"), str(RUNTIME_C / "eomc_fixedstep.c"), str(RUNTIME_C / "eomc_fixedstep_avx2.c"), str(RUNTIME_C / "eomc_bdf.c"), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"gcc failed:\n{' '.join(cmd)}\n{proc.stderr}")
    return out


@functools.lru_cache(maxsize=None)
def build_library():
    """(ffi, lib) of all hand-written models; built once per process in a temp dir."""
    if shutil.which("gcc") is None:
        raise RuntimeError("gcc is needed to build the hand-written test models")
    tmp = Path(tempfile.mkdtemp(prefix="eomc_standin_"))
    so = compile_shared(tmp / "libstandin.so", [MODELS_DIR / s for s in SOURCES])
    ffi = cffi.FFI()
    ffi.cdef(MODEL_CDEF + INTEGRATOR_CDEF
             + "".join(f"const eomc_model *{n}_model(void);\n" for n in MODEL_NAMES))
    return ffi, ffi.dlopen(str(so))


def _strings(ffi, arr, n):
    return tuple(ffi.string(arr[i]).decode() for i in range(n))


class StandInModel:
    """The runtime Model's attributes over a hand-written C model (no metadata file)."""

    def __init__(self, ffi, lib, name):
        m = getattr(lib, f"{name}_model")()
        self.ffi, self.lib, self.c_model, self.name = ffi, lib, m, name
        self.integrators = lib  # the stand-in library links the integrators itself
        for f in ("nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol", "nvel", "work_size"):
            setattr(self, f, int(getattr(m, f)))
        self.state_names = _strings(ffi, m.state_names, self.nx)
        self.param_names = _strings(ffi, m.param_names, self.nparam)
        self.input_names = _strings(ffi, m.input_names, self.ninput)
        self.output_names = _strings(ffi, m.output_names, self.noutput)
        self.param_defaults = np.array([m.param_defaults[i] for i in range(self.nparam)])
        self.metadata = {"name": name}
        self.initial_state = None

    def _call(self, fn, size, t, x, p, r):
        p = self.param_defaults if p is None else np.ascontiguousarray(p, float)
        r = np.zeros(max(self.ninput, 1)) if r is None else np.ascontiguousarray(r, float)
        x = np.ascontiguousarray(x, float)
        out, work = np.empty(size), np.empty(self.work_size + 1)
        ptr = lambda a: self.ffi.from_buffer("double[]", a)  # noqa: E731
        status = fn(float(t), ptr(x), ptr(p), ptr(r), ptr(out), ptr(work))
        if status:
            raise SimulationError(f"{self.name}: status {status} at t={t}")
        return out

    def rhs(self, t, x, p=None, r=None):
        return self._call(self.c_model.rhs, self.nx, t, x, p, r)

    def mass_matrix(self, t, x, p=None, r=None):
        return self._call(self.c_model.mass_matrix, self.nu * self.nu, t, x, p, r).reshape(self.nu, self.nu)

    def jacobian(self, t, x, p=None, r=None):
        return self._call(self.c_model.jac_x, self.nx * self.nx, t, x, p, r).reshape(self.nx, self.nx)

    def simulate(self, x0, t_span, **kw):
        from eomc.runtime.simulate import simulate
        return simulate(self, x0, t_span, **kw)


def get_model(name):
    ffi, lib = build_library()
    return StandInModel(ffi, lib, name)
