"""Check the optional model-file variables (parameters, inputs, initial_state, outputs).

Each checker returns a normalized value or raises :class:`Invalid` naming the
variable and what is wrong; the caller adds where (file:line or argument).
Checks are against the formed system, so a misspelled parameter or an output
that uses an unknown dynamic symbol is caught before any code is generated.
"""
import keyword
import numbers
import re
from collections.abc import Mapping

import sympy as sm
from sympy.core.function import AppliedUndef

from ..emit.layout import sanitize_name  # noqa: F401 -- model files' names; the CLI imports it here
from ..ir.program import distinct_atoms
from ..mechanics.formed import FormedSystem

__all__ = ["Invalid", "check_functions", "FUNCTIONS", "check_parameters", "check_inputs", "check_initial_state", "check_outputs",
           "check_name", "sanitize_name", "check_equations", "non_real_constants", "unset_parameters"]

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class Invalid(ValueError):
    """A model variable is wrong: ``variable`` names it, the message says why."""

    def __init__(self, variable, message):
        super().__init__(message)
        self.variable = variable


def _real(value, what, variable):
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, sm.Basic)):
        raise Invalid(variable, f"{what} must be a real number, not {type(value).__name__} {value!r}")
    try:
        number = float(value)
    except OverflowError:
        raise Invalid(variable, f"{what} must be a finite real number; {_short(value)} is too large "
                                f"for a double") from None
    except (TypeError, ValueError):
        raise Invalid(variable, f"{what} must be a real number, not the expression {value}") from None
    if number != number or number in (float("inf"), float("-inf")):
        # the C code would hold `nan`/`inf` literals (which do not compile) or run on them silently
        raise Invalid(variable, f"{what} must be a finite real number, not {value}")
    return number


def _short(value, limit=60):
    if isinstance(value, int) and abs(value).bit_length() > 200:
        return f"an integer of about {int(abs(value).bit_length() * 0.30103)} digits"
    text = str(value)
    return text if len(text) <= limit else text[:limit - 5] + " ..."


# Constants that have no place in real-valued C code, and what to tell the user about each.
_NON_REAL = {
    sm.zoo: "zoo (complex infinity: a division by zero?)",
    sm.nan: "nan (not a number: 0/0 or oo - oo?)",
    sm.oo: "oo (infinity)",
    sm.S.NegativeInfinity: "-oo (infinity)",
    sm.I: "I (the imaginary unit: eomc models are real-valued)",
}


def non_real_constants(exprs):
    """The plain words for every non-real or infinite constant (zoo, nan, oo, I) in ``exprs``.

    Walks each shared subexpression once (the formed equations are DAGs that
    can be far larger as trees), so it stays cheap on big models.
    """
    found = []
    for e in distinct_atoms(exprs):
        if e.is_number and not (e.is_extended_real and e.is_finite):
            word = _NON_REAL.get(e, f"{e} (not a finite real number)")
            if word not in found:
                found.append(word)
    return found


def _derivative_inputs(formed):
    return [i for i in formed.inputs if isinstance(i, sm.Derivative)]


