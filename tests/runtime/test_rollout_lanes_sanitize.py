"""eomc_rollout_lanes (runtime/c/eomc_rollout.c) under AddressSanitizer and UBSan, and under
ThreadSanitizer: a C driver integrates 45 rows of the generated cart-pole (NAME_rhs_batch_p,
built with libm's sin/cos in the lanes) on 2 threads in blocks of 16 -- so blocks end in a
part-filled group of lanes and a scalar tail -- with one parameter row and one input sequence
(a 4-point table ending inside the span) per trajectory, every step recorded and one row that
overflows, and compares every row with the scalar C rollout
(eomc_rollout, RK4) byte for byte: final states, statuses, step counts and, for the rows
that ran to the end, every recorded step.  A clean run is a correct run.

eomc_rollout_implicit_lanes under ASan/UBSan: the gym hopper's implicitfast rows (contacts,
split steps, a parameter row per trajectory) in fibers, their NAME_implicit calls made by
NAME_implicit_batch, against eomc_rollout_stats byte for byte -- once with the hand-written
stack switch (each switch announced to ASan, runtime/c/eomc_rollout.c) and once with ucontext
(-DEOMC_FIBER_UCONTEXT).  And eomc_rollout_implicit_lanes_rows on a small scene with body-body
pairs (a ball thrown at a free body's trunk and arm): each round's NAME_implicit_batch_rows call
writes the pairs' slope block into the rows' own buffers (the padding lanes into a scratch row),
and the assembly in lanes reads the pair points from there."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.driver import generate
from eomc.runtime.simulate import IMPLICITFAST_SPLIT, depth_limits

from helpers import emit_support as es

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

ROOT = Path(__file__).resolve().parents[2]
CART = ROOT / "examples" / "cart_pole_system.py"
RUNTIME_C = ROOT / "runtime" / "c"

# The two drivers' shared C: the buffers of two rollouts (A: the scalar one, B: the lanes one)
# of n rows of `rows` samples of nx states, declared once n, nx, np and rows are, and freed.
BUFFERS = """    double *X0 = malloc((size_t)n * nx * sizeof(double)), *P = malloc((size_t)n * np * sizeof(double));
    double *A_last = malloc((size_t)n * nx * sizeof(double)), *B_last = malloc((size_t)n * nx * sizeof(double));
    double *A_out = malloc((size_t)n * rows * nx * sizeof(double));
    double *B_out = malloc((size_t)n * rows * nx * sizeof(double));
    double *t_eval = malloc(rows * sizeof(double));
    int *A_st = malloc((size_t)n * sizeof(int)), *B_st = malloc((size_t)n * sizeof(int));
    long *A_steps = malloc((size_t)n * sizeof(long)), *B_steps = malloc((size_t)n * sizeof(long));"""
FREE_BUFFERS = """free(X0); free(P); free(A_last); free(B_last); free(A_out); free(B_out); free(t_eval);
    free(A_st); free(B_st); free(A_steps); free(B_steps);"""


def _with_buffers(driver):
    return driver.replace("@BUFFERS@", BUFFERS).replace("@FREE_BUFFERS@", FREE_BUFFERS)


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
@BUFFERS@
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
                       (size_t)(nr * ni), B_out, B_last, B_st, B_steps, 16, 2, 0, NULL);
    for (k = 0; k < n; k++) {
        if (A_st[k] != B_st[k] || A_steps[k] != B_steps[k]) wrong++;
        if (memcmp(A_last + (size_t)k * nx, B_last + (size_t)k * nx, (size_t)nx * sizeof(double))) wrong++;
        if (A_st[k] != EOMC_OK) { failed++; continue; }
        if (memcmp(A_out + (size_t)k * rows * nx, B_out + (size_t)k * rows * nx, rows * nx * sizeof(double)))
            wrong++;
    }
    printf("%s wrong=%d failed=%d\n", m->name, wrong, failed);
    @FREE_BUFFERS@ free(R);
    return wrong != 0;
}
"""
DRIVER = _with_buffers(DRIVER)


@pytest.fixture(scope="module")
def cart_source(tmp_path_factory):
    directory = tmp_path_factory.mktemp("lanes_san")
    gm = generate(str(CART), "lanescart", functions=("rhs", "rhs_batch"), formulation="recursive",
                  cache_dir=directory / "cache", progress=False)[1]
    assert gm.metadata["rhs_batch"]["vectorized"], gm.metadata["rhs_batch"]
    return gm, es.write_sources(gm, str(directory))


