"""examples/biomechanical_arm.py (SymPy 1.14's "Biomechanical Model Example") against SymPy's
own lambdified equations, the tutorial's way: ``lambdify((q, u, a, e, p), (kane.mass_matrix,
kane.forcing, dadt))`` with u' = solve(M, f), q' = u.  The same file is run with
``sympy.physics.mechanics`` in place of ``eomc.mechanics`` for the oracle.  States on the
constraints (the tutorial's start, and random lever angles, speeds and activations completed
by consistent_state), random excitations: x' agrees to 1e-12.
"""
import pathlib

import numpy as np
import pytest
import sympy as sm

import eomc

EXAMPLE = pathlib.Path(__file__).resolve().parents[3] / "examples" / "biomechanical_arm.py"


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    model = eomc.compile(EXAMPLE, cache_dir=tmp_path_factory.mktemp("arm"))
    ns = {}
    src = EXAMPLE.read_text().replace("import eomc.mechanics as me", "import sympy.physics.mechanics as me")
    exec(compile(src, "biomechanical_arm (SymPy)", "exec"), ns)
    kane, p = ns["kane"], ns["parameters"]
    eval_diffeq = sm.lambdify((kane.q, kane.u, ns["a"], ns["e"], list(p)),
                              (kane.mass_matrix, kane.forcing, ns["dadt"]), cse=True)
    p_vals = np.array(list(p.values()))

    def sympy_rhs(x, e):
        m, f, ad = eval_diffeq(x[0:4], x[4:8], x[8:10], e, p_vals)
        return np.hstack((x[4:8], np.linalg.solve(m, f).squeeze(), np.asarray(ad, float).squeeze()))
    # the muscles' lengths and tensions, as SymPy's own objects give them (u' enters no output)
    b, t = ns["biceps"], ns["triceps"]
    qdots = {qi.diff(ns["me"].dynamicsymbols._t): ui for qi, ui in zip(kane.q, kane.u)}   # kd_eqs: q' = u
    exprs = [sm.sympify(v).xreplace(qdots) for v in (b.pathway.length, t.pathway.length, -b.force, -t.force)]
    sympy_rhs.outputs = sm.lambdify((kane.q, kane.u, ns["a"], list(p)), exprs, cse=True)
    sympy_rhs.p_vals = p_vals
    return model, sympy_rhs


def test_arm_states_inputs_and_start(arm):
    model, _ = arm
    assert model.state_names == ("q1", "q2", "q3", "q4", "u1", "u2", "u3", "u4", "a_biceps", "a_triceps")
    assert model.input_names == ("e_biceps", "e_triceps")
    # the tutorial's fsolve start, in degrees as its doctest prints it
    np.testing.assert_allclose(np.rad2deg(model.initial_state[:4]),
                               [5.0, -0.60986636, 9.44918589, 88.68812842], atol=5e-9)
    assert max(abs(model.constraints(0.0, model.initial_state))) < 1e-14


def test_arm_matches_sympy_lambdified(arm):
    model, sympy_rhs = arm
    rng = np.random.default_rng(14)
    states = [model.initial_state]
    for _ in range(4):
        x = model.initial_state.copy()
        x[0] = rng.uniform(0.0, 0.3)            # lever angle
        x[4] = rng.uniform(-1.0, 1.0)           # lever speed
        x[8:10] = rng.uniform(0.0, 1.0, 2)      # activations
        states.append(model.consistent_state(x))
    for x in states:
        e = rng.uniform(0.0, 1.0, 2)
        want, got = sympy_rhs(x, e), model.rhs(0.0, x, r=e)
        assert np.max(np.abs(got - want)) <= 1e-12 * max(1.0, np.max(np.abs(want))), (got, want)


def test_arm_biceps_pulls_the_lever_back(arm):
    """The tutorial's second run: biceps at 80 % from 0.5 s to 1.5 s (its eval_r, called per stage)."""
    model, _ = arm

    def eval_r(t):
        return np.array([0.0, 0.0]) if t < 0.5 or t > 1.5 else np.array([0.8, 0.0])
    rest = model.simulate(model.initial_state, (0.0, 1.5), rtol=1e-8, atol=1e-8)
    pulled = model.simulate(model.initial_state, (0.0, 1.5), r=eval_r, rtol=1e-8, atol=1e-8)
    assert pulled["a_biceps"][-1] > 0.7 and rest["a_biceps"][-1] == 0.0
    assert abs(pulled["q1"][-1] - rest["q1"][-1]) > 0.05      # the biceps moved the lever


def test_arm_outputs_are_the_muscles_lengths_and_tensions(arm):
    """The example named no outputs before session 29 (a biomechanics user's CSV, plot and page
    showed none): now each muscle's musculotendon length and tension, against SymPy's
    pathway.length and -force at states on the constraints; the biceps at 80 % pulls harder
    than at rest and is shorter as it moves the lever."""
    model, sympy_rhs = arm
    assert model.output_names == ("l_biceps", "l_triceps", "F_biceps", "F_triceps")
    rng = np.random.default_rng(3)
    for _ in range(4):
        x = model.initial_state.copy()
        x[0], x[4] = rng.uniform(0.0, 0.3), rng.uniform(-1.0, 1.0)
        x[8:10] = rng.uniform(0.0, 1.0, 2)
        x = model.consistent_state(x)
        want = np.array(sympy_rhs.outputs(x[0:4], x[4:8], x[8:10], sympy_rhs.p_vals), float)
        got = np.array(list(model.outputs(0.0, x).values()))
        assert np.max(np.abs(got - want)) <= 1e-12 * max(1.0, np.max(np.abs(want))), (got, want)
    rest = model.simulate(model.initial_state, (0.0, 1.0), rtol=1e-8, atol=1e-8)
    pulled = model.simulate(model.initial_state, (0.0, 1.0), r=[0.8, 0.0], rtol=1e-8, atol=1e-8)
    # at rest the biceps' fibre is at a third of its optimal length, where De Groote's passive
    # curve is below zero (-9.2 N); 80 % activation adds ~8 N of active tension
    assert rest.outputs["F_biceps"][-1] < 0 and pulled.outputs["F_biceps"][-1] > rest.outputs["F_biceps"][-1] + 5.0
    assert pulled.outputs["l_biceps"][-1] < rest.outputs["l_biceps"][-1]
