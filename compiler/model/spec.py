"""One model, however given: a model file or a system object plus keyword arguments.

:func:`model_spec` returns a :class:`ModelSpec` holding the formed system
(``FormedSystem``) and the checked optional variables -- the single input of
the code generator.  Mistakes raise ModelFileError with file:line for model
files and ModelError for objects passed in Python.
"""
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Union

from eomc.runtime.errors import EomcError, EomcWarning, ModelError, ModelFileError

from ..mechanics.formed import FormedSystem
from ..multibody.model import Model
from .modelfile import assignment_lines, run_model_file
from .states import attach_states, entry_line
from .validate import (Invalid, check_equations, check_events, check_initial_state, check_inputs,
                       check_name, check_outputs, check_parameters, sanitize_name,
                       unset_parameters)

__all__ = ["ModelSpec", "Reading", "model_spec", "read_model", "spec_of", "formed_system", "named_files",
           "with_contact_specs"]


@dataclass(frozen=True)
class ModelSpec:
    name: str
    # what the generator lowers: Kane's or Lagrange's FormedSystem, or -- a tree read, nothing
    # formed -- the Model itself (the same variables' names; eomc.compiler.multibody)
    formed: Union[FormedSystem, Model]
    parameters: dict = None             # Symbol -> default, or None
    inputs: list = None                 # dynamic symbols in order, or None
    initial_state: list = None          # values in state order, or None
    outputs: dict = None                # name -> expression, or None
    events: dict = None                 # name -> event expression, or None
    event_options: list = None          # [{"name", "terminal", "direction"}] in events' order
    path: Path = None                   # the model file, if any
    geometry: dict = None               # the model file's `geometry` (eomc.geometry shapes), or None
    poses: object = None                # PoseSource (compiler/emit/poses.py), set by the driver
    frames: object = None               # FrameSource (compiler/tree/frames.py), set by the driver
    system: object = field(default=None, repr=False)
    # the multibody model a reader produced (a robot file's, or a System's tree): frames,
    # poses, shapes; on a robot's Kane route beside Kane's formed system
    model: Optional[Model] = field(default=None, repr=False)
    timestep: float = None              # the model file's own time step (MJCF <option timestep>), or None
    ground_check: dict = field(default=None, compare=False)  # a robot's points that must stay above its ground (URDF), or None
    pair_check: dict = field(default=None, compare=False)    # the body-body pairs' shapes (MJCF; runtime/pair_check.py), or None
    limit_laws: dict = field(default=None, compare=False)    # MJCF limits' shapes (runtime/limit_energy.py), or None
    start_in_range: list = field(default=None, compare=False)  # joints the default start moved into range (URDF), or None
    gimbal_locks: list = field(default=None, compare=False)    # hinge triples' locks in reach (URDF; runtime/diagnose.py), or None
    # what the ``energy`` output a robot reader gave Kane's route holds (NAME.json "energy", as the
    # recursive route's tree says it: the runtime's verdict reads it; eomc.compiler.urdf.model._kane_energy)
    energy_note: str = field(default=None, compare=False)
    # a robot's bodies whose mass and inertia parameters are checked at run time (runtime/
    # law_parameters.py; eomc.compiler.mechanics.body_parameters): the URDF reader's tree, unless
    # built for identification (all_inertial_parameters: its fits pass unphysical vectors through
    # simulate on purpose); body_checks False: none (MJCF for now, identification builds)
    body_tree: object = field(default=None, compare=False)
    body_checks: bool = field(default=True, compare=False)


@dataclass(frozen=True)
class Reading:
    """A model as read, once: what :func:`model_spec` derives from under any formulation.

    ``kind``: "robot" (a URDF or MJCF file: ``model`` is its Model), "file" (a model file:
    ``values`` are its variables, ``lines`` their lines) or "object" (a system passed in);
    ``formed_by``: the robot reader's formed step (eomc.compiler.urdf.model.urdf_formed, ...)."""
    kind: str
    path: Optional[Path] = None
    name: Optional[str] = None
    values: Mapping[str, Any] = field(default_factory=dict)
    lines: Mapping[str, int] = field(default_factory=dict)
    source: str = ""
    filename: str = ""
    model: Optional[Model] = None
    formed_by: Optional[Callable] = field(default=None, repr=False)
    body_checks: bool = False           # a robot whose bodies' parameters are checked at run time (ModelSpec)


