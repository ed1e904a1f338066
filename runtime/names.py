"""How a user's key names a model's state, parameter, input or output.

Why one module: dict arguments arrive keyed by strings (``"q1"``) or by the
SymPy objects the model was written with (``q1`` is ``q1(t)``; a Lagrange
speed is ``Derivative(q1(t), t)``), and every entry point must read them the
same way.  Only their text is used, so this never imports SymPy.
"""
import re

__all__ = ["model_name", "index_of"]

_DERIVATIVE = re.compile(r"^Derivative\((\w+)\(t\), (?:t|\(t, (\d+)\))\)$")


def model_name(key):
    """The model's name for ``key``: 'q1(t)' -> 'q1', 'Derivative(q1(t), t)' -> "q1'"."""
    text = str(key)
    m = _DERIVATIVE.match(text)
    if m:
        return m.group(1) + "'" * int(m.group(2) or 1)
    return text[:-3] if text.endswith("(t)") else text


def index_of(key, names, what, model):
    """Position of ``key`` in ``names``; a ValueError listing the valid names otherwise."""
    for candidate in (str(key), model_name(key)):
        if candidate in names:
            return names.index(candidate)
    raise ValueError(f"{model}: unknown {what} {model_name(key)!r}; "
                     f"valid names: {', '.join(names) or 'none'}")
