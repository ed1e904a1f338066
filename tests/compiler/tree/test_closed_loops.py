"""Issue 19 item 3: closed loops on the tree (compiler/tree/constrained.py).

A System of joints whose loops holonomic constraints close -- the four-bar example, a
slider-crank, a five-bar, a spatial RSSR four-bar through a ball joint -- runs as its spanning tree's dynamics plus a constraint solve.
The oracle is eomc's Kane formulation of the same System (itself checked against SymPy's
KanesMethod elsewhere): same states, and every function agrees to 1e-12 at random
consistent states (rhs, mass matrix, forcing, inverse dynamics, outputs and an event
that read u', constraints), simulations agree and keep the constraints, and what the
recursion does not build (jac_x, ...) makes auto fall back to Kane saying why.

Cheap: four small models, each compiled once per formulation (module fixture).
"""
import importlib.util
import runpy
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

import eomc
from eomc.compiler.driver import generate
from eomc.compiler.tree.model import NotATree
from eomc.compiler.tree.recognize import tree_from_system
from eomc.errors import EomcError, ModelError

ROOT = Path(__file__).resolve().parents[3]
FOUR_BAR = ROOT / "examples" / "four_bar_system.py"
_spec = importlib.util.spec_from_file_location("bench_loops", ROOT / "benchmarks" / "bench_loops.py")
bench_loops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_loops)

FUNCTIONS = ["rhs", "mass_matrix", "forcing", "inverse_dynamics", "outputs", "events", "constraints",
             "constraints_jac"]
t = sm.Symbol("t")


def _four_bar():
    ns = runpy.run_path(str(FOUR_BAR))
    x0 = {k: v for k, v in ns["initial_state"].items()}
    return ns["system"], ns["parameters"], x0, ns["inputs"], ns


def _models():
    sys_fb, p_fb, x_fb, inputs, ns = _four_bar()
    u1 = ns["u1"]
    out = {"four_bar": (sys_fb, p_fb, x_fb, inputs,
                        {**ns["outputs"], "crank_acc": u1.diff(t), "power": ns["T"] * u1},
                        {"crank_acc_zero": u1.diff(t) - 0.5})}
    from eomc.mechanics import dynamicsymbols
    for label, (system, params, x0), inputs in (
            ("slider_crank", bench_loops.slider_crank(), [dynamicsymbols("T")]),
            ("five_bar", bench_loops.closed_chain(4), []),
            ("spatial_rssr", bench_loops.rssr(), [])):
        u = list(system.u)
        out[label] = (system, params, x0, inputs, {"acc": u[0].diff(t) + u[-1].diff(t) * u[0]},
                      {"acc_zero": u[0].diff(t) - 0.25})
    return out


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for label, (system, params, x0, inputs, outputs, events) in _models().items():
        pair = {}
        for f in ("recursive", "kane"):      # recursive first: reading the tree forms nothing
            kw = dict(parameters=params, outputs=outputs, events=events, functions=FUNCTIONS,
                      formulation=f, cache_dir=str(cache), name=f"{label}_{f}")
            if inputs:
                kw["inputs"] = inputs
            pair[f] = eomc.compile(system, **kw)
        out[label] = (pair, x0)
    return out


def _consistent_states(model, x0, count, rng):
    names = model.state_names
    by_name = {str(k).replace("(t)", ""): float(v) for k, v in x0.items()}
    start = np.array([by_name[n] for n in names])
    nq = model.nq
    states = []
    for _ in range(10 * count):
        x = start.copy()
        x[:nq] += rng.uniform(-0.3, 0.3, nq)
        x[nq:] = rng.uniform(-1.0, 1.0, len(x) - nq)
        try:
            states.append(np.asarray(model.consistent_state(dict(zip(names, x))), dtype=float))
        except EomcError:
            continue
        if len(states) == count:
            break
    assert len(states) == count
    return states


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(a))))


