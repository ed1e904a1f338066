"""Extra first-order states: ``states = {z: dz_dt, ...}`` and the states musculotendons bring.

Why a module of its own: the state of a mechanism is x = [q; u], but what is coupled to
it often has states of its own (a muscle's activation, an elastic tendon's fibre length,
a motor's current, a controller's integrator).  They are explicit ODEs z' = g(t, q, u, z,
p, r), so they join the FormedSystem as a third block (``extra_states``/``extra_rhs``)
and the generator appends their rows to every function.  This module reads them from the
model (a dict, plus every ``sympy.physics.biomechanics`` musculotendon among a System's
actuators: its ``state_vars`` and ``rhs()``, exactly as SymPy's docs combine them by
hand), checks them and returns the FormedSystem with the block attached: the states are
taken out of the inputs (where an undeclared a(t) in the equations of motion would
otherwise land) and the symbols their derivatives bring in become parameters and inputs.
"""
import sys
from collections.abc import Mapping
from dataclasses import replace

import sympy as sm
from sympy.core.function import AppliedUndef

from .validate import Invalid, _label, _names, _short, non_real_constants

__all__ = ["attach_states", "musculotendon_states", "entry_line"]

_T = sm.Symbol("t")


def musculotendon_states(system):
    """[(state, rate, where)] of the musculotendons among ``system.actuators``, in actuator order.

    A ``MusculotendonBase`` (SymPy's biomechanics) lists its state variables (an elastic
    tendon's first, then its activation dynamics') in ``x`` and their rates in ``rhs()``.
    Nothing is imported: a model that never loaded sympy.physics.biomechanics has none.
    """
    module = sys.modules.get("sympy.physics.biomechanics.musculotendon")
    actuators = getattr(system, "actuators", None)
    if module is None or not actuators:
        return []
    found = []
    for actuator in actuators:
        if isinstance(actuator, module.MusculotendonBase):
            x, rhs = list(actuator.x), list(actuator.rhs())
            where = f"musculotendon {getattr(actuator, 'name', actuator)!s}"
            found += [(z, rate, where) for z, rate in zip(x, rhs)]
    return found


def _rate(value, label):
    """One scalar expression from a dict value (a 1x1 Matrix, e.g. ``muscle.rhs()``, too)."""
    if value is None:
        raise Invalid("states", f"state `{label}` has no derivative: give `states = {{{label}: "
                                f"expression of d{label}/dt, ...}}`")
    if isinstance(value, sm.MatrixBase):
        if value.shape != (1, 1):
            raise Invalid("states", f"the derivative of state `{label}` is a {value.shape[0]}x"
                                    f"{value.shape[1]} matrix; give one expression per state")
        value = value[0, 0]
    try:
        value = sm.sympify(value)
    except (sm.SympifyError, TypeError):
        raise Invalid("states", f"the derivative of state `{label}` is not a SymPy expression: "
                                f"{value!r}") from None
    if not isinstance(value, sm.Expr):
        raise Invalid("states", f"the derivative of state `{label}` must be a scalar expression, "
                                f"not {type(value).__name__}")
    return value


def entry_line(source, index):
    """Line of the ``index``-th key of the model file's module-level ``states = {...}`` literal
    (None when ``states`` is not assigned a dict literal there)."""
    import ast
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return None
    found = None
    for node in tree.body:
        if (isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "states"
                                                  for t in node.targets)):
            found = node.value if isinstance(node.value, ast.Dict) else None
    if found is None or not 0 <= index < len(found.keys) or found.keys[index] is None:
        return None
    return found.keys[index].lineno


def _entry(exc, index):
    """``exc`` (an Invalid) marked with the position of its state in the user's dict."""
    exc.entry = index
    return exc


def _read(states):
    """[(state, rate)] of the model's ``states`` dict."""
    if states is None:
        return []
    if not isinstance(states, Mapping):
        if hasattr(states, "__iter__") and not isinstance(states, str):
            items = list(states)
            label = _label(items[0]) if items else "z"
            raise Invalid("states", f"`states` lists {len(items)} state(s) without derivatives; give a "
                                    f"dict state -> derivative, e.g. `states = {{{label}: ...}}`")
        raise Invalid("states", f"`states` must be a dict state -> derivative, not {type(states).__name__}")
    out = []
    for index, (z, value) in enumerate(states.items()):
        if not (isinstance(z, AppliedUndef) and z.args == (_T,)):
            raise _entry(Invalid("states", f"state {z!r} is not a dynamic symbol of t (use "
                                           f"dynamicsymbols('{z}'))"), index)
        try:
            out.append((z, _rate(value, _label(z))))
        except Invalid as exc:
            raise _entry(exc, index) from None
    return out


