"""SymPy biomechanics musculotendons bring their states: a System whose actuator is a
``MusculotendonDeGroote2016`` with ``FirstOrderActivationDeGroote2016`` (rigid or elastic
tendon) compiles with the muscle's ``x`` appended to the state and its ``rhs()`` as their
derivatives, the excitation an input -- what SymPy's docs assemble by hand.  Checked
against SymPy's own System (``mass_matrix_full``, ``forcing_full``, ``muscle.rhs()``,
lambdified) at random states to 1e-12, and jac_x against central differences.
"""
import numpy as np
import pytest
import sympy as sm

import eomc
from helpers.state_models import MUSCLE

RNG = np.random.default_rng(2016)


def _sympy_rhs(formulation):
    namespace = {}
    exec(MUSCLE.format(mech="sympy.physics.mechanics", formulation=formulation), namespace)
    system, muscle = namespace["system"], namespace["muscle"]
    system.form_eoms()
    p = namespace["parameters"]
    q, u, e = namespace["q"], namespace["u"], namespace["activation"].e
    rates = muscle.rhs().xreplace({q.diff(): u})
    x = [q, u] + list(muscle.x)
    M, F = system.mass_matrix_full.xreplace(p), system.forcing_full.xreplace(p)
    fun = sm.lambdify((x, [e]), (M, F, rates.xreplace(p)), cse=True)

    def f(xv, rv):
        Mv, Fv, zv = fun(xv, rv)
        return np.concatenate([np.linalg.solve(np.asarray(Mv, float), np.asarray(Fv, float)).ravel(),
                               np.asarray(zv, float).ravel()])
    return f, [str(s).replace("(t)", "") for s in x]


@pytest.fixture(scope="module", params=["RIGID_TENDON", "FIBER_LENGTH_EXPLICIT"])
def case(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("muscle")
    path = tmp / f"muscle_{request.param.lower()}.py"
    path.write_text(MUSCLE.format(mech="eomc.mechanics", formulation=request.param))
    model = eomc.compile(path, cache_dir=tmp / "cache")
    return request.param, model, _sympy_rhs(request.param)


def test_musculotendon_states_appended_and_match_sympy(case):
    formulation, model, (f, names) = case
    assert model.state_names == tuple(names)
    assert model.state_names[-1] == "a_muscle" and model.input_names == ("e_muscle",)
    assert model.nz == (1 if formulation == "RIGID_TENDON" else 2)
    assert model.initial_state[-1] == 0.1       # initial_state may name the activation
    for _ in range(4):
        q = RNG.uniform(0.5, 0.6)
        # an elastic tendon stretched 0..4 % past its slack length 0.25 (further, the De Groote
        # tendon curve's force overflows the inverse force-velocity curve: SymPy's numbers too)
        fibre = [(q - 0.25 * RNG.uniform(1.0, 1.04)) / 0.3] if model.nz == 2 else []
        x = np.array([q, RNG.uniform(-0.5, 0.5)] + fibre + [RNG.uniform(0.05, 1.0)])
        r = [RNG.uniform(0.0, 1.0)]
        want, got = f(x, r), model.rhs(0.0, x, r=r)
        assert np.max(np.abs(got - want)) <= 1e-12 * max(1.0, np.max(np.abs(want)))
        J = model.jacobian(0.0, x, r=r)
        h = 1e-7
        Jfd = np.array([(f(x + h * e, r) - f(x - h * e, r)) / (2 * h) for e in np.eye(x.size)]).T
        assert np.max(np.abs(J - Jfd)) <= 1e-5 * max(1.0, np.max(np.abs(J)))


def test_musculotendon_simulates_and_writes_its_states(case, tmp_path):
    formulation, model, _ = case
    res = model.simulate(model.initial_state, (0.0, 0.3), r=[0.2], rtol=1e-8, atol=1e-8)
    assert res.success
    assert 0.1 < res["a_muscle"][-1] <= 0.2 + 1e-9      # activation rises towards the excitation
    path = res.to_csv(tmp_path / "traj.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:len(model.state_names) + 1] == ["t", *model.state_names]
