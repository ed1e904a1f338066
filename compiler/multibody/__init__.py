"""eomc.compiler.multibody: the format-neutral multibody model every reader produces.

    Model, Frame, Provenance   model.py   the joint tree, frames, poses, defaults, inputs, where from
"""
from .model import Frame, Model, Provenance

__all__ = ["Model", "Frame", "Provenance"]
