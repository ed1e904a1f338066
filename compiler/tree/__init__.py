"""eomc.compiler.tree: joint trees and the recursive O(n) formulation (ABA, RNEA, CRBA)."""
from .model import Load, NotATree, Tree, TreeBody
from .recognize import tree_from_kane, tree_from_system, tree_of

__all__ = ["Tree", "TreeBody", "Load", "NotATree", "tree_of", "tree_from_system", "tree_from_kane"]
