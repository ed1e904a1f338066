"""A machine-built model must return with the ymm/zmm upper halves clean (XINUSE bit 2 clear).

The default double build adds ``-mavx2`` on x86-64 CPUs with AVX2 (toolchain.MACHINE_FLAGS),
while the runtime that calls the model (integrators, sensitivities, adjoint, batch rollouts)
is compiled for SSE.  A model function that returned with the upper halves in use would make
those SSE loops pay for it on CPUs that penalize the mix.  gcc inserts ``vzeroupper`` before
every return and call of a function that dirtied them; these tests read the state right after
each generated function returns (tests/helpers/avx_state.py: a C harness, ``xgetbv(1)``) on
models that exercise jvp/vjp/hvp with lanes, the batch lanes, NAME_implicit, outputs and
events, with normal inputs and with inputs that take the failure returns (NaN states, zero
parameters: a singular mass matrix).  A self-check proves the harness sees a dirty return.
"""
import platform
import subprocess
import warnings
from pathlib import Path

import pytest

from helpers import zoo
from helpers.avx_state import dirty_functions
from eomc.runtime import cpu

X86 = platform.machine().lower() in ("x86_64", "amd64")
AVX = X86 and "avx" in (cpu.cpu_features() or ())
pytestmark = pytest.mark.skipif(not AVX, reason="the upper ymm state exists only on x86-64 CPUs with AVX")

MODES = ("const", "random", "nan", "zero")


def _assert_clean(model, tmp_path, expect):
    if "-mavx2" not in model.metadata["build"]["cflags"]:
        pytest.skip("the library is the portable build (no -mavx2: CPU without AVX2, $EOMC_PORTABLE "
                    "or another compiler), so it never touches the ymm upper halves")
    for k in (1, 4):
        for mode in MODES:
            found = dirty_functions(model, tmp_path, k=k, mode=mode)
            assert expect <= set(found), f"harness missed functions: {expect - set(found)}"
            dirty = [f for f, (_, d) in found.items() if d]
            assert not dirty, f"{dirty} returned with the ymm upper halves dirty (k = {k}, inputs {mode})"


def test_harness_sees_a_dirty_return(tmp_path):
    from eomc.compiler.build import find_compiler
    lib = tmp_path / "fake"
    lib.mkdir()
    include = Path(__import__("eomc.runtime", fromlist=["x"]).__file__).parent / "c"
    (lib / "model.h").write_text(
        '#include "eomc_model.h"\n'
        "int fake_rhs(double t, const double *x, const double *p, const double *r, double *xdot, double *work);\n"
        "int fake_jac_x(double t, const double *x, const double *p, const double *r, double *out, double *work);\n"
        "const eomc_model *fake_model(void);\n")
    (lib / "m.c").write_text(
        '#include "model.h"\nstatic const double d[1] = {1.0};\nstatic eomc_model M;\n'
        "const eomc_model *fake_model(void) { M.nparam = 1; M.param_defaults = d; return &M; }\n"
        "int fake_rhs(double t, const double *x, const double *p, const double *r, double *xdot, double *work)\n"
        '{ (void)t; (void)p; (void)r; (void)work; __asm__ volatile("vmovupd (%0), %%ymm3\\n\\tvmovupd %%ymm3, (%1)"'
        ' :: "r"(x), "r"(xdot) : "xmm3", "memory"); return 0; }\n'
        "int fake_jac_x(double t, const double *x, const double *p, const double *r, double *out, double *work)\n"
        "{ (void)t; (void)x; (void)p; (void)r; (void)out; (void)work; return 0; }\n")
    subprocess.run([*find_compiler().argv, "-O2", "-fPIC", "-shared", f"-I{include}", str(lib / "m.c"),
                    "-o", str(lib / "libmodel.so")], check=True)

    class Fake:
        directory, header_path, library_path = lib, lib / "model.h", lib / "libmodel.so"
    assert dirty_functions(Fake, tmp_path) == {"fake_rhs": (0, True), "fake_jac_x": (0, False)}


def test_kane_cart_derivatives_and_batch_return_clean(tmp_path):
    import eomc
    from eomc import mechanics
    kane, specified = zoo.n_link_pendulum_on_cart(3, mechanics)
    fns = ["rhs", "jac_x", "jac_p", "jvp", "vjp", "hvp", "rhs_batch", "jac_x_batch"]
    model = eomc.compile(kane, inputs=specified, functions=fns, cache_dir=tmp_path / "c", progress=False)
    _assert_clean(model, tmp_path, {f"{model.name}_{f}" for f in fns})
    # (Until session 8 this also asserted that under the flags before -fno-ipa-ra gcc 12
    # left vzeroupper out of this jvp; with the parameter columns in a function of their
    # own it no longer does, so that compiler quirk is gone from this model.  The fake
    # model above is the check's positive control.)


def test_mjcf_contacts_implicit_outputs_events_return_clean(tmp_path):
    import eomc
    gymnasium = pytest.importorskip("gymnasium")
    from eomc.compiler.mjcf.model import MjcfModel
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    fns = ["rhs", "jac_x", "outputs", "implicit", "rhs_batch", "jac_x_batch"]
    with warnings.catch_warnings():      # the file's self-collision pairs left out (said by a warning)
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path), name="ustate_hopper", functions=fns, cache_dir=tmp_path / "c",
                             progress=False)
    _assert_clean(model, tmp_path, {f"{model.name}_{f}" for f in fns} | {"ustate_hopper_events"})
