"""cffi declarations read from eomc's shipped C headers (runtime/c/*.h).

The headers are the contract; reading the cffi declarations out of them
instead of keeping copies means the Python side cannot drift from the C side.
cffi's parser takes plain declarations and ``#define NAME <integer>`` lines,
so this drops include guards, ``#include`` lines and the C++ ``extern "C"``
wrapper and keeps the rest as written.
"""
import re
from functools import lru_cache
from pathlib import Path


__all__ = ["C_DIR", "header_cdef"]

# The plain C shipped with eomc: the model ABI header, the integrators (compiled
# once at install) and the batch helper (compiled into every model library).
C_DIR = Path(__file__).resolve().parent / "c"

_INTEGER_DEFINE = re.compile(r"#\s*define\s+\w+\s+-?\d+\s*$")


def _strip(text):
    out, in_cplusplus = [], False
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#ifdef __cplusplus"):
            in_cplusplus = True
        elif in_cplusplus:
            in_cplusplus = not stripped.startswith("#endif")
        elif not stripped.startswith("#") or _INTEGER_DEFINE.match(stripped):
            out.append(line)
    return "\n".join(out) + "\n"


@lru_cache(maxsize=None)
def header_cdef(name):
    """The declarations of runtime/c/NAME (e.g. "eomc_model.h") as cffi cdef text."""
    path = C_DIR / name
    return _strip(path.read_text())
