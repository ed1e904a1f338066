"""Compile a generated model into a cached shared library (and, optionally, a Cython module).

``build(generated)`` returns a :class:`BuildResult` whose ``directory`` holds
NAME.c, NAME.h, the shipped headers, libNAME.so and NAME.json (metadata plus
the cffi declarations and build facts) -- everything ``eomc.runtime.loader``
needs.  The library is NAME.c compiled together with the 25-line batch helper
eomc_batch.c.  The integrators are not in it: they are the same for every
model and were compiled once when eomc was installed (setup.py), so a new
model pays only for its own translation unit.
"""
import json
import platform
import shlex
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from eomc.runtime.header_cdef import C_DIR
from eomc.runtime.version import __version__

from .cache import CACHE_SCHEMA, cache_root, get_or_build, hash_key, sha256_file
from .cache_admin import auto_prune, max_size_from_env
from .stack import CALLGRAPH_FLAG, measure_stack, stack_header_block, supports_callgraph
from .toolchain import (DEFAULT_CFLAGS, ERRNO_FREE_FLAGS, ERRNO_FREE_UP_TO, find_compiler, machine_flags,
                        parallel_flags, portable_from_env, run_compiler)

__all__ = ["BuildResult", "build", "compile_jobs", "shipped_c_dir", "SHIPPED_HEADERS", "resolve_cflags"]

SHIPPED_HEADERS = ("eomc_model.h", "eomc_integrators.h", "eomc_batch.h")
MODEL_RUNTIME_SOURCES = ("eomc_batch.c",)  # compiled into every model library
BACKENDS = ("cffi", "cython")


@dataclass(frozen=True)
class BuildResult:
    name: str
    directory: Path      # cache entry (read-only): sources, headers, library, NAME.json
    library: Path
    key: str
    hit: bool            # True when served from the cache
    backend: str


def shipped_c_dir():
    """runtime/c: the ABI header, integrators and batch helper shipped with eomc."""
    return C_DIR


# Flags that let the compiler assume no NaN or infinity exists: it would then delete the
# model's non-finite checks (isfinite folds to true) and NaN would come back with status 0.
_FINITE_MATH = ("-ffast-math", "-Ofast", "-ffinite-math-only")
KEEP_NONFINITE_CHECKS = "-fno-finite-math-only"


def resolve_cflags(cflags):
    """Flags as a list: the defaults, or the user's (a string is split like a shell would).

    -fPIC is added when missing: a shared library cannot be linked without it.
    -fno-finite-math-only is added after -ffast-math, -Ofast or -ffinite-math-only
    (the rest of fast-math stays): the model's non-finite checks must keep working.
    """
    flags = list(DEFAULT_CFLAGS) if cflags is None else (
        shlex.split(cflags) if isinstance(cflags, str) else [str(f) for f in cflags])
    if not sys.platform.startswith("win") and "-fPIC" not in flags and "-fpic" not in flags:
        flags.append("-fPIC")
    last_finite = max((i for i, f in enumerate(flags) if f in _FINITE_MATH), default=-1)
    if last_finite >= 0 and KEEP_NONFINITE_CHECKS not in flags[last_finite:]:
        flags.append(KEEP_NONFINITE_CHECKS)
    return flags


def machine_lanes():
    """Doubles per SIMD register on this machine for NAME_rhs_batch: 8 with AVX-512F, 4 with
    AVX2, else 2 (SSE2, NEON).  The generated C is the same for all; the build picks the width
    by -DEOMC_BATCH_LANES, which a user's CFLAGS may set instead (and the C checks the CPU at
    run time, falling back to the scalar rhs).  On UR10 here (AMD EPYC), 8 lanes ran 4.75x the
    scalar rhs and 4 lanes 3.91x (benchmarks/results/rhs_batch.md)."""
    from eomc.runtime.cpu import machine_lanes as lanes
    return lanes()


def _link_flags():
    # -Bsymbolic: calls inside one model library bind to its own functions even
    # if another loaded library exports the same name.
    return ["-Wl,-Bsymbolic"] if sys.platform.startswith("linux") else []


def _base_inputs(tc, flags):
    return {"schema": CACHE_SCHEMA, "eomc_version": __version__, "platform": f"{sys.platform}-{platform.machine()}",
            "compiler": {"path": tc.path, "argv": list(tc.argv), "version": tc.version},
            "cflags": flags}


def _model_json(generated, key, backend, tc, flags, extra, extension=None, parallel=()):
    data = dict(generated.metadata)
    data.update(extra or {})
    data["cdef"] = generated.cdef
    data["build"] = {"library": f"lib{generated.name}.so", "backend": backend,
                     "compiler": tc.version, "cflags": flags, "key": key,
                     "extension": extension}
    if parallel:        # how the compile ran (toolchain.parallel_flags), not what it computes
        data["build"]["parallel"] = list(parallel)
    return json.dumps(data, indent=1, sort_keys=True)


