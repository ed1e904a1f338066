"""Which instruction sets this CPU has, and which a model library's build flags assume.

Why: a model's library is built for the machine that builds it -- on x86-64 with AVX2 the
default flags add ``-mavx2 -ffp-contract=off`` (compiler/build/toolchain.py; and -fno-ipa-ra: the same
result bits, a faster rhs).  Such a library carried to a CPU without AVX2 (an exported
directory, a pickled model, a build cache shared between machines) would die of SIGILL at
its first call.  The loader asks :func:`missing_isa` first and refuses it with a message
instead, and a travelling model is recompiled without the flags the worker lacks.

Only the flags eomc itself adds are known here (a user's own ``--cflags='-march=native'``
is the user's choice, as before).  Where the CPU's features cannot be read (not Linux),
nothing is refused: eomc adds no such flag there either.
"""
import functools
import platform
import sys

__all__ = ["ISA_FLAGS", "cpu_features", "machine_lanes", "missing_isa"]

# compiler flag -> the /proc/cpuinfo feature the code it allows needs
ISA_FLAGS = {"-mavx2": "avx2"}


@functools.lru_cache(maxsize=None)
def cpu_features():
    """The feature words of this CPU (/proc/cpuinfo's first 'flags' line), or None when unknown."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[-1].split())
    except OSError:
        pass
    return None


def machine_lanes():
    """Doubles per SIMD register on this machine: 8 with AVX-512F, 4 with AVX2, else 2 (SSE2,
    NEON) -- the EOMC_BATCH_LANES a model's batch functions are built with here
    (compiler/build/builder.machine_lanes), and the rows an implicitfast rollout in lanes runs at
    once (runtime/rollout.py)."""
    if platform.machine().lower() not in ("x86_64", "amd64", "i386", "i686"):
        return 2
    words = cpu_features()
    if words is not None:
        return 8 if "avx512f" in words else 4 if "avx2" in words else 2
    return 4 if sys.platform == "darwin" else 2


def missing_isa(cflags):
    """The flags in ``cflags`` that assume an instruction set this CPU does not have."""
    features = cpu_features()
    if features is None:
        return []
    return [f for f in cflags or () if f in ISA_FLAGS and ISA_FLAGS[f] not in features]
