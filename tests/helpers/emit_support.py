"""Helpers for the C generator tests: FormedSystems from SymPy's own mechanics
classes (independent of eomc's front end), a direct gcc build, a cffi ABI-mode
loader and lambdify oracles."""
import os
import shutil
import subprocess

import cffi
import numpy as np
import sympy as sm
from sympy.physics import mechanics as me
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.mechanics.formed import FormedSystem

HEADER_DIR = os.path.join(os.path.dirname(__file__), "..", "..", "runtime", "c")
STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"]
STRUCT_CDEF = """
typedef struct eomc_model {
    int abi_version; const char *name; int nq, nu, nx; int nparam, ninput; int noutput;
    int nhol; int nvel; size_t work_size;
    const char *const *state_names; const char *const *param_names;
    const double *param_defaults; const char *const *input_names;
    const char *const *output_names;
    void *rhs, *jac_x, *jac_r, *mass_matrix, *forcing, *outputs, *constraints, *constraints_jac;
} eomc_model;
"""
t = dynamicsymbols._t


def _params(mats, states):
    syms = set()
    for m in mats:
        syms |= m.free_symbols
    syms.discard(t)
    return tuple(sorted(syms, key=lambda s: s.name))


def kane_formed(kane, specified=()):
    """FormedSystem from a SymPy KanesMethod (kinematics from kindiffdict)."""
    q, u = list(kane.q), list(kane.u)
    kd = kane.kindiffdict()
    kin = sm.Matrix([kd[qi.diff(t)] for qi in q])
    M, f = kane.mass_matrix, kane.forcing
    hol = kane._f_h if kane._f_h.shape[0] else sm.zeros(0, 1)
    vel = (kane._f_nh + kane._k_nh * sm.Matrix(u)) if kane._k_nh.shape[0] else sm.zeros(0, 1)
    return FormedSystem(
        method="kane", coordinates=tuple(q), speeds=tuple(u),
        n_dependent_coordinates=len(kane._qdep), n_dependent_speeds=len(kane._udep),
        kinematics=kin, dynamics_matrix=M, dynamics_rhs=f, multipliers=(),
        holonomic_constraints=hol, velocity_constraints=vel, inputs=tuple(specified),
        parameters=_params([kin, M, f, hol, vel], q + u))


def lagrange_formed(lm, specified=()):
    """FormedSystem from a SymPy LagrangesMethod: A = [[m_d, Φᵀ], [m_cd, 0]], w = [q''; λ]."""
    n = len(lm.q)
    A = lm.mass_matrix_full[n:, n:]
    b = lm.forcing_full[n:, :]
    qd = [qi.diff(t) for qi in lm.q]
    hol = sm.Matrix(lm._hol_coneqs) if lm._hol_coneqs else sm.zeros(0, 1)
    vel = sm.Matrix(lm.coneqs) if lm.coneqs else sm.zeros(0, 1)
    return FormedSystem(
        method="lagrange", coordinates=tuple(lm.q), speeds=tuple(qd),
        n_dependent_coordinates=0, n_dependent_speeds=0, kinematics=sm.Matrix(qd),
        dynamics_matrix=A, dynamics_rhs=b, multipliers=tuple(lm.lam_vec),
        holonomic_constraints=hol, velocity_constraints=vel, inputs=tuple(specified),
        parameters=_params([A, b, hol, vel], list(lm.q) + qd))


def write_sources(gm, directory):
    shutil.copy(os.path.join(HEADER_DIR, "eomc_model.h"), directory)
    with open(os.path.join(directory, f"{gm.name}.c"), "w") as fh:
        fh.write(gm.c_source)
    with open(os.path.join(directory, f"{gm.name}.h"), "w") as fh:
        fh.write(gm.header)
    return os.path.join(directory, f"{gm.name}.c")


