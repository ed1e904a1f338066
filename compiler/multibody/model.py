"""The multibody model: what a reader (URDF, MJCF, a SymPy System or KanesMethod) found.

Why a record of its own: everything after the reader -- frame outputs, the animation's
poses, the recursive formulation, Kane's formulation for a robot file, extra states --
needs to know what the robot *is*, and before this record existed each went back to the
file for it (a two-joint URDF arm was parsed eight times by one default build) or read
it off private attributes stuck on Kane's record, which a copy could drop (an extra
state lost a URDF robot's poses and its welded links).  A reader fills one
:class:`Model`; nothing after it opens a file.

The record is formulation-neutral: it carries the joint tree (eomc.compiler.tree.model,
the recursive formulation's input), the state's variables in the order the generated C
uses (the names a :class:`~eomc.compiler.mechanics.formed.FormedSystem` gives them, so
the model checks read either), the named frames, the animation's poses and shapes, the
parameter defaults and joint inputs the file declares, where it came from, and -- for
robot files -- how to build the SymPy System Kane's formulation forms, from what was
read.  Joint laws (limits, damping, friction), armature, contacts and loop closures
are in the tree (its loads, ``TreeBody.armature``, ``Tree.loops``).
"""
from dataclasses import dataclass, field
from typing import Callable, Mapping, Optional, Tuple

import sympy as sm
import sympy.physics.mechanics   # noqa: F401 -- the System type named below

from ..emit.poses import PoseSource
from ..mechanics.formed import StateSizes
from ..tree.model import Tree

__all__ = ["Model", "Frame", "Collision", "Provenance", "merged_defaults", "merged_initial_state"]


@dataclass(frozen=True)
class Provenance:
    """Where a model came from: its format ("urdf", "mjcf", "system") and file:line."""
    format: str
    path: Optional[str] = None
    line: Optional[int] = None

    def __str__(self):
        return f"{self.path}:{self.line}" if self.line else (self.path or f"a {self.format} model")


@dataclass(frozen=True)
class Frame:
    """A named frame fixed to tree body ``body`` (-1: the ground): every URDF link (welded
    ones included), every MuJoCo body, every body of a System's tree.

    ``rotation``: 3x3 numbers, the frame's axes in body components; ``offset``: 3
    expressions (the body's mass-centre parameters where the tree has them), the frame's
    origin from the body's origin in body components.  ``aliases``: other names it answers
    to (a link's C identifier, a MuJoCo body's sanitized name)."""
    name: str
    body: int
    rotation: tuple
    offset: tuple
    aliases: tuple = ()


@dataclass(frozen=True)
class Collision:
    """A collision shape as the file wrote it, on frame ``frame`` (a URDF link): ``origin``,
    its 4x4 placement in the frame's axes (rows); ``geometry``, the shape's tag ("box",
    "cylinder", "sphere", "capsule", "mesh", or whatever the file has) and ``attributes``, its
    attributes as written ((name, text) pairs: sizes are read, and refused with this record's
    line, only when a contact uses them -- a robot that never touches the ground does not
    fail on a collision shape it never uses); ``line``/``geometry_line``: the element's and
    the shape's lines in the file."""
    frame: str
    origin: tuple
    geometry: Optional[str]
    attributes: tuple = ()
    line: Optional[int] = None
    geometry_line: Optional[int] = None

    def attribute(self, name):
        return dict(self.attributes).get(name)


