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

:func:`seed_monomials` (session 20) then puts the one-seed monomials on the primal's own
products: d(l sin q) = ``(-sin q dq) l`` becomes ``-(l sin q) dq`` and a product such as
``m (-sin q dq) l w`` reads that temporary (``m (l sin q dq) w``, one product fewer), the
plain factors of a primal two-leaf temporary become that temporary.  8-link cart: jvp with one
direction 267 -> 262 ns in a C loop, whole DOP853 one-parameter runs 1.437 -> 1.404x a plain
run (in-process A/B, two library copies each), J·d within 5.1e-13 of before on values up to
1.4e3, S within 1.7e-14 (one parameter) and 3.2e-14 (four), relative.
"""
from itertools import combinations

import sympy as sm

from ..ir import needed_assignments, symbols_of
from ..ir.opcount import count_ops

__all__ = ["seed_pairs", "seed_monomials", "SEED_PAIRS", "SEED_MONOMIALS"]

SEED_PAIRS = True    # off: the tangent as differentiated (compiler/build/reuse.generator_switches)
SEED_MONOMIALS = True   # off: the one-seed monomials as differentiated (same)

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


def seed_monomials(inner, results, seeds, primal):
    """The tangent's one-seed monomials on the primal's own products (session 20).

    The differentiated tangent writes d(l sin q) as ``(-sin q * dq) * l`` and
    ``l * (cos q * dq)`` and multiplies such a temporary by further primal factors inside
    larger products (``m * (-sin q * dq) * l * w``), though the primal already holds
    ``l sin q`` and ``l cos q``.  Here
    - a temporary that is one seed times primal monomials is written as its sign, the
      primal's two-leaf temporaries covering its leaves (:func:`_fold`) and the seed:
      ``-(l sin q) * dq``, ``(l cos q) * dq``;
    - inside any other product, a one-seed factor takes in the product's plain factors when
      an earlier one-seed temporary is exactly that product (``(-sin q * dq) * l`` is
      ``-(l sin q) * dq``, already a temporary), and the plain factors that make up a primal
      two-leaf temporary are replaced by it (``cos q * l`` -> ``l cos q``).
    ``inner``: the tangent's assignments (order kept), ``results``: {key: expr} read after
    them, ``seeds``, ``primal``: as :func:`seed_pairs`.  Returns (assignments, results); the
    caller drops the temporaries no longer read.  Kept only when the needed program has
    fewer operations.  Exact in real arithmetic; in floating point the products associate
    otherwise (another rounding of the same value)."""
    seedset = set(seeds)
    defs = {t: e for t, e in primal.items() if isinstance(e, sm.Mul)}
    monos = _monomials(defs)
    lin, index = {}, {}
    out = []
    for t, e in inner:
        m = _linear(e, lin, seedset, defs)
        if m is not None:
            sign, leaves, seed = m
            new = sm.Mul(sign, _fold(sm.Mul(*leaves), monos), seed)
            lin[t] = m
            index.setdefault((seed, _key(leaves)), (t, sign))
        else:
            new = _absorb(e, lin, index, seedset, monos)
        out.append((t, new))
    res = {k: _absorb(e, lin, index, seedset, monos) for k, e in results.items()}
    if _program_weight(out, res.values()) < _program_weight(inner, results.values()):
        return out, res
    return list(inner), dict(results)


def _key(leaves):
    return tuple(sorted(leaves, key=str))


def _program_weight(assignments, exprs):
    """Operations of the assignments ``exprs`` read (directly or through each other) and of
    ``exprs``."""
    return (sum(_weight(e) for _, e in needed_assignments(assignments, exprs))
            + sum(_weight(e) for e in exprs))


def _absorb(e, lin, index, seedset, monos):
    """``e`` with its products rewritten as :func:`seed_monomials` says."""
    if isinstance(e, sm.Add):
        args = [_absorb(a, lin, index, seedset, monos) for a in e.args]
        return e if all(a is b for a, b in zip(args, e.args)) else sm.Add(*args)
    if not isinstance(e, sm.Mul):
        return e
    orig = _factors(e)
    factors = [_absorb(a, lin, index, seedset, monos) for a in orig]
    nested = any(a is not b for a, b in zip(factors, orig))
    sign = 1
    if any(a == -1 for a in factors):
        sign = (-1) ** sum(1 for a in factors if a == -1)
        factors = [a for a in factors if a != -1]
    tang = [i for i, a in enumerate(factors) if a in lin or a in seedset]
    plain = [i for i, a in enumerate(factors) if isinstance(a, sm.Symbol) and i not in tang]
    changed = False
    if len(tang) == 1:
        a = factors[tang[0]]
        s0, leaves, seed = lin[a] if a in lin else (1, (), a)
        best = None
        for r in range(len(plain), 0, -1):
            for combo in combinations(plain, r):
                hit = index.get((seed, _key(leaves + tuple(factors[i] for i in combo))))
                if hit is not None and hit[0] != a:
                    best = combo, hit
                    break
            if best:
                break
        if best:
            combo, (u, su) = best
            sign *= s0 * su
            factors = [u if i == tang[0] else f for i, f in enumerate(factors) if i not in combo]
            changed = True
    # the plain factors that make up a primal two-leaf temporary
    syms = [f for f in factors if isinstance(f, sm.Symbol) and f not in lin and f not in seedset]
    for t, leaves in monos:
        if all(syms.count(x) >= leaves.count(x) for x in leaves):
            for x in leaves:
                syms.remove(x)
                factors.remove(x)
            factors.insert(0, t)
            changed = True
    if not (changed or nested):
        return e
    return sm.Mul(sign, *factors)
