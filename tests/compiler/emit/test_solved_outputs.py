"""Outputs and events that read accelerations (u', q'') and Lagrange multipliers.

They are computed in the same C function after solving A [u'; lam] = b.  Oracles:
the rod tension of a Cartesian pendulum m (l w^2 + g cos th), a particle's normal
force on a sphere m (g z - v^2) / R, and the height where it leaves the sphere,
z = (v0^2 + 2 g R) / (3 g) for a start at the top with horizontal speed v0.
"""
import numpy as np
import pytest
import sympy as sm

import eomc
from eomc.mechanics import LagrangesMethod, dynamicsymbols

t = dynamicsymbols._t


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


def test_rod_tension_and_accelerations_of_cartesian_pendulum(cache):
    x, y = dynamicsymbols("x y")
    m, g, l = sm.symbols("m g l")
    lm = LagrangesMethod(m / 2 * (x.diff() ** 2 + y.diff() ** 2) - m * g * y, [x, y],
                         hol_coneqs=[x ** 2 + y ** 2 - l ** 2])
    lm.form_lagranges_equations()
    lam = lm.lam_vec[0]
    model = eomc.compile(lm, "cpend", parameters={m: 2.0, g: 9.81, l: 1.5}, cache_dir=cache,
                         progress=False, outputs={"tension": 2 * lam * l, "xdd": x.diff(t, 2),
                                                  "ydd": y.diff().diff()})
    rng = np.random.default_rng(1)
    for th, w in rng.uniform(-2, 2, size=(5, 2)):
        X = np.array([1.5 * np.sin(th), -1.5 * np.cos(th), 1.5 * w * np.cos(th), 1.5 * w * np.sin(th)])
        out = model.outputs(0.0, X)
        assert out["tension"] == pytest.approx(2.0 * (1.5 * w ** 2 + 9.81 * np.cos(th)), rel=1e-12)
        np.testing.assert_allclose([out["xdd"], out["ydd"]], model.rhs(0.0, X)[2:], rtol=1e-13)
    assert "tension" in model.simulate([0, -1.5, 1.0, 0], (0, 1), n_points=5).outputs


def test_normal_force_on_sphere_and_the_event_where_the_particle_leaves(cache):
    x, y, z = q = dynamicsymbols("x y z")
    m, g, R = sm.symbols("m g R")
    v2 = sum(c.diff() ** 2 for c in q)
    lm = LagrangesMethod(m / 2 * v2 - m * g * z, q, hol_coneqs=[x ** 2 + y ** 2 + z ** 2 - R ** 2])
    lm.form_lagranges_equations()
    normal = -2 * lm.lam_vec[0] * R
    model = eomc.compile(lm, "sphere", parameters={m: 0.7, g: 9.81, R: 2.0}, cache_dir=cache,
                         progress=False, outputs={"normal": normal},
                         events={"leaves": {"expr": normal, "terminal": True, "direction": -1}})
    rng = np.random.default_rng(2)
    for _ in range(5):                       # random states on the sphere, velocity tangent
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        v = np.cross(n, rng.normal(size=3))
        X = np.concatenate([2.0 * n, v])
        expected = 0.7 * (9.81 * X[2] - v @ v) / 2.0
        assert model.outputs(0.0, X)["normal"] == pytest.approx(expected, rel=1e-11, abs=1e-12)
    v0 = 0.5
    res = model.simulate([0, 0, 2.0, v0, 0, 0], (0, 10), rtol=1e-12, atol=1e-12, project=True)
    assert res.event_stop == "leaves"
    z_leave = res.x_final[2]
    assert z_leave == pytest.approx((v0 ** 2 + 2 * 9.81 * 2.0) / (3 * 9.81), rel=1e-8)


def test_output_with_unknown_multiplier_is_refused(cache):
    x = dynamicsymbols("x")
    m = sm.symbols("m")
    lm = LagrangesMethod(m / 2 * x.diff() ** 2, [x])
    lm.form_lagranges_equations()
    with pytest.raises(eomc.runtime.errors.ModelError, match="lam7"):
        eomc.compile(lm, "free", parameters={m: 1.0}, cache_dir=cache, progress=False,
                     outputs={"bad": dynamicsymbols("lam7")})


def test_rolling_disc_contact_forces_from_auxiliary_equations_with_udot(cache):
    """Kane's auxiliary equations solved for the contact force with u' left symbolic (a small
    linear solve) compile to outputs that read the solved u'; SymPy's closed form (u' substituted
    symbolically first, as examples/rolling_disc.py does) is the oracle at random states."""
    import eomc.mechanics as me
    from helpers import zoo
    km, _ = zoo.rolling_disc_aux(me)
    f = sm.symbols("f1:4")
    r, m, g = sm.symbols("r m g")
    values = {r: 0.5, m: 1.3, g: 9.81}
    forces = sm.solve(list(km.auxiliary_eqs), f, dict=True)[0]
    model = eomc.compile(km, "disc_aux", parameters=values, cache_dir=cache, progress=False,
                         outputs={f"f{i + 1}": forces[s] for i, s in enumerate(f)})
    udot = dict(zip([ui.diff() for ui in km.u], km.mass_matrix.LUsolve(km.forcing)))
    closed = sm.solve(list(km.auxiliary_eqs.xreplace(udot)), f, dict=True)[0]
    states = list(km.q) + list(km.u)
    oracle = sm.lambdify(states, [closed[s].xreplace(values) for s in f])
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.uniform(-1, 1, size=6)
        x[1] = rng.uniform(-0.8, 0.8)              # lean away from lying flat
        got = model.outputs(0.0, x)
        np.testing.assert_allclose([got["f1"], got["f2"], got["f3"]], oracle(*x), rtol=1e-10,
                                   atol=1e-10)
