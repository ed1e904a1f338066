"""eomc_rollout_lanes (runtime/c/eomc_rollout.c) under AddressSanitizer and UBSan, and under
ThreadSanitizer: a C driver integrates 45 rows of the generated cart-pole (NAME_rhs_batch_p,
built with libm's sin/cos in the lanes) on 2 threads in blocks of 16 -- so blocks end in a
part-filled group of lanes and a scalar tail -- with one parameter row and one input sequence
(a 4-point table ending inside the span) per trajectory, every step recorded and one row that
overflows, and compares every row with the scalar C rollout
(eomc_rollout, RK4) byte for byte: final states, statuses, step counts and, for the rows
that ran to the end, every recorded step.  A clean run is a correct run."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.driver import generate

from helpers import emit_support as es

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

ROOT = Path(__file__).resolve().parents[2]
CART = ROOT / "examples" / "cart_pole_system.py"
RUNTIME_C = ROOT / "runtime" / "c"

DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "NAME.h"
#include "eomc_rollout.h"

static unsigned long long seed = 12345;
static double uniform(void)      /* in [-1, 1), the same on every machine */
{
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return 2.0 * (double)(seed >> 11) / 9007199254740992.0 - 1.0;
}

int main(void)
{
    const eomc_model *m = NAME_model();
    const int n = 45, nx = m->nx, np = m->nparam, ni = m->ninput, bad = 7, nr = 4;
    const double r_t[4] = {0.0, 0.05, 0.12, 0.2};
    double *R = malloc((size_t)n * nr * (ni ? ni : 1) * sizeof(double));
    const double dt = 0.01, t1 = 0.255;           /* 26 steps, the last one shortened */
    const long nsteps = 26;
    const size_t rows = (size_t)(nsteps + 1);
    double *X0 = malloc((size_t)n * nx * sizeof(double)), *P = malloc((size_t)n * np * sizeof(double));
    double *A_last = malloc((size_t)n * nx * sizeof(double)), *B_last = malloc((size_t)n * nx * sizeof(double));
    double *A_out = malloc((size_t)n * rows * nx * sizeof(double));
    double *B_out = malloc((size_t)n * rows * nx * sizeof(double));
    double *t_eval = malloc(rows * sizeof(double));
    int *A_st = malloc((size_t)n * sizeof(int)), *B_st = malloc((size_t)n * sizeof(int));
    long *A_steps = malloc((size_t)n * sizeof(long)), *B_steps = malloc((size_t)n * sizeof(long));
    eomc_options opt;
    int i, k, wrong = 0, failed = 0;
    for (i = 0; i < n * nx; i++) X0[i] = uniform();
    for (k = 0; k < n; k++)
        for (i = 0; i < np; i++) P[(size_t)k * np + i] = m->param_defaults[i] * (1.0 + 0.3 * uniform());
    for (i = 0; i < n * nr * ni; i++) R[i] = 3.0 * uniform();
    X0[(size_t)bad * nx + 3] = 1e200;             /* overflows within the first step */
    for (k = 0; k < nsteps; k++) t_eval[k] = k * dt;
    t_eval[nsteps] = t1;
    memset(&opt, 0, sizeof opt);
    opt.method = EOMC_RK4;
    opt.h0 = dt;
    opt.max_steps = 1000;
    eomc_rollout_stats(m, &opt, 0.0, t1, n, X0, P, (size_t)np, nr, r_t, R, (size_t)(nr * ni), (int)rows, t_eval,
                       A_out, A_last, A_st, A_steps, NULL, 2);
    eomc_rollout_lanes(NAME_rhs_batch_p, nx, np, ni, m->work_size, 0.0, t1, dt, n, X0, P, (size_t)np, nr, r_t, R,
                       (size_t)(nr * ni), B_out, B_last, B_st, B_steps, 16, 2);
    for (k = 0; k < n; k++) {
        if (A_st[k] != B_st[k] || A_steps[k] != B_steps[k]) wrong++;
        if (memcmp(A_last + (size_t)k * nx, B_last + (size_t)k * nx, (size_t)nx * sizeof(double))) wrong++;
        if (A_st[k] != EOMC_OK) { failed++; continue; }
        if (memcmp(A_out + (size_t)k * rows * nx, B_out + (size_t)k * rows * nx, rows * nx * sizeof(double)))
            wrong++;
    }
    printf("%s wrong=%d failed=%d\n", m->name, wrong, failed);
    free(X0); free(P); free(A_last); free(B_last); free(A_out); free(B_out); free(t_eval);
    free(A_st); free(B_st); free(A_steps); free(B_steps); free(R);
    return wrong != 0;
}
"""


@pytest.fixture(scope="module")
def cart_source(tmp_path_factory):
    directory = tmp_path_factory.mktemp("lanes_san")
    gm = generate(str(CART), "lanescart", functions=("rhs", "rhs_batch"), formulation="recursive",
                  cache_dir=directory / "cache", progress=False)[1]
    assert gm.metadata["rhs_batch"]["vectorized"], gm.metadata["rhs_batch"]
    return gm, es.write_sources(gm, str(directory))


@pytest.mark.parametrize("sanitizers", ["address,undefined", "thread"])
def test_lanes_rollout_sanitizer_clean_and_equal_to_the_scalar_rollout(cart_source, tmp_path, sanitizers):
    gm, src = cart_source
    assert gm.metadata["ninput"] > 0
    main = tmp_path / "main.c"
    main.write_text(DRIVER.replace("NAME", gm.name))
    exe = tmp_path / "driver"
    cmd = ["gcc", "-std=c99", "-O1", "-g1", "-Wall", "-Wextra", "-Werror", "-pthread", f"-fsanitize={sanitizers}",
           "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", f"-DEOMC_BATCH_LANES={machine_lanes()}",
           "-DEOMC_BATCH_LIBM_TRIG", "-I", str(Path(src).parent), "-I", str(RUNTIME_C), src, str(main),
           *(str(RUNTIME_C / f) for f in ("eomc_integrators.c", "eomc_fixedstep.c", "eomc_bdf.c",
                                          "eomc_rollout.c")),
           "-o", str(exe), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, ASAN_OPTIONS="detect_leaks=1", TSAN_OPTIONS="halt_on_error=1"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert "runtime error" not in run.stderr and "Sanitizer" not in run.stderr, run.stderr
    assert run.stdout.strip() == f"{gm.name} wrong=0 failed=1", run.stdout
