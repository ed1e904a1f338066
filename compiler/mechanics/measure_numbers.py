"""Tidy the measure numbers Kane's reader takes from the user's vectors.

Two exact rewrites, applied to every sum bottom-up (each shared subtree once):

1. Expanded sines and cosines of angle sums are contracted:
   cos a cos b − sin a sin b -> cos(a + b).
2. Terms that differ only in which speed they hold are grouped:
   u1·r + u2·r -> (u1 + u2)·r.

Why: SymPy composes the direction cosine matrices of chained frames (each link
frame oriented from the previous one) by multiplying them out, so a velocity
SymPy's ``v2pt_theory`` builds for link k holds nested sums like
``(cos q3 cos q4 − sin q3 sin q4) cos q5 − (sin q3 cos q4 + cos q3 sin q4) sin q5``
where the same link written with summed angles holds ``cos(q3 + q4 + q5)``.
Kane's reader takes the user's vectors as given; contracting them when they are
read makes the two ways of writing a chain give (nearly) the same equations and
the same generated code.  Every rewrite is an exact identity:

    k r cos a cos b − k r sin a sin b  =  k r cos(a + b)
    k r cos a cos b + k r sin a sin b  =  k r cos(a − b)
    k r sin a cos b + k r cos a sin b  =  k r sin(a + b)
    k r sin a cos b − k r cos a sin b  =  k r sin(a − b)

with k a number and r the same remaining factors in both terms.  Sums are
contracted bottom-up, so nested products contract to sums of three and more
angles.

The grouping is the same story for speeds: a frame's angular velocity written
link by link (u1 N.z + u2 B1.z, as a chained frame's is) reaches N as
u1 r + u2 r where the summed form has (u1 + u2) r, and the accelerations Kane
differentiates from it would otherwise stay longer.
"""
import itertools

import sympy as sm

__all__ = ["tidy"]


def tidy(expr, speeds=frozenset(), angles=frozenset(), memo=None):
    """``expr`` with sines and cosines contracted into the angle sums ``angles`` (only
    those: a new sum is a new sin/cos call) and terms grouped by ``speeds`` (see above)."""
    memo = {} if memo is None else memo
    return _tidy(sm.sympify(expr), frozenset(speeds), frozenset(angles), memo)


def _tidy(expr, speeds, angles, memo):
    hit = memo.get(expr)
    if hit is not None:
        return hit
    if not expr.args or expr.is_Atom:
        out = expr
    else:
        args = tuple(_tidy(a, speeds, angles, memo) for a in expr.args)
        out = expr.func(*args) if args != expr.args else expr
        if out.is_Add and angles:
            out = _contract_add(out, angles)
        if out.is_Add and speeds:
            out = _group_speeds(out, speeds)
    memo[expr] = out
    return out


def _group_speeds(add, speeds):
    """c1·u1·r + c2·u2·r -> r·(c1 u1 + c2 u2), numbers c, speeds u, the same rest r."""
    groups, keep = {}, []
    for term in add.args:
        coeff, factors = term.as_coeff_mul()
        hit = [k for k, f in enumerate(factors) if f in speeds]
        if len(hit) != 1:
            keep.append(term)
            continue
        k = hit[0]
        rest = sm.Mul(*(factors[:k] + factors[k + 1:]))
        if rest.free_symbols & speeds:
            keep.append(term)
            continue
        groups.setdefault(rest, []).append(coeff * factors[k])
    if all(len(v) == 1 for v in groups.values()):
        return add
    return sm.Add(*keep, *[r * sm.Add(*us) for r, us in groups.items()])


def _is_trig(f):
    return isinstance(f, (sm.sin, sm.cos))