@pytest.mark.parametrize("label", ["four_bar", "slider_crank", "five_bar", "spatial_rssr"])
def test_recursive_and_kane_agree_at_random_consistent_states(built, label):
    pair, x0 = built[label]
    rec, kane = pair["recursive"], pair["kane"]
    assert rec.metadata["formulation"] == "recursive" and kane.metadata["formulation"] == "kane"
    assert rec.state_names == kane.state_names and rec.param_names == kane.param_names
    m = 3 if label == "spatial_rssr" else 2
    assert (rec.nhol, rec.nvel) == (kane.nhol, kane.nvel) == (m, m)
    rng = np.random.default_rng(19)
    r = np.full(kane.ninput, 0.7)
    for x in _consistent_states(kane, x0, 4, rng):
        assert np.max(np.abs(kane.constraints(0.0, x, r=r))) < 1e-10
        for fn in ("rhs", "mass_matrix", "forcing", "constraints"):
            a, b = getattr(kane, fn)(0.0, x, r=r), getattr(rec, fn)(0.0, x, r=r)
            assert _rel(a, b) < 1e-12, (label, fn, a, b)
        a, b = kane.outputs(0.0, x, r=r), rec.outputs(0.0, x, r=r)
        assert a.keys() == b.keys() and _rel(list(a.values()), list(b.values())) < 1e-12, (a, b)
        assert _rel(kane.constraints_jacobian(0.0, x, r=r), rec.constraints_jacobian(0.0, x, r=r)) < 1e-12
        udot = rng.uniform(-1, 1, kane.nu)
        assert _rel(kane.inverse_dynamics(0.0, x, udot, r=r), rec.inverse_dynamics(0.0, x, udot, r=r)) < 1e-12
        # the dependent accelerations keep the velocity constraints: d/dt (J u) = 0
        xd = rec.rhs(0.0, x, r=r)
        h = 1e-6
        g1 = rec.constraints(0.0, x + h * xd, r=r)[m:]
        g0 = rec.constraints(0.0, x - h * xd, r=r)[m:]
        assert np.max(np.abs(g1 - g0)) / (2 * h) < 1e-6


def test_the_rhs_agrees_off_the_constraints_too(built):
    """Kane's reduced equations and the constraint solve are the same equations at every
    state (Nᵀ(M u' - b) = 0 iff M u' - b is in Jᵀ's range): not only on the manifold."""
    pair, _ = built["four_bar"]
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-1, 1, 6)
        r = rng.uniform(-1, 1, 1)
        assert _rel(pair["kane"].rhs(0.0, x, r=r), pair["recursive"].rhs(0.0, x, r=r)) < 1e-12


def test_simulations_agree_keep_the_constraints_and_find_the_same_event(built):
    pair, x0 = built["four_bar"]
    kane, rec = pair["kane"], pair["recursive"]
    start = {str(k).replace("(t)", ""): v for k, v in x0.items()}
    runs = {f: m.simulate(start, (0.0, 2.0), rtol=1e-11, atol=1e-11, n_points=41, r=[0.3],
                          events=["crank_acc_zero"])
            for f, m in (("kane", kane), ("recursive", rec))}
    a, b = runs["kane"], runs["recursive"]
    assert a.status == b.status == 0
    assert np.max(np.abs(a.x - b.x)) < 1e-8
    # constraint drift of the plain (unprojected) integration stays at the tolerance's level
    assert b.constraint_residual is not None and np.max(b.constraint_residual) < 1e-7
    ta, tb = a.t_events["crank_acc_zero"], b.t_events["crank_acc_zero"]
    assert len(ta) == len(tb) >= 1 and np.max(np.abs(np.asarray(ta) - np.asarray(tb))) < 1e-8


def test_the_tree_is_the_spanning_tree_and_the_constraints_ride_along():
    system, *_ = _four_bar()
    tree = tree_from_system(system)
    assert [b.joint for b in tree.bodies] == ["J1", "J2", "J3"]
    loops = tree.loops
    assert loops.m == 2 and loops.joints == ("J1", "J2", "J3")
    assert (loops.n_dependent_coordinates, loops.n_dependent_speeds) == (2, 2)


def test_the_regressor_of_a_closed_tree_is_refused_by_name_in_both(tmp_path):
    for formulation in ("recursive", "auto"):
        with pytest.raises(ModelError, match=r"regressor of a tree closed by constraints is not "
                                             r"generated"):
            generate(str(FOUR_BAR), "fb", formulation=formulation, functions=["rhs", "regressor"],
                     use_cache=False, progress=False)


def test_auto_compares_the_two_for_rhs_and_keeps_the_cheaper(tmp_path):
    _, gm = generate(str(FOUR_BAR), "fb", formulation="auto", functions=["rhs"], use_cache=False,
                     progress=False)
    costs = gm.metadata["formulation_costs"]
    cheaper = min(("kane", "recursive"), key=lambda f: costs[f])
    assert gm.metadata["formulation"] == cheaper