def _is_eomc_kane(system):
    from eomc.compiler.formulations.select import is_eomc_kane
    return is_eomc_kane(system)


def _is_sympy_method(system):
    # not hasattr(mass_matrix_full): an unformed SymPy System raises there, and it converts too
    return type(system).__module__.startswith("sympy.physics.mechanics")


def formed_system(system, formulation="kane"):
    """FormedSystem of ``system``: eomc's methods via .formed(), SymPy's via from_sympy.

    For the kane formulation the equations are formed (an unformed System by eomc's
    Kane).  For recursive and auto an unformed System, or an eomc KanesMethod, is read
    as a joint tree instead (a FormedSystem of method "tree": nothing formed, so a model
    file's lazily formed KanesMethod is never formed); when the recursion cannot take it,
    recursive is refused here, before anything is formed, and auto forms Kane's
    equations (eomc.compiler.formulations.select says why in the metadata)."""
    from eomc.compiler.mechanics.formed import FormedSystem
    if isinstance(system, FormedSystem):
        return system
    from eomc.compiler.mechanics.system import check_single_parents
    from eomc.compiler.mechanics.unformed import form_system, is_unformed_system
    unformed = is_unformed_system(system)
    check_single_parents(getattr(system, "joints", None))   # before a tree or Kane's form is tried
    if formulation != "kane" and (unformed or _is_eomc_kane(system)):
        from eomc.compiler.tree.model import NotATree
        from eomc.compiler.formulations.select import recursive_refusal
        try:
            if unformed:
                from eomc.compiler.multibody.formed import tree_formed
                return tree_formed(system)
            from eomc.compiler.formulations.select import kane_tree_formed
            return kane_tree_formed(system)
        except NotATree as exc:
            if formulation == "recursive":    # refused now, before forming Kane's equations
                raise recursive_refusal(exc) from None
        except EomcError:
            if formulation == "recursive":
                raise
        except Exception as exc:          # noqa: BLE001 -- auto: Kane's form below, or its error
            if formulation == "recursive":
                raise ModelError(f"recursive formulation: reading the joint tree failed "
                                 f"({type(exc).__name__}: {exc})") from exc
    if unformed:
        system = form_system(system)
    if _is_sympy_method(system):
        try:
            from eomc.compiler.mechanics import from_sympy
        except ImportError:
            raise ModelError("converting a SymPy-formed system needs eomc.mechanics.from_sympy, "
                             "which this installation lacks") from None
        system = from_sympy(system)
    if callable(getattr(system, "formed", None)):
        return system.formed()
    raise ModelError(f"`system` is a {type(system).__name__}; expected a System, JointsMethod or a "
                     f"formed KanesMethod or LagrangesMethod (from eomc.mechanics or "
                     f"sympy.physics.mechanics)")


def _warn_unset_parameters(formed, parameters, where):
    """No `parameters` at all: every parameter, gravity included, is 1.0 -- say so, naming them."""
    unset = unset_parameters(formed, parameters)
    if unset:
        names = ", ".join(s.name for s in unset)
        message = (f"{where}no `parameters` dict: {'every parameter' if len(unset) > 1 else 'the parameter'} "
                   f"defaults to 1.0 ({names}); give `parameters = {{symbol: value, ...}}` to set them")
        if message not in _WARNED:  # once per model and process, however often it is compiled
            _WARNED.add(message)
            warnings.warn(message, EomcWarning, stacklevel=caller_level())


_WARNED = set()


def caller_level():
    """warnings.warn's stacklevel for the first frame outside eomc (the user's call)."""
    frame, level = sys._getframe(2), 2
    while frame is not None and frame.f_globals.get("__name__", "").startswith("eomc"):
        frame, level = frame.f_back, level + 1
    return level


