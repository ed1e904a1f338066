"""Kane's jvp tangent with its two-seed entries as a coefficient times a seed difference, and its
one-seed monomials on the primal's products (compiler/emit/seed_pairs.py), against the tangent
as differentiated (each switch off)."""
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as sme

import eomc
from eomc.compiler.emit import seed_pairs
from helpers import zoo
from helpers.module_cache import cache  # noqa: F401 -- the module's own build cache (a fixture)


def _scaled(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))

def _assert_same_jvp(on, off, seed):
    """The two builds' jvp at random states for 1, 2, 5 and 6 directions (the scalar path and the
    lanes), half of them parameter seeds: xdot bit-equal, J.d within 1e-12 scaled."""
    rng = np.random.default_rng(seed)
    nx, npar = on.nx, on.nparam
    for _ in range(4):
        x, r = rng.uniform(-1.5, 1.5, nx), rng.uniform(-1, 1, on.ninput)
        D = rng.normal(size=(6, nx + npar))
        D[::2, nx:] = 0.0
        D[np.arange(0, 6, 2), nx + np.arange(0, 6, 2) % npar] = 1.0
        for k in (1, 2, 5, 6):
            xa, a = on.jvp(0.0, x, D[:k], r=r)
            xb, b = off.jvp(0.0, x, D[:k], r=r)
            assert np.array_equal(xa, xb)
            assert _scaled(a, b) < 1e-12, k



def _build(n, on, switch="SEED_PAIRS"):
    kane, specified = zoo.n_link_pendulum_on_cart(n, sme)
    params = sorted((kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols)
                    - {sme.dynamicsymbols._t}, key=str)
    saved = getattr(seed_pairs, switch)
    setattr(seed_pairs, switch, on)
    try:
        return eomc.compile(kane, parameters={s: 0.7 + 0.1 * i for i, s in enumerate(params)},
                            inputs=specified, functions=["rhs", "jvp", "jvp_more"], formulation="kane")
    finally:
        setattr(seed_pairs, switch, saved)


def _differences(model):
    c = (Path(model.library_path).parent / f"{model.name}.c").read_text()
    jvp = c[c.index(f"int {model.name}_jvp("):]
    return len(re.findall(r"\(dx\[\d+\] - dx\[\d+\]\)", jvp)), len(re.findall(r"\(XT\[\d+\]\[ln\] - XT\[\d+\]\[ln\]\)", jvp))


@pytest.mark.parametrize("n", [6, 8])     # looped tangents (from 14 states; fewer: unrolled columns)
def test_seed_pairs_match_the_differentiated_tangent(cache, n):
    """Random states, one to six directions (sensitivity-shaped and dense, so both the lone
    direction's scalar tangent and the lanes run): J·d within 1e-12 (scaled) of the build with
    the switch off, xdot the same to the bit; the rewritten entries are in the on build only
    (the cart's n (n - 1) / 2 link pairs in each path, in jvp and in jvp_more)."""
    on, off = _build(n, True), _build(n, False)
    pairs = n * (n - 1) // 2
    assert _differences(on) == (2 * pairs, 2 * pairs)
    assert _differences(off) == (0, 0)
    _assert_same_jvp(on, off, seed=n)


def test_seed_pairs_rewrites_only_a_cancelling_pair():
    """The rewrite on hand-made programs: the cart's entry shape becomes m (C_i S_j - S_i C_j)
    (dq_i - dq_j), equal at random points; an entry whose seed coefficients do not cancel, or
    with three seeds, stays as it is."""
    c1, s1, c2, s2, l1, l2, m, d1, d2, d3 = sm.symbols("c1 s1 c2 s2 l1 l2 m d1 d2 d3")
    C1, S1, C2, S2 = sm.symbols("C1 S1 C2 S2")          # primal temporaries l cos q, l sin q
    primal = {C1: c1 * l1, S1: l1 * s1, C2: c2 * l2, S2: l2 * s2}
    u1, v1, u2, v2 = sm.symbols("u1 v1 u2 v2")          # tangent temporaries: dC = -S dq, dS = C dq
    lin = [(u1, sm.Mul(-1, S1, d1)), (v1, sm.Mul(C1, d1)), (u2, sm.Mul(-1, S2, d2)), (v2, sm.Mul(C2, d2))]
    e = sm.Symbol("e")
    entry = m * sm.Add(sm.Add(u2 * C1, C2 * u1, evaluate=False), sm.Add(v1 * S2, S1 * v2, evaluate=False),
                       evaluate=False)
    out = dict(seed_pairs.seed_pairs(lin + [(e, entry)], [d1, d2, d3], primal))
    new = out[e]
    assert new != entry and new.has(d1 - d2)
    rng = np.random.default_rng(0)
    for _ in range(5):
        vals = dict(zip((c1, s1, c2, s2, l1, l2, m, d1, d2), rng.normal(size=9)))
        subs = {**{k: v.subs(vals) for k, v in primal.items()}}
        subs.update(vals)
        tang = {t: ex.subs(subs) for t, ex in lin}
        ref = entry.subs(tang).subs(subs)
        assert abs(float(new.subs(subs)) - float(ref)) < 1e-12 * max(1.0, abs(float(ref)))
    # not cancelling: C1 C2 + S1 S2's tangent with dS2 = C2 d3 (another seed): three seeds
    lin3 = lin[:3] + [(v2, sm.Mul(C2, d3))]
    assert dict(seed_pairs.seed_pairs(lin3 + [(e, entry)], [d1, d2, d3], primal))[e] == entry
    # two seeds, coefficients not opposite (C1 C2 - S1 S2)
    minus = m * sm.Add(sm.Add(u2 * C1, C2 * u1, evaluate=False), sm.Mul(-1, sm.Add(v1 * S2, S1 * v2, evaluate=False)),
                       evaluate=False)
    assert dict(seed_pairs.seed_pairs(lin + [(e, minus)], [d1, d2, d3], primal))[e] == minus


