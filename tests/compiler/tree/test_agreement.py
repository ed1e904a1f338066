"""The recursive formulation (ABA, RNEA, CRBA) against Kane's, compiled, at random states.

Same system, same states: rhs, mass_matrix, inverse_dynamics and jac_x of
``formulation="recursive"`` must equal ``formulation="kane"`` to 1e-12 relative.
Systems: the relative-coordinate cart (hand-built and as a SymPy System of
joints) and hypothesis-generated random chains (tests/helpers/random_chains.py:
sliders and pins about random axes, particles and rigid bodies, joint torques,
drag, q' = c·u), random branching trees (tests/helpers/random_trees.py), and
random trees whose roots are free joints (floating bases).  The comparison
itself is tests/helpers/tree_agreement.py.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import eomc
import eomc.mechanics as em
from eomc.errors import ModelError
from helpers import random_trees, zoo
from helpers.random_chains import build, chain
from helpers.tree_agreement import agree as _agree
from helpers.trees import cart_joints, cart_relative

FUNCTIONS = ["rhs", "jac_x", "mass_matrix", "inverse_dynamics"]
TOL = 1e-12


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.parametrize("torques", [False, True])
def test_hand_built_relative_cart(torques):
    kane, inputs = cart_relative(3, em, torques=torques)
    mk = eomc.compile(kane, "cart_k", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="kane")   # auto may take the recursive form (task autocost)
    mr = eomc.compile(kane, "cart_r", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="recursive")
    assert _agree(mk, mr, 1) < TOL


@pytest.mark.parametrize("rigid", [False, True])
def test_system_of_joints(rigid):
    """A SymPy System whose equations were never formed: recursive straight away;
    kane forms them (System.form_eoms) on request."""
    system, _ = cart_joints(2, rigid=rigid)
    assert system.eom_method is None
    mr = eomc.compile(system, "joints_r", functions=FUNCTIONS, progress=False, formulation="recursive")
    assert system.eom_method is None
    mk = eomc.compile(cart_joints(2, rigid=rigid)[0], "joints_k", functions=FUNCTIONS,
                      progress=False, formulation="kane")
    assert _agree(mk, mr, 2) < TOL


def test_zoo_spring_damper_chain():
    """The zoo's tree in joint coordinates: masses on sliders, springs and dampers as loads
    (its other models are absolute-angle, ball-joint, constrained or closed-loop: see
    test_recognize.py and test_select.py for their refusals)."""
    kane, inputs = zoo.spring_damper_chain(3, em)
    mk = eomc.compile(kane, "springs_k", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="kane")
    mr = eomc.compile(kane, "springs_r", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="recursive")
    assert _agree(mk, mr, 3) < TOL


# derandomize: CI sees the same examples every run (a 5-body tree with two ball joints once
# differed by 1.3e-12, rounding in a stiff M); explore more by hand with --hypothesis-seed
@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=chain, seed=st.integers(0, 2**32 - 1))
def test_random_chains(spec, seed):
    ours = build(em, spec)
    M = ours.mass_matrix
    if any(all(M[i, j] == 0 for i in range(M.rows)) for j in range(M.cols)):
        # a particle on its own pin axis: refused by both formulations, naming the speed
        with pytest.raises(ModelError, match="no inertia"):
            ours.formed()
        with pytest.raises(ModelError, match="no inertia"):
            eomc.compile(ours, "chain_r", functions=FUNCTIONS, progress=False, formulation="recursive")
        return
    mk = eomc.compile(ours, "chain_k", functions=FUNCTIONS, progress=False, formulation="kane")
    try:
        mr = eomc.compile(ours, "chain_r", functions=FUNCTIONS, progress=False, formulation="recursive")
    except ModelError as exc:
        # a known limit of the recognizer (hypothesis found it): a particle link whose child
        # hangs from the particle's point, not from a frame, reads as one joint of two speeds
        # (the refusal names the particle, or its child when the particle sits on its own
        # pin's axis and so shows no speed of its own).  auto must fall back to Kane's equations.
        assert "one speed per joint" in str(exc) and ("Bob" in str(exc) or "Body" in str(exc))
        assert any(not link["rigid"] for link in spec["links"])
        auto = eomc.compile(ours, "chain_a", functions=FUNCTIONS, progress=False, formulation="auto")
        assert auto.metadata.get("formulation", "kane") == "kane"
        return
    assert _agree(mk, mr, seed, nstates=3) < TOL


def test_system_with_actuators_and_pathways():
    """Springs, dampers, forces and torques of a System's actuators reach the recursion
    (they were once dropped): the shipped cart-pole System example, both formulations.
    The recursive one reads the tree with the file's own parameters: the cart only
    translates and the pole turns about z, so neither the cart's inertias nor the pole's
    other moments are parameters (once "no default value for cart_ixx")."""
    from pathlib import Path
    path = Path(__file__).resolve().parents[3] / "examples" / "cart_pole_system.py"
    kane = eomc.compile(str(path), "cp_k", functions=FUNCTIONS, progress=False)
    rec = eomc.compile(str(path), "cp_r", functions=FUNCTIONS, progress=False,
                       formulation="recursive")
    assert rec.param_names == kane.param_names
    assert _agree(kane, rec, 5) < TOL


def _tree_compiler(spec, prefix):
    """formulation -> the compiled random tree ``spec`` (a fresh System each time)."""
    def compile_(formulation):
        system, inputs = random_trees.build(spec)
        return eomc.compile(system, f"{prefix}_{formulation[0]}", inputs=inputs,
                            functions=FUNCTIONS, progress=False, formulation=formulation)
    return compile_


def _kane_or_refused_by_both(compile_):
    """The Kane model, or None when a speed meets no inertia: then both formulations must
    refuse the tree, saying so."""
    try:
        return compile_("kane")
    except ModelError as exc:
        assert "no inertia" in str(exc)
        with pytest.raises(ModelError, match="no inertia"):
            compile_("recursive")
        return None


# derandomize: CI sees the same examples every run (a 5-body tree with two ball joints once
# differed by 1.3e-12, rounding in a stiff M); explore more by hand with --hypothesis-seed
@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=random_trees.tree(), seed=st.integers(0, 2**32 - 1))
def test_random_trees(spec, seed):
    """Branching trees of pins, sliders and ball joints (random parents, axes, points, full inertias,
    joint loads), a SymPy System of joints: recursive agrees with eomc's Kane.  A speed
    nothing resists (a point mass on its own pin axis) is refused by both, naming it."""
    compile_ = _tree_compiler(spec, "tree")
    mk = _kane_or_refused_by_both(compile_)
    if mk is None:
        return
    try:
        mr = compile_("recursive")
    except ModelError as exc:
        # refused with the body named; Kane's M is then singular too (not structurally)
        assert "no inertia" in str(exc) and "body" in str(exc)
        x = np.random.default_rng(seed).uniform(-1, 1, mk.nq + mk.nu)
        assert np.linalg.cond(mk.mass_matrix(0.0, x, r=np.zeros(mk.ninput))) > 1e8
        return
    assert _agree(mk, mr, seed, nstates=3) < TOL


@pytest.mark.parametrize("rotation", [("BODY", 123), ("SPACE", 123), ("BODY", 313)])
def test_ball_joints(rotation):
    """A SphericalJoint is read as three pins through massless intermediate frames: a body
    on a ball joint with a pendulum on a pin and a second ball-jointed body hanging from it,
    a joint torque; recursive agrees with Kane.  Reading the tree leaves the user's frame
    graph as it was (the intermediate frames are unlinked again)."""
    def body(parent, kind, child_point, load=False):
        return {"parent": parent, "kind": kind, "rotation": rotation, "axis": (1, 0, 1),
                "parent_point": (0, 0, 1), "child_point": child_point, "rigid": True,
                "products": True, "load": load}
    spec = [body(-1, "ball", (1, 1, 0), load=True), body(0, "pin", (0, -1, 0)),
            body(0, "ball", (0, 1, -1))]
    system, inputs = random_trees.build(spec)
    frames = [b.frame for b in system.bodies]
    before = [(set(f._dcm_dict), set(f._ang_vel_dict)) for f in frames]
    mr = eomc.compile(system, "ball_r", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="recursive")
    assert [(set(f._dcm_dict), set(f._ang_vel_dict)) for f in frames] == before
    assert mr.nq == mr.nu == 7
    system, inputs = random_trees.build(spec)
    mk = eomc.compile(system, "ball_k", inputs=inputs, functions=FUNCTIONS, progress=False,
                      formulation="kane")
    assert _agree(mk, mr, 7) < TOL


def test_cache_tells_tree_shapes_apart():
    """Two trees with the same joint expressions, one body hanging from the other or from
    the ground, are different models: the generation cache key includes the parents
    (hypothesis found them sharing a cached build)."""
    def spec(parent):
        return [{"parent": -1, "kind": "slider", "rotation": ("BODY", 123), "axis": (-1, 1, -1),
                 "parent_point": (0, 1, 0), "child_point": (0, -1, 0), "rigid": False,
                 "products": False, "load": False},
                {"parent": parent, "kind": "slider", "rotation": ("BODY", 123), "axis": (0, 1, -1),
                 "parent_point": (1, -1, 1), "child_point": (-1, 1, -1), "rigid": False,
                 "products": False, "load": False}]
    x = np.array([0.3, -0.2, 0.1, 0.4])
    M = []
    for parent in (0, -1):
        system, _ = random_trees.build(spec(parent))
        model = eomc.compile(system, "shape", functions=["mass_matrix"], progress=False,
                             formulation="recursive")
        M.append(model.mass_matrix(0.0, x))
    assert abs(M[0][0, 1]) > 0.1 and M[1][0, 1] == 0.0


@settings(max_examples=5, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=random_trees.tree(max_bodies=4, free=True), seed=st.integers(0, 2**32 - 1))
def test_random_floating_trees(spec, seed):
    """Random trees whose roots may be free joints (the first one always is: a floating
    base, 6 body-frame twist speeds) with pins, sliders and balls below: recursive agrees
    with Kane in the Kane path's state layout."""
    assert spec[0]["kind"] == "free"
    compile_ = _tree_compiler(spec, "ftree")
    mk = _kane_or_refused_by_both(compile_)
    if mk is None:
        return
    mr = compile_("recursive")
    assert mr.state_names == mk.state_names
    assert _agree(mk, mr, seed, nstates=3) < TOL
