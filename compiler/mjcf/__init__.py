"""eomc.compiler.mjcf: MuJoCo models (MJCF) through MuJoCo's own compiler, as the recursive tree.

    check_model  model.py    what a rigid-body tree cannot express: refused (or ignored on request)
    tree_ir      treeir.py   the compiled MjModel's arrays -> eomc.compiler.tree.model.Tree
    mjcf_formed  model.py    the FormedSystem and parameter/input defaults of an MJCF file
    with_ignore  model.py    the CLI's --ignore: an MJCF path with what to drop
    mjcf_pose_source  poses.py   the animation's body frames (MuJoCo's) and geoms as shapes
    Clamp        clamp.py    ctrlrange/forcerange clamping as an expression node (fmin/fmax in C)
"""
from .model import MjcfModel, check_model, is_mjcf_model, is_mjcf_path, load_mjmodel, mjcf_formed
from .treeir import tree_ir

__all__ = ["MjcfModel", "check_model", "is_mjcf_model", "is_mjcf_path", "load_mjmodel", "mjcf_formed",
           "tree_ir"]