@dataclass(frozen=True)
class Model(StateSizes):
    """One multibody model as read (see the module docstring).

    ``coordinates`` ... ``extra_rhs``: x = [q; u; z] and q' as the generated C orders them,
    named as in FormedSystem (nothing is formed: there is no A or b, and no ``method`` that
    formed them: ``isinstance(record, Model)`` tells a model as read from formed equations).  ``frames``: the
    frames ``frames=["tool0"]`` may name.  ``poses``: the animation's bodies along the tree
    (a :class:`~eomc.compiler.emit.poses.PoseSource`), ``shapes``: {body or "world":
    [eomc.geometry shape dicts]} and ``welds``: {link: (body or "world", 4x4)}, the links
    welded to a body, when the reader was asked for poses.  ``collisions``: the file's
    collision geometry (:class:`Collision`), what ground contacts are made from.  ``defaults``/``joint_inputs``:
    the file's parameter values and its joints' torques in joint order; ``outputs``/
    ``events``: those the reader defines (contact depths).  ``initial_state``: {coordinate
    name: value} the file starts from.  ``mechanics``: builds the SymPy System Kane's
    formulation forms, from what was read (None: the format has none, e.g. MJCF).
    ``refusal``: why the recursive formulation does not take it (a URDF's mimic joints
    under mimic=True), or None; ``kane_refusal``: why Kane's cannot, or None."""
    tree: Tree
    coordinates: tuple
    speeds: tuple
    kinematics: sm.Matrix
    inputs: tuple
    parameters: tuple
    source: Provenance
    n_dependent_coordinates: int = 0
    n_dependent_speeds: int = 0
    holonomic_constraints: sm.Matrix = field(default_factory=sm.Matrix)
    velocity_constraints: sm.Matrix = field(default_factory=sm.Matrix)
    extra_states: tuple = ()
    extra_rhs: tuple = ()
    frames: Tuple[Frame, ...] = ()
    collisions: Tuple[Collision, ...] = field(default=(), compare=False)
    poses: Optional[PoseSource] = field(default=None, compare=False)
    shapes: Mapping[str, list] = field(default_factory=dict, compare=False)
    welds: Mapping[str, tuple] = field(default_factory=dict, compare=False)
    defaults: Mapping[sm.Symbol, float] = field(default_factory=dict, compare=False)
    joint_inputs: tuple = ()
    outputs: Mapping[str, sm.Expr] = field(default_factory=dict, compare=False)
    events: Mapping[str, sm.Expr] = field(default_factory=dict, compare=False)
    initial_state: Optional[Mapping[str, float]] = None
    timestep: Optional[float] = None     # the file's own time step (MJCF <option timestep>)
    # the points of each body that must stay above the ground a robot's contacts touch, for the
    # run's verdict (eomc.compiler.urdf.collision.ground_check; eomc.runtime.ground_check), or None
    ground_check: Optional[dict] = field(default=None, compare=False)
    # the body-body pairs' shapes, for the run's verdict on two shapes that passed into each other
    # (MJCF: eomc.compiler.mjcf.model._pair_check; eomc.runtime.pair_check), or None
    pair_check: Optional[dict] = field(default=None, compare=False)
    # per joint with a limit whose spring has no closed-form potential (MJCF's): its shape, for
    # the energy verdict of a run that starts past it (joint_laws.law_shape; runtime/limit_energy.py)
    limit_laws: Optional[dict] = field(default=None, compare=False)
    # the joints whose zero is outside their range and which the default start moved inside
    # (eomc.compiler.urdf.model.start_in_range), for the note naming them; () if none
    start_in_range: tuple = field(default=(), compare=False)
    # a URDF's hinge triples' gimbal locks in reach (eomc.compiler.urdf.tree._check_gimbal_locks), for
    # the run's check that it did not pass one (runtime/diagnose.gimbal_passed); () if none
    gimbal_locks: tuple = field(default=(), compare=False)
    mechanics: Optional[Callable[[], sm.physics.mechanics.System]] = field(default=None, compare=False,
                                                                         repr=False)
    refusal: Optional[str] = None
    kane_refusal: Optional[str] = None   # why Kane's formulation cannot take it (no System: MJCF)
    frame_noun: str = "body"      # what its frames are called in messages ("link" for URDF)

    multipliers = ()          # no Lagrange multipliers: the tree's constraints are its loops

    def frame(self, name):
        """The :class:`Frame` named (or aliased) ``name``, or None."""
        for f in self.frames:
            if f.name == name:
                return f
        for f in self.frames:
            if name in f.aliases:
                return f
        return None


def merged_defaults(overrides, formed, defaults, joint_inputs, uses=()):
    """``overrides`` (the caller's parameters, inputs, ...) with a robot file's parameter
    ``defaults`` and ``joint_inputs`` filled in where not given: the defaults of the
    parameters ``formed`` (a Model or FormedSystem) has, and of those in ``uses`` (an output's
    only: a root joint's height in Kane's ``energy`` of a URDF robot), the joints' inputs in
    joint order and the caller's own after them."""
    result = dict(overrides)
    used = set(formed.parameters) | set(uses)
    defaults = {symbol: value for symbol, value in defaults.items() if symbol in used}
    given = overrides.get("parameters")
    if isinstance(given, dict):
        by_name = {str(s): s for s in formed.parameters}
        given = {by_name.get(k, k) if isinstance(k, str) else k: v for k, v in given.items()}
        result["parameters"] = {**defaults, **given}
    elif given is None:
        result["parameters"] = defaults
    if overrides.get("inputs") is None:
        present, joints = set(formed.inputs), set(joint_inputs)     # sets: linear in the joints
        extra = [r for r in formed.inputs if r not in joints]   # the user's own, after the joints'
        result["inputs"] = [r for r in joint_inputs if r in present] + extra
    return result


def merged_initial_state(overrides, read):
    """``overrides`` with the reader's initial state (a quaternion's w = 1) under the caller's:
    the caller names only what differs (an initial_state without the quaternion still starts
    upright)."""
    own = getattr(read, "initial_state", None)
    if not own:
        return overrides
    given = overrides.get("initial_state")
    if given is not None and not isinstance(given, dict):
        return overrides          # check_initial_state refuses it, naming what is wrong
    from sympy.core.function import AppliedUndef
    merged = dict(own)
    for key, value in (given or {}).items():     # a dynamic symbol q(t) is the state named q
        merged[key if isinstance(key, str) else key.func.__name__ if isinstance(key, AppliedUndef)
               else str(key)] = value
    return {**overrides, "initial_state": merged}