def sanitized_run(gm, directory, driver, flags=(), defines=()):
    """``driver`` (C text, NAME for the model's name) built with the model's C under strict
    warnings and ASan/UBSan, and run: (the compiler's result, the run's result)."""
    import subprocess
    directory = str(directory)
    src = write_sources(gm, directory)
    main = os.path.join(directory, "main.c")
    with open(main, "w") as fh:
        fh.write(driver.replace("NAME", gm.name))
    exe = os.path.join(directory, "driver")
    cmd = ["gcc", *STRICT, *flags, "-O1", "-g", "-fsanitize=address,undefined",
           "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", *defines, src, main,
           "-I", directory, "-o", exe, "-lm"]
    built = subprocess.run(cmd, capture_output=True, text=True)
    if built.returncode:
        return built, None
    return built, subprocess.run([exe], capture_output=True, text=True,
                                 env=dict(os.environ, ASAN_OPTIONS="detect_leaks=1"))


def compile_shared(gm, directory, cc="gcc", flags=("-O2",)):
    """lib<name>.so built with strict warnings; raises with the compiler's message."""
    src = write_sources(gm, str(directory))
    lib = os.path.join(str(directory), f"lib{gm.name}.so")
    cmd = [cc, *STRICT, *flags, "-fPIC", "-shared", src, "-o", lib, "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return lib


def load(gm, lib_path):
    ffi = cffi.FFI()
    ffi.cdef(STRUCT_CDEF + gm.cdef)
    return ffi, ffi.dlopen(lib_path)


class Compiled:
    """Call the compiled functions with numpy arrays."""

    def __init__(self, gm, directory, **kw):
        self.gm, self.meta = gm, gm.metadata
        self.ffi, self.lib = load(gm, compile_shared(gm, directory, **kw))

    def _ptr(self, a):
        return self.ffi.cast("double *", self.ffi.from_buffer(a))

    def call(self, fn, shape, t, x, p, r=None, extra=None):
        out = np.full(shape, np.nan)
        x, p = np.ascontiguousarray(x, float), np.ascontiguousarray(p, float)
        r = np.ascontiguousarray(np.zeros(0) if r is None else r, float)
        args = [t, self._ptr(x)]
        if extra is not None:
            args.append(self._ptr(np.ascontiguousarray(extra, float)))
        args += [self._ptr(p) if p.size else self.ffi.NULL,
                 self._ptr(r) if r.size else self.ffi.NULL, self._ptr(out), self.ffi.NULL]
        status = getattr(self.lib, f"{self.gm.name}_{fn}")(*args)
        return status, out


class Oracle:
    """lambdify of kinematics, A and b; u' from numpy.linalg.solve."""

    def __init__(self, formed, params, inputs=()):
        states = list(formed.coordinates) + list(formed.speeds)
        self.plain = sm.symbols(f"s0:{len(states)}")
        self.rs = sm.symbols(f"r0:{len(inputs)}") if inputs else ()
        sub = dict(zip(states, self.plain))
        sub.update(dict(zip(inputs, self.rs)))
        args = [t, self.plain, list(params), list(self.rs)]
        conv = lambda m: m.xreplace(sub)  # noqa: E731
        self.kin = sm.lambdify(args, conv(formed.kinematics), "numpy")
        self.A = sm.lambdify(args, conv(formed.dynamics_matrix), "numpy")
        self.b = sm.lambdify(args, conv(formed.dynamics_rhs), "numpy")
        self.nu = formed.nu

    def rhs(self, tv, x, p, r=()):
        a = (tv, x, p, r)
        w = np.linalg.solve(np.array(self.A(*a), float), np.array(self.b(*a), float).ravel())
        return np.concatenate([np.array(self.kin(*a), float).ravel(), w[:self.nu]])


def rel_err(a, b):
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def particle_on_sphere():
    """A particle on a sphere of radius R under gravity, Cartesian q with one multiplier."""
    x, y, z = q = dynamicsymbols("x y z")
    m, g, R = sm.symbols("m g R")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, x.diff(t) * N.x + y.diff(t) * N.y + z.diff(t) * N.z)
    pa = me.Particle("pa", P, m)
    pa.potential_energy = m * g * z
    L = me.Lagrangian(N, pa)
    lm = me.LagrangesMethod(L, q, hol_coneqs=[x**2 + y**2 + z**2 - R**2], frame=N)
    lm.form_lagranges_equations()
    return lm


def random_sphere_state(rng, R):
    """A state on the sphere |r| = R with a tangent velocity."""
    r = rng.normal(size=3)
    r *= R / np.linalg.norm(r)
    v = rng.normal(size=3)
    v -= r * (v @ r) / (r @ r)
    return np.concatenate([r, v])
