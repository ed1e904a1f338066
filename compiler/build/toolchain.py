"""Find the system C compiler and describe it for the build cache.

Search order: ``$CC`` (which may carry arguments, e.g. ``ccache gcc``), then
``cc``, ``gcc`` and ``clang`` on ``PATH``.  The compiler's resolved path and
``--version`` text go into every cache key, so changing compilers never
serves a stale library.
"""
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass

from eomc.runtime.errors import CompileError, CompilerNotFoundError

from .cache import discard

__all__ = ["Toolchain", "find_compiler", "install_hint", "run_compiler", "DEFAULT_CFLAGS", "MACHINE_FLAGS", "GCC_MACHINE_FLAGS",
           "ERRNO_FREE_UP_TO", "ERRNO_FREE_FLAGS", "PARALLEL_FROM",
           "machine_flags", "build_jobs", "parallel_flags"]

DEFAULT_CFLAGS = ("-O2", "-fPIC", "-std=c99")
# Added to the defaults for double (c99-f64) libraries built on x86-64 with AVX2, unless portable
# (build(portable=True), `eomc build --portable`, EOMC_PORTABLE=1).  Why: the VEX encoding's
# three-operand instructions drop the register copies of two-operand SSE2 and shrink the code
# (G1's rhs + jac_x object 658 -> 542 kB), which is what large models' rhs time is made of.
# Measured (benchmarks/results/machine_flags.md): rhs 1.05-1.38x faster (UR10 ... Solo12).
# The result bits stay those of the portable -O2 build: AVX2 adds no fused multiply-add
# (that is -mfma, never added), and -ffp-contract=off keeps a compiler from contracting a*b+c
# (clang's default would).  Not -march=native: on an AVX-512 machine gcc 12's SLP vectorizer
# forms vfmaddsub even under -ffp-contract=off, and Talos' rhs changed by 7e-13 (measured).
MACHINE_FLAGS = ("-mavx2", "-ffp-contract=off")
# Added to MACHINE_FLAGS for gcc (clang rejects the option).  Why: with interprocedural register
# allocation gcc 12 left vzeroupper out of some functions that call a static one (the 3-link
# cart's jvp on every call, its jac_x on the failure return, after ldlt_factor/ldlt_solve), so
# they returned to the SSE-compiled runtime with the ymm upper halves dirty, which Intel CPUs
# make SSE code pay for.  -fno-ipa-ra lets the vzeroupper pass see the call as it is; the
# vectors stay 256-bit (-mprefer-vector-width=128 also cured it, but sensitivity runs, whose
# jvp carries four directions in one ymm, were 7-8 % slower; benchmarks/results/upper_state.md).
# tests/compiler/build/test_upper_state.py reads the state after every generated function.
# -fno-math-errno (gcc only here: measured with gcc 12): nothing reads errno (the generated C
# checks its results' finiteness), so sqrt, sin, cos are the same functions with the same bits and
# only their errno side effect goes: sqrt is the bare instruction (the ant's library had 502 libm
# calls for negative arguments, 49 kB) and gcc may share repeated calls.  -mmemset-strategy comes
# with it: alone, -fno-math-errno made gcc expand the ground slopes' zeroing of an out-of-touch
# point (18 doubles) as rep stosq, whose start-up cost made Go2's NAME_implicit 1.7x slower;
# vector stores up to 512 bytes, memset above, avoid rep stos everywhere.  The pair, measured
# (benchmarks/results/machine_flags.md, 2026-12-02): every function of the gym ant, humanoid,
# hopper, walker2d, Go2 and G1 bit-equal; Go2's NAME_implicit 13-17 % and G1's ~8 % faster, the
# rhs and jac_x equal; T2 (the gym four) equal within the copies' spread (ant -1.5 to -3.6 %).
GCC_MACHINE_FLAGS = ("-fno-ipa-ra", "-fno-math-errno", "-mmemset-strategy=vector_loop:512:noalign,libcall:-1:noalign")
# ... but not for a translation unit above ERRNO_FREE_UP_TO bytes of C: with sqrt, sin and cos pure,
# gcc 12 works on the huge straight-line functions much longer (dm_control's quadruped.xml, 8 MB
# of C, cc1 alone, core 0, session 36: 72 s user and 0.86 GB without the pair, 235 s and 1.39 GB
# with it -- its default build went from ~97 s to ~250 s CPU when the pair landed; same bits
# either way).  The sizes the pair was measured on (the gym four, Go2, G1) are all below 2.1 MB.
ERRNO_FREE_UP_TO = 2_500_000
ERRNO_FREE_FLAGS = GCC_MACHINE_FLAGS[1:]
# A translation unit from PARALLEL_FROM bytes of C is compiled by gcc's link-time optimiser, whose
# back end (the expensive part on eomc's long straight-line functions) runs as one job per partition
# of the functions, on as many cores as build_jobs() gives.  Measured (session 44, gcc 12, 2 cores,
# the cached C of each build, the same flags with and without -flto=2): dm_control's stacker (3.2 MB)
# 30.3 -> 20.8 s wall (27 partitions; 6.5 s of it the serial front end), gymnasium's humanoid with
# implicit (2.2 MB) 16.3 -> 10.5 s; below ~1 MB the serial front end and the partitions' own overhead
# eat the gain (ant, 0.9 MB: 4.70 -> 4.22 s wall for 4.56 -> 6.32 s CPU), hence the threshold.  Every
# generated function's result bits are those of the one-unit build (stacker: rhs, jac_x, outputs at
# 300 states; the humanoid: every function, 200 states; tests/compiler/build/test_parallel_build.py).
PARALLEL_FROM = 1_500_000
_MACHINE = {}  # (path, version) -> the machine flags this compiler accepts
_CANDIDATES = ("cc", "gcc", "clang")
_VERSIONS = {}  # (path, mtime) -> version text; a compiler is probed once per process