def _checked(values, formed, name, where, origin=""):
    """Run the validators; ``where(variable)`` turns an Invalid into the right error."""
    try:
        # extra first-order states (the `states` dict, a System's musculotendons): compiler/model/states.py
        formed = attach_states(formed, values.get("states"), values.get("system"), values.get("inputs"),
                               values.get("parameters"))
        check_equations(formed)
        outputs = check_outputs(values.get("outputs"), formed)
        _warn_unset_parameters(formed, values.get("parameters"), origin)
        events, event_options = check_events(values.get("events"), formed)
        return ModelSpec(
            name=check_name(name), formed=formed, events=events, event_options=event_options,
            parameters=check_parameters(values.get("parameters"), formed,
                                        {**(outputs or {}), **(events or {})}),
            inputs=check_inputs(values.get("inputs"), formed),
            initial_state=check_initial_state(values.get("initial_state"), formed),
            outputs=outputs, system=values.get("system"), geometry=values.get("geometry"),
            timestep=values.get("timestep"), ground_check=values.get("ground_check"),
            pair_check=values.get("pair_check"),
            limit_laws=values.get("limit_laws"),
            start_in_range=values.get("start_in_range"), gimbal_locks=values.get("gimbal_locks"),
            energy_note=values.get("energy_note"))
    except Invalid as exc:
        raise where(exc) from None


def _the_only_system(namespace, lines, filename):
    """A file without `system` (SymPy's documentation scripts name theirs KM, LM, sys...): the one
    module-level System, KanesMethod or LagrangesMethod it defines, with a warning naming it;
    none or several: the error says what to assign."""
    import sympy.physics.mechanics as sme
    kinds = (sme.System, sme.KanesMethod, sme.LagrangesMethod)
    found = {k: v for k, v in namespace.items()
             if not k.startswith("_") and isinstance(v, kinds) and not isinstance(v, type)}
    owned = {id(v.eom_method) for v in found.values() if isinstance(v, sme.System)}
    found = {k: v for k, v in found.items() if id(v) not in owned}   # a System's own method
    unique = {}
    for k, v in found.items():
        unique.setdefault(id(v), k)                                  # one object, several names
    named = [(k, found[k]) for k in unique.values()]
    base = ("does not define `system` (assign a System, or a formed KanesMethod or LagrangesMethod, to a "
            "module-level variable named system)")
    if not named:
        raise ModelFileError(base, filename)
    if len(named) > 1:
        listed = ", ".join(f"{k} ({type(v).__name__}, line {lines.get(k, '?')})" for k, v in named)
        raise ModelFileError(f"{base}; it defines {listed}: assign the one to compile, "
                             f"e.g. `system = {named[0][0]}`", filename)
    variable, value = named[0]
    message = (f"{filename}:{lines.get(variable, '?')}: no `system` variable: compiling {variable}, the "
               f"file's one {type(value).__name__} (write `system = {variable}` to say so)")
    if message not in _WARNED:
        _WARNED.add(message)
        warnings.warn(message, EomcWarning, stacklevel=caller_level())
    return variable, value


def _built_model(path):
    """The refusal for a built model given where a model file is read, or None.  A directory
    made by `eomc build -o DIR` or its NAME.json is loaded (eomc.load, `eomc simulate DIR`), not
    derived: read as Python the JSON failed at its first `null` ("NameError: name 'null' is not
    defined") and a directory at the OS ("cannot read model file (Is a directory)")."""
    if path.is_dir():
        built = sorted(p.name for p in path.glob("*.json")
                       if not p.name.startswith(".") and (path / f"lib{p.stem}.so").exists())
        if not built:
            return ModelFileError("a directory, not a model file (.py, .urdf or MuJoCo's .xml)", str(path))
        what = f"a built model directory ({', '.join(built)})"
    elif path.suffix.lower() == ".json":
        what = "a built model's metadata (NAME.json), not a model file"
    else:
        return None
    return ModelFileError(f"{what}: a built model is loaded (eomc.load, or eomc simulate, check, report, "
                          f"linearize, animate, sweep with it), not derived again; give the model file "
                          f"it was built from (.py, .urdf or MuJoCo's .xml)", str(path))


