"""Frame outputs read back as arrays: position, rotation, velocity, Jacobian of a named frame.

A model built with ``frames=["tool0", "com"]`` (``--frame tool0``) has, among its outputs,
``tool0.p.x`` ... ``tool0.R[i][j]`` ... ``tool0.v.x`` ... ``tool0.w.x`` ... ``tool0.J[i][j]``
and ``com.p.x`` ... ``com.v.x`` ... (eomc.compiler.tree.frames says how they are computed:
world components, Pinocchio's LOCAL_WORLD_ALIGNED convention).  Each is an ordinary output
(CSV column, event function, ``res["tool0.p.z"]``); :class:`Frame` gathers one frame's
numbers into arrays, from one state (``model.frame("tool0", t, x)``) or along a run
(``res.frame("tool0")``).  The layout is read from the output names alone, so a built model
needs no metadata beyond its ``output_names``.
"""
from dataclasses import dataclass

import numpy as np

__all__ = ["Frame", "frame_names", "frame_indices", "frame_from_columns"]

_XYZ = ("x", "y", "z")


@dataclass(frozen=True)
class Frame:
    """One frame at one state (no leading axis) or along a run (n_t first).

    ``p`` (3,) origin, ``R`` (3, 3) rotation (columns: the frame's axes), ``v`` (3,) velocity
    of the origin, ``w`` (3,) angular velocity, ``J`` (6, nu) with (v; w) = J u -- all in world
    components.  The centre of mass (``com``) has ``p`` and ``v`` only (the others None)."""
    name: str
    p: np.ndarray
    v: np.ndarray
    R: np.ndarray = None
    w: np.ndarray = None
    J: np.ndarray = None

    @property
    def twist(self):
        """(v; w), 6 components: Pinocchio's ``getFrameVelocity(..., LOCAL_WORLD_ALIGNED)``."""
        if self.w is None:
            raise AttributeError(f"{self.name} is the centre of mass: it has a velocity, no twist")
        return np.concatenate([self.v, self.w], axis=-1)

    @property
    def T(self):
        """The 4x4 homogeneous pose [[R, p], [0, 1]] (a frame, not the centre of mass)."""
        if self.R is None:
            raise AttributeError(f"{self.name} is the centre of mass: it has a position, no pose")
        lead = self.p.shape[:-1]
        out = np.zeros(lead + (4, 4))
        out[..., :3, :3], out[..., :3, 3], out[..., 3, 3] = self.R, self.p, 1.0
        return out


def frame_names(output_names):
    """Names of the frames (and ``com``) among ``output_names``, in output order."""
    out = []
    for n in output_names:
        if n.endswith(".p.x"):
            out.append(n[:-4])
    names = set(output_names)
    return tuple(f for f in out if f"{f}.v.z" in names)


def frame_indices(output_names, name):
    """{part: index array} of frame ``name`` in ``output_names`` (parts p, v, and R, w, J for a
    frame); KeyError naming the frames there are when ``name`` is not one of them."""
    index = {n: i for i, n in enumerate(output_names)}
    if f"{name}.p.x" not in index or f"{name}.v.z" not in index:
        known = frame_names(output_names)
        if not known:
            raise KeyError(f"{name!r}: this model has no frame outputs; build it with frames=[{name!r}] "
                           f"(eomc build --frame {name})")
        raise KeyError(f"{name!r} is no frame output of this model; frames: {', '.join(known)}")
    out = {"p": [index[f"{name}.p.{a}"] for a in _XYZ], "v": [index[f"{name}.v.{a}"] for a in _XYZ]}
    if f"{name}.R[0][0]" in index:
        out["R"] = [index[f"{name}.R[{i}][{j}]"] for i in range(3) for j in range(3)]
        out["w"] = [index[f"{name}.w.{a}"] for a in _XYZ]
        nu = 0
        while f"{name}.J[0][{nu}]" in index:
            nu += 1
        out["J"] = [index[f"{name}.J[{i}][{j}]"] for i in range(6) for j in range(nu)]
        out["nu"] = nu
    return out


def frame_from_columns(output_names, values, name):
    """The :class:`Frame` ``name`` from output ``values`` (..., noutput) in ``output_names`` order."""
    parts = frame_indices(output_names, name)
    values = np.asarray(values, dtype=float)
    lead = values.shape[:-1]
    take = lambda key: values[..., parts[key]]      # noqa: E731
    if "R" not in parts:
        return Frame(name, take("p"), take("v"))
    return Frame(name, take("p"), take("v"), take("R").reshape(lead + (3, 3)), take("w"),
                 take("J").reshape(lead + (6, parts["nu"])))