@dataclass(frozen=True)
class Toolchain:
    """A working C compiler: the argv prefix to run it, its path and version."""
    argv: tuple        # e.g. ("/usr/bin/gcc",) or ("/usr/bin/ccache", "gcc")
    path: str          # resolved path of argv[0]
    version: str       # first line of `CC --version`

    @property
    def is_clang(self):
        return "clang" in self.version.lower()


def install_hint():
    """How to install a C compiler on this platform, in one sentence."""
    if sys.platform == "darwin":
        return "install the Xcode command line tools with `xcode-select --install`"
    if sys.platform.startswith("win"):
        return "install a C compiler (e.g. MSYS2 gcc or clang) and put it on PATH, or set CC"
    return ("install one, e.g. `sudo apt-get install gcc` (Debian/Ubuntu), "
            "`sudo dnf install gcc` (Fedora) or `sudo apk add gcc musl-dev` (Alpine), "
            "or set CC to a C compiler")


def _probe(path):
    """`path --version`'s first line, or None when it does not run."""
    try:
        key = (path, os.stat(path).st_mtime_ns)
    except OSError:
        return None
    if key not in _VERSIONS:
        try:
            out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=30)
        except (OSError, subprocess.SubprocessError):
            return None
        text = (out.stdout or out.stderr).strip()
        _VERSIONS[key] = text.splitlines()[0] if out.returncode == 0 and text else None
    return _VERSIONS[key]


def _from_cc(cc, path_env):
    argv = shlex.split(cc)
    if not argv:
        return None
    # `ccache gcc`: the last word is the compiler that determines the output.
    real = shutil.which(argv[-1], path=path_env) if len(argv) > 1 else shutil.which(argv[0], path=path_env)
    first = shutil.which(argv[0], path=path_env)
    if first is None or real is None:
        raise CompilerNotFoundError(
            f"CC={cc!r} is not an executable C compiler; unset CC or point it at one. "
            f"To get a C compiler, {install_hint()}.")
    version = _probe(real)
    if version is None:
        raise CompilerNotFoundError(f"CC={cc!r} does not run (`{argv[-1]} --version` failed); "
                                    f"to get a working C compiler, {install_hint()}.")
    return Toolchain((first, *argv[1:]), os.path.realpath(real), version)


def find_compiler(env=None):
    """The C compiler to use; raises CompilerNotFoundError saying how to install one."""
    env = os.environ if env is None else env
    path_env = env.get("PATH", os.defpath)
    if env.get("CC"):
        return _from_cc(env["CC"], path_env)
    for name in _CANDIDATES:
        found = shutil.which(name, path=path_env)
        if found:
            version = _probe(found)
            if version is not None:
                return Toolchain((found,), os.path.realpath(found), version)
    raise CompilerNotFoundError(
        f"no C compiler found (looked for $CC, {', '.join(_CANDIDATES)} on PATH); "
        f"eomc compiles models to C, so {install_hint()}.")


def portable_from_env(env=None):
    """True when $EOMC_PORTABLE asks for libraries that run on any CPU of the platform."""
    value = (os.environ if env is None else env).get("EOMC_PORTABLE", "").strip().lower()
    return value not in ("", "0", "no", "false", "off")