def check_equations(formed):
    """The model must have states; its equations must be real and finite, and their inputs
    plain dynamic symbols.

    Caught here, the user hears which equation is wrong at the `system` line;
    left alone, zoo/nan/I reach the C printer (a SymPy traceback) or the C
    compiler (`'I' undeclared`), and the derivative of an undeclared dynamic
    symbol w would silently become a second, independent input named w'.
    """
    if not _states(formed):
        # Left alone, a 0-state model builds and the integrator then fails with "bad argument
        # (the model failed at t=nan ...)", which names nothing (reliability r3: an empty System).
        raise Invalid("system", "the system has no coordinates, speeds or states: a model without "
                                "states has nothing to integrate; add a joint (or q_ind/u_ind) that moves "
                                "a body")
    derivs = _derivative_inputs(formed)
    if derivs:
        d = derivs[0]
        base = _label(d.expr)
        raise Invalid("system", f"the equations of motion use {base}' (the time derivative of {base}), "
                                f"but {base} is not a coordinate or speed: eomc would have to treat "
                                f"{base}' as a second input unrelated to {base}. Make {base} a coordinate "
                                f"(with a speed and a kinematic equation), or give its rate its own "
                                f"input symbol")
    parts = [("kinematic equation of " + _label(q), [k]) for q, k in zip(formed.coordinates, formed.kinematics)]
    if isinstance(formed, FormedSystem):    # a Model (a tree read) has no A and b
        nrows = formed.dynamics_matrix.rows
        parts += [(f"mass matrix row {i + 1}", list(formed.dynamics_matrix.row(i))) for i in range(nrows)]
        parts += [(f"forcing row {i + 1}", [e]) for i, e in enumerate(formed.dynamics_rhs)]
    parts += [(f"holonomic constraint {i + 1}", [e]) for i, e in enumerate(formed.holonomic_constraints)]
    parts += [(f"velocity constraint {i + 1}", [e]) for i, e in enumerate(formed.velocity_constraints)]
    for where, exprs in parts:
        bad = non_real_constants(exprs)
        if bad:
            culprit = next(e for e in exprs if non_real_constants([e]))
            raise Invalid("system", f"the {where} contains {' and '.join(bad)}: {_short(culprit, 120)}; "
                                    f"eomc compiles real, finite equations only")
    return formed


def unset_parameters(formed, parameters):
    """Parameters that silently default to 1.0 because the model gives no `parameters` dict."""
    return [] if parameters is not None else sorted(formed.parameters, key=lambda s: s.name)


def _dynamic(expr):
    return {f for f in sm.sympify(expr).atoms(AppliedUndef)}


def _label(symbol):
    """q for the dynamic symbol q(t), the plain name otherwise."""
    return symbol.func.__name__ if isinstance(symbol, AppliedUndef) else str(symbol)


def _names(symbols):
    return ", ".join(sorted(_label(s) for s in symbols)) or "none"


def _states(formed):
    return tuple(formed.coordinates) + tuple(formed.speeds) + tuple(getattr(formed, "extra_states", ()))


def _state_rate(d, formed):
    """A derivative an output may use: a coordinate's rate or acceleration (q', q''), or a
    speed's rate (u'), which the generated code takes from the solved dynamics."""
    order = sum(n for _, n in d.variable_count)
    if d.expr in set(formed.coordinates):
        return order <= 2
    return d.expr in set(formed.speeds) and order == 1


def check_outputs(outputs, formed):
    """dict name -> SymPy expression in q, u, t, parameters and inputs."""
    if outputs is None:
        return None
    if not isinstance(outputs, Mapping):
        raise Invalid("outputs", f"`outputs` must be a dict name -> expression, not {type(outputs).__name__}")
    allowed = set(_states(formed)) | set(formed.inputs) | set(formed.multipliers)
    result = {}
    for name, expr in outputs.items():
        if not isinstance(name, str) or not _IDENT.match(name) or keyword.iskeyword(name):
            raise Invalid("outputs", f"output name {name!r} must be an identifier (letters, digits, _)")
        try:
            value = sm.sympify(expr)
        except (sm.SympifyError, TypeError):
            raise Invalid("outputs", f"output `{name}` is not a SymPy expression: {expr!r}") from None
        if not isinstance(value, sm.Expr):
            raise Invalid("outputs", f"output `{name}` must be a scalar expression, not {type(value).__name__}")
        bad = non_real_constants([value])
        if bad:
            raise Invalid("outputs", f"output `{name}` contains {' and '.join(bad)}: {_short(value, 120)}; "
                                     f"outputs must be real and finite")
        stray_rates = [d for d in value.atoms(sm.Derivative) if not _state_rate(d, formed)]
        if stray_rates:
            base = _label(stray_rates[0].expr)
            raise Invalid("outputs", f"output `{name}` uses {base}' (the time derivative of {base}), "
                                     f"which is not a coordinate's rate or a state of the system")
        stray = _dynamic(value) - allowed
        if stray:
            raise Invalid("outputs", f"output `{name}` uses {_names(stray)}, which is not a coordinate, "
                                     f"speed or input of the system (those are {_names(allowed)})")
        result[name] = value
    return result


