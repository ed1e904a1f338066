"""A URDF robot's state, input and link names from its tree alone, before anything is derived.

Why: the command line's run options (``--x0 q_knee=0.3``, ``--input tau_knee=1``,
``--frame foot``, ``--contact foot``) name these; a typo must be reported in a moment,
not after the minutes a large robot takes to build (G1: 83 s).  Reading the file and
building its tree takes milliseconds; the names follow eomc.compiler.urdf.treeir's rule
(``q_<joint>[_<suffix>]``, ``u_<joint>[_<suffix>]``, ``tau_<joint>``), the same on the
Kane path (eomc.compiler.urdf.system).
"""
import warnings
from dataclasses import dataclass

__all__ = ["UrdfNames", "urdf_names"]


@dataclass(frozen=True)
class UrdfNames:
    states: tuple
    inputs: tuple
    links: tuple
    floating: bool
    mimic: bool          # a joint mimics another: with mimic=True its coordinates are not states


def urdf_names(path, floating_base=False):
    """:class:`UrdfNames` of the URDF at ``path``; the file's own errors are raised as the
    build would raise them (file:line), its warnings are left to the build."""
    from .reader import read_urdf
    from .tree import build_tree, coordinate_suffixes, identifier
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = read_urdf(path)
        tree = build_tree(robot, floating_base=floating_base, allow_nonphysical_inertia=True)
    q, u, inputs = [], [], []
    for joint in tree.joints:
        j = identifier(joint.name)
        sq, su = coordinate_suffixes(joint.type)
        q += [f"q_{j}" + (f"_{x}" if x else "") for x in sq]
        u += [f"u_{j}" + (f"_{x}" if x else "") for x in su]
        if joint.type in ("revolute", "continuous", "prismatic"):
            inputs.append(f"tau_{j}")
    return UrdfNames(tuple(q + u), tuple(inputs), tuple(robot.links), floating_base,
                     any(j.mimic is not None for j in tree.joints))
