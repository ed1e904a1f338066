"""jac_x's articulated solve runs its row helpers (NAME_rd_bw / NAME_rd_fw) as AVX2 twins
where the CPU has AVX2 and the build's flags do not (compiler/tree/analytic._aba_avx2_lines,
_aba_dispatch): four columns an instruction instead of SSE2's two, the same bits.

Oracle: the same C with the twins left out (-DEOMC_RD_AVX2=0, gcc -O0, clang: the portable
helpers only), at random states, compared bit for bit.  Also: the C is clean under gcc's and
clang's strict flags, and under ASan/UBSan with the twins compiled in; jac_x_batch's lanes
(whose kernel drops the choice) are covered in tests/compiler/emit/test_jac_x_batch.py."""
import shutil
import subprocess
import warnings

import numpy as np
import pytest

from eomc.compiler.driver import generate
from eomc.runtime.cpu import cpu_features

from helpers import emit_support as es
from helpers.trees import cart_joints

DRIVER = r"""
#include <stdio.h>
#include <math.h>
#include "NAME.h"

int main(void)
{
    const eomc_model *m = NAME_model();
    double x[64], p[64], r[8] = {0.3, -0.2, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0}, out[64 * 64];
    int i, k, bad = 0;
    for (i = 0; i < m->nparam; i++) p[i] = 0.7 + 0.05 * i;
    for (k = 0; k < 4; k++) {
        for (i = 0; i < m->nx; i++) x[i] = sin(1.3 * i + k);
        if (NAME_jac_x(0.5, x, p, r, out, NULL) != EOMC_OK) bad++;
        for (i = 0; i < m->nx * m->nx; i++) if (!isfinite(out[i])) bad++;
    }
    printf("%s %d\n", m->name, bad);
    return bad;
}
"""


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    """The 6-link cart (14 states: 12 row columns and a rest of two for the twins' loops),
    its jac_x on the articulated solve (forced: this shallow a chain would take LᵀDL)."""
    from eomc.compiler.tree import analytic
    system, _ = cart_joints(6, rigid=True)
    saved, analytic.ABA_DEPTH = analytic.ABA_DEPTH, 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, gm = generate(system, "avxcart", functions=["rhs", "jac_x"], formulation="recursive",
                             use_cache=False, progress=False)
    finally:
        analytic.ABA_DEPTH = saved
    assert "avxcart_rd_bw_avx2(" in gm.c_source and "avxcart_rd_fw_avx2(" in gm.c_source
    return gm


def _symbols(lib):
    return subprocess.run(["nm", lib], capture_output=True, text=True, check=True).stdout


def test_avx2_twins_give_the_portable_bits(cart, tmp_path):
    builds = {"gcc -O2": ("gcc", ("-O2",)), "gcc -O2 -DEOMC_RD_AVX2=0": ("gcc", ("-O2", "-DEOMC_RD_AVX2=0")),
              "gcc -O0": ("gcc", ("-O0",))}
    if shutil.which("clang"):
        builds["clang -O2"] = ("clang", ("-O2",))
    rng = np.random.default_rng(30)
    nx, nparam = cart.metadata["nx"], cart.metadata["nparam"]
    p, r = rng.uniform(0.5, 1.5, nparam), rng.uniform(-1.0, 1.0, cart.metadata["ninput"])
    X = rng.uniform(-2.0, 2.0, (24, nx))
    got = {}
    for n, (label, (cc, flags)) in enumerate(builds.items()):
        d = tmp_path / str(n)
        d.mkdir()
        c = es.Compiled(cart, d, cc=cc, flags=flags)
        has_twins = "avxcart_rd_bw_avx2" in _symbols(str(d / "libavxcart.so"))
        # compiled in only by gcc, optimizing, without AVX in the flags
        assert has_twins == (label == "gcc -O2"), label
        outs = []
        for x in X:
            status, out = c.call("jac_x", (nx, nx), 0.0, x, p, r)
            assert status == 0, label
            outs.append(out)
        got[label] = np.array(outs)
    want = got["gcc -O2 -DEOMC_RD_AVX2=0"]
    assert np.all(np.isfinite(want)) and np.count_nonzero(want) > X.size
    for label, outs in got.items():
        assert np.array_equal(outs.view(np.uint64), want.view(np.uint64)), label
    if "avx2" not in (cpu_features() or ()):
        pytest.skip("this CPU has no AVX2: the twins were compiled but not taken")


def test_avx2_twins_sanitizer_clean(cart, tmp_path):
    """ASan/UBSan (gcc -O1: the twins compiled in, taken on an AVX2 CPU), strict warnings."""
    built, run = es.sanitized_run(cart, tmp_path, DRIVER)
    assert built.returncode == 0, built.stderr
    assert run.returncode == 0 and run.stdout.startswith("avxcart 0"), run.stdout + run.stderr
    assert "runtime error" not in run.stderr


def test_avx2_twins_return_with_the_upper_state_clean(cart, tmp_path):
    """The twins dirty the ymm upper halves; jac_x, built without AVX for an SSE caller,
    must return with them clean (gcc's vzeroupper on the twins' returns; see
    tests/compiler/build/test_upper_state.py for why it matters)."""
    from helpers.avx_state import dirty_functions
    if "avx2" not in (cpu_features() or ()):
        pytest.skip("this CPU has no AVX2: the twins are not taken")
    lib = es.compile_shared(cart, tmp_path, flags=("-O2",))

    class Built:
        directory, header_path, library_path = tmp_path, tmp_path / "avxcart.h", lib
    for mode in ("const", "random"):
        found = dirty_functions(Built, tmp_path, mode=mode)
        assert found["avxcart_jac_x"] == (0, False), (mode, found)
