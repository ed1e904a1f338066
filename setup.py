"""Build step that pyproject.toml cannot express: eomc's integrators in C.

The integrators (templates/c/eomc_integrators.c) are the same for every model,
so they are compiled once, when eomc is installed, into a plain shared library
inside eomc.runtime.  A model's own library then holds only its equations,
which keeps a cold model build to one small C compile.  The library has no
Python entry point: eomc.runtime opens it with cffi (ffi.dlopen), like a model.
"""
from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "eomc.runtime._eomc_integrators",
            sources=["templates/c/eomc_integrators.c"],
            include_dirs=["templates/c"],
            extra_compile_args=["-O2", "-std=c99"],
            libraries=["m"],
        )
    ]
)
