"""A c99-f32 build, loaded: its float functions callable from Python, for comparison with double.

A c99-f32 model is firmware code (``eomc build --target c99-f32``): float signatures and no
``eomc_model`` struct, so the integrators, sweeps and the Model class (all double) cannot
run it.  What Python can usefully do with it is evaluate it next to the double build --
the price of float, measured on the host -- so :class:`Float32Model` calls NAME_rhs,
NAME_jac_x, NAME_mass_matrix, NAME_forcing, NAME_outputs and NAME_step_rk4 through cffi
with float32 arrays, and everything else is a clear error saying what to build instead.
"""
import cffi
import numpy as np

from .cdef import STATUS_NAMES
from .errors import EomcError

__all__ = ["Float32Model", "FLOAT32_TARGET", "float32_cdef"]

FLOAT32_TARGET = "c99-f32"
_ARGS = "float t, const float *x, const float *p, const float *r"
_SHAPES = {"rhs": ("nx",), "jac_x": ("nx", "nx"), "jac_r": ("nx", "ninput"),
           "mass_matrix": ("nu", "nu"), "forcing": ("nu",), "outputs": ("noutput",),
           "constraints": ("ncon",), "events": ("nevent",)}


def float32_cdef(name, functions):
    """The declarations of a c99-f32 library (compiler/emit/target.py writes the same text)."""
    lines = [f"int {name}_{fn}({_ARGS}, float *out, float *work);" for fn in _SHAPES if fn in functions]
    if "rhs" in functions:   # the step exists when rhs does (compiler/emit/target.py)
        lines.append(f"int {name}_step_rk4(float t, float h, float *x, const float *p, const float *r, float *work);")
    return "\n".join(lines) + "\n"


