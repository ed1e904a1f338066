"""hess_id's kernel runs as an AVX2 twin (NAME_rnea_hess_avx2, compiler/tree/second_order._avx2_twin)
where the CPU has AVX2 and the build's flags do not: the AVX2 forms of the triple loop's dots, the
pair products and the tiles' transposes, chosen per call by ``__builtin_cpu_supports``; the same bits.

Oracle: the same C with the twin left out (-DEOMC_RD_AVX2=0, gcc -O0, clang -O2: the portable kernel)
and built with -mavx2 (the machine build: the plain kernel in its AVX2 forms, the twin preprocessed
out), at random states, compared bit for bit from outputs filled with NaN.  Two trees: a chain written
by halves (second_order.HALF_FROM forced to 0: the twin's own transposes and scratch copies) and a
floating tree (a root free joint folded into the loop, a ball below it: the change of coordinates).
Also: strict warnings, ASan/UBSan with the twin compiled in, and hess_id returns with the ymm upper
halves clean.  The c99-f32 target drops the twin (tests/compiler/emit/test_target_f32.py's builds)."""
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc.compiler.tree.second_order as second_order
from eomc.compiler.driver import generate
from eomc.runtime.cpu import cpu_features

from helpers import emit_support as es
from helpers.random_trees import build

sys.path.insert(0, str(Path(__file__).parent))
import test_second_order  # noqa: E402

# test_second_order.py's chain (9 joints in order: its mirror images are tiled transposes) and floating tree
CHAIN = [{'parent': i - 1, 'kind': ('pin', 'slider', 'pin')[i % 3], 'rotation': (('BODY', 123), ('SPACE', 231))[i % 2],
          'axis': ((0, 1, 1), (1, 0, -1), (0, 0, 1))[i % 3], 'parent_point': (1, -1, i % 2), 'child_point': (0, 1, 1),
          'rigid': i % 2 == 0, 'products': i % 3 == 0, 'load': i % 4 == 0} for i in range(9)]
FLOATING_TREE = test_second_order.FLOATING_TREE

FNS = ["rhs", "inverse_dynamics", "jac_id", "hess_id"]

DRIVER = r"""
#include <stdio.h>
#include <math.h>
#include "NAME.h"

int main(void)
{
    const eomc_model *m = NAME_model();
    static double x[64], ud[32], p[256], r[32], out[32 * 64 * 64];
    int i, k, bad = 0;
    for (i = 0; i < m->nparam; i++) p[i] = 0.7 + 0.05 * i;
    for (i = 0; i < m->ninput; i++) r[i] = 0.1 * i - 0.2;
    for (k = 0; k < 4; k++) {
        for (i = 0; i < m->nx; i++) x[i] = sin(1.3 * i + k);
        for (i = 0; i < m->nu; i++) ud[i] = cos(0.7 * i + k);
        if (NAME_hess_id(0.5, x, ud, p, r, out, NULL) != EOMC_OK) bad++;
        for (i = 0; i < m->nu * m->nx * m->nx; i++) if (!isfinite(out[i])) bad++;
    }
    printf("%s %d\n", m->name, bad);
    return bad;
}
"""


def _generate(tree, name, half):
    system, inputs = build(tree)
    saved = second_order.HALF_FROM
    second_order.HALF_FROM = 0 if half else saved
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, gm = generate(system, name, functions=FNS, inputs=inputs, formulation="recursive",
                             use_cache=False, progress=False)
    finally:
        second_order.HALF_FROM = saved
    assert gm.metadata["hess_id"].startswith("analytic"), gm.metadata["hess_id"]
    return gm


@pytest.fixture(scope="module")
def trees():
    chain = _generate(CHAIN, "avxchain", half=True)
    floating = _generate(FLOATING_TREE, "avxfloat", half=False)
    c = chain.c_source
    assert "avxchain_rnea_hess_avx2(" in c and "avxchain_h2_trt_avx2(" in c and "avxchain_h2_trs_avx2(" in c
    assert "avxfloat_rnea_hess_avx2(" in floating.c_source
    return chain, floating


def _symbols(lib):
    return subprocess.run(["nm", lib], capture_output=True, text=True, check=True).stdout


