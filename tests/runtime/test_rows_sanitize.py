"""eomc_energy_screen (runtime/c/eomc_rows.c) under ASan/UBSan: a plain C driver screens rows held in
arrays of exactly their size (an overrun is caught), with a failing and a non-finite energy, a row
not run, per-row parameters and inputs, and with and without the watch's stats."""
import shutil
import subprocess

import pytest

from helpers.stand_in import RUNTIME_C

DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "eomc_integrators.h"

/* energy = x0 + x1 + p[0] + r[0] (r NULL: 0); fails below x0 = -100, NaN above x0 = 100 */
static int energy(double t, const double *x, const double *p, const double *r, double *out, double *work)
{
    (void)t; (void)work;
    if (x[0] < -100.0) return 1;
    out[0] = x[0] > 100.0 ? NAN : x[0] + x[1] + p[0] + (r ? r[0] : 0.0);
    return 0;
}

static double *copy(const double *v, size_t n)
{
    double *out = malloc(n * sizeof *out);
    for (size_t i = 0; i < n; ++i) out[i] = v[i];
    return out;
}

int main(void)
{
    enum { N = 6, NX = 2 };
    const double x0[N * NX] = {1, 0, 1, 0, 1, 0, -200, 0, 1, 0, 1, 0};
    const double xl[N * NX] = {1, 0, 2, 0, 1, 0, 1, 0, 200, 0, 1, 0};
    const double pv[N] = {0, 0, 0, 0, 0, 0}, rv[N] = {0, 0, 0, 0, 0, 0};
    const int sv[N] = {0, 0, 5, 0, 0, 0};
    double *X0 = copy(x0, N * NX), *XL = copy(xl, N * NX), *P = copy(pv, N), *R = copy(rv, N);
    int *status = malloc(N * sizeof *status);
    double *E = malloc(2 * N * sizeof *E), *work = malloc(sizeof *work);
    unsigned char *flag = malloc(N);
    eomc_stats *stats = calloc(N, sizeof *stats);
    size_t i, got;
    int bad = 0;
    for (i = 0; i < N; ++i) {
        status[i] = sv[i];
        stats[i].watch_lo = stats[i].watch_hi = 1.0;
        stats[i].watch_total0 = stats[i].watch_total_lo = stats[i].watch_total_hi = 1.0;
        stats[i].watch_rise = 0.0;
    }
    stats[5].watch_rise = 1.0;      /* row 5: its total rose */
    got = eomc_energy_screen(energy, N, 1.0, X0, XL, NX, P, 1, R, 1, status, stats, 1, 1e-6, E, flag, work);
    /* row 1 rose (1 -> 2), row 5's total rose; 2 not run, 3 failed at its start, 4 NaN at its end */
    bad |= got != 2 || !flag[1] || !flag[5] || flag[0] || flag[2] || flag[3] || flag[4];
    bad |= E[0] != 1 || E[3] != 2 || !isnan(E[4]) || !isnan(E[6]) || !isnan(E[9]);
    got = eomc_energy_screen(energy, N, 1.0, X0, XL, NX, P, 0, NULL, 0, status, NULL, 0, 1e-6, E, flag, work);
    bad |= got != 1 || !flag[1];     /* no stats: the start and end alone; one shared p, no inputs */
    printf(bad ? "SCREEN WRONG\n" : "SCREEN SANITIZE OK\n");
    free(X0); free(XL); free(P); free(R); free(status); free(E); free(work); free(flag); free(stats);
    return bad;
}
"""


def test_energy_screen_clean_under_asan_ubsan(tmp_path):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the C screen test")
    src, exe = tmp_path / "screen_driver.c", tmp_path / "screen_driver"
    src.write_text(DRIVER)
    cmd = ["gcc", "-std=c99", "-g1", "-O1", "-Wall", "-Wextra", "-Werror", "-fsanitize=address,undefined",
           "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", f"-I{RUNTIME_C}", "-o", str(exe), str(src),
           str(RUNTIME_C / "eomc_rows.c"), "-lm"]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60,
                          env={"ASAN_OPTIONS": "detect_leaks=1", "UBSAN_OPTIONS": "print_stacktrace=1"})
    assert proc.returncode == 0 and "SCREEN SANITIZE OK" in proc.stdout, proc.stdout + proc.stderr
