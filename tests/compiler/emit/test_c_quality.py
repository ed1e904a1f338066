"""Generated C is strict-clean (gcc, clang), sanitizer-clean, exports only what exists,
and is byte-identical across runs and hash seeds."""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me

from helpers import emit_support as es
from helpers import zoo
from eomc.compiler.emit import generate_c

COMPILERS = [cc for cc in ("gcc", "clang") if shutil.which(cc)]


def _cart_with_outputs():
    kane, spec = zoo.n_link_pendulum_on_cart(2, me)
    formed = es.kane_formed(kane, spec)
    q = formed.coordinates
    outs = {"tip": sm.Symbol("l0") * sm.sin(q[1]) + q[0], "e": formed.speeds[0] ** 2}
    return generate_c(formed, "cartout", outputs=outs)


def _minimal():
    """The 1-link cart with no input, no outputs, no constraints."""
    kane, _ = zoo.n_link_pendulum_on_cart(1, me, cart_force=False)
    return generate_c(es.kane_formed(kane, ()), "bare")


def _looped_jacobian():
    """The 2-link cart with the large-model code shapes (normally used above 12 states /
    a 10 x 10 dense M): jac_x as a tangent loop, LDLᵀ in loops."""
    from eomc.compiler.emit import linsolve, symbolic
    saved = symbolic.TANGENT_MIN_STATES, linsolve.UNROLL_MAX_DENSE
    symbolic.TANGENT_MIN_STATES = linsolve.UNROLL_MAX_DENSE = 0
    try:
        kane, spec = zoo.n_link_pendulum_on_cart(2, me)
        gm = generate_c(es.kane_formed(kane, spec), "looped")
        assert "for (j = 0; j < 3; j++)" in gm.c_source
        return gm
    finally:
        symbolic.TANGENT_MIN_STATES, linsolve.UNROLL_MAX_DENSE = saved


@pytest.fixture(scope="module")
def models():
    return [_cart_with_outputs(), _minimal(),
            generate_c(es.lagrange_formed(es.particle_on_sphere()), "sphere"), _looped_jacobian()]


DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

static double *filled(size_t n, double v)
{
    double *a = (double *)malloc((n ? n : 1) * sizeof(double));
    size_t i;
    for (i = 0; i < n; i++) a[i] = v + 0.1 * (double)i;
    return a;
}

