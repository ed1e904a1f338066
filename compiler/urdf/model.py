"""URDF files and URDF-built Systems as eomc models: forming, parameter defaults, inputs.

``eomc.compile("robot.urdf")`` and ``eomc.compile(from_urdf(path))`` land
here through :func:`eomc.compiler.model.model_spec`.  A SymPy ``System``
that has not formed its equations is formed with eomc's KanesMethod (not
SymPy's, which is slower and which ``form_eoms`` insists on).  The URDF's
values become the parameter defaults -- only for the parameters that survive
in the equations (a link's mass on a vertical axis through its centre of
mass does not) -- and the joint torques the inputs, in joint order; what
the caller passes overrides them.
"""
from pathlib import Path

from sympy.physics import mechanics as sme

__all__ = ["is_urdf_path", "urdf_overrides", "load_urdf_model", "with_options"]


def is_urdf_path(model):
    return isinstance(model, (str, Path)) and Path(model).suffix.lower() == ".urdf"


def urdf_overrides(system, formed, overrides):
    """``overrides`` with the URDF's parameter defaults and inputs filled in where not given."""
    built = getattr(system, "urdf", None)
    if built is None:
        return overrides
    result = dict(overrides)
    used = set(formed.parameters)
    defaults = {symbol: value for symbol, value in built.parameters.items() if symbol in used}
    given = overrides.get("parameters")
    if isinstance(given, dict):
        by_name = {str(s): s for s in formed.parameters}
        given = {by_name.get(k, k) if isinstance(k, str) else k: v for k, v in given.items()}
        result["parameters"] = {**defaults, **given}
    elif given is None:
        result["parameters"] = defaults
    if overrides.get("inputs") is None:
        present = set(formed.inputs)
        extra = [r for r in formed.inputs if r not in built.inputs]   # the user's own, after the joints'
        result["inputs"] = [r for r in built.inputs if r in present] + extra
    return result


def with_options(model, name=None, *, floating_base=False):
    """(model, name) for the driver: a URDF path with options becomes its System.

    The CLI's ``--floating-base`` lands here; without options the path goes
    through unchanged (the driver reads URDF paths itself).
    """
    if not floating_base:
        return model, name
    if not is_urdf_path(model):
        from eomc.runtime.errors import ModelError
        raise ModelError(f"--floating-base applies to URDF robots (.urdf), not to {model}")
    from eomc.compiler.model.validate import sanitize_name
    return load_urdf_model(model, floating_base=True), name or sanitize_name(Path(model).stem)


def load_urdf_model(path, **options):
    """The System of the URDF file ``path`` (``options`` as :func:`eomc.compiler.urdf.from_urdf`)."""
    from . import from_urdf
    return from_urdf(path, **options)
