"""Issue 8, item 6: a chain written with chained frames costs what the summed-angle form costs.

Kane's reader merges successive rotations about a shared axis (kane_forms.chained_dcm),
so a link frame oriented from the previous one gives the same equations as one oriented
from the run's base frame by the summed angle.  These tests pin that down structurally
(identical expressions, identical generated operation counts) -- the timings live in
benchmarks/bench_chain.py -- and check the equations against SymPy's at random states.
"""
import pytest
import sympy as sm
import sympy.physics.mechanics as sme
from sympy.core.function import AppliedUndef

import eomc.mechanics as em
from eomc.compiler.driver import generate
from eomc.compiler.mechanics.kane_linear import _walk, input_symbols
from helpers.chained_frames import STYLES, chain_cart
from helpers.kane_oracle import compare_kane

PLANAR = "zzzz"
SPATIAL = "zzxxz"     # runs of equal axes separated by turns about another axis


@pytest.mark.parametrize("axes", [PLANAR, SPATIAL])
@pytest.mark.parametrize("style", [s for s in STYLES if s != "sum"])
def test_chained_frames_give_the_summed_form_exactly(axes, style):
    summed = chain_cart(em, axes, "sum")
    chained = chain_cart(em, axes, style)
    assert chained.mass_matrix == summed.mass_matrix
    assert chained.forcing == summed.forcing
    # the summed angles are what the equations hold, not products of the link rotations
    q = chained.q
    angle = sum(q[1:5]) if axes == PLANAR else q[3] + q[4]
    assert sm.cos(angle) in chained.mass_matrix.atoms(sm.cos)


def test_a_longer_spatial_chain_gives_the_summed_form_exactly():
    """z, z, x, x, z, z, x: SymPy splits cos(q3 + q4) across products with q7's sin and cos."""
    assert chain_cart(em, "zzxxzzx", "chain").forcing == chain_cart(em, "zzxxzzx", "sum").forcing


def test_chained_rigid_links_match_the_summed_form_and_sympy():
    summed = chain_cart(em, PLANAR, "sum", rigid=True)
    chained = chain_cart(em, PLANAR, "chainrel", rigid=True)
    assert chained.mass_matrix == summed.mass_matrix
    assert chained.forcing == summed.forcing
    compare_kane(chained, chain_cart(sme, PLANAR, "chainrel", rigid=True), seeds=(3,), rhs=False)


def test_spatial_rigid_chain_matches_sympy_and_generates_the_summed_rhs():
    """Rigid links about z, z, x, x, z: SymPy's v2pt_theory expands cos(q3 + q4); Kane's reader
    contracts it (measure_numbers.tidy), so the generated rhs is the summed form's."""
    chained = chain_cart(em, SPATIAL, "chain", rigid=True)
    compare_kane(chained, chain_cart(sme, SPATIAL, "chain", rigid=True), seeds=(4,), rhs=False)
    summed = chain_cart(em, SPATIAL, "sum", rigid=True)
    assert chained.mass_matrix == summed.mass_matrix
    assert _rhs_ops(chained, "kane") == _rhs_ops(summed, "kane")


def _rhs_ops(km, formulation):
    _, gm = generate(km, "c", functions=["rhs"], formulation=formulation, use_cache=False,
                     progress=False, inputs=[em.dynamicsymbols("F")])
    return sum(gm.metadata["op_counts"]["rhs"].values())


@pytest.mark.parametrize("formulation", ["kane", "recursive"])
def test_chained_frames_generate_the_same_rhs(formulation):
    summed = _rhs_ops(chain_cart(em, PLANAR, "sum"), formulation)
    for style in ("chain", "chainrel"):
        assert _rhs_ops(chain_cart(em, PLANAR, style), formulation) == summed


def test_one_walk_finds_what_atoms_and_free_symbols_find():
    """formed_system reads inputs and parameters in one shared-subtree walk (kane_linear._walk)."""
    t = em.dynamicsymbols._t
    q, u, F, T = em.dynamicsymbols("q u F T")
    a, b, x = sm.symbols("a b x")
    exprs = [sm.Matrix([a * sm.sin(q) * F + T.diff(t), sm.Integral(b * x, (x, 0, 1)) * u]),
             sm.Matrix([[sm.Subs(sm.Function("h")(x) * a, x, q)]])]
    dyn, syms = _walk(exprs)
    want_dyn = set().union(*(e.atoms(AppliedUndef, sm.Derivative) for m in exprs for e in m))
    want_syms = {s for m in exprs for s in m.free_symbols if isinstance(s, sm.Symbol)}
    assert dyn == want_dyn
    assert syms == want_syms and x not in syms
    assert input_symbols(exprs, {q, u}) == [F, T, T.diff(t)]