def test_a_loop_closed_by_a_joint_without_constraints_names_the_joints():
    """eomc's System refuses the second parent when the joint is added; SymPy's System takes
    it, and the recogniser names the body, both joints and the way out."""
    import sympy.physics.mechanics as sme
    import warnings
    from eomc.mechanics import PinJoint, RigidBody, System, dynamicsymbols
    q = dynamicsymbols("q1:4")
    u = dynamicsymbols("u1:4")
    for mech in ("eomc", "sympy"):
        M = sme if mech == "sympy" else None
        ground = (M.RigidBody if M else RigidBody)("ground")
        a = (M.RigidBody if M else RigidBody)("a", mass=1)
        b = (M.RigidBody if M else RigidBody)("b", mass=1)
        system = (M.System if M else System).from_newtonian(ground)
        Pin = M.PinJoint if M else PinJoint
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")          # SymPy warns of the frames' loop
            joints = [Pin("J1", ground, a, q[0], u[0]), Pin("J2", a, b, q[1], u[1]),
                      Pin("J3", ground, b, q[2], u[2])]
        if mech == "eomc":
            with pytest.raises(EomcError, match=r"joint J3: body b is already attached as the child "
                                                r"of joint J2.*add_holonomic_constraints"):
                system.add_joints(*joints)
            continue
        system.add_joints(*joints)
        with pytest.raises(NotATree, match=r"body b is the child of joints J2 and J3: a closed loop, "
                                           r"not a tree \(leave one joint of the loop out and close "
                                           r"the loop with holonomic constraints instead\)"):
            tree_from_system(system)


@pytest.mark.parametrize("formulation", ["auto", "kane", "recursive"])
def test_compiling_a_sympy_system_with_a_doubly_attached_body_names_it(formulation):
    """Issue 34: compiling such a System said "joint J2 has no inertia" (auto and kane); every
    formulation now names the body and both joints before anything is formed."""
    import sympy.physics.mechanics as sme
    import warnings
    import eomc
    from eomc.runtime.errors import ModelError
    q, u = sme.dynamicsymbols("q1:4"), sme.dynamicsymbols("u1:4")
    ground, a, b = sme.RigidBody("ground"), sme.RigidBody("a", mass=1), sme.RigidBody("b", mass=1)
    system = sme.System.from_newtonian(ground)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # SymPy warns of the frames' loop
        system.add_joints(sme.PinJoint("J1", ground, a, q[0], u[0]), sme.PinJoint("J2", a, b, q[1], u[1]),
                          sme.PinJoint("J3", ground, b, q[2], u[2]))
    with pytest.raises(ModelError, match=r"^body b is the child of two joints, J2 and J3; .*"
                                         r"add_holonomic_constraints"):
        eomc.compile(system, "loop", formulation=formulation, functions=["rhs"], progress=False)


def test_nonholonomic_constraints_stay_kanes():
    from eomc.mechanics import PinJoint, RigidBody, System, dynamicsymbols
    q1, u1 = dynamicsymbols("q1 u1")
    ground, a = RigidBody("ground"), RigidBody("a", mass=1)
    system = System.from_newtonian(ground)
    system.add_joints(PinJoint("J1", ground, a, q1, u1))
    system.add_nonholonomic_constraints(u1 - 1)
    system.u_ind, system.u_dep = [], [u1]
    with pytest.raises(NotATree, match="1 nonholonomic constraint"):
        tree_from_system(system)


def test_auto_takes_the_tree_for_a_long_closed_chain_without_forming_kane(monkeypatch):
    """Above 6 speeds a closed tree's recursive rhs has won on every chain measured
    (benchmarks/results/loops.md): auto lowers it without forming Kane's equations."""
    from eomc.compiler.mechanics import unformed

    def forbidden(system):
        raise AssertionError("Kane's equations were formed")

    monkeypatch.setattr(unformed, "form_system", forbidden)
    system, params, _ = bench_loops.closed_chain(8)
    _, gm = generate(system, "chain8", formulation="auto", functions=["rhs"], parameters=params,
                     use_cache=False, progress=False)
    assert gm.metadata["formulation"] == "recursive"
    assert gm.metadata["formulation_costs"]["kane"].startswith("not formed (8 speeds > 6")
    assert (gm.metadata["nhol"], gm.metadata["nvel"]) == (2, 2)


def test_a_systems_formed_kanes_method_closes_its_loops_too(tmp_path):
    """The KanesMethod a System forms (dependent speeds, its constraint matrices) is read as a
    tree plus its loops; it agrees with Kane's formulation of the same KanesMethod."""
    system, params, _, inputs, _ = _four_bar()
    system.form_eoms()
    km = system.eom_method
    models = {}
    for f in ("recursive", "kane"):
        p = dict(params)
        if f == "recursive":     # the tree keeps the ground body's mass symbol (it moves nothing)
            p[sm.Symbol("ground_mass")] = 1.0
        models[f] = eomc.compile(km, formulation=f, functions=["rhs", "mass_matrix"], inputs=inputs,
                                 parameters=p, cache_dir=str(tmp_path / f))
    assert models["recursive"].metadata["formulation"] == "recursive"
    rng = np.random.default_rng(5)
    for _ in range(3):
        x, r = rng.uniform(-1, 1, 6), rng.uniform(-1, 1, 1)
        for fn in ("rhs", "mass_matrix"):
            a, b = (getattr(models[f], fn)(0.0, x, r=r) for f in ("kane", "recursive"))
            assert _rel(a, b) < 1e-12, (fn, a, b)
