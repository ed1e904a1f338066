"""Where each symbol of a formed system lives in the C arrays.

q(t), u(t), then the extra first-order states z(t) -> x[i]; inputs r(t) -> r[k]; parameters -> p[j]; time -> t.
Expressions are rewritten with plain slot symbols once (``xreplace``), so
every later stage works on ordinary SymPy expressions of those symbols.
"""
import re
from dataclasses import dataclass

import sympy as sm
from sympy.core.function import AppliedUndef
from sympy.physics.vector import dynamicsymbols

from eomc.runtime.errors import ModelError

__all__ = ["Layout", "make_layout", "check_identifier", "sanitize_name", "DEFAULT_PARAMETER_VALUE"]

DEFAULT_PARAMETER_VALUE = 1.0
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class Layout:
    x: tuple            # slot symbols x_0.. (nx)
    p: tuple            # slot symbols of runtime parameters
    r: tuple            # slot symbols of inputs
    t: sm.Symbol
    subs: dict          # mechanics object -> slot symbol (or folded value)
    state_names: tuple
    param_names: tuple
    param_defaults: tuple
    input_names: tuple
    folded: dict        # parameter name -> value, when folded
    c_names: dict       # slot symbol -> C text

    def apply(self, expr, what, memo=None, keep=()):
        """``expr`` in slot symbols; ModelError naming ``what`` if something is left unmapped.

        A memoized rename: subtrees shared between entries are rebuilt once, and unmapped
        dynamic symbols or constants are found in the same walk.  Pass one ``memo`` dict
        for related calls.
        """
        memo = {} if memo is None else memo
        bad = []
        subs = {**self.subs, **{k: k for k in keep}} if keep else self.subs   # keep: symbols left as they are
        out = _rename(sm.sympify(expr), subs, memo, bad)
        if bad:
            deps = sorted({str(b) for b in bad if not b.is_Symbol})
            if deps:
                raise ModelError(f"{what} depends on {', '.join(deps)}, which is neither a "
                                 f"coordinate, a speed nor a declared input")
            names = ", ".join(sorted({b.name for b in bad}))
            raise ModelError(f"{what} uses symbol(s) {names} that are not parameters of the model")
        return out


def _rename(expr, subs, memo, bad):
    """Rebuild ``expr`` with atoms/dynamic symbols replaced by ``subs``; record leftovers in ``bad``.

    Nodes are rebuilt with SymPy's evaluation (it canonicalizes products, which CSE
    profits from, and folds parameters replaced by numbers).
    """
    hit = subs.get(expr)
    if hit is not None:
        return hit
    if expr.is_Atom:
        if expr.is_Symbol:
            bad.append(expr)
        return expr
    done = memo.get(expr)
    if done is not None:
        return done
    if isinstance(expr, (AppliedUndef, sm.Derivative)):
        bad.append(expr)
        return expr
    args = [_rename(a, subs, memo, bad) for a in expr.args]
    out = power_as_it_stands(*args) if expr.is_Pow else None
    if out is None:
        out = expr.func(*args)
    memo[expr] = out
    return out


_NOT_FINITE_OR_REAL = (sm.I, sm.oo, -sm.oo, sm.zoo, sm.nan)


def power_as_it_stands(base, e):
    """``base**e`` built as it stands where SymPy's evaluation provably leaves it so, else None:
    a sum that is not a number, with no I and no infinity in it, to a rational power other than
    0 and 1 (Pow.__new__ then asks Add._eval_power, which returns something only for a number or
    for a two-term sum with an infinite term and an imaginary literal).  Why: Add._eval_power
    asks whether each term is infinite, which SymPy answers by walking the MJCF limit laws' and
    contacts' sums per rename: 0.15 s of the humanoid's generate (session 22).  The same
    expression, the same C."""
    if (base.is_Add and e.is_Rational and e is not sm.S.Zero and e is not sm.S.One
            and not base.is_number and not base.has(*_NOT_FINITE_OR_REAL)):
        return sm.Pow(base, e, evaluate=False)
    return None


def _name(obj):
    """``q1`` for q1(t), ``q1'`` for its derivative (Lagrange's speeds)."""
    if isinstance(obj, sm.Derivative):
        return _name(obj.expr) + "'" * sum(n for _, n in obj.variable_count)
    return str(obj).replace("(t)", "")


def _parameter_table(formed, parameters, uses=()):
    """Ordered (symbol, default) pairs: the dict's order, then the rest sorted by name.

    ``uses``: the symbols the outputs and events use -- a parameter used only there (a ball's
    radius in its impact event) is a parameter like the others."""
    parameters = dict(parameters or {})
    known = set(formed.parameters) | set(uses)
    unknown = [s for s in parameters if s not in known]
    if unknown:
        raise ModelError("parameters used neither by the system nor by its outputs or events: "
                         + ", ".join(map(str, unknown)))
    table = [(s, float(v)) for s, v in parameters.items()]
    rest = sorted((s for s in formed.parameters if s not in parameters), key=lambda s: s.name)
    table += [(s, DEFAULT_PARAMETER_VALUE) for s in rest]
    return table


def make_layout(formed, parameters=None, inputs=None, fold_parameters=False, uses=()):
    """The slot assignment of ``formed`` (see module docstring)."""
    inputs = tuple(formed.inputs if inputs is None else inputs)
    missing = [i for i in formed.inputs if i not in inputs]
    if missing:
        raise ModelError("the system depends on inputs not listed in `inputs`: "
                         + ", ".join(map(_name, missing)))
    t = sm.Symbol("t", real=True)
    states = tuple(formed.coordinates) + tuple(formed.speeds) + tuple(getattr(formed, "extra_states", ()))
    x = tuple(sm.Symbol(f"x_{i}", real=True) for i in range(len(states)))
    r = tuple(sm.Symbol(f"r_{k}", real=True) for k in range(len(inputs)))
    table = _parameter_table(formed, parameters, uses)
    subs = {dynamicsymbols._t: t}
    subs.update(zip(states, x))
    subs.update(zip(inputs, r))
    c_names = {t: "t"}
    c_names.update({s: f"x[{i}]" for i, s in enumerate(x)})
    c_names.update({s: f"r[{k}]" for k, s in enumerate(r)})
    if fold_parameters:
        p, folded = (), {s.name: v for s, v in table}
        subs.update({s: sm.Float(v) for s, v in table})
        table = []
    else:
        p, folded = tuple(sm.Symbol(f"p_{j}", real=True) for j in range(len(table))), {}
        subs.update({s: ps for (s, _), ps in zip(table, p)})
        c_names.update({s: f"p[{j}]" for j, s in enumerate(p)})
    return Layout(x=x, p=p, r=r, t=t, subs=subs,
                  state_names=tuple(_name(s) for s in states),
                  param_names=tuple(s.name for s, _ in table),
                  param_defaults=tuple(v for _, v in table),
                  input_names=tuple(_name(i) for i in inputs),
                  folded=folded, c_names=c_names)


def sanitize_name(stem):
    """A C identifier from a file stem: other characters become _, a leading digit gets a prefix."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem)
    return name if _IDENT.match(name) else f"model_{name}"


def check_identifier(name):
    """ModelError unless ``name`` can prefix C identifiers."""
    if not isinstance(name, str) or not _IDENT.match(name):
        raise ModelError(f"model name {name!r} is not a valid C identifier "
                         "(letters, digits and _, not starting with a digit)")
    return name
