"""cffi declarations read from eomc's shipped C headers (templates/c/*.h).

The headers are the contract; reading the cffi declarations out of them
instead of keeping copies means the Python side cannot drift from the C side.
cffi's parser takes plain declarations and ``#define NAME <integer>`` lines,
so this drops include guards, ``#include`` lines and the C++ ``extern "C"``
wrapper and keeps the rest as written.
"""
import re
from functools import lru_cache
from pathlib import Path

import eomc.templates

__all__ = ["header_cdef"]

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
    """The declarations of templates/c/NAME (e.g. "eomc_model.h") as cffi cdef text."""
    path = Path(eomc.templates.__file__).resolve().parent / "c" / name
    return _strip(path.read_text())
