"""NAME_tree_lu, NAME_tree_solve and NAME_tree_residual (compiler/emit/tree_lu.py) against the fixed
step's own loops, fs_tree_lu, fs_tree_solve, fs_tree_solve2 and fs_residual's (over fs_columns).

The generated factorisation and solves must be the loops' to the bit (the fixed step takes either, by
pattern): both are compiled into one C harness -- the runtime's eomc_fixedstep.c included whole,
so its static functions are the ones the step runs -- and fed the same matrices on the gymnasium
humanoid's tree and on random trees (chains, stars, floating roots, forests), including exact zeros on
the pattern (a skipped row), a pivot too small and a non-finite entry (both must refuse alike); each
factor then solves the same right sides, one and two at a time, and the matrix (before it is
factored) multiplies a vector as the residual does.  One harness holds every tree (one compile of
eomc_fixedstep.c: ~2 s each)."""
import shutil
import subprocess

import numpy as np
import pytest

from eomc.compiler.emit.tree_lu import (TREE_LU_MAX_SPEEDS, TREE_LU_MAX_UPDATES, tree_functions, tree_lists,
                                        tree_lu_function)
from helpers.stand_in import RUNTIME_C

HUMANOID = [-1, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 8, 13, 14, 15, 5, 17, 18, 5, 20, 21]
COUNT = 24      # matrices per tree

# One tree's check: its matrices from stdin, the loops and the generated functions side by side;
# the number of differences (0: the same bits everywhere).
CHECK = r"""
static int check_%(t)s(void)
{
    enum { n = %(n)d };
    static const int parent[n] = {%(parents)s};
    static int start[n + 1], anc[n * n], cstart[n + 1], cols[n * n];
    static unsigned char mark[n * n];
    static double A[n * n], B[n * n];
    int differ = 0;
    fs_ancestors(n, parent, NULL, mark, start, anc);
    fs_columns(n, start, anc, cstart, cols);
    for (int m = 0; m < %(count)d; m++) {
        int sa, sb;
        if (fread(A, sizeof A, 1, stdin) != 1) return -1;
        {   /* r = M du - h f: fs_residual's loop over fs_columns' lists, and the generated one */
            double du[n], f[n], r0[n], r1[n], h = 0.003 * (m + 1);
            for (int i = 0; i < n; i++) du[i] = sin(5.0 * i - m), f[i] = cos(2.0 * i + m);
            for (int i = 0; i < n; i++) {
                double r = -h * f[i];
                for (int x = cstart[i]; x < cstart[i + 1]; x++) r += A[i * n + cols[x]] * du[cols[x]];
                r0[i] = r;
            }
            %(t)s_tree_residual(A, f, du, h, r1);
            differ += memcmp(r0, r1, sizeof r0) != 0;
        }
        memcpy(B, A, sizeof A);
        sa = fs_tree_lu(n, A, start, anc);
        sb = %(t)s_tree_lu(B);
        if (sa != sb || (sa == 0 && memcmp(A, B, sizeof A) != 0)) differ++;
        if (sa == 0 && sb == 0) {
            double b0[n], b1[n], b2[n], b3[n], c0[n], c1[n];
            for (int i = 0; i < n; i++) {
                b0[i] = b1[i] = b2[i] = b3[i] = sin(3.0 * i + m);
                c0[i] = c1[i] = cos(7.0 * i - m);
            }
            fs_tree_solve(n, A, start, anc, b0);                 /* one right side */
            %(t)s_tree_solve(B, b2, NULL);
            differ += memcmp(b0, b2, sizeof b0) != 0;
            fs_tree_solve2(n, A, start, anc, b1, c0);            /* two */
            %(t)s_tree_solve(B, b3, c1);
            differ += memcmp(b1, b3, sizeof b1) != 0 || memcmp(c0, c1, sizeof c0) != 0;
        }
    }
    return differ;
}
"""


def _matrices(parents, rng, count=COUNT):
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


def _differences(trees, tmp_path, rng):
    """Per tree, the number of results that differ from the loops' (in one harness)."""
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the generated C tests")
    parts, data = ['#include "eomc_fixedstep.c"\n#include <stdio.h>\n#include <string.h>\n'], []
    for t, parents in enumerate(trees):
        fns = tree_functions(f"t{t}", parents)
        assert len(fns) == 3, parents
        parts += [f"{fn['prototype']}\n{{\n{fn['body']}\n}}\n" for fn in fns]
        parts.append(CHECK % {"t": f"t{t}", "n": len(parents), "parents": ", ".join(map(str, parents)),
                              "count": COUNT})
        data.append(_matrices(parents, rng).tobytes())
    parts.append("int main(void)\n{\n" + "".join(f'    printf("%d\\n", check_t{t}());\n' for t in range(len(trees)))
                 + "    return 0;\n}\n")
    src, exe = tmp_path / "h.c", tmp_path / "h"
    src.write_text("".join(parts))
    build = subprocess.run(["gcc", "-std=c99", "-O2", "-mavx2", "-ffp-contract=off", "-Wall", "-Wextra",
                            "-Wno-unused-function", f"-I{RUNTIME_C}", str(src), "-o", str(exe), "-lm", "-pthread"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], input=b"".join(data), capture_output=True, check=True)
    return [int(v) for v in run.stdout.split()]


def _random_tree(rng):
    """A tree ordered parent before child: a chain, a star, a floating root with limbs, or a forest."""
    n = int(rng.integers(1, 19))
    shape = rng.integers(4)
    if shape == 0:
        return list(range(-1, n - 1))
    if shape == 1:
        return [-1] + [0] * (n - 1)
    if shape == 2:                          # six root speeds, then limbs hanging from the last
        parents = list(range(-1, 5))
        for s in range(6, n + 6):
            parents.append(5 if rng.random() < 0.3 else s - 1)
        return parents
    return [-1 if s == 0 or rng.random() < 0.15 else int(rng.integers(0, s)) for s in range(n)]


def test_the_humanoid_and_random_trees_to_the_bit(tmp_path):
    rng = np.random.default_rng(45)
    trees = [HUMANOID] + [_random_tree(rng) for _ in range(12)]
    assert _differences(trees, tmp_path, rng) == [0] * len(trees)


def test_what_the_step_would_not_use_is_not_written():
    assert tree_lu_function("t", [0]) is None                          # not a tree (its own parent)
    assert tree_lu_function("t", [-1, 2, -1]) is None                  # a parent after its child
    assert tree_lu_function("t", [-1] * (TREE_LU_MAX_SPEEDS + 1)) is None
    chain = list(range(-1, 40))                                         # 41 speeds in one chain
    assert sum(k * k for k in range(41)) > TREE_LU_MAX_UPDATES
    assert tree_lu_function("t", chain) is None
    assert tree_lu_function("t", [-1, 0, 1]) is not None
    assert tree_functions("t", [0]) == []
