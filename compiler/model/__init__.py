"""eomc.compiler.model: load model files and check them (errors point at the user's file:line)."""
from .modelfile import assignment_lines, run_model_file
from .spec import ModelSpec, formed_system, model_spec

__all__ = ["ModelSpec", "model_spec", "formed_system", "run_model_file", "assignment_lines"]
