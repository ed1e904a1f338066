"""URDF files and URDF-built Systems as eomc models: forming, parameter defaults, inputs.

``eomc.compile("robot.urdf")`` and ``eomc.compile(from_urdf(path))`` land
here through :func:`eomc.compiler.model.model_spec`.  A URDF file (or a
:class:`UrdfModel`: the file plus options, what ``--floating-base`` gives) goes
straight to the recursive formulation's tree (:mod:`.treeir`) under the
``recursive`` and ``auto`` formulations: no SymPy System, frames or velocities
are built, which is what made large robots take minutes.  Under ``kane`` (and
for ``mimic=True`` robots that have mimic joints: a constraint the tree cannot
carry) the file becomes the System of :func:`.from_urdf`, formed with eomc's
KanesMethod, as before.  Both give the same coordinates, speeds, parameters
(names and URDF defaults) and inputs.

The URDF's values become the parameter defaults -- on the Kane path only for
the parameters that survive in the equations (a link's mass on a vertical axis
through its centre of mass does not) -- and the joint torques the inputs, in
joint order; what the caller passes overrides them.
"""
import warnings
from dataclasses import dataclass
from pathlib import Path

from eomc.runtime.errors import EomcWarning

__all__ = ["is_urdf_path", "is_urdf_model", "UrdfModel", "urdf_overrides", "load_urdf_model",
           "with_options", "urdf_formed"]


@dataclass(frozen=True)
class UrdfModel:
    """A URDF file with the options of :func:`eomc.compiler.urdf.from_urdf`, not yet read."""
    path: Path
    floating_base: bool = False
    fold_parameters: bool = False
    mimic: bool = False
    gravity: float = 9.81
    limits: bool = True          # the file's joint limits, damping and friction act (False: ignored)
    contacts: tuple = ()        # ground contacts (eomc.compiler.contact.tree.ContactSpec or text)
    allow_nonphysical_inertia: bool = False
    ground: bool = False        # the <collision> geometry touches the plane z = 0 (.collision); also
                                # contacts=["@ground"] / --ground

    def options(self):
        return dict(floating_base=self.floating_base, fold_parameters=self.fold_parameters,
                    mimic=self.mimic, gravity=self.gravity, limits=self.limits,
                    allow_nonphysical_inertia=self.allow_nonphysical_inertia)


def is_urdf_path(model):
    return isinstance(model, (str, Path)) and Path(model).suffix.lower() == ".urdf"


def is_urdf_model(model):
    """A URDF path or a :class:`UrdfModel`."""
    return isinstance(model, UrdfModel) or is_urdf_path(model)


def _merged(overrides, formed, defaults, joint_inputs):
    """``overrides`` with the URDF's parameter defaults and inputs filled in where not given."""
    result = dict(overrides)
    used = set(formed.parameters)
    defaults = {symbol: value for symbol, value in defaults.items() if symbol in used}
    given = overrides.get("parameters")
    if isinstance(given, dict):
        by_name = {str(s): s for s in formed.parameters}
        given = {by_name.get(k, k) if isinstance(k, str) else k: v for k, v in given.items()}
        result["parameters"] = {**defaults, **given}
    elif given is None:
        result["parameters"] = defaults
    if overrides.get("inputs") is None:
        present = set(formed.inputs)
        extra = [r for r in formed.inputs if r not in joint_inputs]   # the user's own, after the joints'
        result["inputs"] = [r for r in joint_inputs if r in present] + extra
    return result


def urdf_overrides(system, formed, overrides):
    """``overrides`` with a from_urdf System's parameter defaults and inputs filled in."""
    built = getattr(system, "urdf", None)
    if built is None:
        return overrides
    return _merged(overrides, formed, built.parameters, built.inputs)


