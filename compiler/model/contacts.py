"""``contacts=`` of eomc.compile: which models take ground contacts, and how they carry them.

One job: the dispatch on the robot formats (as :func:`.spec.read_model`'s), so it lives
with the model layer, above the readers, which the contact package is below.
"""
from eomc.runtime.errors import ModelError

from ..contact.tree import ContactSpec, as_spec

__all__ = ["with_contact_specs"]


def with_contact_specs(model, contacts):
    """``model`` (a URDF path or UrdfModel) carrying ``contacts``: what ``contacts=`` of
    eomc.compile does.  Other models are refused with the way to give them contacts."""
    import dataclasses
    from pathlib import Path
    from eomc.compiler.mjcf.model import MjcfModel, is_mjcf_path
    from eomc.compiler.urdf.model import UrdfModel, is_urdf_path
    if isinstance(contacts, (str, ContactSpec, dict)):
        contacts = [contacts]
    specs = tuple(as_spec(c) for c in contacts)
    if isinstance(model, (UrdfModel, MjcfModel)):
        return dataclasses.replace(model, contacts=tuple(model.contacts) + specs)
    if is_urdf_path(model):
        return UrdfModel(Path(model), contacts=specs)
    if is_mjcf_path(model):
        return MjcfModel(Path(model), contacts=specs)
    raise ModelError("contacts= applies to URDF and MJCF robots; a model written with SymPy mechanics adds "
                     "eomc.contact.ground(point, body, world=system, ...) loads itself")