def build(generated, *, backend="cffi", cflags=None, cache_dir=None, force=False, extra_metadata=None,
          hold_in=None, portable=False):
    """Build (or fetch from the cache) the library of ``generated``; see the module docstring.

    Without ``cflags``, a double (c99-f64) library is built for this machine's CPU: the
    defaults plus toolchain.MACHINE_FLAGS where the CPU has AVX2 (the same result bits,
    faster).  ``portable=True`` (or $EOMC_PORTABLE=1) keeps the plain defaults, for a library
    that is to run on other CPUs of the platform; the float target always keeps them.
    The loader refuses a library whose flags this CPU cannot run (runtime/cpu.py).

    ``extra_metadata`` (JSON-able) is merged into NAME.json, e.g. the model file's initial state.
    ``hold_in`` (a contextlib.ExitStack): keep the cache entry from being pruned until it closes.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    max_size_from_env()  # a bad $EOMC_CACHE_MAX_SIZE is an error before the compile, not after
    name = generated.name
    tc = find_compiler()
    flags = resolve_cflags(cflags)
    embedded = generated.metadata.get("target", "c99-f64") != "c99-f64"
    if cflags is None and not embedded and not portable and not portable_from_env():
        flags += [f for f in machine_flags(tc)
                  if len(generated.c_source) <= ERRNO_FREE_UP_TO or f not in ERRNO_FREE_FLAGS]
    if {"rhs_batch", "jac_x_batch", "outputs_batch", "implicit_batch"} & set(generated.metadata.get("functions", ())) and not any(
            f.startswith("-DEOMC_BATCH_LANES") for f in flags):
        flags.append(f"-DEOMC_BATCH_LANES={machine_lanes()}")   # the lanes of this machine
    if embedded and backend != "cffi":
        raise ValueError(f"model {name!r} is built for {generated.metadata['target']}: its Python "
                         f"module loads through cffi only (backend='cffi'); the Cython backend "
                         f"binds the double ABI")
    # Every target's worst-case stack is measured by the compile that builds the library (one
    # flag; it changes no generated code).  The c99-f64 key keeps the argv without the flag, so
    # the keys of double builds are what they were before the measurement existed.
    measured = supports_callgraph(tc)
    parallel = _parallel(generated, cflags, tc)
    root = cache_root(cache_dir)
    c_dir = shipped_c_dir()
    lib = f"lib{name}.so"
    tail = ["-shared", "-o", lib, f"{name}.c", *MODEL_RUNTIME_SOURCES, "-lm", *_link_flags()]
    link = [*tc.argv, *flags, *parallel, *([CALLGRAPH_FLAG] if measured else []), *tail]
    keyed = link if embedded else [*tc.argv, *flags, *tail]
    inputs = {**_base_inputs(tc, flags), "backend": backend,
              "argv": keyed[len(tc.argv):],
              "source": hash_key(generated.c_source), "header": hash_key(generated.header),
              "headers": {n: sha256_file(c_dir / n) for n in SHIPPED_HEADERS + MODEL_RUNTIME_SOURCES},
              "metadata": hash_key([generated.metadata, generated.cdef, extra_metadata])}
    if backend == "cython":
        from .cython_ext import extension_key_inputs
        inputs["cython"] = extension_key_inputs()
    key = hash_key(inputs)

    def compile_model(tmp):
        (tmp / f"{name}.c").write_text(generated.c_source)
        (tmp / f"{name}.h").write_text(generated.header)
        for n in SHIPPED_HEADERS + MODEL_RUNTIME_SOURCES:
            shutil.copyfile(c_dir / n, tmp / n)
        run_compiler(link, tmp, name, key, root)
        stack = _stack(tmp, generated, tc, measured)
        extension = None
        if backend == "cython":
            from .cython_ext import build_extension
            extension = build_extension(tmp, generated, tc, flags, key, root)
        (tmp / f"{name}.json").write_text(
            _model_json(generated, key, backend, tc, flags, {**(extra_metadata or {}), **(stack or {})},
                        extension, parallel))

    entry, hit = get_or_build(root, "models", key, compile_model, inputs, force=force, hold_in=hold_in)
    if not hit:
        auto_prune(root, keep=(key,))
    return BuildResult(name, entry, entry / lib, key, hit, backend)


def _parallel(generated, cflags, tc):
    """The flags that compile ``generated`` on several cores (toolchain.parallel_flags), or ().

    Only eomc's own double build: the user's cflags rule, and a float target is C for someone
    else's compiler.  The library's result bits are the one-unit build's, so the flag is in
    neither the cache key nor NAME.json's cflags (which a worker re-compiling a pickled model
    reuses): NAME.json's build.parallel records it."""
    if cflags is not None or generated.metadata.get("target", "c99-f64") != "c99-f64":
        return ()
    return parallel_flags(tc, len(generated.c_source))


def compile_jobs(generated, cflags=None):
    """How many compiler jobs :func:`build` runs for ``generated`` on a cache miss (1: one
    process), for the progress line."""
    flags = _parallel(generated, cflags, find_compiler())
    return int(flags[0].split("=", 1)[1]) if flags else 1


def _stack(tmp, generated, tc, measured):
    """The worst-case stack per function (every target): into NAME.h (#defines) and NAME.json.

    Measured from gcc's call-graph dump of this very compile (compiler/build/stack.py); the dump
    files are removed after.  With a compiler that has no dump, NAME.json says so instead.
    """
    name = generated.name
    if not measured:
        return {"stack": None, "stack_note": f"not measured: {tc.version} has no {CALLGRAPH_FLAG} "
                                             f"(gcc 10 or later does)"}
    functions = list(generated.metadata["functions"])
    if generated.metadata.get("target", "c99-f64") != "c99-f64" and "rhs" in functions:
        functions.append("step_rk4")   # the float target's generated integrator step
    stack = measure_stack(tmp, name, functions) or {}
    for path in list(tmp.glob("*.ci")) + list(tmp.glob("*.su")):
        path.unlink()
    header = tmp / f"{name}.h"
    text = header.read_text()
    anchor = "\n#ifdef __cplusplus\n}"
    at = text.rfind(anchor)
    header.write_text(text[:at] + "\n" + stack_header_block(name, stack, tc.version) + text[at:])
    return {"stack": stack}
