"""Build step that pyproject.toml cannot express: eomc's integrators in C.

The integrators (runtime/c/eomc_integrators.c) are the same for every model,
so they are compiled once, when eomc is installed, into a plain shared library
inside eomc.runtime.  A model's own library then holds only its equations,
which keeps a cold model build to one small C compile.  The library has no
Python entry point: eomc.runtime opens it with cffi (ffi.dlopen), like a model.

eomc.runtime._fastcall (runtime/_fastcall.pyx) is one Cython extension, also
built once here, that calls ANY model through its eomc_model struct, so the
default (cffi) backend gets a compiled per-call path without a per-model build.
"""
import numpy
from Cython.Build import cythonize
from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "eomc.runtime._eomc_integrators",
            sources=["runtime/c/eomc_integrators.c", "runtime/c/eomc_fixedstep.c", "runtime/c/eomc_fixedstep_avx2.c",
                     "runtime/c/eomc_bdf.c",
                     "runtime/c/eomc_sensitivity.c", "runtime/c/eomc_rollout.c",
                     "runtime/c/eomc_adjoint.c", "runtime/c/eomc_rows.c"],
            include_dirs=["runtime/c"],
            # Aligned functions and loops: otherwise the hot loops' speed depends on where
            # they happen to land (+-5% on a DOP853 run from edits elsewhere in the file;
            # benchmarks/results/events.md).
            extra_compile_args=["-O2", "-std=c99", "-pthread", "-falign-functions=64", "-falign-loops=32"],
            libraries=["m", "pthread"],
            extra_link_args=["-pthread"],
        )
    ] + cythonize(
        [
            Extension(
                "eomc.runtime._fastcall",
                sources=["runtime/_fastcall.pyx"],
                include_dirs=["runtime/c", numpy.get_include()],
                define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
                extra_compile_args=["-O2"],
            )
        ],
        compiler_directives={"language_level": "3"},
        build_dir="build/cython",  # generated C stays out of the package (its "*.c" data glob)
        quiet=True,
    )
)
