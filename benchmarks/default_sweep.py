"""Every real model file we can find, with no flags, as a new user runs it.

"Defaults are the product": what ``eomc build FILE`` and ``eomc simulate FILE --t-final 1``
do, with nothing else on the command line, on files nobody here wrote:

- every URDF of the installed example-robot-data wheel,
- every MJCF of gymnasium's ``envs/mujoco/assets``,
- dm_control's suite (``dm_control/suite/*.xml``) when dm_control is importable (or
  ``--dm-control DIR`` names its suite folder).

Per file, two child processes sharing one fresh cache (so simulate reuses the build):

1. ``eomc build FILE -o DIR``: exit code, CPU s (user+sys of the child and gcc), wall s,
   peak RSS of the child Python, size of the C;
2. ``eomc simulate FILE --t-final 1 -o out.csv``: exit code, CPU s, and what the run said
   (warnings counted, the first one quoted).

Outcome per step: ``ok``; ``ok, N warnings``; ``refused`` (non-zero exit, a message and no
traceback: a clear error); ``TRACEBACK`` (a Python traceback reached the user: a bug);
``TIMEOUT``.  Nothing is judged right or wrong physically here (the benchmarks per issue do
that); this table says whether the first command works and what it costs.

    python benchmarks/default_sweep.py                 # everything (an hour or more of CPU)
    python benchmarks/default_sweep.py -k go2 -k hopper
    python benchmarks/default_sweep.py --target c99-f32   # the float C for firmware: built, not simulated
"""
import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import environment_header, format_table, write_results  # noqa: E402

CHILD = r"""
import runpy, sys
sys.argv = ["eomc"] + sys.argv[1:]
try:
    runpy.run_module("eomc", run_name="__main__")
except SystemExit as exc:
    code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
else:
    code = 0
hwm = [l.split()[1] for l in open("/proc/self/status") if l.startswith("VmHWM:")]
print("RSS_KB", hwm[0] if hwm else 0, file=sys.stderr)
sys.exit(code)
"""