def check_events(events, formed):
    """dict name -> expression, or name -> {"expr": ..., "terminal": ..., "direction": ...}.

    Returns (expressions, options): {name: SymPy expression} and a list of
    {"name", "terminal", "direction"} in the same order (the simulate defaults).
    """
    if events is None:
        return None, None
    if not isinstance(events, Mapping):
        raise Invalid("events", f"`events` must be a dict name -> expression, not {type(events).__name__}")
    exprs, options = {}, []
    for name, value in events.items():
        opts = {}
        if isinstance(value, Mapping):
            unknown = set(value) - {"expr", "terminal", "direction"}
            if "expr" not in value or unknown:
                raise Invalid("events", f"event `{name}`: a dict value needs \"expr\" and may have "
                                        f"\"terminal\" and \"direction\""
                                        + (f" (unknown: {', '.join(sorted(map(str, unknown)))})" if unknown else ""))
            opts = {k: value[k] for k in ("terminal", "direction") if k in value}
            value = value["expr"]
        terminal, direction = opts.get("terminal", 0), opts.get("direction", 0)
        if isinstance(terminal, bool):
            terminal = int(terminal)
        if not isinstance(terminal, numbers.Integral) or terminal < 0:
            raise Invalid("events", f"event `{name}`: terminal must be True/False or a count >= 0, "
                                    f"not {terminal!r}")
        if isinstance(direction, bool) or direction not in (-1, 0, 1):
            raise Invalid("events", f"event `{name}`: direction must be -1, 0 or +1, not {direction!r}")
        try:
            exprs.update(check_outputs({name: value}, formed))
        except Invalid as exc:
            raise Invalid("events", str(exc).replace("output", "event")) from None
        options.append({"name": name, "terminal": int(terminal), "direction": int(direction)})
    return exprs, options


def check_parameters(parameters, formed, outputs=None):
    """dict Symbol (or its name) -> default value; every key must appear in the model, and
    every parameter of the equations of motion needs a key (None: all default to 1.0).

    Parameters used only in outputs or events (a ball's radius in its impact event) are
    parameters like the others: with no dict they default to 1.0 too."""
    if parameters is None:
        extra = set()
        for expr in (outputs or {}).values():
            extra |= {s for s in expr.free_symbols if isinstance(s, sm.Symbol)}
        extra.discard(sm.Symbol("t"))
        extra -= set(formed.parameters)
        if not extra:
            return None
        return {s: 1.0 for s in sorted(set(formed.parameters) | extra, key=lambda s: s.name)}
    if not isinstance(parameters, Mapping):
        raise Invalid("parameters", f"`parameters` must be a dict symbol -> default value, "
                                    f"not {type(parameters).__name__}")
    known = {s for s in formed.parameters}
    for expr in (outputs or {}).values():
        known |= {s for s in expr.free_symbols if isinstance(s, sm.Symbol)}
    known.discard(sm.Symbol("t"))
    by_name = {str(s): s for s in known}
    result = {}
    for key, value in parameters.items():
        symbol = by_name.get(key) if isinstance(key, str) else key
        if symbol is None or symbol not in known:
            raise Invalid("parameters", f"unknown parameter `{key}`: it does not appear in the equations "
                                        f"of motion or outputs (parameters: {_names(known)})")
        result[symbol] = _real(value, f"the default of parameter `{key}`", "parameters")
    missing = set(formed.parameters) - set(result)
    if missing:
        # A partial dict is almost always a forgotten entry; a silent 1.0 would be a wrong model.
        raise Invalid("parameters", f"no default value for {_names(missing)}: the equations of motion use "
                                    f"{'it' if len(missing) == 1 else 'them'}, so `parameters` must give "
                                    f"{'it' if len(missing) == 1 else 'each'} a value")
    return result


