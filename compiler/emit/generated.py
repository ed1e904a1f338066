"""What the C generator hands to the build step."""
from dataclasses import dataclass

__all__ = ["GeneratedModel"]


@dataclass(frozen=True)
class GeneratedModel:
    name: str
    c_source: str       # NAME.c (includes "NAME.h")
    header: str         # NAME.h (includes "eomc_model.h")
    cdef: str           # cffi declarations of NAME_* (needs the eomc_model type declared)
    metadata: dict      # JSON-able; keys listed in the team's pipeline interfaces