class Float32Model:
    """The float functions of a c99-f32 build (see the module docstring)."""

    def __init__(self, library, metadata, directory):
        self.metadata = metadata
        self.name = metadata["name"]
        self.directory = directory
        self.target = FLOAT32_TARGET
        for key in ("nq", "nu", "nx", "nparam", "ninput", "noutput", "work_size"):
            setattr(self, key, int(metadata[key]))
        self.ncon = int(metadata["nhol"]) + int(metadata["nvel"])
        self.nevent = len(metadata.get("events") or ())
        self.state_names = list(metadata["state_names"])
        self.param_names = list(metadata["param_names"])
        self.param_defaults = np.asarray(metadata["param_defaults"], dtype=np.float32)
        self.functions = tuple(metadata["functions"])
        self._ffi = cffi.FFI()
        self._ffi.cdef(float32_cdef(self.name, self.functions))
        try:
            self._lib = self._ffi.dlopen(str(library))
            for fn in list(_SHAPES) + ["step_rk4"]:
                if fn in self.functions or (fn == "step_rk4" and "rhs" in self.functions):
                    getattr(self._lib, f"{self.name}_{fn}")
        except (OSError, AttributeError) as exc:
            from .metadata import LoadError
            raise LoadError(f"cannot load the c99-f32 model {self.name!r} from {library}: {exc}") from None

    def _vec(self, value, n, what):
        a = np.ascontiguousarray(value, dtype=np.float32).reshape(-1)
        if a.shape != (n,):
            raise EomcError(f"{self.name}: {what} has {a.size} entries; the model expects {n}")
        return a

    def _ptr(self, a):
        return self._ffi.cast("float *", self._ffi.from_buffer(a))

    def _inputs(self, x, p, r):
        x = self._vec(x, self.nx, "x")
        p = self.param_defaults if p is None else self._vec(p, self.nparam, "p")
        r = np.zeros(self.ninput, np.float32) if r is None else self._vec(r, self.ninput, "r")
        return x, p, r

    def _call(self, fn, t, x, p, r):
        if fn not in self.functions:
            raise EomcError(f"{self.name}_{fn} was not generated for this model")
        x, p, r = self._inputs(x, p, r)
        shape = tuple(getattr(self, k) for k in _SHAPES[fn])
        out = np.empty(int(np.prod(shape)), np.float32)
        work = np.empty(max(self.work_size, 1), np.float32)
        status = getattr(self._lib, f"{self.name}_{fn}")(
            float(t), self._ptr(x), self._ptr(p), self._ptr(r), self._ptr(out), self._ptr(work))
        if status:
            raise EomcError(f"{self.name}_{fn} (float) failed at t={float(t):g}: "
                            f"{STATUS_NAMES.get(status, f'status {status}')}")
        return out.reshape(shape)

    def rhs(self, t, x, p=None, r=None):
        """xdot in float32, shape (nx,)."""
        return self._call("rhs", t, x, p, r)

    def jacobian(self, t, x, p=None, r=None):
        """d rhs / d x in float32, shape (nx, nx)."""
        return self._call("jac_x", t, x, p, r)

    def mass_matrix(self, t, x, p=None, r=None):
        return self._call("mass_matrix", t, x, p, r)

    def forcing(self, t, x, p=None, r=None):
        return self._call("forcing", t, x, p, r)

    def outputs(self, t, x, p=None, r=None):
        """The named outputs as a dict name -> float (computed in float32)."""
        values = self._call("outputs", t, x, p, r)
        return dict(zip(self.metadata["output_names"], values.tolist()))

    def step_rk4(self, t, h, x, p=None, r=None):
        """One NAME_step_rk4 step from (t, x): the new state (float32); x is not modified."""
        if "rhs" not in self.functions:
            raise EomcError(f"{self.name}_step_rk4 was not generated: the model was built without rhs")
        x, p, r = self._inputs(x, p, r)
        x = x.copy()
        work = np.empty(max(self.work_size, 1), np.float32)
        status = getattr(self._lib, f"{self.name}_step_rk4")(
            float(t), float(h), self._ptr(x), self._ptr(p), self._ptr(r), self._ptr(work))
        if status:
            raise EomcError(f"{self.name}_step_rk4 (float) failed at t={float(t):g}: "
                            f"{STATUS_NAMES.get(status, f'status {status}')}")
        return x

    def float_concerns(self, x0=None):
        """What float cannot hold at the model's default state, in words naming the coordinate,
        speed or parameter: values beyond float's range, an rhs that fails in float, and a mass
        matrix whose condition number times float's epsilon passes 1% (the relative error the
        speeds' derivatives may then carry; benchmarks/results/embedded.md measures it).
        ``x0``: the default state (the model file's initial_state), else zeros."""
        out, beyond = [], False
        finfo = np.finfo(np.float32)
        x0 = np.zeros(self.nx) if x0 is None else np.asarray(x0, dtype=np.float64)
        for kind, names, values in (("state", self.state_names, x0),
                                    ("parameter", self.param_names, self.metadata["param_defaults"])):
            for n, v in zip(names, values):
                if abs(v) > finfo.max:
                    beyond = True
                    out.append(f"{kind} {n} = {v:g} overflows float (largest {float(finfo.max):.4g}): it would be inf")
                elif 0 < abs(v) < finfo.smallest_subnormal:
                    out.append(f"{kind} {n} = {v:g} is below float's smallest number "
                               f"({float(finfo.smallest_subnormal):.3g}): it is 0 in float"
                               + (" (its default is written as 0)" if kind == "parameter" else ""))
                elif 0 < abs(v) < finfo.tiny:
                    out.append(f"{kind} {n} = {v:g} is below float's smallest normal number "
                               f"({float(finfo.tiny):.3g}): it loses its digits")
        if beyond:          # an inf in the inputs: the checks below would only repeat it
            return out
        try:
            if "rhs" in self.functions:
                self.rhs(0.0, x0)
        except EomcError as exc:
            out.append(f"at the default state the float rhs fails: {exc}")
        if "mass_matrix" in self.functions:
            try:
                M = self.mass_matrix(0.0, x0).astype(np.float64)
                cond = np.linalg.cond(M)
            except (EomcError, np.linalg.LinAlgError):
                return out
            if not np.isfinite(cond) or cond * float(finfo.eps) > 1e-2:
                _, vectors = np.linalg.eigh(0.5 * (M + M.T))
                speed = self.state_names[self.nq + int(np.argmax(np.abs(vectors[:, 0])))]
                out.append(f"the mass matrix is ill-conditioned for float at the default state "
                           f"(cond(M) = {cond:.3g}: relative errors up to ~{cond * float(finfo.eps):.1g} "
                           f"in the accelerations); its weakest direction is mostly the speed {speed}: "
                           f"rescale that body's mass or inertia, or build for c99-f64")
        return out

    def __getattr__(self, attr):
        if attr.startswith("_"):
            raise AttributeError(attr)
        raise EomcError(f"model {self.name!r} was built for {FLOAT32_TARGET} (firmware): from Python it "
                        f"evaluates rhs, jacobian, mass_matrix, forcing, outputs and step_rk4 in float; "
                        f"{attr} runs on double builds: rebuild with --target c99-f64 (the default)")

    def __repr__(self):
        return f"<eomc Float32Model {self.name!r} nx={self.nx} ({FLOAT32_TARGET}) in {self.directory}>"