def machine_flags(tc):
    """The flags (``MACHINE_FLAGS``, plus ``GCC_MACHINE_FLAGS`` with gcc, or none) that build libraries
    for this machine's CPU with ``tc``.

    Only on x86-64 whose CPU reports AVX2 (measured there; elsewhere the portable defaults
    stay), only with gcc or clang (by their --version line: another compiler's flags are not
    known), and only when the compiler accepts them (one probe compile per compiler and process).
    """
    from eomc.runtime.cpu import cpu_features
    if platform.machine().lower() not in ("x86_64", "amd64") or "avx2" not in (cpu_features() or ()):
        return ()
    if not (tc.is_clang or re.match(r"\S*(gcc|cc) \(", tc.version)):
        return ()
    flags = MACHINE_FLAGS if tc.is_clang else MACHINE_FLAGS + GCC_MACHINE_FLAGS
    probe = (tc.path, tc.version)
    if probe not in _MACHINE:
        with tempfile.TemporaryDirectory(prefix="eomc_probe_") as tmp:
            src = os.path.join(tmp, "probe.c")
            with open(src, "w") as fh:
                fh.write("double probe(double a, double b, double c) { return a * b + c; }\n")
            try:
                proc = subprocess.run([*tc.argv, *DEFAULT_CFLAGS, *flags, "-c", src, "-o",
                                       os.path.join(tmp, "probe.o")], capture_output=True, timeout=60)
                ok = proc.returncode == 0
            except (OSError, subprocess.SubprocessError):
                ok = False
        _MACHINE[probe] = flags if ok else ()
    return _MACHINE[probe]


def build_jobs(env=None):
    """How many compiler processes one build may run at once: $EOMC_BUILD_JOBS (a whole number
    >= 1), else the CPUs this process may use, at most 8."""
    env = os.environ if env is None else env
    value = env.get("EOMC_BUILD_JOBS", "").strip()
    if value:
        try:
            jobs = int(value)
        except ValueError:
            jobs = 0
        if jobs < 1:
            raise ValueError(f"EOMC_BUILD_JOBS={value!r}: give a whole number of compiler jobs >= 1 "
                             f"(1 compiles in one process)")
        return jobs
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(8, cpus))


def parallel_flags(tc, source_bytes, env=None):
    """``-flto=N`` when a translation unit of ``source_bytes`` is worth compiling on N > 1 cores
    (:data:`PARALLEL_FROM`) with ``tc``, else ().

    gcc only (clang's ThinLTO is another pipeline, not measured), and only where ``make`` is on
    PATH: gcc's lto-wrapper runs its parallel jobs through make and, without it, compiles the
    partitions one after another with a warning -- slower than no -flto at all.
    """
    if tc.is_clang or not re.match(r"\S*(gcc|cc) \(", tc.version) or source_bytes < PARALLEL_FROM:
        return ()
    jobs = build_jobs(env)
    path_env = (os.environ if env is None else env).get("PATH", os.defpath)
    if jobs < 2 or shutil.which("make", path=path_env) is None:
        return ()
    return (f"-flto={jobs}",)


def _end_group(proc, grace=2.0):
    """Stop the compiler and everything it started (cc1, as, ld): its whole process group."""
    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, None)):
        try:
            os.killpg(proc.pid, sig)
        except (ProcessLookupError, PermissionError):
            break
        try:
            proc.wait(timeout=wait)
            break
        except subprocess.TimeoutExpired:
            continue


def _run(argv, cwd):
    """Run ``argv`` in its own process group; if eomc is interrupted or terminated meanwhile
    (KeyboardInterrupt, or SIGTERM raised as an exception by the CLI), end the whole group.

    Without the group, a signal sent to eomc alone (``kill -INT <pid>`` from a job runner)
    killed the ``cc`` driver but left its ``cc1`` compiling on, re-parented to init.
    """
    if sys.platform.startswith("win"):  # pragma: no cover
        return subprocess.run(argv, cwd=cwd, capture_output=True, text=True)
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate()
    except BaseException:
        _end_group(proc)
        raise
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


def run_compiler(argv, cwd, name, key, root):
    """Run the compiler; on failure keep the sources under failed/ and raise CompileError."""
    try:
        proc = _run(argv, cwd)
    except OSError as exc:
        proc = subprocess.CompletedProcess(argv, 127, "", str(exc))
    if proc.returncode == 0:
        return proc
    kept = root / "failed" / f"{name}-{key[:12]}"
    discard(root, kept)
    try:
        kept.parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(cwd, kept)
        where = f"source kept in {kept}"
    except OSError as exc:  # e.g. the disk is full (which is often why the compile failed)
        discard(root, kept)
        why = exc.args[0][0][2] if isinstance(exc, shutil.Error) and exc.args and exc.args[0] else \
            (exc.strerror or exc)
        where = f"the source could not be kept ({why})"
    message = (proc.stderr or proc.stdout).strip()
    raise CompileError(f"the C compiler failed on model {name!r} (exit status {proc.returncode}); "
                       f"{where}\ncommand: {shlex.join(argv)}\n{message}")
