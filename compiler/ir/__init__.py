"""eomc.compiler.ir: the flat single-assignment program the passes transform."""
from .evaluate import evaluate
from .printer import format_program
from .program import IRError, Names, Program, c_names, free_inputs, needed_assignments, symbols_of
from .verify import verify

__all__ = ["Program", "Names", "IRError", "c_names", "free_inputs", "verify",
           "format_program", "evaluate", "symbols_of", "needed_assignments"]
from .nodes import IMul  # noqa: E402

__all__ += ["IMul"]
from .opcount import count_ops, count_program  # noqa: E402

__all__ += ["count_ops", "count_program"]