int main(void)
{
    const eomc_model *m = NAME_model();
    size_t nx = (size_t)m->nx, nu = (size_t)m->nu, nr = (size_t)m->ninput;
    size_t nc = (size_t)(m->nhol + m->nvel);
    double *x = filled(nx, 0.3), *p = filled((size_t)m->nparam, 0.9);
    double *r = nr ? filled(nr, 0.2) : NULL, *work = filled(m->work_size, 0.0);
    double *out = filled(nx * nx + nx * nr + nu * nu + nc * nx + (size_t)m->noutput + 1, 0.0);
    double *udot = filled(nu, 0.1), *B = filled(nx * nr + 1, 0.0);
    int bad = 0;
#ifdef ZERO_LAST_PARAM
    p[m->nparam - 1] = 0.0;
#endif
    if (m->abi_version != EOMC_ABI_VERSION) bad++;
    if (m->rhs(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->mass_matrix && m->mass_matrix(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->forcing && m->forcing(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->jac_x && m->jac_x(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->jac_r && m->jac_r(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->outputs && m->outputs(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->constraints && m->constraints(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (m->constraints_jac && m->constraints_jac(0.5, x, p, r, out, work) != EOMC_OK) bad++;
    if (NAME_inverse_dynamics(0.5, x, udot, p, r, out, work) != EOMC_OK) bad++;
    if (NAME_linearize(0.5, x, p, r, out, B, work) != EOMC_OK) bad++;
    printf("%s %d %s\n", m->name, bad, m->state_names[0]);
    free(x); free(p); free(r); free(work); free(out); free(udot); free(B);
    return bad;
}
"""


@pytest.mark.parametrize("cc", COMPILERS)
def test_strict_warnings_clean(models, cc, tmp_path):
    for gm in models:
        d = tmp_path / f"{gm.name}_{cc}"
        d.mkdir()
        es.compile_shared(gm, d, cc=cc, flags=("-O2", "-Wshadow", "-Wconversion"))


def _sanitized_run(gm, d, defines=()):
    proc, run = es.sanitized_run(gm, d, DRIVER, defines=defines)
    assert proc.returncode == 0, proc.stderr
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith(f"{gm.name} 0 ") and "runtime error" not in run.stderr


def test_sanitizers_clean(models, tmp_path):
    for gm in models:
        d = tmp_path / gm.name
        d.mkdir()
        _sanitized_run(gm, d)


def test_sanitizers_clean_on_lu_fallback(tmp_path):
    """The unrolled LU's dense-pivoting fallback path (A = [[10 m, 1], [1, 0]] at m = 0)."""
    q, u = me.dynamicsymbols("q u")
    m, k = sm.symbols("m k")
    from eomc.compiler.mechanics.formed import FormedSystem
    formed = FormedSystem(
        method="lagrange", coordinates=(q,), speeds=(u,), n_dependent_coordinates=0,
        n_dependent_speeds=0, kinematics=sm.Matrix([u]),
        dynamics_matrix=sm.Matrix([[10 * m, 1], [1, 0]]), dynamics_rhs=sm.Matrix([-k * q, u]),
        multipliers=(me.dynamicsymbols("lam"),), holonomic_constraints=sm.zeros(0, 1),
        velocity_constraints=sm.Matrix([u]), inputs=(), parameters=(k, m))
    gm = generate_c(formed, "saddle")
    assert "goto dense;" in gm.c_source
    _sanitized_run(gm, tmp_path, ["-DZERO_LAST_PARAM"])


def _exports(lib):
    out = subprocess.run(["nm", "-D", "--defined-only", lib], capture_output=True, text=True,
                         check=True).stdout
    return {line.split()[-1] for line in out.splitlines() if " T " in line}


def test_absent_functions_are_not_exported(models, tmp_path):
    cart, bare, sphere = models[:3]
    full = _exports(es.compile_shared(cart, tmp_path))
    assert {"cartout_outputs", "cartout_jac_r", "cartout_rhs", "cartout_model"} <= full
    assert "cartout_constraints" not in full
    names = _exports(es.compile_shared(bare, tmp_path))
    assert "bare_rhs" in names and "bare_linearize" in names
    for absent in ("constraints", "constraints_jac", "outputs", "jac_r"):
        assert f"bare_{absent}" not in names
        assert f"bare_{absent}" not in bare.c_source and f"bare_{absent}" not in bare.cdef
    rhs = bare.c_source[bare.c_source.index("int bare_rhs("):]
    rhs = rhs[:rhs.index("\n}\n")]
    assert "(void)r;" in rhs and "r[" not in rhs
    assert bare.metadata["functions"] == ["rhs", "jac_x", "mass_matrix", "forcing",
                                          "inverse_dynamics", "linearize"]
    assert {"sphere_constraints", "sphere_constraints_jac"} <= _exports(
        es.compile_shared(sphere, tmp_path))


def test_only_requested_functions(tmp_path):
    kane, spec = zoo.n_link_pendulum_on_cart(2, me)
    gm = generate_c(es.kane_formed(kane, spec), "onlyrhs", functions=["rhs"])
    assert gm.metadata["functions"] == ["rhs"]
    names = _exports(es.compile_shared(gm, tmp_path))
    assert {n for n in names if n.startswith("onlyrhs_")} == {"onlyrhs_rhs", "onlyrhs_model"}
    assert set(gm.metadata["op_counts"]) == {"rhs"}


_SCRIPT = """
import sys
sys.path[:0] = {paths!r}
from helpers import zoo, emit_support as es
from sympy.physics import mechanics as me
from eomc.compiler.emit import generate_c, linsolve, symbolic
kane, spec = zoo.n_link_pendulum_on_cart(2, me)
formed = es.kane_formed(kane, spec)
gm = generate_c(formed, "det")
out = [gm.c_source, gm.header, gm.cdef]
symbolic.TANGENT_MIN_STATES = linsolve.UNROLL_MAX_DENSE = 0      # large-model code shapes
out.append(generate_c(formed, "det").c_source)
out.append(generate_c(es.lagrange_formed(es.particle_on_sphere()), "sphere").c_source)
sys.stdout.write("\\n=====\\n".join(out))
"""


def test_byte_identical_across_runs_and_hash_seeds():
    kane, spec = zoo.n_link_pendulum_on_cart(2, me)
    formed = es.kane_formed(kane, spec)
    a, b = generate_c(formed, "det"), generate_c(formed, "det")
    assert a.c_source == b.c_source and a.header == b.header and a.metadata == b.metadata
    here = os.path.dirname(os.path.abspath(__file__))
    script = _SCRIPT.format(paths=[here, os.path.dirname(os.path.dirname(here))])
    outs = []
    for seed in ("1", "12345"):
        proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                              env=dict(os.environ, PYTHONHASHSEED=seed), check=True)
        outs.append(proc.stdout)
    assert outs[0] == outs[1]
    assert outs[0].split("\n=====\n")[:3] == [a.c_source, a.header, a.cdef]
    assert "dx[k] = 1.0;" in outs[0].split("\n=====\n")[3]


def test_metadata_is_json_and_complete(models):
    import json
    keys = {"name", "abi_version", "eomc_version", "nq", "nu", "nx", "nparam", "ninput",
            "noutput", "nhol", "nvel", "work_size", "state_names", "param_names",
            "param_defaults", "input_names", "output_names", "functions", "op_counts",
            "mass_matrix_sparsity"}
    for gm in models:
        meta = json.loads(json.dumps(gm.metadata))
        assert keys <= set(meta)
        for fn in meta["functions"]:
            assert set(meta["op_counts"][fn]) == {"adds", "muls", "divs", "calls"}
        assert len(meta["mass_matrix_sparsity"]) == meta["nu"] + (1 if gm.name == "sphere" else 0)
    assert models[2].metadata["mass_matrix_sparsity"] == ["x..x", ".x.x", "..xx", "xxx."]
    assert np.all(np.array(models[0].metadata["mass_matrix_sparsity"]) == "xxx")