def _contract_add(add, angles):
    """One sum: merge matching pairs of terms, repeated while any pair merges; then try
    once more with the products of a sine/cosine and a sum multiplied out."""
    terms = _merge_all(list(add.args), angles)
    spread = [i for i, t in enumerate(terms) if _trig_times_sum(t)]
    if len(spread) >= 2:
        # cos a (cos b X − sin b Y) + sin a (−sin b X − cos b Y) = cos(a + b) X − sin(a + b) Y:
        # the pairs only meet once both products are multiplied out.  Kept only if at least
        # half the multiplied-out terms merged, so a sum never grows.
        out = [t for k in spread for t in _distribute(terms[k])]
        merged = _merge_all(out, angles)
        if 2 * len(merged) <= len(out):
            terms = [t for i, t in enumerate(terms) if i not in spread] + merged
    return sm.Add(*terms)


def _merge_all(terms, angles):
    while True:
        merged = _merge_once(terms, angles)
        if merged is None:
            return terms
        terms = merged


def _trig_times_sum(term):
    return term.is_Mul and any(_is_trig(f) for f in term.args) and any(f.is_Add for f in term.args)


def _distribute(term):
    """c·f·(x1 + x2 + ...) -> [c·f·x1, c·f·x2, ...] for the first sum among the factors."""
    k = next(i for i, f in enumerate(term.args) if f.is_Add)
    rest = sm.Mul(*(term.args[:k] + term.args[k + 1:]))
    return [rest * x for x in term.args[k].args]


def _split(term):
    """(number, rest factors, trig factors) of a product."""
    coeff, factors = term.as_coeff_mul()
    trig = [f for f in factors if _is_trig(f)]
    if len(trig) < 2:
        return coeff, None, None
    rest = [f for f in factors if not _is_trig(f)]
    return coeff, rest, trig


def _merge_once(terms, angles):
    """terms with one pair merged, or None when no pair matches."""
    seen = {}    # key -> (index, coeff)
    for i, term in enumerate(terms):
        coeff, rest, trig = _split(term)
        if trig is None:
            continue
        for x, y in itertools.permutations(range(len(trig)), 2):
            fx, fy = trig[x], trig[y]
            others = [t for k, t in enumerate(trig) if k not in (x, y)]
            r = sm.Mul(*(rest + others))
            a, b = fx.args[0], fy.args[0]
            if isinstance(fx, sm.cos) and isinstance(fy, sm.cos):
                if x > y:
                    continue              # cos a cos b: one key per unordered pair
                key, want = ("cc", r, frozenset((a, b))), "ss"
            elif isinstance(fx, sm.sin) and isinstance(fy, sm.sin):
                if x > y:
                    continue
                key, want = ("ss", r, frozenset((a, b))), "cc"
            elif isinstance(fx, sm.sin):  # sin a cos b matches cos a sin b = sin b cos a
                key, want = ("sc", r, (a, b)), ("sc", r, (b, a))
            else:
                continue
            partner_key = (want, r, key[2]) if want in ("cc", "ss") else want
            hit = seen.get(partner_key)
            if hit is not None and hit[0] != i:
                j, k = hit
                new = _merged(key[0], a, b, coeff, k, r, angles)
                if new is not None:
                    return [t for n, t in enumerate(terms) if n not in (i, j)] + [new]
            seen.setdefault(key, (i, coeff))
    return None


def _merged(kind, a, b, c_here, c_there, r, angles):
    """The merged term, or None when the coefficients do not fit an identity or the
    angle is not one of ``angles``."""
    if kind in ("cc", "ss"):
        cc, ss = (c_here, c_there) if kind == "cc" else (c_there, c_here)
        if ss == -cc and a + b in angles:
            return cc * r * sm.cos(a + b)
        if ss == cc and a - b in angles:
            return cc * r * sm.cos(a - b)
        return None
    # here: c_here sin a cos b; there: c_there sin b cos a
    if c_there == c_here and a + b in angles:
        return c_here * r * sm.sin(a + b)
    if c_there == -c_here and a - b in angles:
        return c_here * r * sm.sin(a - b)
    return None
