"""The price of float (eomc build --target c99-f32), measured, and the Cortex-M4 figures.

Host, per model (the double pendulum example; the xArm 7; Solo-12 on a floating base):
- rhs relative error of the float build against the double build over 10^4 random states
  (the same float inputs fed to both), overall and binned by cond(M) -- where precision is lost;
- the speed of NAME_rhs in float and in double, each in its own C loop (thread CPU time, pinned to
  one core, interleaved, median of repeats).
Double pendulum: the energy drift of a 10 s simulation, NAME_step_rk4 in float against the same
RK4 in double, h = 1 ms.
Cortex-M4 (examples/embed_cortex_m under QEMU mps2-an386): code size per object (`size`),
worst-case stack per function (gcc -fcallgraph-info of the ARM compile), instructions per call
(QEMU -icount), and the firmware's largest error against the host double build.

    python benchmarks/bench_embedded.py          # writes benchmarks/results/embedded.md
"""
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import eomc  # noqa: E402
from eomc.compiler.build.stack import measure_stack  # noqa: E402
from eomc.compiler.urdf.model import with_options  # noqa: E402
from common import environment_header, format_table, median_iqr, pin_to_one_core, write_results  # noqa: E402
from tests.helpers.robots import robot_path  # noqa: E402

NSTATES = 10_000
EXAMPLE = ROOT / "examples" / "embed_cortex_m"


def models():
    return {
        "double_pendulum": (str(ROOT / "examples" / "double_pendulum.py"), 2.0),
        "xarm7": (str(robot_path("xarm_description/urdf/xarm7.urdf")), 2.0),
        "solo12 (floating)": with_options(str(robot_path("solo12")), "solo", floating_base=True)[0:1] + (0.5,),
    }


def build_pair(key, source, cache):
    name = "".join(c for c in key.split()[0] if c.isalnum() or c == "_")
    f32 = eomc.compile(source, name + "_f32", functions=["rhs", "mass_matrix"], target="c99-f32",
                       cache_dir=cache, progress=False)
    f64 = eomc.compile(source, name + "_f64", functions=["rhs", "mass_matrix", "outputs"] if key == "double_pendulum"
                       else ["rhs", "mass_matrix"], cache_dir=cache, progress=False)
    return f32, f64


def errors(f32, f64, angle, rng):
    """(relative errors, cond(M)) over NSTATES random states."""
    errs, conds = np.empty(NSTATES), np.empty(NSTATES)
    p = np.float32(f64.param_defaults)
    r = np.zeros(f64.ninput, np.float32)
    for i in range(NSTATES):
        x = np.concatenate([rng.uniform(-angle, angle, f64.nq), rng.uniform(-1, 1, f64.nx - f64.nq)]).astype(np.float32)
        if f64.nq == 18:   # floating base: above the ground
            x[2] += 0.3
        ref = f64.rhs(0.0, x.astype(np.float64), p.astype(np.float64), r.astype(np.float64))
        got = f32.rhs(0.0, x, p, r)
        errs[i] = np.abs(got - ref).max() / max(np.abs(ref).max(), 1e-30)
        conds[i] = np.linalg.cond(f64.mass_matrix(0.0, x.astype(np.float64), p.astype(np.float64)))
    return errs, conds


_HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <time.h>
#include "{name}.h"
#define N {calls}
int main(void) {{
    static {real} x[{nx}], p[{np_}], r[{nr}], out[{nx}], work[1];
    struct timespec a, b;
    int i, k;
    for (i = 0; i < {nx}; i++) x[i] = ({real})(0.1 * (i % 7) - 0.2);
    for (i = 0; i < {np_}; i++) p[i] = ({real}){p0};
    {load_p}
    for (k = 0; k < 7; k++) {{
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        for (i = 0; i < N; i++) {{ {name}_rhs(({real})0, x, p, r, out, work); x[{last}] += out[0] * ({real})1e-12; }}
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        printf("%.6g\n", ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / N);
    }}
    return 0;
}}
"""


def c_speed(model, tmp, calls=20000):
    """ns per NAME_rhs call in a C loop (7 repeats), from the model's own C."""
    d = Path(model.directory)
    real = "float" if getattr(model, "target", "c99-f64") == "c99-f32" else "double"
    work = Path(tmp) / model.name
    work.mkdir(exist_ok=True)
    for f in (f"{model.name}.c", f"{model.name}.h", "eomc_model.h"):
        shutil.copy(d / f, work / f)
    defaults = ", ".join(repr(float(v)) for v in model.metadata["param_defaults"]) or "0"
    src = _HARNESS.format(name=model.name, calls=calls, real=real, nx=model.nx, np_=max(model.nparam, 1),
                          nr=max(model.ninput, 1), p0="1.0", last=model.nx - 1,
                          load_p=f"{{ static const double d[] = {{{defaults}}}; for (i = 0; i < {model.nparam}; i++) "
                                 f"p[i] = ({real})d[i]; }}")
    (work / "bench.c").write_text(src)
    exe = work / "bench"
    subprocess.run(["gcc", "-O2", "-std=c99", "-o", str(exe), "bench.c", f"{model.name}.c", "-lm"], cwd=work,
                   check=True, capture_output=True)
    return exe