@pytest.mark.parametrize("which", [0, 1], ids=["chain_by_halves", "floating"])
def test_avx2_twin_gives_the_portable_bits(trees, which, tmp_path):
    gm = trees[which]
    builds = {"gcc -O2": ("gcc", ("-O2",)), "gcc -O2 -DEOMC_RD_AVX2=0": ("gcc", ("-O2", "-DEOMC_RD_AVX2=0")),
              "gcc -O0": ("gcc", ("-O0",)), "gcc -O2 -mavx2": ("gcc", ("-O2", "-mavx2", "-ffp-contract=off"))}
    if "avx2" not in (cpu_features() or ()):
        del builds["gcc -O2 -mavx2"]
    if shutil.which("clang"):
        builds["clang -O2"] = ("clang", ("-O2",))
    rng = np.random.default_rng(31 + which)
    nx, nu, nparam = gm.metadata["nx"], gm.metadata["nu"], gm.metadata["nparam"]
    p, r = rng.uniform(0.5, 1.5, nparam), rng.uniform(-1.0, 1.0, gm.metadata["ninput"])
    X, UD = rng.uniform(-1.5, 1.5, (24, nx)), rng.uniform(-1.0, 1.0, (24, nu))
    got = {}
    for n, (label, (cc, flags)) in enumerate(builds.items()):
        d = tmp_path / str(n)
        d.mkdir()
        c = es.Compiled(gm, d, cc=cc, flags=flags)
        has_twin = f"{gm.name}_rnea_hess_avx2" in _symbols(str(d / f"lib{gm.name}.so"))
        # compiled in only by gcc, optimizing, without AVX in the flags
        assert has_twin == (label == "gcc -O2"), label
        outs = []
        for x, ud in zip(X, UD):
            # filled with NaN (Compiled.call): every entry written (a chain; the floating tree's
            # off-path entries stay NaN in every build alike: compared as bits)
            status, out = c.call("hess_id", (nu, nx, nx), 0.0, x, p, r, extra=ud)
            assert status == 0, label
            outs.append(out)
        got[label] = np.array(outs)
    want = got["gcc -O2 -DEOMC_RD_AVX2=0"]
    written = ~np.isnan(want)
    assert np.all(np.isfinite(want[written])) and np.count_nonzero(want[written]) > X.size
    if which == 0:
        assert written.all()
    for label, outs in got.items():
        assert np.array_equal(outs.view(np.uint64), want.view(np.uint64)), label
    if "avx2" not in (cpu_features() or ()):
        pytest.skip("this CPU has no AVX2: the twin was compiled but not taken")


def test_avx2_twin_sanitizer_clean(trees, tmp_path):
    """ASan/UBSan (gcc -O1: the twin compiled in, taken on an AVX2 CPU), strict warnings."""
    for n, gm in enumerate(trees):
        d = tmp_path / str(n)
        d.mkdir()
        built, run = es.sanitized_run(gm, d, DRIVER)
        assert built.returncode == 0, built.stderr
        assert run.returncode == 0 and run.stdout.startswith(f"{gm.name} 0"), run.stdout + run.stderr
        assert "runtime error" not in run.stderr


def test_avx2_twin_returns_with_the_upper_state_clean(trees, tmp_path):
    """The twin dirties the ymm upper halves; hess_id, built without AVX for an SSE caller, must
    return with them clean (gcc's vzeroupper; tests/compiler/build/test_upper_state.py says why)."""
    from helpers.avx_state import dirty_functions
    if "avx2" not in (cpu_features() or ()):
        pytest.skip("this CPU has no AVX2: the twin is not taken")
    for n, gm in enumerate(trees):
        d = tmp_path / str(n)
        d.mkdir()
        lib = es.compile_shared(gm, d, flags=("-O2",))

        class Built:
            directory, header_path, library_path = d, d / f"{gm.name}.h", lib
        for mode in ("const", "random"):
            found = dirty_functions(Built, d, mode=mode)
            assert found[f"{gm.name}_hess_id"] == (0, False), (gm.name, mode, found)


def test_the_float_target_drops_the_twin(trees):
    """compiler/emit/target.without_cpu_dispatch cuts the twin and the dispatch (the c99-f32 target
    and the lanes kernels keep the portable code): no AVX2 name and no CPU test is left, and the
    plain kernel's call is."""
    from eomc.compiler.emit.target import without_cpu_dispatch
    for gm in trees:
        left = without_cpu_dispatch(gm.c_source)
        assert "_avx2" not in left and "__builtin_cpu_supports" not in left and 'target("avx2")' not in left
        assert f"big = {gm.name}_rnea_hess(an, u, ud, out);" in left
        assert left.count("{") == left.count("}")


def test_the_prefetches_stay_in_the_output_and_run(trees, tmp_path):
    """A chain written by halves prefetches the next pair's first stores (second_order._prefetch_lines):
    in both kernels (the twin is taken on an AVX2 CPU), and every address is inside the output (an
    address outside it would be a pointer out of its array in C): NAME_H2_PF replaced (-D) by a check
    that traps outside out[0 .. nu nx nx).  The same macro as a plain trap must stop the run, so the
    check is known to run.  The floating tree (not by halves) has none."""
    chain, floating = trees
    assert "AVXFLOAT_H2_PF" not in floating.c_source
    body = chain.c_source.split("static int avxchain_rnea_hess(", 1)[1]
    assert body.count("AVXCHAIN_H2_PF(") >= 2 * 12, "both kernels prefetch"
    n = chain.metadata["nu"] * chain.metadata["nx"] ** 2
    check = f"-DAVXCHAIN_H2_PF(p)=((p) >= out && (p) < out + {n} ? (void)0 : __builtin_trap())"
    for name, define, ok in (("check", check, True), ("trap", "-DAVXCHAIN_H2_PF(p)=((void)(p), __builtin_trap())", False)):
        d = tmp_path / name
        d.mkdir()
        built, run = es.sanitized_run(chain, d, DRIVER, defines=(define,))
        assert built.returncode == 0, built.stderr
        assert (run.returncode == 0 and run.stdout.startswith("avxchain 0")) == ok, (name, run.stdout + run.stderr)
