"""How a user's key names a model's state, parameter, input or output.

Why one module: dict arguments arrive keyed by strings (``"q1"``) or by the
SymPy objects the model was written with (``q1`` is ``q1(t)``; a Lagrange
speed is ``Derivative(q1(t), t)``), and every entry point must read them the
same way.  Only their text is used, so this never imports SymPy.
"""
import re

__all__ = ["model_name", "index_of", "euler_hint"]

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
    raise ValueError(f"{model}: unknown {what} {model_name(key)!r}{euler_hint([model_name(key)], names)}; "
                     f"valid names: {', '.join(names) or 'none'}")


_EULER = re.compile(r"^q_(.+)_r([xyz])$")


def euler_hint(unknown, names):
    """A sentence for unknown state names that are the body-XYZ angles of a joint the model holds
    as a quaternion (q_root_rx where there is q_root_qw): MJCF free and ball joints became
    quaternions by default in session 30, so a script or --x0 written for the Euler build names
    angles that are no longer there; '' when none is."""
    hit = [u for u in unknown if (m := _EULER.match(str(u))) and f"q_{m.group(1)}_qw" in names]
    if not hit:
        return ""
    joint = _EULER.match(str(hit[0])).group(1)
    return (f" ({', '.join(hit)}: a body-XYZ angle; MJCF free and ball joints are quaternions by default, "
            f"q_{joint}_qw, q_{joint}_qx, q_{joint}_qy, q_{joint}_qz (w first, upright 1, 0, 0, 0): give "
            f"those, or build with orientation=\"euler\" (--orientation euler) for the angles)")