def _one_seed(model):
    """(as differentiated, on the primal's products): the jvp's one-seed temporaries
    ``(-sin q) * dq`` and ``p * (cos q * dq)``, and ``-(l sin q) * dq``, ``(l cos q) * dq``."""
    c = (Path(model.library_path).parent / f"{model.name}.c").read_text()
    jvp = c[c.index(f"int {model.name}_jvp("):]
    seed = r"(?:dx\[\d+\]|XT\[\d+\]\[ln\])"
    old = len(re.findall(rf"= \(-t\d+\)\*{seed};", jvp)) + len(re.findall(rf"= p\[\d+\]\*\(t\d+\*{seed}\);", jvp))
    new = len(re.findall(rf"= -?t\d+\*{seed};", jvp))
    return old, new


@pytest.mark.parametrize("n", [6, 8])
def test_seed_monomials_match_the_differentiated_tangent(cache, n):
    """Random states, one to six directions (the scalar tangent and the lanes): J·d within
    1e-12 (scaled) of the build with SEED_MONOMIALS off, xdot the same to the bit; the one-seed
    temporaries are on the primal's products in the on build only (each link's -(l sin q) dq
    and (l cos q) dq, in both paths of jvp and of jvp_more)."""
    on, off = _build(n, True, "SEED_MONOMIALS"), _build(n, False, "SEED_MONOMIALS")
    old_on, new_on = _one_seed(on)
    old_off, new_off = _one_seed(off)
    # two a link (the last link's cos q dq is one already), two paths, jvp and jvp_more
    assert old_on == 0 and old_off == 4 * (2 * n - 1)
    assert new_on == new_off + old_off
    _assert_same_jvp(on, off, seed=n + 10)


def test_seed_monomials_reuse_the_primal_products():
    """On a hand-made program: d(l sin q) = (-sin q dq) l becomes -(l sin q) dq, a product
    m (-sin q dq) l w inside a sum reads that temporary, cos q l w becomes (l cos q) w; equal
    at random points.  A product with no such temporary stays as it is."""
    s1, c1, l1, m, w, d1 = sm.symbols("s1 c1 l1 m w d1")
    S1, C1 = sm.symbols("S1 C1")                        # primal temporaries l sin q, l cos q
    primal = {S1: l1 * s1, C1: c1 * l1}
    u, v, e, f = sm.symbols("u v e f")
    inner = [(u, sm.Mul(-1, s1, d1)), (v, sm.Mul(u, l1)), (e, sm.Add(sm.Mul(m, u, l1, w), f))]
    results = {"g0": sm.Mul(e, c1, l1, w), "g1": sm.Mul(m, u, w)}
    out, res = seed_pairs.seed_monomials(inner, results, [d1], primal)
    out = dict(out)
    assert out[v] == -S1 * d1
    assert out[e].has(v) and not out[e].has(u) and not out[e].has(l1)
    assert res["g0"].has(C1) and not res["g0"].has(c1)
    assert res["g1"] == results["g1"]
    rng = np.random.default_rng(1)
    for _ in range(5):
        vals = dict(zip((s1, c1, l1, m, w, d1, f), rng.normal(size=7)))
        vals.update({k: ex.subs(vals) for k, ex in primal.items()})

        def run(assign, exprs):
            env = dict(vals)
            for t, ex in assign:
                env[t] = ex.subs(env)
            return [float(x.subs(env)) for x in exprs]
        ref = run(inner, results.values())
        got = run(list(out.items()), res.values())
        assert np.allclose(got, ref, rtol=1e-12, atol=0)