def _check_rate(z, rate, states, formed, inputs, parameters):
    """``rate`` may use t, q, u, q', the states, inputs and parameters; what it adds is returned."""
    label = _label(z)
    bad = non_real_constants([rate])
    if bad:
        raise Invalid("states", f"the derivative of state `{label}` contains {' and '.join(bad)}: "
                                f"{_short(rate, 120)}")
    q, u = set(formed.coordinates), set(formed.speeds)
    for d in rate.atoms(sm.Derivative):
        base = d.expr
        order = sum(n for _, n in d.variable_count)
        if base in q and order == 1:
            continue
        what = _label(base)
        if base in u or (base in q and order == 2):
            raise Invalid("states", f"the derivative of state `{label}` uses {what}'"
                                    f"{chr(39) if order == 2 else ''} (an acceleration): extra states must be "
                                    f"explicit, z' = g(t, q, u, z, inputs); an acceleration-dependent state is "
                                    f"not supported")
        if base in states:
            raise Invalid("states", f"the derivative of state `{label}` uses {what}' (the derivative of a "
                                    f"state): give every derivative explicitly")
        raise Invalid("states", f"the derivative of state `{label}` uses {what}' (the time derivative of "
                                f"{what}), which is not a coordinate's rate")
    dynamic = {f for f in rate.atoms(AppliedUndef)}
    new_inputs = dynamic - q - u - set(states) - set(formed.inputs)
    if inputs is not None:
        undeclared = [i for i in new_inputs if i not in set(inputs)]
        if undeclared:
            raise Invalid("states", f"the derivative of state `{label}` uses {_names(undeclared)}, which is "
                                    f"not a coordinate, speed, state or input of the model (`inputs` lists "
                                    f"{_names(inputs)})")
    symbols = {s for s in rate.free_symbols if s != _T}
    new_params = symbols - set(formed.parameters)
    if parameters is not None:
        given = {str(k) if isinstance(k, str) else k.name for k in parameters}
        undeclared = [s for s in new_params if s.name not in given]
        if undeclared:
            raise Invalid("states", f"the derivative of state `{label}` uses {_names(undeclared)}, which "
                                    f"`parameters` does not declare (nor do the equations of motion use "
                                    f"{'it' if len(undeclared) == 1 else 'them'})")
    return new_inputs, new_params


def _about(exc, z):
    exc.state = z
    return exc


def attach_states(formed, states=None, system=None, inputs=None, parameters=None):
    """``formed`` (a FormedSystem, or a Model read as a tree) with the extra first-order states of ``states`` (dict) and of ``system``'s
    musculotendons attached (see the module docstring); ``formed`` itself without any.

    ``inputs``/``parameters``: the model's own lists, when it gives them: a derivative
    that uses a symbol neither declares is refused, naming the state.
    """
    given = _read(states)
    declared = {z for z, _ in given}
    auto = [(z, r, where) for z, r, where in musculotendon_states(system) if z not in declared]
    # where each state came from: its position in the user's dict, or the musculotendon
    origin = {z: where for z, _, where in auto}
    origin.update({z: i for i, (z, _) in enumerate(given)})
    pairs = [(z, r) for z, r, _ in auto] + given
    if not pairs:
        return formed
    try:
        return _attach(formed, pairs, inputs, parameters)
    except Invalid as exc:
        z = getattr(exc, "state", None)
        if isinstance(origin.get(z), str):      # a musculotendon's: reported at `system`
            raise Invalid("system", f"{exc} (a state of {origin[z]})") from None
        if z in origin:
            _entry(exc, origin[z])
        raise


def _attach(formed, pairs, inputs, parameters):
    taken = {}
    for z in tuple(formed.coordinates) + tuple(formed.speeds):
        taken[_label(z)] = "a coordinate" if z in set(formed.coordinates) else "a speed"
    for p in formed.parameters:
        taken.setdefault(p.name, "a parameter")
    seen = []
    for z, _ in pairs:
        label = _label(z)
        if z in seen:
            raise _about(Invalid("states", f"state `{label}` is given twice"), z)
        if label in taken:
            raise _about(Invalid("states", f"state `{label}` has the name of {taken[label]} of the "
                                           f"system; a state needs a name of its own"), z)
        seen.append(z)
    zs = tuple(z for z, _ in pairs)
    new_inputs, new_params = set(), set()
    for z, rate in pairs:
        try:
            ni, np_ = _check_rate(z, rate, zs, formed, inputs, parameters)
        except Invalid as exc:
            raise _about(exc, z) from None
        new_inputs |= ni
        new_params |= np_
    names = {_label(z) for z in zs}
    for s in new_params | new_inputs:
        if _label(s) in names:
            raise Invalid("states", f"state `{_label(s)}` has the name of a symbol its derivatives use")
    kept = tuple(i for i in formed.inputs if i not in set(zs))
    if inputs is not None:
        unlisted = [i for i in kept if i not in set(inputs)]
        if unlisted:
            raise Invalid("states", f"the equations of motion use {_names(unlisted)}, which is neither "
                                    f"a state nor listed in `inputs`: if it is a state, give its "
                                    f"derivative in `states = {{{_label(unlisted[0])}: ...}}`")
    out = replace(formed, extra_states=zs, extra_rhs=tuple(r for _, r in pairs),
                  inputs=kept + tuple(sorted(new_inputs - set(kept), key=str)),
                  parameters=tuple(sorted(set(formed.parameters) | new_params, key=lambda s: s.name)))
    return out    # a Model (a tree read, nothing formed) stays one, tree, frames and poses kept