def run_speed(exe):
    out = subprocess.run(["taskset", "-c", "1", str(exe)] if shutil.which("taskset") else [str(exe)],
                         capture_output=True, text=True, check=True).stdout.split()
    return [float(v) for v in out]


def energy_drift(f32, f64, seconds=10.0, h=1e-3):
    """max |E - E0| / |E0| over the run: float step_rk4 vs the same RK4 in double."""
    x0 = np.array([1.0, 0.5, 0.0, 0.0])
    energy = lambda x: f64.outputs(0.0, np.asarray(x, np.float64))["energy"]
    e0 = energy(x0)
    x32, x64, worst32, worst64 = np.float32(x0), x0.copy(), 0.0, 0.0
    for i in range(int(round(seconds / h))):
        t = i * h
        x32 = f32.step_rk4(t, h, x32)
        k1 = f64.rhs(t, x64)
        k2 = f64.rhs(t + h / 2, x64 + h / 2 * k1)
        k3 = f64.rhs(t + h / 2, x64 + h / 2 * k2)
        k4 = f64.rhs(t + h, x64 + h * k3)
        x64 = x64 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if i % 10 == 9:
            worst32 = max(worst32, abs(energy(x32) - e0) / abs(e0))
            worst64 = max(worst64, abs(energy(x64) - e0) / abs(e0))
    return worst32, worst64, np.abs(x32 - x64).max()