def _read_file(path, name):
    refusal = _built_model(Path(path))
    if refusal is not None:
        raise refusal
    namespace, source, filename = run_model_file(path)
    lines = assignment_lines(source)
    if "system" not in namespace:
        variable, namespace["system"] = _the_only_system(namespace, lines, filename)
        lines["system"] = lines.get(variable)
    values = {k: namespace.get(k) for k in ("system", "parameters", "inputs", "initial_state", "outputs",
                                            "events", "states", "geometry")}
    name = name or namespace.get("name") or sanitize_name(Path(path).stem)
    return Reading("file", Path(path), name, values, lines, source, filename)


def _from_file(read, overrides, formulation="kane"):
    lines, filename, source = read.lines, read.filename, read.source
    try:
        formed = formed_system(read.values["system"], formulation)
    except EomcError as exc:
        raise ModelFileError(str(exc), filename, lines.get("system")) from None
    except Exception as exc:
        raise ModelFileError(f"forming the equations of `system` failed: {type(exc).__name__}: {exc}",
                             filename, lines.get("system")) from exc
    values = dict(read.values)
    given = {k: v for k, v in overrides.items() if v is not None}
    if isinstance(given.get("parameters"), dict) and isinstance(values["parameters"], dict):
        # parameters= overrides some of the file's defaults; the others keep the file's values
        given["parameters"] = {**values["parameters"], **given["parameters"]}
    values.update(given)

    def where(exc):
        if exc.variable in overrides and overrides[exc.variable] is not None:
            return ModelError(str(exc))
        line = lines.get(exc.variable)
        if exc.variable == "states" and getattr(exc, "entry", None) is not None:
            line = entry_line(source, exc.entry) or line    # the state's own entry in the dict
        return ModelFileError(str(exc), filename, line)
    spec = _checked(values, formed, read.name, where, f"{filename}: ")
    return ModelSpec(**{**spec.__dict__, "path": read.path})


def read_model(system, name=None, poses=False):
    """The :class:`Reading` of ``system`` (a model file path, a URDF or MJCF file or model,
    a system object): every file read here, once.  ``poses``: robot readers also read what
    the animation's poses need (visuals, welded links)."""
    from eomc.compiler.urdf.model import UrdfModel, is_urdf_model
    if is_urdf_model(system):   # a robot: straight to the tree, or its System under kane
        from eomc.compiler.urdf.model import read_model as read_urdf_model, urdf_formed
        path = Path(system.path if isinstance(system, UrdfModel) else system)
        return Reading("robot", path, name or sanitize_name(path.stem), model=read_urdf_model(system, poses),
                       formed_by=lambda model, form, overrides: urdf_formed(model, form, overrides, formed_system),
                       body_checks=not getattr(system, "all_inertial_parameters", False))
    from eomc.compiler.mjcf.model import MjcfModel, is_mjcf_model
    if is_mjcf_model(system):   # a MuJoCo model: MuJoCo's compiler, then straight to the tree
        from eomc.compiler.mjcf.model import mjcf_formed, read_model as read_mjcf_model
        path = Path(system.path if isinstance(system, MjcfModel) else system)
        try:        # MuJoCo's own compiler reads the file (first hour s21: a bare ModuleNotFoundError)
            import mujoco  # noqa: F401
        except ImportError:
            from eomc.runtime.errors import MissingExtraError
            raise MissingExtraError(f"reading a MuJoCo model ({path})", "mujoco", ["mujoco"]) from None
        return Reading("robot", path, name or sanitize_name(path.stem), model=read_mjcf_model(system, poses),
                       formed_by=lambda model, form, overrides: (*mjcf_formed(model, overrides), None))
    if isinstance(system, (str, Path)):
        return _read_file(system, name)
    return Reading("object", None, name, {"system": system})


def with_contact_specs(model, contacts):
    """``model`` (a URDF or MJCF path or model) carrying ``contacts``: what ``contacts=`` of
    eomc.compile does (a dispatch on the robot formats, as :func:`read_model`'s).  Other models
    are refused with the way to give them contacts."""
    import dataclasses
    from pathlib import Path
    from eomc.compiler.mjcf.model import MjcfModel, is_mjcf_path
    from eomc.compiler.urdf.model import UrdfModel, is_urdf_path
    from eomc.compiler.contact.tree import ContactSpec, as_spec
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