def model_files(dm_dir=None):
    """[(group, label, path)] of every file the sweep runs."""
    from importlib.metadata import distribution
    files = []
    erd = Path(distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots"))
    files += [("URDF", str(p.relative_to(erd)), p) for p in sorted(erd.rglob("*.urdf"))]
    import gymnasium
    gym = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    files += [("gymnasium", p.name, p) for p in sorted(gym.glob("*.xml"))]
    if dm_dir is None:
        try:
            import dm_control
            dm_dir = Path(dm_control.__file__).parent / "suite"
        except ImportError:
            dm_dir = None
    if dm_dir is not None:
        files += [("dm_control", p.name, p) for p in sorted(Path(dm_dir).glob("*.xml"))
                  if not p.name.startswith(("common", "lqr", "dog"))]
    return files


def run(args, env, cwd, timeout):
    """(exit code or 'TIMEOUT', CPU s, wall s, RSS MB, stderr)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-c", CHILD, *args], env=env, cwd=cwd,
                              capture_output=True, text=True, timeout=timeout)
        code, err = proc.returncode, proc.stderr
    except subprocess.TimeoutExpired as exc:
        code, err = "TIMEOUT", (exc.stderr or b"").decode(errors="replace") if isinstance(exc.stderr, bytes) \
            else (exc.stderr or "")
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rss = [int(line.split()[1]) for line in err.splitlines() if line.startswith("RSS_KB")]
    err = "\n".join(line for line in err.splitlines() if not line.startswith("RSS_KB"))
    return code, cpu, wall, (rss[0] / 1024 if rss else None), err


WARNING = re.compile(r"(warning|Warning)[:\]]")


def outcome(code, err):
    """The user-visible verdict of one step, and the line worth quoting."""
    lines = [line.strip() for line in err.splitlines() if line.strip()]
    if code == "TIMEOUT":
        return "TIMEOUT", (lines[-1] if lines else "")
    if "Traceback (most recent call last)" in err:
        return "TRACEBACK", (lines[-1] if lines else "")
    if code != 0:
        return "refused", next((line for line in lines if "error" in line.lower()), lines[-1] if lines else "")
    warns = [line for line in lines if WARNING.search(line)]
    if warns:
        return f"ok, {len(warns)} warning{'s' if len(warns) > 1 else ''}", warns[0]
    return "ok", ""


def root_z(path, csv, t_final):
    """'MuJoCo/eomc (diff mm)': the root body's height at t_final after MuJoCo's passive mj_step and
    in the last row of eomc's CSV (bench_dm_suite's mapping of a state to MuJoCo's); '-' for
    a URDF or a run without output."""
    if path.suffix != ".xml" or not csv.is_file():
        return "-"
    import numpy as np
    from bench_dm_suite import eomc_root_height, mujoco_root_height
    last = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)[-1]
    try:
        z_m, z_e = mujoco_root_height(path, t_final), eomc_root_height(path, None, last[1:])
    except Exception as exc:  # noqa: BLE001 -- the cell says why
        return f"n/a ({type(exc).__name__})"
    return "-" if np.isnan(z_m) else f"{z_m:.4f}/{z_e:.4f} ({1e3 * (z_e - z_m):+.1f})"


def source_digest():
    """The digest of eomc's compiler source now (compiler/build/reuse.compiler_digest, read afresh).
    Why: the generation cache is keyed on it, so a checkout edited while the sweep runs (an editable
    install) makes a file built before the edit generate again inside its simulate, whose CPU then
    counts a build (session 51: stacker's 1-s simulate read 34.9 s, 2.0 s alone).  A row whose
    digest changed between its build and its simulate is marked, not silently wrong."""
    from eomc.compiler.build import reuse
    reuse._DIGEST.clear()
    return reuse.compiler_digest()


def short(text, root_dirs, n=110):
    for d in root_dirs:
        text = text.replace(str(d) + "/", "")
    return text if len(text) <= n else text[:n - 1] + "…"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", action="append", default=[], help="substring of the file labels to run")
    parser.add_argument("--dm-control", help="dm_control's suite folder (default: the importable package's)")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per step")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--t-final", type=float, default=1.0, help="simulated seconds (default 1)")
    parser.add_argument("--root-z", action="store_true",
                        help="MJCF files: the root body's height at --t-final next to MuJoCo's passive mj_step")
    parser.add_argument("--write-as", default="default_sweep", help="results file name (default default_sweep)")
    parser.add_argument("--target", choices=("c99-f64", "c99-f32"), default=None,
                        help="build with --target (c99-f32: the float C for firmware, built only -- a float "
                             "model does not simulate)")
    args = parser.parse_args()
    span = f"{args.t_final:g} s"
    files = [f for f in model_files(args.dm_control) if not args.k or any(k in f[1] for k in args.k)]
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    rows, loads, moved = [], [], []
    target = ["--target", args.target] if args.target else []
    float_only = args.target == "c99-f32"
    flags = f" {' '.join(target)}" if target else ""
    counts = {}
    for i, (group, label, path) in enumerate(files, 1):
        loads.append(os.getloadavg()[0])
        work = Path(tempfile.mkdtemp(prefix="eomc_sweep_"))
        env = dict(os.environ, EOMC_CACHE_DIR=str(work / "cache"))
        digest = source_digest()
        code, cpu, wall, rss, err = run(["build", str(path), "-o", str(work / "out")] + target, env, work,
                                        args.timeout)
        b_out, b_line = outcome(code, err)
        c_kb = sum(p.stat().st_size for p in (work / "out").glob("*.c")) / 1024 if code == 0 else None
        row = [group, label, b_out, f"{cpu:.1f}", f"{wall:.1f}", f"{rss:.0f}" if rss else "-",
               f"{c_kb:.0f}" if c_kb else "-"]
        if code == 0 and not float_only:
            s_code, s_cpu, _, _, s_err = run(["simulate", str(path), "--t-final", f"{args.t_final:g}", "-o",
                                              "out.csv"], env, work, args.timeout)
            s_out, s_line = outcome(s_code, s_err)
            changed = source_digest() != digest
            if changed:
                moved.append(label)
            row += [s_out, f"{s_cpu:.1f}" + (" (source changed)" if changed else "")] + ([root_z(path, work / "out.csv", args.t_final)] if args.root_z else []) \
                + [short(s_line or b_line, [path.parent, work])]
        else:
            s_out = "-"
            row += ["-", "-"] + (["-"] if args.root_z else []) + [short(b_line, [path.parent, work])]
        counts.setdefault(group, []).append((b_out, s_out))
        rows.append(row)
        print(f"[{i}/{len(files)}] {group} {label}: build {b_out} ({cpu:.1f} s CPU), simulate {s_out}",
              flush=True)
        subprocess.run(["rm", "-rf", str(work)])
    header = ["set", "file", "build", "build CPU s", "build wall s", "RSS MB", "C kB",
              f"simulate {span}", "simulate CPU s"] + (["root z MuJoCo/eomc m (diff mm)"] if args.root_z else []) \
        + ["first warning / error"]
    summary = []
    for group, outs in counts.items():
        built = sum(b.startswith("ok") for b, _ in outs)
        ran = sum(s.startswith("ok") for _, s in outs)
        tb = sum("TRACEBACK" in (b + s) or "TIMEOUT" in (b + s) for b, s in outs)
        summary.append(f"- {group}: {len(outs)} files; built with {flags.strip() or 'no flags'} {built}; "
                       + ("" if float_only else f"simulated {span} with no flags {ran}; ")
                       + f"tracebacks or timeouts {tb}")
    text = "\n".join([
        environment_header(f"Every real model file, {'with ' + flags.strip() if flags else 'no flags'}: `eomc build FILE{flags}`"
                           + ("" if float_only else f" and `eomc simulate FILE --t-final {args.t_final:g}`"), args=True),
        f"- started {started}; 1-min load while it ran: min {min(loads):.1f}, median "
        f"{sorted(loads)[len(loads) // 2]:.1f}, max {max(loads):.1f} (2 shared cores: CPU, not wall, is the figure)",
        f"- each file in a fresh cache{'' if float_only else '; simulate reuses its build'}; a step's outcome: ok / ok with warnings "
        "(counted, the first quoted) / refused (exit != 0 with a message) / TRACEBACK / TIMEOUT "
        f"({args.timeout:.0f} s)",
        *([f"- **the compiler's source changed during the run** (rows marked \"source changed\": {', '.join(moved)}): "
           "their simulate CPU may count a new generation; run them again on a checkout nothing edits"]
          if moved else []), "",
        "## Summary", "", *summary, "",
        "## Per file", "", format_table(header, rows), ""])
    print(text)
    if not args.no_write:
        write_results(args.write_as, text, keep_notes=True)


if __name__ == "__main__":
    main()
