"""Shared plumbing for the benchmark scripts: timing, tables, results files, CLI.

The machine these run on is shared and noisy, so every figure is the median
of several repeats (with the interquartile range beside it), and every ratio
compares tools measured in the same run.  Results files carry a header with
the date, the machine and the library versions, because a number without
them cannot be compared with anything later.
"""
import argparse
import datetime
import math
import os
import platform
import statistics
import sys
import time
from importlib import metadata as importlib_metadata
from pathlib import Path

__all__ = [
    "RESULTS_DIR", "Timing", "time_calls", "time_once", "median_iqr",
    "format_table", "environment_header", "write_results", "parse_args", "pin_to_one_core",
    "fmt", "ratio", "C_CLOCK_AND_RNG",
]

RESULTS_DIR = Path(__file__).resolve().parent / "results"

# The C harnesses' thread-CPU clock (ns) and a splitmix64 uniform in [0, 1): one copy, pasted
# into each harness, so every benchmark draws its random states and reads its clock alike.
C_CLOCK_AND_RNG = r"""static double tnow(void) { struct timespec ts; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec; }
static unsigned long long s = 0x9E3779B97F4A7C15ULL;
static double rnd(void) { unsigned long long z = (s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL; z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31; return (z >> 11) * (1.0 / 9007199254740992.0); }
"""

_VERSIONED = ["numpy", "scipy", "sympy", "cffi", "Cython", "pydy", "symengine",
              "pin", "matplotlib", "eomc"]


class Timing:
    """Median and interquartile range of repeated measurements (seconds)."""

    def __init__(self, samples):
        self.samples = sorted(samples)
        self.median, self.q1, self.q3 = median_iqr(self.samples)

    @property
    def iqr(self):
        return self.q3 - self.q1

    def __repr__(self):
        return f"Timing(median={self.median:.3g}, iqr={self.iqr:.3g}, n={len(self.samples)})"


def median_iqr(samples):
    """(median, first quartile, third quartile); quartiles collapse for < 4 samples."""
    samples = sorted(samples)
    med = statistics.median(samples)
    if len(samples) < 4:
        return med, samples[0], samples[-1]
    q = statistics.quantiles(samples, n=4)
    return med, q[0], q[2]


def time_once(func, *args, **kwargs):
    """(seconds, result) of one call: for things that are slow or have side effects."""
    t0 = time.perf_counter()
    result = func(*args, **kwargs)
    return time.perf_counter() - t0, result


def time_calls(func, number, repeat):
    """Per-call seconds of ``func()`` as a Timing over `repeat` blocks of `number` calls.

    One warm-up block runs first so that caches, lazy imports and allocator
    pools do not land in the first sample.
    """
    for _ in range(max(1, number // 10)):
        func()
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            func()
        samples.append((time.perf_counter() - t0) / number)
    return Timing(samples)


def thread_cpu_per_call(call, n):
    """Thread CPU seconds per call of ``call()`` over n calls, after one warm-up call: what the
    interleaved-rounds benchmarks sample (thread time, so other processes on the core do not count)."""
    call()
    t0 = time.thread_time()
    for _ in range(n):
        call()
    return (time.thread_time() - t0) / n


def pin_to_one_core():
    """Run this process on one core (the last one) so contestants share a core and its caches;
    returns the core's number, or None where affinity cannot be set."""
    try:
        core = max(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {core})
        return core
    except (AttributeError, OSError):
        return None


def fmt(value, digits=3):
    """A number for a table: None means the tool is not available."""
    if value is None:
        return "n/a"
    if isinstance(value, str):
        return value
    if isinstance(value, int):
        return str(value)
    if value == 0:
        return "0"
    return f"{value:.{digits}g}"


def ratio(slow, fast):
    """slow/fast as a printable ratio, or None when either side is missing."""
    if slow is None or fast is None or fast == 0:
        return None
    return slow / fast


def format_table(headers, rows):
    """A GitHub-flavoured Markdown table (also readable in a terminal)."""
    cells = [[fmt(c) for c in row] for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h)
              for i, h in enumerate(headers)]
    line = lambda items: "| " + " | ".join(s.rjust(w) for s, w in zip(items, widths)) + " |"
    out = [line(headers), "|" + "|".join("-" * (w + 1) + ":" for w in widths) + "|"]
    out.extend(line(r) for r in cells)
    return "\n".join(out)


def _version(dist):
    try:
        return importlib_metadata.version(dist)
    except importlib_metadata.PackageNotFoundError:
        return "not installed"


def _cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _compiler_version():
    import shutil
    import subprocess
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        return "none found"
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=10)
        return out.stdout.splitlines()[0]
    except (OSError, subprocess.SubprocessError, IndexError):
        return cc


