"""The unrolled LDLᵀ's lanes solve (linsolve.Solver.lanes_code, what a Kane jvp's lanes of
directions share): compiled with the build's flags, each lane's bits equal the scalar solve's
on the same right-hand side, and both solve A x = b (numpy)."""
import subprocess

import numpy as np

from eomc.compiler.build.toolchain import DEFAULT_CFLAGS, find_compiler, machine_flags
from eomc.compiler.emit.linsolve import choose_ldlt, ldlt_loop_solver

N, LANES = 7, 4
# a sparse lower pattern (fill-in included by the solver): the diagonal, a chain, two long links
PATTERN = {(i, i) for i in range(N)} | {(i, i - 1) for i in range(1, N)} | {(5, 0), (6, 2)}

HARNESS = r"""
#include <float.h>
#include <math.h>
#include <stdio.h>
#define EOMC_OK 0
#define EOMC_NONFINITE 1
#define EOMC_SINGULAR_MASS_MATRIX 2
@CODE@
int main(void) {
    double F[@NF@], B[@N@][@L@], b[@N@];
    int i, l;
    for (i = 0; i < @NN@; i++) if (scanf("%lf", &F[i]) != 1) return 3;
    for (i = 0; i < @N@; i++) for (l = 0; l < @L@; l++) if (scanf("%lf", &B[i][l]) != 1) return 3;
    if (t_ldlt_factor(F) != EOMC_OK) return 4;
    for (l = 0; l < @L@; l++) {
        for (i = 0; i < @N@; i++) b[i] = B[i][l];
        t_ldlt_solve(F, b);
        for (i = 0; i < @N@; i++) printf("%a\n", b[i]);
    }
    @LANES@(F, B);
    for (l = 0; l < @L@; l++) for (i = 0; i < @N@; i++) printf("%a\n", B[i][l]);
    return 0;
}
"""


def _spd(rng):
    """Symmetric, nonzero only on PATTERN (the solver reads nothing else), diagonally dominant."""
    A = np.diag(rng.uniform(3.0, 4.0, N))
    for i, j in PATTERN:
        if i > j:
            A[i, j] = A[j, i] = rng.uniform(-1.0, 1.0)
    return A


def test_lanes_solve_is_each_lanes_scalar_solve_bit_for_bit(tmp_path):
    solver = choose_ldlt("t", N, PATTERN)
    name, code = solver.lanes_code(LANES)
    assert name == "t_ldlt_solve_lanes" and "restrict" in code
    rng = np.random.default_rng(7)
    A = _spd(rng)
    B = rng.normal(size=(N, LANES))
    src = (HARNESS.replace("@CODE@", solver.code + "\n" + code).replace("@LANES@", name)
           .replace("@NF@", str(solver.fsize)).replace("@NN@", str(N * N))
           .replace("@N@", str(N)).replace("@L@", str(LANES)))
    (tmp_path / "t.c").write_text(src)
    tc = find_compiler()
    exe = tmp_path / "t"
    subprocess.run([*tc.argv, *DEFAULT_CFLAGS, *machine_flags(tc), "-Wall", "-Wextra", "-Werror",
                    str(tmp_path / "t.c"), "-o", str(exe), "-lm"], check=True)
    numbers = " ".join(repr(float(v)) for v in np.concatenate([A.ravel(), B.ravel()]))
    out = subprocess.run([str(exe)], input=numbers, capture_output=True, text=True, check=True).stdout.split()
    vals = np.array([float.fromhex(v) for v in out])
    scalar = vals[:N * LANES].reshape(LANES, N)
    lanes = vals[N * LANES:].reshape(LANES, N)
    assert np.array_equal(lanes, scalar)      # the same operations in the same order per lane
    ref = np.linalg.solve(A, B).T
    assert np.max(np.abs(scalar - ref)) < 1e-12 * np.max(np.abs(ref))


def test_only_the_unrolled_ldlt_has_a_lanes_solve():
    assert ldlt_loop_solver("t", 20).lanes_code(LANES) is None