def check_inputs(inputs, formed):
    """Sequence of the system's input dynamic symbols, in the order the user wants them."""
    if inputs is None:
        return None
    if isinstance(inputs, (str, Mapping)) or not hasattr(inputs, "__iter__"):
        raise Invalid("inputs", f"`inputs` must be a list of dynamic symbols, not {type(inputs).__name__}")
    inputs = list(inputs)
    for item in inputs:
        if not isinstance(item, AppliedUndef):
            raise Invalid("inputs", f"input {item} is not a dynamic symbol (use dynamicsymbols('F'))")
    # sets, not lists: `x in list` compares SymPy functions one by one (quadratic: a 5000-joint
    # robot spent most of its derivation here)
    known, listed = set(formed.inputs), set(inputs)
    unknown = [i for i in inputs if i not in known]
    if unknown:
        raise Invalid("inputs", f"unknown input(s) {_names(unknown)}: not in the equations of motion "
                                f"(the system's inputs: {_names(formed.inputs)})")
    missing = [i for i in formed.inputs if i not in listed]
    if missing:
        raise Invalid("inputs", f"the equations of motion use input(s) {_names(missing)} that `inputs` "
                                f"does not list")
    if len(listed) != len(inputs):
        raise Invalid("inputs", "`inputs` lists a symbol twice")
    return inputs


def check_initial_state(initial_state, formed):
    """dict coordinate/speed -> value, returned as a list in state order (missing ones are 0)."""
    if initial_state is None:
        return None
    if not isinstance(initial_state, Mapping):
        raise Invalid("initial_state", f"`initial_state` must be a dict coordinate/speed -> value, "
                                       f"not {type(initial_state).__name__}")
    states = _states(formed)
    by_name = {_label(s): s for s in states}
    x0 = dict.fromkeys(states, 0.0)
    for key, value in initial_state.items():
        symbol = by_name.get(key) if isinstance(key, str) else key
        if symbol not in x0:
            raise Invalid("initial_state", f"`{key}` in initial_state is not a coordinate or speed "
                                           f"(states: {', '.join(map(_label, states))})")
        x0[symbol] = _real(value, f"initial_state[{_label(symbol)}]", "initial_state")
    return [x0[s] for s in states]


def check_name(name):
    if not isinstance(name, str) or not _IDENT.match(name):
        raise Invalid("name", f"model name {name!r} must be a C identifier (letters, digits, _; "
                              f"not starting with a digit)")
    return name


FUNCTIONS = ("rhs", "jac_x", "jac_r", "jac_p", "mass_matrix", "forcing", "inverse_dynamics", "outputs", "energy",
             "constraints", "constraints_jac", "linearize", "events", "poses", "regressor", "jvp", "jvp_more", "jac_id",
             "vjp", "hvp", "hess_id", "implicit", "rhs_batch", "jac_x_batch", "outputs_batch",
             "implicit_batch")
ALIASES = {"jacobian": ("jac_x",), "input_jacobian": ("jac_r",), "parameter_jacobian": ("jac_p",), "constraints_jacobian": ("constraints_jac",)}


def check_functions(functions):
    """The generated-function list (``--outputs``): names or aliases, comma-separated string allowed."""
    if functions is None:
        return None
    if isinstance(functions, str):
        functions = [f.strip() for f in functions.split(",") if f.strip()]
    result = []
    for f in functions:
        for name in ALIASES.get(f, (f,)):
            if name not in FUNCTIONS:
                raise Invalid("functions", f"unknown function {f!r} to generate; choose from "
                                           f"{', '.join(FUNCTIONS + tuple(ALIASES))}")
            if name not in result:
                result.append(name)
    if not result:
        raise Invalid("functions", "no functions to generate were named")
    return result