def _loadavg():
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "unknown"


def _git_commit():
    import subprocess
    root = Path(__file__).resolve().parent.parent
    try:
        out = subprocess.run(["git", "-C", str(root), "log", "-1", "--format=%h %s"],
                             capture_output=True, text=True, timeout=10)
        return out.stdout.strip()[:100] or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def environment_header(title, args=None, notes=()):
    """Markdown header recording when, where and with what a result was measured."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    versions = ", ".join(f"{d} {_version(d)}" for d in _VERSIONED)
    blas = {k: os.environ.get(k, "(unset)") for k in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE",
                                                     "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    lines = [
        f"# {title}", "",
        f"- date: {now}",
        f"- machine: {os.cpu_count()} CPUs (nproc), {_cpu_model()}, {platform.system()} {platform.release()}",
        "- note: the machine is shared with other jobs while this ran; figures are medians of repeats",
        f"- load average (1/5/15 min) at start of write-up: {_loadavg()}",
        f"- python {platform.python_version()}; C compiler: {_compiler_version()}",
        f"- versions: {versions}",
        f"- eomc checkout: {_git_commit()}",
        "- environment: " + ", ".join(f"{k}={v}" for k, v in blas.items()),
    ]
    if args is not None:
        lines.append(f"- command: `python3 {' '.join(sys.argv)}`")
    lines.extend(f"- {n}" for n in notes)
    lines.append("")
    return "\n".join(lines)


NOTES_HEADING = "## Hand-written notes (kept when the script rewrites this file)"


def kept_notes(path):
    """The hand-written part of a results file: from its NOTES_HEADING line to the end ("" when
    it has none).  Why: a script that rewrites its .md whole erased the notes written under its
    table by hand (analyses, before/after comparisons) on every re-run."""
    if not path.is_file():
        return ""
    lines = path.read_text().splitlines(keepends=True)
    for k, line in enumerate(lines):
        if line.rstrip("\n") == NOTES_HEADING:
            return "".join(lines[k:])
    return ""


def write_results(name, text, csv_rows=None, csv_headers=None, keep_notes=False):
    """Write benchmarks/results/<name>.md (and .csv when rows are given); return the paths.

    ``keep_notes``: the old file's hand-written section (:func:`kept_notes`) is appended to
    the new text, so re-running the script keeps it."""
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    md = RESULTS_DIR / f"{name}.md"
    text = text if text.endswith("\n") else text + "\n"
    notes = kept_notes(md) if keep_notes else ""
    md.write_text(text + ("\n" + notes if notes else ""))
    paths = [md]
    if csv_rows is not None:
        import csv
        path = RESULTS_DIR / f"{name}.csv"
        with path.open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(csv_headers)
            for row in csv_rows:
                writer.writerow(["" if v is None else v for v in row])
        paths.append(path)
    return paths


def publish(name, title, parts, argv):
    """A results file's usual shape: the environment header, then ``parts`` (tables, notes) one
    after another with a blank line between; printed, and written to results/<name>.md (its
    hand-written notes kept) unless ``--no-write`` is in ``argv``.  Returns the text."""
    text = "\n\n".join([environment_header(title), *parts])
    print(text)
    if "--no-write" not in argv:
        write_results(name, text, keep_notes=True)
    return text


def parse_args(description, default_n, default_repeat=5, argv=None, extra=None):
    """The CLI every benchmark shares: --quick, --n LIST, --repeat, --no-write."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true",
                        help="small sizes and few repeats: a smoke run, not a result")
    parser.add_argument("--n", type=lambda s: [int(v) for v in s.split(",") if v],
                        default=None, help="comma-separated link counts, e.g. 4,8,12")
    parser.add_argument("--repeat", type=int, default=None, help="repeats per measurement")
    parser.add_argument("--no-write", action="store_true",
                        help="print the table but do not overwrite benchmarks/results/")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    if args.n is None:
        args.n = default_n[:2] if args.quick else list(default_n)
    if args.repeat is None:
        args.repeat = 2 if args.quick else default_repeat
    if args.quick:
        args.no_write = True
    return args


