"""NAME_tree_lu, NAME_tree_solve and NAME_tree_residual (compiler/emit/tree_lu.py) against the fixed
step's own loops, fs_tree_lu, fs_tree_solve, fs_tree_solve2 and fs_residual's (over fs_columns).

The generated factorisation and solves must be the loops' to the bit (the fixed step takes either, by
pattern): both are compiled into one C harness -- the runtime's eomc_fixedstep.c included whole,
so its static functions are the ones the step runs -- and fed the same matrices on random trees
(hypothesis), including exact zeros on the pattern (a skipped row), a pivot too small and a
non-finite entry (both must refuse alike); each factor then solves the same right sides, one and
two at a time, and the matrix (before it is factored) multiplies a vector as the residual does."""
import shutil
import subprocess

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from eomc.compiler.emit.tree_lu import (TREE_LU_MAX_SPEEDS, TREE_LU_MAX_UPDATES, tree_functions, tree_lists,
                                        tree_lu_function)
from helpers.stand_in import RUNTIME_C

HARNESS = r"""
#include "eomc_fixedstep.c"
#include <stdio.h>
#include <string.h>
%(function)s
int main(void)
{
    enum { n = %(n)d };
    static const int parent[n] = {%(parents)s};
    static int start[n + 1], anc[n * n];
    static unsigned char mark[n * n];
    static double A[n * n], B[n * n];
    int m = 0, differ = 0, sa, sb;
    fs_ancestors(n, parent, NULL, mark, start, anc);
    static int cstart[n + 1], cols[n * n];
    fs_columns(n, start, anc, cstart, cols);
    while (fread(A, sizeof A, 1, stdin) == 1) {
        {   /* r = M du - h f: fs_residual's loop over fs_columns' lists, and the generated one */
            double du[n], f[n], r0[n], r1[n], h = 0.003 * (m + 1);
            for (int i = 0; i < n; i++) du[i] = sin(5.0 * i - m), f[i] = cos(2.0 * i + m);
            for (int i = 0; i < n; i++) {
                double r = -h * f[i];
                for (int x = cstart[i]; x < cstart[i + 1]; x++) r += A[i * n + cols[x]] * du[cols[x]];
                r0[i] = r;
            }
            t_tree_residual(A, f, du, h, r1);
            differ += memcmp(r0, r1, sizeof r0) != 0;
        }
        memcpy(B, A, sizeof A);
        sa = fs_tree_lu(n, A, start, anc);
        sb = t_tree_lu(B);
        if (sa != sb || (sa == 0 && memcmp(A, B, sizeof A) != 0)) differ++;
        if (sa == 0 && sb == 0) {
            double b0[n], b1[n], b2[n], b3[n], c0[n], c1[n];
            for (int i = 0; i < n; i++) {
                b0[i] = b1[i] = b2[i] = b3[i] = sin(3.0 * i + m);
                c0[i] = c1[i] = cos(7.0 * i - m);
            }
            fs_tree_solve(n, A, start, anc, b0);                 /* one right side */
            t_tree_solve(B, b2, NULL);
            differ += memcmp(b0, b2, sizeof b0) != 0;
            fs_tree_solve2(n, A, start, anc, b1, c0);            /* two */
            t_tree_solve(B, b3, c1);
            differ += memcmp(b1, b3, sizeof b1) != 0 || memcmp(c0, c1, sizeof c0) != 0;
        }
        m++;
    }
    printf("%%d %%d\n", m, differ);
    return 0;
}
"""


def _matrices(parents, rng, count=24):
    """Matrices on the tree's pattern (M-like, diagonally dominant), some with exact zeros on
    it, one with a tiny pivot, one with an infinity."""
    n, lists = len(parents), tree_lists(parents)
    out = []
    for m in range(count):
        A = np.zeros((n, n))
        A[np.diag_indices(n)] = 5.0 + rng.random(n) * 10.0
        for k, a in enumerate(lists):
            for i in a:
                A[k, i] = rng.standard_normal() * (0.0 if m % 4 == 1 and rng.random() < 0.3 else 1.0)
                A[i, k] = rng.standard_normal()
        out.append(A)
    out[-2][0, 0] = 1e-300
    out[-1][n - 1, n - 1] = np.inf
    return np.array(out)


def _check(parents, tmp_path, rng):
    fns = tree_functions("t", parents)
    assert len(fns) == 3
    src = tmp_path / "h.c"
    text = "".join(f"{fn['prototype']}\n{{\n{fn['body']}\n}}\n" for fn in fns)
    src.write_text(HARNESS % {"function": text, "n": len(parents),
                              "parents": ", ".join(map(str, parents))})
    exe = tmp_path / "h"
    build = subprocess.run(["gcc", "-std=c99", "-O2", "-mavx2", "-ffp-contract=off", "-Wall", "-Wextra",
                            "-Wno-unused-function", f"-I{RUNTIME_C}", str(src), "-o", str(exe), "-lm", "-pthread"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    data = _matrices(parents, rng)
    run = subprocess.run([str(exe)], input=data.tobytes(), capture_output=True, check=True)
    m, differ = map(int, run.stdout.split())
    assert m == len(data) and differ == 0


def test_the_gymnasium_humanoids_tree_to_the_bit(tmp_path):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the generated C tests")
    humanoid = [-1, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 8, 13, 14, 15, 5, 17, 18, 5, 20, 21]
    _check(humanoid, tmp_path, np.random.default_rng(0))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=30), st.integers(0, 2 ** 31))
def test_random_trees_to_the_bit(tmp_path, draws, seed):
    parents = [-1] + [int(d * s) if d < 0.9 else -1 for s, d in enumerate(draws[1:], start=1)]
    parents = [p if p < s else s - 1 for s, p in enumerate(parents)]
    _check(parents, tmp_path, np.random.default_rng(seed))


def test_what_the_step_would_not_use_is_not_written():
    assert tree_lu_function("t", [0]) is None                          # not a tree (its own parent)
    assert tree_lu_function("t", [-1, 2, -1]) is None                  # a parent after its child
    assert tree_lu_function("t", [-1] * (TREE_LU_MAX_SPEEDS + 1)) is None
    chain = list(range(-1, 40))                                         # 41 speeds in one chain
    assert sum(k * k for k in range(41)) > TREE_LU_MAX_UPDATES
    assert tree_lu_function("t", chain) is None
    assert tree_lu_function("t", [-1, 0, 1]) is not None
    assert tree_functions("t", [0]) == []
