"""eomc.compiler.build: find a C compiler, compile generated models, cache the results.

See builder.build (one model -> cached library), cache (the content-addressed
store) and toolchain (compiler discovery and install hints).
"""
from .builder import BuildResult, build, compile_jobs, resolve_cflags, shipped_c_dir
from .cache import cache_root
from .toolchain import DEFAULT_CFLAGS, Toolchain, find_compiler

__all__ = ["BuildResult", "build", "compile_jobs", "resolve_cflags", "shipped_c_dir", "cache_root",
           "DEFAULT_CFLAGS", "Toolchain", "find_compiler"]