def with_floating_base(model, name, floating_base):
    """(model, name) with a URDF robot's root on a free joint: what ``floating_base=`` of
    eomc.compile does (the command line's --floating-base).  Anything but a URDF is refused:
    an MJCF model's free joints are its file's, a System's its own."""
    import dataclasses
    from eomc.compiler.urdf.model import UrdfModel, is_urdf_path, with_options
    if isinstance(model, UrdfModel):
        return dataclasses.replace(model, floating_base=floating_base), name
    if not is_urdf_path(model):
        raise ModelError(f"floating_base= applies to URDF robots (.urdf), not to {model!r}: an MJCF "
                         f"model's free joints come from its file, a System's from its joints")
    return with_options(model, name, floating_base=floating_base)


def named_files(path):
    """The files a model file names besides itself, which a build depends on (an MJCF file's
    includes and assets), or None when one cannot be found: the format's own answer."""
    from eomc.compiler.mjcf.model import is_mjcf_path
    if is_mjcf_path(path):
        from eomc.compiler.mjcf.files import named_files as mjcf_named_files
        return mjcf_named_files(path)
    return []


def spec_of(read, *, parameters=None, inputs=None, initial_state=None, outputs=None, events=None,
            formulation="kane", states=None):
    """The ModelSpec of a :class:`Reading` under ``formulation`` (see :func:`model_spec`):
    called once per formulation ``auto`` compares, the files read once before."""
    overrides = dict(parameters=parameters, inputs=inputs, initial_state=initial_state, outputs=outputs,
                     events=events, states=states)
    if read.kind == "robot":
        path = read.path
        formed, values, robot = read.formed_by(read.model, formulation, overrides)
        spec = _checked({**values, "system": robot}, formed, read.name,
                        lambda exc: ModelFileError(str(exc), str(path)), f"{path}: ")
        return ModelSpec(**{**spec.__dict__, "path": path, "model": _model_of(spec, read.model),
                            "body_checks": read.body_checks,
                            "body_tree": getattr(read.model, "tree", None) if read.body_checks else None})
    if read.kind == "file":
        spec = _from_file(read, overrides, formulation)
        return ModelSpec(**{**spec.__dict__, "model": _model_of(spec)})
    from eomc.compiler.urdf.model import urdf_overrides
    system, name = read.values["system"], read.name
    try:
        formed = formed_system(system, formulation)
    except EomcError:
        raise
    except Exception as exc:   # SymPy's own errors on a system it cannot form: say what failed
        raise ModelError(f"forming the equations of the system failed: {type(exc).__name__}: "
                         f"{exc}") from exc
    values = {**urdf_overrides(system, formed, overrides), "system": system}
    spec = _checked(values, formed, name or "model", lambda exc: ModelError(str(exc)),
                    f"model {name or 'model'}: ")
    return ModelSpec(**{**spec.__dict__, "model": _model_of(spec)})


def _model_of(spec, read=None):
    """The spec's Model: what the recursive route lowers (extra states attached), else the
    robot reader's beside Kane's formed system, else none."""
    return spec.formed if isinstance(spec.formed, Model) else read


def model_spec(system, name=None, *, parameters=None, inputs=None, initial_state=None, outputs=None,
               events=None, formulation="kane", states=None):
    """Normalize a model file path or a system object into a ModelSpec (see the module docstring).

    ``states``: {z: dz/dt} extra first-order states appended to x after q and u.
    ``formulation`` decides what is derived, not what is generated: "kane" (this function's
    default, for callers that read the formed equations: `eomc show`, the tests) forms
    them; "auto" and "recursive" read a tree instead where they can (:func:`formed_system`).
    The compiler's default formulation is auto (eomc.compiler.driver), which reads once
    (:func:`read_model`) and derives each formulation it compares from the reading
    (:func:`spec_of`)."""
    return spec_of(read_model(system, name), parameters=parameters, inputs=inputs,
                   initial_state=initial_state, outputs=outputs, events=events,
                   formulation=formulation, states=states)
