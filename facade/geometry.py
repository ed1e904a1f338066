"""Shapes for a model file's ``geometry`` dict: how bodies and points look in an animation.

    from eomc.geometry import sphere, box, cylinder, mesh
    geometry = {B: box(0.1, 0.02, 1.0, color="red"), P2: sphere(0.05), A: mesh("link.stl")}

Keys are bodies or points of the model (the objects, or their names); a value
is one shape or a list of them.  ``at`` places a shape in the body frame: a
3-vector offset or a 4x4 transform.  Without a ``geometry`` dict every body
still shows (a sphere at each particle and mass centre, a line from each joint
point to the next body's points, small axes per body frame).
"""
from pathlib import Path

import numpy as np

from eomc.runtime.geometry import shape

__all__ = ["sphere", "box", "cylinder", "mesh", "Shape"]

_COLORS = {"red": (0.85, 0.2, 0.15), "green": (0.2, 0.65, 0.25), "blue": (0.2, 0.4, 0.85),
           "orange": (0.95, 0.55, 0.1), "gray": (0.6, 0.6, 0.6), "grey": (0.6, 0.6, 0.6),
           "black": (0.1, 0.1, 0.1), "white": (0.95, 0.95, 0.95), "yellow": (0.95, 0.85, 0.2),
           "purple": (0.55, 0.3, 0.75)}


class Shape:
    """One shape (use the functions below); ``as_dict()`` is what NAME.json stores."""

    def __init__(self, kind, size=(), *, path=None, scale=None, at=None, color=None):
        self._dict = shape(kind, size, path=path, scale=scale, origin=_origin(at), color=_color(color))

    def as_dict(self):
        return dict(self._dict)

    def __repr__(self):
        return f"{self._dict['kind']}({', '.join(map(str, self._dict['size']))})"


def _origin(at):
    if at is None:
        return None
    a = np.asarray(at, dtype=float)
    if a.shape == (3,):
        T = np.eye(4)
        T[:3, 3] = a
        return T
    if a.shape == (4, 4):
        return a
    raise ValueError(f"at= must be a 3-vector offset or a 4x4 transform, not shape {a.shape}")


def _color(color):
    if color is None:
        return None
    if isinstance(color, str):
        if color.startswith("#") and len(color) == 7:
            return tuple(int(color[i:i + 2], 16) / 255 for i in (1, 3, 5))
        if color not in _COLORS:
            raise ValueError(f"unknown colour {color!r}; use #rrggbb, an (r, g, b) tuple in 0..1 or "
                             f"one of {', '.join(sorted(_COLORS))}")
        return _COLORS[color]
    rgb = tuple(float(c) for c in color)
    if len(rgb) != 3 or any(not 0 <= c <= 1 for c in rgb):
        raise ValueError(f"a colour tuple is (r, g, b) in 0..1, not {color!r}")
    return rgb


def sphere(r, *, at=None, color=None):
    """A sphere of radius ``r``."""
    return Shape("sphere", (r,), at=at, color=color)


def box(a, b, c, *, at=None, color=None):
    """A box of edges ``a``, ``b``, ``c`` along the body's x, y, z, centred on its origin."""
    return Shape("box", (a, b, c), at=at, color=color)


def cylinder(r, h, *, at=None, color=None):
    """A cylinder of radius ``r`` and length ``h`` along the body's z (as URDF), centred."""
    return Shape("cylinder", (r, h), at=at, color=color)


def mesh(path, *, scale=1.0, at=None, color=None):
    """A triangle mesh file (STL, OBJ, DAE, ... read with trimesh when a page is written).

    A relative path is relative to the file that calls ``mesh`` (the model file), not to
    the directory eomc happens to run in."""
    import sys
    path = Path(path).expanduser()
    if not path.is_absolute():
        caller = sys._getframe(1).f_globals.get("__file__")
        path = (Path(caller).resolve().parent if caller else Path.cwd()) / path
    return Shape("mesh", path=path.resolve(), scale=scale, at=at, color=color)
