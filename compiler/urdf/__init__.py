"""eomc.compiler.urdf: robots from URDF files, as the recursive formulation's tree or as SymPy Systems.

    read_urdf      reader.py   the file -> links and joints (numbers, line numbers)
    build_tree     tree.py     fixed joints merged, the tree checked (and repaired, warned)
    tree_ir        treeir.py   the tree IR (eomc.compiler.tree.model.Tree) straight from it
    system_from_tree system.py SymPy System from SymPy's joint classes (kane, user extensions)
    urdf_formed    model.py    which of the two a URDF file becomes, per formulation
    from_urdf      (here)      read + tree + System
"""
from .reader import read_urdf
from .tree import build_tree
from .system import UrdfSystem, system_from_tree

__all__ = ["from_urdf", "urdf_system", "read_urdf", "build_tree", "system_from_tree", "UrdfSystem"]


def urdf_system(path, *, floating_base=False, fold_parameters=False, mimic=False, gravity=9.81, limits=True,
                allow_nonphysical_inertia=False):
    """The :class:`UrdfSystem` of the URDF file ``path`` (System, parameters, inputs, ...);
    ``limits=False`` leaves out the joints' limits, damping and friction."""
    tree = build_tree(read_urdf(path), floating_base=floating_base,
                      allow_nonphysical_inertia=allow_nonphysical_inertia)
    return system_from_tree(tree, fold=fold_parameters, mimic=mimic, gravity=gravity, laws=limits)


def from_urdf(path, *, floating_base=False, fold_parameters=False, mimic=False, gravity=9.81, limits=True,
              allow_nonphysical_inertia=False):
    """A SymPy ``System`` of the robot in the URDF file ``path``, ready to extend and compile.

    Its ``parameters`` (Symbol -> URDF value) and ``inputs`` (joint torques) are
    attached as attributes ``urdf_parameters`` and ``urdf_inputs``.
    ``allow_nonphysical_inertia``: build a robot whose moving links have negative principal
    moments beyond rounding (refused by default), with a warning naming each link.
    """
    built = urdf_system(path, floating_base=floating_base, fold_parameters=fold_parameters,
                        mimic=mimic, gravity=gravity, limits=limits,
                        allow_nonphysical_inertia=allow_nonphysical_inertia)
    system = built.system
    system.urdf = system.reading = built     # reading: what format-neutral code asks a reader's System
    return system