def _build_and_run(src, driver, tmp_path, sanitizers, *defines):
    """The driver built with the model's source, the rollout's C and the sanitizers, and run:
    its stdout (asserted clean: status 0, no sanitizer report)."""
    main = tmp_path / "main.c"
    main.write_text(driver)
    exe = tmp_path / "driver"
    cmd = ["gcc", "-std=c99", "-O1", "-g1", "-Wall", "-Wextra", "-Werror", "-pthread", f"-fsanitize={sanitizers}",
           "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", f"-DEOMC_BATCH_LANES={machine_lanes()}",
           "-DEOMC_BATCH_LIBM_TRIG", *defines, "-I", str(Path(src).parent), "-I", str(RUNTIME_C), src, str(main),
           *(str(RUNTIME_C / f) for f in ("eomc_integrators.c", "eomc_fixedstep.c", "eomc_fixedstep_avx2.c", "eomc_bdf.c",
                                          "eomc_rollout.c")),
           "-o", str(exe), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, ASAN_OPTIONS="detect_leaks=1:detect_stack_use_after_return=1",
                                  TSAN_OPTIONS="halt_on_error=1"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert "runtime error" not in run.stderr and "Sanitizer" not in run.stderr, run.stderr
    return run.stdout.strip()


@pytest.mark.parametrize("sanitizers", ["address,undefined", "thread"])
def test_lanes_rollout_sanitizer_clean_and_equal_to_the_scalar_rollout(cart_source, tmp_path, sanitizers):
    gm, src = cart_source
    assert gm.metadata["ninput"] > 0
    out = _build_and_run(src, DRIVER.replace("NAME", gm.name), tmp_path, sanitizers)
    assert out == f"{gm.name} wrong=0 failed=1", out


# ---------------------------------------------------------------- implicitfast rows in fibers

HOPPER_DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "NAME.h"
#include "eomc_rollout.h"

#ifdef BLOCK_FIRST
int NAME_implicit_batch_rows(int n, double t, const double *X, const double *p, const double *R, double *OUT,
                             double *const *rows, int *status, double *work);
#endif

static unsigned long long seed = 2024;
static double uniform(void)      /* in [-1, 1), the same on every machine */
{
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return 2.0 * (double)(seed >> 11) / 9007199254740992.0 - 1.0;
}

static const double x_start[] = {X_START};
static const int chain_start[] = {CHAIN_START}, chain[] = {CHAIN}, parent[] = {PARENT}, masses[] = {MASSES};
static const double depth_limit[] = {DEPTH_LIMIT};

int main(void)
{
    const eomc_model *m = NAME_model();
    const int n = NROWS, nx = m->nx, np = m->nparam, nq = NQ, lanes = LANES;
    const double dt = 0.008, t1 = 0.2;
    const long nsteps = 25;
    const size_t rows = (size_t)(nsteps + 1);
@BUFFERS@
    eomc_stats *A_stats = calloc((size_t)n, sizeof(eomc_stats)), *B_stats = calloc((size_t)n, sizeof(eomc_stats));
    eomc_implicit imp;
    eomc_options opt;
    long calls = 0, steps = 0;
    int i, k, wrong = 0, failed = 0;
    /* the file's start, the speeds uniform in +-0.5 (the hopper falls onto its foot); every
       fourth row's links 10 % heavier: rows with other parameters share no batch call */
    for (k = 0; k < n; k++)
        for (i = 0; i < nx; i++) X0[(size_t)k * nx + i] = i < nq ? x_start[i] : 0.5 * uniform();
    for (k = 0; k < n; k++) {
        memcpy(P + (size_t)k * np, m->param_defaults, (size_t)np * sizeof(double));
        if (k % 4 == 3)
            for (i = 0; i < (int)(sizeof masses / sizeof masses[0]); i++) P[(size_t)k * np + masses[i]] *= 1.1;
    }
    for (k = 0; k < nsteps; k++) t_eval[k] = k * dt;
    t_eval[nsteps] = t1;
    memset(&imp, 0, sizeof imp);
#ifdef TERMS_CONST      /* the constant outputs once per buffer (the lanes then copy only the others) */
    imp.terms = NAME_implicit_var;
    imp.terms_const = NAME_implicit_const;
#else
    imp.terms = NAME_implicit;
#endif
    imp.ncontact = NCONTACT;
    imp.chain_start = chain_start;
    imp.chain = chain;
    imp.parent = parent;
    imp.work_len = eomc_fs_implicit_work_size(nq, nx - nq, NCONTACT);
    imp.split = SPLIT;
    imp.depth_limit = depth_limit;
#ifdef FIXED_LISTS      /* the run's fixed lists made once (eomc_fs_pattern), as rollout's structs carry them */
    {
        size_t len = eomc_fs_pattern(&imp, nq, nx - nq, NULL, NULL);
        double *scratch = malloc(imp.work_len * sizeof(double)), *lists = malloc(len * sizeof(double));
        if (eomc_fs_pattern(&imp, nq, nx - nq, scratch, lists) != len) return 2;
        free(scratch);
        imp.pattern = lists;
        imp.pattern_len = len;
    }
#endif
    memset(&opt, 0, sizeof opt);
    opt.method = EOMC_IMPLICITFAST;
    opt.h0 = dt;
    opt.max_steps = 1000;
    opt.implicit = &imp;
    eomc_rollout_stats(m, &opt, 0.0, t1, n, X0, P, (size_t)np, 0, NULL, NULL, 0, (int)rows, t_eval,
                       A_out, A_last, A_st, A_steps, A_stats, 2);
#ifdef BLOCK_FIRST      /* the pairs' slope block into the rows' own buffers */
    eomc_rollout_implicit_lanes_rows(m, &opt, NAME_implicit_batch_rows, BLOCK_FIRST, BLOCK_LEN, lanes, OUT_LEN, READS_T,
                                     0.0, t1, n, X0, P, (size_t)np, 0, NULL, NULL, 0, (int)rows, t_eval, B_out, B_last,
                                     B_st, B_steps, B_stats, 2);
#else
    eomc_rollout_implicit_lanes(m, &opt, NAME_implicit_batch, lanes, OUT_LEN, READS_T, 0.0, t1, n, X0, P, (size_t)np, 0,
                                NULL, NULL, 0, (int)rows, t_eval, B_out, B_last, B_st, B_steps, B_stats, 2);
#endif
    for (k = 0; k < n; k++) {
        if (A_st[k] != B_st[k] || A_steps[k] != B_steps[k]) wrong++;
        if (memcmp(&A_stats[k], &B_stats[k], sizeof(eomc_stats))) wrong++;
        if (memcmp(A_last + (size_t)k * nx, B_last + (size_t)k * nx, (size_t)nx * sizeof(double))) wrong++;
        if (memcmp(A_out + (size_t)k * rows * nx, B_out + (size_t)k * rows * nx, rows * nx * sizeof(double)))
            wrong++;
        if (A_st[k] != EOMC_OK) failed++;
        calls += A_stats[k].nfev;
        steps += A_steps[k];
    }
    printf("%s wrong=%d failed=%d split=%d\n", m->name, wrong, failed, calls > steps + n);
    @FREE_BUFFERS@ free(A_stats); free(B_stats); free((void *)imp.pattern);
    return wrong != 0;
}
"""
HOPPER_DRIVER = _with_buffers(HOPPER_DRIVER)


@pytest.fixture(scope="module")
def hopper_source(tmp_path_factory):
    import warnings
    gymnasium = pytest.importorskip("gymnasium")
    from eomc.compiler.mjcf.model import MjcfModel
    directory = tmp_path_factory.mktemp("fiber_san")
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    with warnings.catch_warnings():      # the file's self-collision pairs left out (said by a warning)
        warnings.simplefilter("ignore")
        spec, gm = generate(MjcfModel(path), "fiberhopper", functions=("rhs", "implicit", "implicit_batch"),
                            cache_dir=directory / "cache", progress=False)
    assert gm.metadata["implicit_batch"]["vectorized"], gm.metadata["implicit_batch"]
    return spec, gm, es.write_sources(gm, str(directory))


def _hopper_driver(spec, gm, x_start=None):
    """HOPPER_DRIVER with the model's start, contact structure (NAME.json's "implicit", as
    simulate.implicit_terms reads it) and depth limits written in."""
    md, info = gm.metadata, gm.metadata["implicit"]
    # (a body-body pair's point has no depth limit: inf, C's INFINITY)
    c_list = lambda values: ", ".join("INFINITY" if v == float("inf") else repr(v) for v in values)   # noqa: E731
    starts = [0]
    for c in info["contacts"]:
        starts.append(starts[-1] + len(c["speeds"]))
    shape = type("Shape", (), {"metadata": md, "param_names": md["param_names"]})
    lanes = machine_lanes()
    start = spec.initial_state if x_start is None else x_start
    fill = {"X_START": c_list(float(v) for v in start[:md["nq"]]),
            "CHAIN_START": c_list(starts), "CHAIN": c_list(int(s) for c in info["contacts"] for s in c["speeds"]),
            "PARENT": c_list(int(q) for q in info["parents"]),
            "MASSES": c_list(k for k, name in enumerate(md["param_names"]) if name.startswith("m_")),
            "DEPTH_LIMIT": c_list(float(v) for v in depth_limits(shape, md["param_defaults"])),
            "NCONTACT": str(len(info["contacts"])), "NQ": str(md["nq"]), "LANES": str(lanes),
            "NROWS": str(2 * lanes + 3), "SPLIT": repr(float(IMPLICITFAST_SPLIT)),
            "OUT_LEN": str(info["layout"]["size"]), "READS_T": str(int(md["implicit_batch"]["reads_t"]))}
    driver = HOPPER_DRIVER
    for key, value in fill.items():
        driver = driver.replace(key, value)
    return driver.replace("NAME", gm.name)


@pytest.mark.parametrize("switch", ["hand-written", "ucontext", "constants apart"])
def test_implicitfast_fibers_clean_under_asan_and_equal_to_the_scalar_rollout(hopper_source, tmp_path, switch):
    """Every fiber switch under ASan (the hand-written one announced to it, swapcontext
    intercepted), UBSan on the batch and the scalar rows; the rows split steps (more model
    calls than steps) and must equal the scalar rollout's bytes, stats included.  "constants
    apart": terms NAME_implicit_var with terms_const NAME_implicit_const, as rollout runs a model
    with constant outputs (the lanes copy only the blocks holding the others: var_blocks), and the
    run's fixed lists made once (eomc_fs_pattern, N's lists from the constants), as rollout's struct
    carries them."""
    spec, gm, src = hopper_source
    assert (gm.metadata.get("const_outputs") or {}).get("implicit")
    defines = {"ucontext": ("-DEOMC_FIBER_UCONTEXT",),
               "constants apart": ("-DTERMS_CONST", "-DFIXED_LISTS")}.get(switch, ())
    out = _build_and_run(src, _hopper_driver(spec, gm), tmp_path, "address,undefined", *defines)
    assert out == f"{gm.name} wrong=0 failed=0 split=1", out


def test_implicitfast_rows_path_clean_under_asan_and_equal_to_the_scalar_rollout(tmp_path):
    """eomc_rollout_implicit_lanes_rows (the pairs' slope block written by each lane straight into
    its row; the padding lanes' into a scratch row; the lanes' assembly gathering the pair points
    from the rows) under ASan/UBSan: the limbs scene's rows, the ball 10 mm from the trunk with
    speeds in +-0.5 (rows close in on it), against the scalar rollout byte for byte; the run's fixed
    lists made once (eomc_fs_pattern: the ball-trunk pair's branch mask), as rollout's struct carries them."""
    import warnings
    from eomc.compiler.mjcf.model import MjcfModel
    from ..compiler.contact.test_narrow import LIMBS
    path = tmp_path / "limbs.xml"
    path.write_text(LIMBS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        spec, gm = generate(MjcfModel(path, pairs=True), "fiberlimbs", functions=("rhs", "implicit", "implicit_batch"),
                            cache_dir=tmp_path / "cache", progress=False)
    first, length = gm.metadata["implicit_batch"]["rows_block"]
    src = es.write_sources(gm, str(tmp_path))
    names = list(gm.metadata["state_names"])
    x0 = [0.0] * len(names)
    for i in gm.metadata.get("quaternions", ()):     # upright (the MJCF default: each quaternion's w)
        x0[i] = 1.0
    for name, v in (("q_joint0_z", 0.3), ("q_joint3_y", -0.1), ("q_joint3_z", 0.3)):
        x0[names.index(name)] = v
    out = _build_and_run(src, _hopper_driver(spec, gm, x0), tmp_path, "address,undefined",
                         f"-DBLOCK_FIRST={first}", f"-DBLOCK_LEN={length}", "-DFIXED_LISTS")
    assert out.startswith(f"{gm.name} wrong=0 failed=0"), out