def cortex_m(tmp, cache):
    """(rows of the size/stack/instruction table, max errors) from examples/embed_cortex_m."""
    if any(shutil.which(t) is None for t in ("make", "arm-none-eabi-gcc", "qemu-system-arm")):
        return None, "the Cortex-M toolchain or QEMU is not installed"
    build = Path(tmp) / "cm"
    env = dict(os.environ, EOMC_CACHE_DIR=str(cache))
    common = [f"BUILD={build}", f"EOMC={sys.executable} -m eomc", f"PYTHON={sys.executable}"]
    subprocess.run(["make", "-s", "-C", str(EXAMPLE), *common], check=True, capture_output=True, env=env)
    run = subprocess.run(["make", "-s", "-C", str(EXAMPLE), *common, "run"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, check=True, env=env).stdout
    size = subprocess.run(["arm-none-eabi-size", str(build / "arm.o"), str(build / "quad.o"),
                           str(build / "firmware.elf")], capture_output=True, text=True, check=True).stdout
    texts = {Path(l.split()[-1]).name: int(l.split()[0]) for l in size.splitlines()[1:]}
    ticks = {}
    for line in run.splitlines():
        parts = line.split()
        if parts and parts[0] == "ticks":
            ticks[parts[1]] = struct.unpack("<f", bytes.fromhex(parts[3])[::-1])[0]
    per_tick = 20000 / ticks["calibration_20000_instructions"]
    rows = []
    for obj, name, fns in (("arm.o", "arm", ("rhs", "jac_x", "step_rk4")), ("quad.o", "quad", ("rhs", "step_rk4"))):
        ci = Path(tmp) / f"ci_{name}"
        ci.mkdir(exist_ok=True)
        shutil.copy(build / f"{name}.ci", ci / f"{name}.ci")
        stack = measure_stack(ci, name, fns)
        for fn in fns:
            instr = ticks.get(f"{name}_{fn}")
            rows.append([f"{name}_{fn}", f"{texts[obj]:,}" if fn == fns[0] else "",
                         stack[fn]["bytes"], ", ".join(stack[fn]["external"]) or "-",
                         f"{instr * per_tick:,.0f}" if instr is not None else "-"])
    return rows, texts["firmware.elf"]


def main():
    pin_to_one_core()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(2026)
    tmp = tempfile.mkdtemp(prefix="bench-embedded-")
    cache = Path(tmp) / "cache"
    err_rows, cond_rows, speed_rows = [], [], []
    pairs = {}
    for key, (source, angle) in models().items():
        f32, f64 = build_pair(key, source, cache)
        pairs[key] = (f32, f64)
        errs, conds = errors(f32, f64, angle, rng)
        err_rows.append([key, f64.nx, f"{np.median(errs):.2e}", f"{np.percentile(errs, 99):.2e}",
                         f"{errs.max():.2e}", f"{np.median(conds):.2e}", f"{conds.max():.2e}",
                         f"{np.max(errs / (conds * np.finfo(np.float32).eps)):.2g}"])
        edges = [1, 1e2, 1e3, 1e4, 1e5, np.inf]
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (conds >= lo) & (conds < hi)
            if sel.any():
                cond_rows.append([key, f"{lo:.0e} - {hi:.0e}", int(sel.sum()), f"{np.median(errs[sel]):.2e}",
                                  f"{errs[sel].max():.2e}"])
    # speed: float and double executables interleaved, 3 rounds x 7 repeats each
    exes = {key: (c_speed(f32, tmp), c_speed(f64, tmp)) for key, (f32, f64) in pairs.items()}
    samples = {key: ([], []) for key in exes}
    for _ in range(3):
        for key, (e32, e64) in exes.items():
            samples[key][0].extend(run_speed(e32))
            samples[key][1].extend(run_speed(e64))
    for key, (s32, s64) in samples.items():
        m32, m64 = median_iqr(s32)[0], median_iqr(s64)[0]
        speed_rows.append([key, f"{m32:,.0f}", f"{m64:,.0f}", f"{m64 / m32:.2f}"])
    drift32, drift64, gap = energy_drift(*pairs["double_pendulum"])
    arm_rows, elf = cortex_m(tmp, cache)

    text = environment_header("The price of float: eomc's c99-f32 target against c99-f64, and on a Cortex-M4",
                              notes=[f"{NSTATES} random states per model (angles uniform in +-angle, speeds in "
                                     f"+-1); float inputs rounded once and fed to both builds"])
    text += "\n## rhs relative error, float vs double (host)\n\n"
    text += ("max|xdot32 - xdot64| / max|xdot64| per state; the last column is max(error / (cond(M) "
             "eps32)), the constant of the bound the tests use (64).\n\n")
    text += format_table(["model", "nx", "median", "99th pct", "max", "median cond(M)", "max cond(M)",
                          "max err/(cond eps32)"], err_rows)
    text += "\n\n## Where precision is lost: error by cond(M)\n\n"
    text += format_table(["model", "cond(M)", "states", "median error", "max error"], cond_rows)
    text += "\n\n## Energy drift, double pendulum, 10 s, RK4 with h = 1 ms\n\n"
    text += format_table(["build", "max |E - E0| / |E0|"],
                         [["c99-f32 (NAME_step_rk4)", f"{drift32:.2e}"], ["c99-f64 (same RK4)", f"{drift64:.2e}"]])
    text += f"\n\nlargest state difference after 10 s: {gap:.2e}\n"
    text += "\n## Speed of NAME_rhs on the host (gcc -O2, ns per call, median of 21)\n\n"
    text += format_table(["model", "float", "double", "double / float"], speed_rows)
    text += "\n\n## Cortex-M4 (arm-none-eabi-gcc -O2 -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard, QEMU mps2-an386)\n\n"
    if arm_rows is None:
        text += f"not measured: {elf}\n"
    else:
        text += ("Code size is the object's .text (`arm-none-eabi-size`); stack is the worst case over the "
                 "calls inside the file, from the ARM compile's -fcallgraph-info, plus the libm functions "
                 "named; instructions per call from QEMU -icount (instructions, not cycles; a real M4 "
                 "takes roughly 1-1.5 cycles each plus flash wait states).  The firmware's results are "
                 "checked against the host double build by tests/compiler/build/test_embed_cortex_m.py.\n\n")
        text += format_table(["function", "object .text (bytes)", "stack (bytes)", "plus libm", "instructions/call"],
                             arm_rows)
        text += f"\n\nwhole firmware (both models, startup, libm): {elf:,} bytes of .text\n"
    print(text)
    write_results("embedded", text)


if __name__ == "__main__":
    main()