def work_precision_figure(panels, path, panel_width=6.5, xlabel="wall time [s] (median)"):
    """Write a work-precision PNG: panels is [(title, {tool: [(wall_s, error), ...]})], one per axes.

    Log-log, one line per tool, lower-left is better; errors are floored at 1e-16 so a
    perfect point still shows.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogFormatterSciNotation

    class TwoFive(LogFormatterSciNotation):
        """A log axis's minor ticks labelled at 2 and 5 times a power of ten only: on a narrow panel
        matplotlib labels 2, 3, 4 and 6 as well when the axis spans under a decade, and they overlap
        (fixedstep_wp.png, session 49)."""
        def __call__(self, x, pos=None):
            if x > 0 and round(x / 10.0 ** math.floor(math.log10(x)), 6) not in (1.0, 2.0, 5.0):
                return ""
            return super().__call__(x, pos)
    fig, axes = plt.subplots(1, len(panels), figsize=(panel_width * len(panels), 4.8), squeeze=False)
    for ax, (title, series) in zip(axes[0], panels):
        for name, pts in series.items():
            pts = sorted(pts)
            ax.loglog([a for a, _ in pts], [max(b, 1e-16) for _, b in pts], "o-", label=name)
        ax.set_title(title)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("final-state error (max norm)")
        ax.grid(True, which="both", alpha=0.3)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_formatter(TwoFive(labelOnlyBase=False, minor_thresholds=(1, 0.4)))
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def robots_dir():
    """example-robot-data's robots folder, wherever its wheel is installed (a venv, CI's fresh one):
    the benchmarks' URDF robots come from there, never from a path of one machine."""
    return Path(importlib_metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))


def compile_pinocchio(source, obj, extra_includes=(), flags=()):
    """Compile a C++ harness ``source`` against Pinocchio header-only (the `pin` and
    `cmeel-eigen` wheels' headers) into ``obj``, with g++ -O2 and ``flags`` (e.g. -mavx2, to
    match the eomc build it is timed against); returns ``obj``, or None (with the
    compiler's message printed) when the wheels are missing or it does not compile."""
    import subprocess
    try:
        import pinocchio  # noqa: F401
        import cmeel
    except ImportError:
        return None
    inc = Path(cmeel.__file__).resolve().parents[1] / "cmeel.prefix" / "include"
    defs = ["-DBOOST_MPL_LIMIT_LIST_SIZE=30", "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
            "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "-DBOOST_FUSION_INVOKE_MAX_ARITY=12"]
    includes = [f"-I{d}" for d in extra_includes] + [f"-I{inc}", f"-I{inc / 'eigen3'}"]
    proc = subprocess.run(["g++", "-O2", *flags, "-std=c++17", *defs, "-DNDEBUG", "-c", str(source),
                           "-o", str(obj), *includes], capture_output=True, text=True)
    if proc.returncode:
        print(f"Pinocchio harness {Path(source).name} did not compile:", proc.stderr[-500:])
        return None
    return obj


def cold_build(model, n, formulation, outdir, outputs, pythonpath=None, prelude=None):
    """`eomc build` of an EOMC_N_LINKS model file in a fresh child process and a fresh cache:
    (CPU s of the child, wall s, the built NAME.json, peak RSS MB of children so far).
    ``prelude``: Python statements the child runs before the command line (a compiler
    setting changed for an A/B, say)."""
    import json
    import resource
    import subprocess
    import tempfile
    env = dict(os.environ, EOMC_N_LINKS=str(n), EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_cb_"))
    if pythonpath:
        env["PYTHONPATH"] = str(pythonpath)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    launch = ([sys.executable, "-m", "eomc"] if prelude is None else
              [sys.executable, "-c", prelude + "\nimport sys\nfrom eomc.cli import main\nsys.exit(main(sys.argv[1:]))"])
    proc = subprocess.run([*launch, "build", str(model), "-o", str(outdir),
                           "--fold-parameters", "--outputs", outputs, "--formulation", formulation,
                           "-q"], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode:
        raise RuntimeError(proc.stderr)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    meta = json.loads(next(p for p in Path(outdir).glob("*.json")
                           if not p.name.startswith(".")).read_text())
    return cpu, wall, meta, after.ru_maxrss / 1024


def peer_versions(modules):
    """'mujoco 4.0.0', 'pinocchio not installed', ... for a results file's notes."""
    out = []
    for mod in modules:
        try:
            out.append(f"{mod} {__import__(mod).__version__}")
        except ImportError:
            out.append(f"{mod} not installed")
    return out
