"""A jvp tangent's two-seed entries written as one coefficient times a seed difference.

Kane's one-direction tangent is bound by its multiplications (benchmarks/results/
sensitivity_dop853.md, session 19): the n-link cart's mass-matrix entries
m (C_i C_j + S_i S_j) (C = l cos q, S = l sin q) differentiate to
m ((dC_j C_i + C_j dC_i) + (dS_i S_j + S_i dS_j)) with dC = -S dq, dS = C dq: five products
and three sums per direction.  Collected per seed the same entry is
m ((C_i S_j - S_i C_j) dq_i + (S_i C_j - C_i S_j) dq_j), two coefficients equal up to sign,
so it is m (C_i S_j - S_i C_j) (dq_i - dq_j): four products and two sums, the coefficient
free of the direction.

:func:`seed_pairs` does that for any tangent temporary of this shape: a sum of products whose
factors are primal temporaries and tangent temporaries each one primal monomial times one
seed.  Expanded over leaves (the primal monomials' own factors), it must depend on exactly two
seeds with coefficients that cancel; the coefficient is then folded back into the primal's
monomial temporaries (``l cos q`` is the primal's own temporary) and the rewrite is kept only
when it has fewer operations than the entry it replaces.  Exact in real arithmetic; in floating
point another rounding of the same value (the 8-link cart's J·d within 3e-12 of the tangent as
differentiated on values up to 1.4e3; whole DOP853 runs' S within 2.3e-14, relative).
"""
import sympy as sm

from ..ir import symbols_of
from ..ir.opcount import count_ops

__all__ = ["seed_pairs", "SEED_PAIRS"]

SEED_PAIRS = True    # off: the tangent as differentiated (compiler/build/reuse.generator_switches)

MAX_TERMS = 8       # products in a candidate entry (the cart's: 4)
MAX_FACTORS = 4     # leaves of a primal monomial expanded (l cos q: 2)


def _weight(expr):
    c = count_ops(expr)
    return sum(c.values())


def _monomial(expr, defs, depth=0):
    """``expr`` as a tuple of leaf factors and a sign, when it is a product of primal
    monomials (each at most MAX_FACTORS leaves); else None."""
    if isinstance(expr, sm.Symbol):
        d = defs.get(expr)
        if d is not None and depth < 3 and isinstance(d, sm.Mul):
            m = _monomial(d, defs, depth + 1)
            if m is not None and len(m[1]) <= MAX_FACTORS:
                return m
        return 1, (expr,)
    if isinstance(expr, sm.Mul):
        sign, leaves = 1, []
        for a in expr.args:
            if a == -1:
                sign = -sign
                continue
            m = _monomial(a, defs, depth)
            if m is None:
                return None
            sign *= m[0]
            leaves += m[1]
        return sign, tuple(leaves)
    return None


def seed_pairs(inner, seeds, primal):
    """``inner``: the tangent's assignments (order kept), ``seeds``: the direction's symbols,
    ``primal``: {symbol: expr} of the primal temporaries in scope.  Returns the assignments
    with each two-seed entry rewritten where that has fewer operations; the others as they
    are (the caller drops the temporaries no longer read)."""
    seedset = set(seeds)
    defs = {t: e for t, e in primal.items() if isinstance(e, sm.Mul)}
    lin = {}                    # tangent temporary -> (sign, primal leaves, seed)
    monos = None
    out = []
    for t, e in inner:
        new = None
        m = _linear(e, lin, seedset, defs)
        if m is not None:
            lin[t] = m
        elif isinstance(e, sm.Mul):
            coef = _pair(e, lin, seedset, defs)
            if coef is not None:
                if monos is None:
                    monos = _monomials(defs)
                outer, ci, si, sj = coef
                new = sm.Mul(*outer) * _fold(ci, monos) * (si - sj)
                if not _weight(new) < _weight(e):
                    new = None
        out.append((t, new if new is not None else e))
    return out


def _linear(e, lin, seedset, defs):
    """(sign, leaves, seed) when ``e`` is one seed times primal monomials, else None."""
    sign, leaves, seed = 1, [], None
    for a in _factors(e):
        if a == -1:
            sign = -sign
        elif a in seedset or a in lin:
            if seed is not None:
                return None
            if a in seedset:
                seed = a
            else:
                s, lv, seed = lin[a]
                sign *= s
                leaves += lv
        else:
            m = _monomial(a, defs)
            if m is None or symbols_of(a) & seedset:
                return None
            sign *= m[0]
            leaves += m[1]
    return None if seed is None else (sign, tuple(leaves), seed)


def _factors(e):
    """The factors of a (possibly nested, unevaluated) product."""
    if not isinstance(e, sm.Mul):
        return [e]
    out = []
    for a in e.args:
        out += _factors(a)
    return out


def _pair(e, lin, seedset, defs):
    """m * (sum of products) with seed coefficients c, -c: (m's factors, c, s_i, s_j), or None."""
    outer = [a for a in e.args if not isinstance(a, sm.Add)]
    sums = [a for a in e.args if isinstance(a, sm.Add)]
    if len(sums) != 1 or any(symbols_of(a) & (seedset | set(lin)) for a in outer):
        return None
    terms = _flat_terms(sums[0])
    if terms is None or len(terms) > MAX_TERMS:
        return None
    coef = {}
    for term in terms:
        m = _linear(term, lin, seedset, defs)
        if m is None:
            return None
        sign, leaves, seed = m
        coef[seed] = coef.get(seed, 0) + sign * sm.Mul(*leaves)
    if len(coef) != 2:
        return None
    (si, ci), (sj, cj) = sorted(coef.items(), key=lambda kv: str(kv[0]))
    ci, cj = sm.expand(ci), sm.expand(cj)
    if ci == 0 or sm.expand(ci + cj) != 0:
        return None
    return outer, ci, si, sj


def _flat_terms(add):
    """The products of a (possibly nested, unevaluated) sum, or None when a term is a sum
    inside a product."""
    out = []
    stack = [add]
    while stack:
        a = stack.pop()
        if isinstance(a, sm.Add):
            stack.extend(reversed(a.args))
        else:
            out.append(a)
    return out


def _monomials(defs):
    """The primal's temporaries that are a product of two leaves, in the primal's order."""
    monos = []
    for t, d in defs.items():
        m = _monomial(d, defs)
        if m is not None and m[0] == 1 and len(m[1]) == 2:
            monos.append((t, sorted(m[1], key=str)))
    return monos


def _fold(expr, monos):
    """The expanded coefficient with the primal's monomial temporaries put back for their
    factors (the first one each product finds, in the primal's order)."""
    out = []
    for term in sm.Add.make_args(expr):
        c, factors = term.as_coeff_mul()
        factors = list(factors)
        kept = []
        for t, leaves in monos:
            if all(factors.count(x) >= leaves.count(x) for x in leaves):
                for x in leaves:
                    factors.remove(x)
                kept.append(t)
        out.append(c * sm.Mul(*(kept + factors)))
    return sm.Add(*out)
