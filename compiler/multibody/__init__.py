"""eomc.compiler.multibody: the format-neutral multibody model every reader produces.

    Model, Frame, Collision, Provenance   model.py   the joint tree, frames, collision geometry,
                                          poses, defaults, inputs, where from
"""
from .model import Collision, Frame, Model, Provenance

__all__ = ["Model", "Frame", "Collision", "Provenance"]
