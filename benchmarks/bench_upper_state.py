"""Whole runs of machine-built models: before the upper-state fix, with either cure, and portable.

Why: gcc 12 left out ``vzeroupper`` in some -mavx2 model functions (the 3-link cart's jvp on
every call, its jac_x on the failure return; tests/compiler/build/test_upper_state.py), so
the SSE-compiled runtime ran after them with the ymm upper halves dirty.  Two flags cure it
(no function returns dirty): -fno-ipa-ra (the vectors stay 256-bit; what the build adds now,
compiler/build/toolchain.GCC_MACHINE_FLAGS) and -mprefer-vector-width=128 (xmm only).  This
compares, in one process, four builds of the same generated C (compiled here with gcc from
each model's cached directory): portable (-O2), the machine flags before (-mavx2
-ffp-contract=off), plus -mprefer-vector-width=128, plus -fno-ipa-ra.  DOP853, Radau, BDF and
implicitfast runs; thread CPU, pinned by the caller (taskset -c 1), contestants interleaved,
medians.  Usage: python benchmarks/bench_upper_state.py [--repeats 7]
"""
import argparse
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

BASE = ["-O2", "-fPIC", "-std=c99"]
VARIANTS = {"portable": BASE, "machine-256": BASE + ["-mavx2", "-ffp-contract=off"],
            "machine-128": BASE + ["-mavx2", "-ffp-contract=off", "-mprefer-vector-width=128"],
            "machine-noipara": BASE + ["-mavx2", "-ffp-contract=off", "-fno-ipa-ra"]}


def models():
    """(label, model built by eomc, x0, methods with options)."""
    import eomc
    import gymnasium
    import mujoco
    import models as bm
    from bench_fixedstep import eomc_start
    from eomc.compiler.mjcf.model import MjcfModel
    out = []
    for n in (3, 8):
        kane, specified = bm.eomc_kane(n)
        syms = sorted((kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols), key=str)
        values = bm.parameter_values(n)
        params = {s: values[str(s)] for s in syms if s.is_Symbol and str(s) != "t"}
        cart = eomc.compile(kane, parameters=params, inputs=specified, functions=["rhs", "jac_x", "jac_p", "jvp"],
                            progress=False)
        out.append((f"cart n={n}", cart, bm.initial_state(n), 10.0))
    xml = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ant = eomc.compile(MjcfModel(xml), name="vzu_ant", functions=("rhs", "jac_x", "outputs", "implicit",
                                                                        "rhs_batch", "jac_x_batch"), progress=False)
    out.append(("gym ant", ant, eomc_start(ant, mujoco.MjModel.from_xml_path(str(xml))), 1.0))
    return out


def variant(model, flags, tmp):
    """A copy of the model's directory with its library rebuilt with ``flags``; loaded."""
    from eomc.runtime.loader import load
    src = Path(model.directory)
    dst = Path(tmp) / ("_".join(f.strip("-") for f in flags[3:]) or "portable")
    shutil.copytree(src, dst)
    lib = Path(model.library_path).name
    sources = [str(p) for p in sorted(dst.glob("*.c"))]
    subprocess.run(["cc", *flags, *(["-DEOMC_BATCH_LANES=8"] if "-mavx2" in flags else []), "-shared",
                    *sources, "-o", str(dst / lib), "-lm"], check=True)
    return load(dst)


def timed(fn):
    t0 = time.thread_time()
    fn()
    return time.thread_time() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="eomc_vzu_") as tmp:
        for label, model, x0, t1 in models():
            built = {}
            for k, f in VARIANTS.items():
                d = Path(tmp) / label.replace(" ", "_").replace("=", "")
                d.mkdir(exist_ok=True)
                built[k] = variant(model, f, d)
            runs = {"dop853": dict(method="dop853", rtol=1e-8, atol=1e-8),
                    "radau": dict(method="radau", rtol=1e-6, atol=1e-6),
                    "bdf": dict(method="bdf", rtol=1e-6, atol=1e-6),
                    "implicitfast": dict(method="implicitfast", dt=1e-3 if label.startswith("cart") else 0.01)}
            if label.startswith("cart"):     # jvp in the loop (the 3-link cart's was the dirty one)
                runs["dop853 + 4 sensitivities"] = dict(method="dop853", rtol=1e-8, atol=1e-8,
                                                        sensitivities=list(model.param_names[:4]))
            for run, kw in runs.items():
                calls = {k: (lambda m=m: m.simulate(x0, (0.0, t1), t_eval=[t1], **kw)) for k, m in built.items()}
                with warnings.catch_warnings():     # the ant's qpos0 starts past its ankle limits (said once)
                    warnings.simplefilter("ignore")
                    ends = {k: c().x[-1] for k, c in calls.items()}
                same = all(np.array_equal(ends["portable"], e) for e in ends.values())
                warnings.simplefilter("ignore")
                times = {k: [] for k in calls}
                for r in range(args.repeats):
                    order = list(calls) if r % 2 == 0 else list(calls)[::-1]
                    for k in order:
                        times[k].append(timed(calls[k]))
                med = {k: float(np.median(v)) * 1e3 for k, v in times.items()}
                new = med["machine-noipara"]
                rows.append([label, run, f"{med['portable']:.2f}", f"{med['machine-256']:.2f}",
                             f"{med['machine-128']:.2f}", f"{new:.2f}", f"{med['machine-256'] / new:.3f}",
                             f"{med['machine-128'] / new:.3f}", f"{med['portable'] / new:.3f}", "yes" if same else "NO"])
                print(rows[-1], flush=True)
    head = ["model", "method", "portable [ms]", "machine before [ms]", "+ prefer-width 128 [ms]",
            "+ -fno-ipa-ra (now) [ms]", "before / now", "128 / now", "portable / now", "same end-state bits (all four)"]
    text = format_table(head, rows)
    print(text)
    title = "Machine builds before and after the ymm upper-state fix (-fno-ipa-ra), -mprefer-vector-width=128, portable"
    write_results("upper_state", environment_header(title, sys.argv[1:]) + "\n" + text + "\n")


if __name__ == "__main__":
    main()