def urdf_formed(model, formulation, overrides, formed_system):
    """(FormedSystem, overrides with the URDF's defaults, System or None) of a URDF file or
    :class:`UrdfModel` under ``formulation`` (see the module docstring).

    ``formed_system(system, formulation)`` forms the robot's System when it takes that
    route (the caller's, :func:`eomc.compiler.model.spec.formed_system`: passed in so
    that the URDF package does not import the model layer that imports it)."""
    from . import build_tree, read_urdf, system_from_tree
    model = model if isinstance(model, UrdfModel) else UrdfModel(Path(model))
    tree = build_tree(read_urdf(model.path), floating_base=model.floating_base,
                      allow_nonphysical_inertia=model.allow_nonphysical_inertia)
    mimics = [j.name for j in tree.joints if j.mimic is not None]
    if formulation != "kane" and not (model.mimic and mimics):
        from eomc.compiler.tree.formed import formed_of_tree
        from .treeir import tree_ir
        built = tree_ir(tree, fold=model.fold_parameters, gravity=model.gravity, laws=model.limits)
        named, ground = _ground(model)
        if named or ground:
            from eomc.compiler.contact.tree import with_contacts, merged_outputs
            contact_outputs, contact_events = {}, {}
            if named:
                built, contact_outputs, contact_events = with_contacts(built, named, fold=model.fold_parameters)
            if ground:
                built, more_outputs, more_events = _with_ground(built, model.fold_parameters)
                contact_outputs, contact_events = {**contact_outputs, **more_outputs}, {**contact_events, **more_events}
            overrides = merged_outputs(overrides, contact_outputs, contact_events)
        formed = formed_of_tree(built.tree)
        object.__setattr__(formed, "_urdf", built)   # for the animation's poses (treeir.pose_source)
        return formed, _merged(overrides, formed, built.parameters, built.inputs), None
    if model.contacts or model.ground:
        from eomc.runtime.errors import ModelError
        from eomc.compiler.contact.tree import with_contacts
        from .treeir import tree_ir
        with_contacts(tree_ir(tree, fold=model.fold_parameters, gravity=model.gravity), _ground(model)[0])
        raise ModelError(f"{model.path}: ground contacts on a URDF robot are lowered by the recursive "
                         f"formulation only (formulation 'recursive' or 'auto'"
                         f"{'; mimic=True robots with mimic joints take Kane' if mimics else ''})")
    if formulation != "kane":
        warnings.warn(f"{model.path}: mimic joints ({', '.join(mimics[:5])}{', ...' if len(mimics) > 5 else ''}) "
                      f"are constraints, which the URDF reader's tree does not carry: the robot goes "
                      f"through its SymPy System, whose constraints close the joint tree (formulation "
                      f"{formulation})", EomcWarning,
                      stacklevel=3)
    built = system_from_tree(tree, fold=model.fold_parameters, mimic=model.mimic, gravity=model.gravity,
                             laws=model.limits)
    system = built.system
    system.urdf = built
    formed = formed_system(system, formulation)
    return formed, urdf_overrides(system, formed, overrides), system


GROUND = "@ground"      # contacts=[...] entry: the robot's <collision> geometry on the plane z = 0


def _ground(model):
    """(the named contact specs, whether the collision geometry touches the ground)."""
    from eomc.compiler.contact.tree import as_spec
    specs = [as_spec(c) for c in model.contacts]
    return [s for s in specs if s.link != GROUND], model.ground or any(s.link == GROUND for s in specs)


def _with_ground(built, fold):
    """(built, outputs, events) with the <collision> shapes on the ground (.collision)."""
    from eomc.compiler.contact.geometry import with_shapes
    from eomc.compiler.contact.tree import _com
    from eomc.runtime.errors import ModelError
    from .collision import collision_shapes
    from .tree import identifier
    shapes = collision_shapes(built)
    if not shapes:
        raise ModelError(f"{built.source.path}: a ground was asked for (--ground, ground=True), but no moving "
                         f"link has <collision> geometry")
    coms = {identifier(b.name): tuple(float(x) for x in b.com) for b in built.source.bodies.values()}
    return with_shapes(built, shapes, lambda i: _com(built, built.tree.bodies[i].name,
                                                     coms.get(built.tree.bodies[i].name, (0.0, 0.0, 0.0))),
                       fold=fold)


def with_options(model, name=None, *, floating_base=False, allow_nonphysical_inertia=False, limits=True):
    """(model, name) for the driver: a URDF path with options becomes a :class:`UrdfModel`.

    The CLI's ``--floating-base``, ``--allow-nonphysical-inertia`` and ``--limits off`` land
    here (an MJCF path with ``--limits off`` is the CLI's own:
    :func:`eomc.cli.common.with_options`); without options the path goes through unchanged
    (the driver reads URDF paths itself).
    """
    given = {k: v for k, v in (("floating_base", floating_base),
                               ("allow_nonphysical_inertia", allow_nonphysical_inertia)) if v}
    if not limits:
        given["limits"] = False
    if not given:
        return model, name
    if not is_urdf_path(model):
        from eomc.runtime.errors import ModelError
        flags = " and ".join("--limits off" if k == "limits" else "--" + k.replace("_", "-") for k in given)
        raise ModelError(f"{flags} applies to URDF robots (.urdf){' and MJCF models' if given == {'limits': False} else ''}, "
                         f"not to {model}")
    from eomc.compiler.model.validate import sanitize_name
    return UrdfModel(Path(model), **given), name or sanitize_name(Path(model).stem)


def load_urdf_model(path, **options):
    """The System of the URDF file ``path`` (``options`` as :func:`eomc.compiler.urdf.from_urdf`)."""
    from . import from_urdf
    return from_urdf(path, **options)
