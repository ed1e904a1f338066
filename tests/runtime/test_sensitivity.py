"""Forward sensitivities (runtime/sensitivity.py, runtime/c/eomc_sensitivity.c).

dx(t)/dx0 and dx(t)/dp from the variational equations, checked against
central differences of whole simulations (run at tighter tolerance) for the
explicit methods and Radau, plus the errors for what cannot be computed.
"""
import numpy as np
import pytest

import eomc
from eomc.errors import ModelError
from helpers.shared_builds import EXAMPLES
from helpers.module_cache import cache  # noqa: F401 -- the module's own build cache (a fixture)

MODEL = str(EXAMPLES / "cart_pole_system.py")   # not relative to the working directory
T = np.linspace(0.0, 2.0, 9)
X0 = np.array([0.1, 0.5, 0.0, 0.3])
R = np.array([0.2, -0.1])


@pytest.fixture(scope="module", params=["jac_x", "jvp"])
def model(cache, request):
    """Two builds: S' = J S + P from jac_x and jac_p, or from directional derivatives (jvp)."""
    extra = ["jvp"] if request.param == "jvp" else []
    return eomc.compile(MODEL, functions=["rhs", "jac_x", "jac_p", "outputs"] + extra)


def _fd(model, method, which, j, h):
    def run(sign):
        x0, p = X0.copy(), model.param_defaults.copy()
        (x0 if which == "x" else p)[j] += sign * h
        return model.simulate(x0, (0, 2), p=p, r=R, method=method, rtol=1e-12, atol=1e-12, t_eval=T).x
    return (run(1) - run(-1)) / (2 * h)


@pytest.mark.parametrize("method", ["dop853", "dopri5", "radau"])
def test_sensitivities_match_differences_of_whole_runs(model, method):
    names = ["q_pole", "u_cart", "m_pole", "l", "c", "g"]
    res = model.simulate(X0, (0, 2), r=R, method=method, rtol=1e-10, atol=1e-10, t_eval=T,
                         sensitivities=names)
    assert res.sensitivity_states == ("q_pole", "u_cart")
    assert res.sensitivity_params == ("m_pole", "l", "c", "g")
    assert res.dx_dx0.shape == (T.size, 4, 2) and res.dx_dp.shape == (T.size, 4, 4)
    # the state itself is the plain run's
    plain = model.simulate(X0, (0, 2), r=R, method=method, rtol=1e-10, atol=1e-10, t_eval=T)
    assert np.max(np.abs(res.x - plain.x)) < 1e-8
    assert np.array_equal(res.dx_dx0[0], np.eye(4)[:, [1, 2]])
    assert np.all(res.dx_dp[0] == 0.0)
    for k, (which, j) in enumerate([("x", 1), ("x", 2)]):
        fd = _fd(model, method, which, j, 1e-6)
        assert np.max(np.abs(res.dx_dx0[:, :, k] - fd)) < 1e-6 * np.max(np.abs(fd))
    for k, name in enumerate(res.sensitivity_params):
        j = model.param_names.index(name)
        fd = _fd(model, method, "p", j, 1e-6 * max(1.0, abs(model.param_defaults[j])))
        assert np.max(np.abs(res.dx_dp[:, :, k] - fd)) < 1e-6 * np.max(np.abs(fd)), name


def test_all_columns(model):
    res = model.simulate(X0, (0, 1), t_eval=[0.0, 1.0], sensitivities=True, rtol=1e-8, atol=1e-8)
    assert res.dx_dx0.shape == (2, 4, 4) and res.dx_dp.shape == (2, 4, model.nparam)
    assert res.sensitivity_params == model.param_names
    only_x0 = model.simulate(X0, (0, 1), t_eval=[0.0, 1.0], sensitivities="x0", rtol=1e-8, atol=1e-8)
    assert only_x0.dx_dp.shape == (2, 4, 0)
    assert np.allclose(only_x0.dx_dx0, res.dx_dx0, rtol=1e-6, atol=1e-9)


def test_bad_requests(cache):
    model = eomc.compile(MODEL, functions=["rhs", "jac_x", "jac_p", "outputs"])   # the fixture's (cached)
    with pytest.raises(ValueError, match="is neither a state"):
        model.simulate(X0, (0, 1), sensitivities=["mass"])
    with pytest.raises(ValueError, match="callable"):
        model.simulate(X0, (0, 1), r=lambda t: R, sensitivities=True)
    with pytest.raises(ValueError, match="twice"):
        model.simulate(X0, (0, 1), sensitivities=["g", "g"])
    bare = eomc.compile(MODEL, functions=["rhs", "jac_x"])
    jvp_only = eomc.compile(MODEL, functions=["rhs", "jac_x", "jvp"])      # jvp has the parameter directions
    assert jvp_only.simulate(X0, (0, 1), sensitivities=["g"], t_eval=[1.0]).dx_dp.shape == (1, 4, 1)
    with pytest.raises(ModelError, match=r"jac_p.*--outputs rhs,jac_x,jac_p"):
        bare.simulate(X0, (0, 1), sensitivities=True)
    assert bare.simulate(X0, (0, 1), sensitivities="x0", t_eval=[1.0]).dx_dx0.shape == (1, 4, 4)
    rhs_only = eomc.compile(MODEL, functions=["rhs"])
    with pytest.raises(ModelError, match="jac_x"):
        rhs_only.simulate(X0, (0, 1), sensitivities="x0")
    folded = eomc.compile(MODEL, functions=["rhs", "jac_x", "jac_p"], fold_parameters=True)
    with pytest.raises(ModelError, match="'m_pole' was folded"):
        folded.simulate(X0, (0, 1), sensitivities=["m_pole"])


@pytest.fixture(scope="module")
def jvp_model(cache):
    return eomc.compile(MODEL, functions=["rhs", "jac_x", "jac_p", "outputs", "jvp"])


def test_radau_staggered_takes_the_plain_runs_steps(jvp_model):
    """Radau with jvp solves S's collocation equations after each accepted step with that
    step's Newton matrix (staggered direct): the state and the steps are the plain run's bit
    for bit, S agrees with the error-controlled (simultaneous) run and with central
    differences of whole runs, also under a time-varying input table."""
    m = jvp_model
    r = (np.array([0.0, 0.7, 2.0]), np.array([[0.2, -0.1], [-0.4, 0.3], [0.1, 0.0]]))
    kw = dict(r=r, method="radau", rtol=1e-10, atol=1e-10, t_eval=T)
    plain = m.simulate(X0, (0, 2), **kw)
    res = m.simulate(X0, (0, 2), sensitivities=["q_pole", "l", "g"], **kw)
    assert np.array_equal(res.x, plain.x)
    assert res.stats["steps"] == plain.stats["steps"] and res.stats["nfev"] == plain.stats["nfev"]
    # per accepted step: the first iteration 3 jvp calls (one per stage), each later one 1
    acc, its = res.stats["accepted"], res.stats["sens_iterations"]
    assert its > acc > 0 and res.stats["njvp"] == 3 * acc + (its - acc)
    assert res.stats["sens_slow"] == 0
    iq = m.state_names.index("q_pole")
    assert np.array_equal(res.dx_dx0[0], np.eye(4)[:, [iq]]) and np.all(res.dx_dp[0] == 0.0)
    old = m.simulate(X0, (0, 2), sensitivities=["q_pole", "l", "g"], sensitivity_errors=True, **kw)
    assert old.stats["steps"] > plain.stats["steps"] and old.stats["njvp"] == 0
    S, S_old = (np.concatenate([z.dx_dx0, z.dx_dp], axis=2) for z in (res, old))
    assert np.max(np.abs(S - S_old)) < 1e-7 * np.max(np.abs(S_old))

    def fd(which, j, h):
        def run(sign):
            x0, p = X0.copy(), m.param_defaults.copy()
            (x0 if which == "x" else p)[j] += sign * h
            # (DOP853's runs at 1e-12 differ smoothly in p; Radau's at 1e-12 carry ~3e-6 of
            # step-selection noise into a difference over 2e-6)
            return m.simulate(x0, (0, 2), p=p, **dict(kw, method="dop853", rtol=1e-12, atol=1e-12)).x
        return (run(1) - run(-1)) / (2 * h)
    ref = np.stack([fd("x", iq, 1e-6)] + [fd("p", m.param_names.index(n), 1e-6) for n in ("l", "g")], 2)
    assert np.max(np.abs(S - ref)) < 1e-6 * np.max(np.abs(ref))


@pytest.mark.parametrize("method", ["dop853", "dopri5"])
def test_explicit_sensitivities_ride_the_plain_steps(jvp_model, method):
    """Explicit methods carry [x; S] through the same stages (jvp) with the error test on x
    alone: the plain run's steps; sensitivity_errors=True lets S steer them (more steps)."""
    m = jvp_model
    kw = dict(r=R, method=method, rtol=1e-9, atol=1e-9, t_eval=T)
    plain = m.simulate(X0, (0, 2), **kw)
    res = m.simulate(X0, (0, 2), sensitivities=["u_cart", "m_pole"], **kw)
    old = m.simulate(X0, (0, 2), sensitivities=["u_cart", "m_pole"], sensitivity_errors=True, **kw)
    assert abs(res.stats["steps"] - plain.stats["steps"]) <= 1
    assert old.stats["steps"] > res.stats["steps"]
    assert np.max(np.abs(res.x - plain.x)) < 1e-9
    S, S_old = (np.concatenate([z.dx_dx0, z.dx_dp], axis=2) for z in (res, old))
    assert np.max(np.abs(S - S_old)) < 1e-6 * np.max(np.abs(S_old))


@pytest.mark.parametrize("cols", [["l"], ["q_pole", "l", "g"]])
def test_radau_jvp_more_changes_nothing_but_the_calls_primal(jvp_model, cols):
    """A build with jvp_more carries Radau's second staggered iteration in the first one's
    middle-stage call (one primal fewer a step): the same operations, so x, S, the steps and
    the jvp call and iteration counts are the build with jvp alone's, bit for bit (with a
    time-varying input table); with the switch off the new build takes the old path."""
    from eomc.runtime import sensitivity
    more = eomc.compile(MODEL, functions=["rhs", "jac_x", "jac_p", "outputs", "jvp_more"])
    assert "jvp" in more.functions and "jvp_more" in more.functions
    assert "jvp_more" not in jvp_model.functions
    r = (np.array([0.0, 0.7, 2.0]), np.array([[0.2, -0.1], [-0.4, 0.3], [0.1, 0.0]]))
    kw = dict(r=r, method="radau", rtol=1e-10, atol=1e-10, t_eval=T, sensitivities=cols)
    a, b = jvp_model.simulate(X0, (0, 2), **kw), more.simulate(X0, (0, 2), **kw)
    sensitivity.USE_JVP_MORE = False
    try:
        c = more.simulate(X0, (0, 2), **kw)
    finally:
        sensitivity.USE_JVP_MORE = True
    for z in (b, c):
        assert np.array_equal(z.x, a.x)
        assert np.array_equal(z.dx_dp, a.dx_dp) and np.array_equal(z.dx_dx0, a.dx_dx0)
        for key in ("steps", "accepted", "nfev", "njvp", "sens_iterations", "sens_slow"):
            assert z.stats[key] == a.stats[key], key
    assert a.stats["sens_iterations"] > a.stats["accepted"] > 0   # the second iterations ran


def test_jvp_more_refused_by_the_recursive_formulation(cache):
    with pytest.raises(ModelError, match="jvp_more"):
        eomc.compile(MODEL, functions=["rhs", "jac_x", "jvp_more"], formulation="recursive")


# ---- issue 30 S3c: the benchmark's oracle (benchmarks/bench_sensitivity.oracle) -----------------------
def _bench_sensitivity():
    import importlib.util
    from pathlib import Path
    spec = importlib.util.spec_from_file_location(
        "bench_sensitivity", Path(__file__).resolve().parents[2] / "benchmarks" / "bench_sensitivity.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bench_sensitivity_oracle_is_accurate_differences(jvp_model):
    """bench_sensitivity holds S to D, five-point central differences of fixed-step RK4 runs.
    The five-point formula is exact (to rounding) on a quartic in theta where the two-point
    one is off by d^2 f'''/6; on the cart-pole over 2 s, D (h = 1.25e-4, step 1e-5) is within
    1e-9 of S from a 1e-12 DOP853 run, state and parameter columns (2.6e-10; two-point
    differences of the same runs with step 1e-6: 1.8e-9)."""
    from types import SimpleNamespace
    bench = _bench_sensitivity()
    fake = SimpleNamespace(param_names=("a",), param_defaults=np.array([2.0]), state_names=("y",))

    def quartic(x, p):          # x0 y and parameter a: f = a^4 + y^3 (both smooth, known slopes)
        a = 2.0 if p is None else p[0]
        return np.array([[a ** 4 + x[0] ** 3]])
    d = 1e-2
    four = bench.central_differences(fake, np.array([1.5]), ["a", "y"], quartic, d, order=4)
    two = bench.central_differences(fake, np.array([1.5]), ["a", "y"], quartic, d, order=2)
    exact = np.array([4 * 2.0 ** 3, 3 * 1.5 ** 2])
    assert np.allclose(four[0, 0], exact, rtol=1e-12, atol=0)
    assert abs(two[0, 0, 0] - exact[0]) > 1e-4 * exact[0]         # 4 a (2 d)^2 = 3.2e-3 off

    m = jvp_model
    cols = ["q_pole", "u_cart", "l", "g"]
    S = m.simulate(X0, (0, 2), method="dop853", rtol=1e-12, atol=1e-12, t_eval=T, sensitivities=cols)
    S = np.concatenate([S.dx_dx0, S.dx_dp], axis=2)
    D = bench.oracle(m, X0, cols, T)
    assert D.shape == S.shape
    assert np.max(np.abs(S - D)) < 1e-9 * np.max(np.abs(D))


@pytest.mark.parametrize("cols", [["l"], ["q_pole", "l", "g"]])
def test_radau_solves_skip_the_lus_structural_zeros(jvp_model, cols):
    """With J's top rows [0 I] (x = [q; u], q' = u) the LU of Radau's Newton matrix keeps the
    top rows [mu e_i, -e_(h+i)] (first half pivots on the diagonal), and the staggered S
    solves skip their zero entries (sensitivity.TRIM_SOLVES, eomc_integrators.c
    sg_top_structure): x, S, the steps and the counts are the whole-row solves' bit for bit.
    One column takes them at each factorization; from two columns on the half-order solves
    (sg_half_factor) run instead and nothing is skipped."""
    from eomc.runtime import sensitivity
    r = (np.array([0.0, 0.7, 2.0]), np.array([[0.2, -0.1], [-0.4, 0.3], [0.1, 0.0]]))
    kw = dict(r=r, method="radau", rtol=1e-10, atol=1e-10, t_eval=T, sensitivities=cols)
    a = jvp_model.simulate(X0, (0, 2), **kw)
    sensitivity.TRIM_SOLVES = False
    try:
        b = jvp_model.simulate(X0, (0, 2), **kw)
    finally:
        sensitivity.TRIM_SOLVES = True
    assert (a.stats["sens_trimmed"] > 0) == (len(cols) == 1)
    assert b.stats["sens_trimmed"] == 0
    assert np.array_equal(a.x, b.x)
    assert np.array_equal(a.dx_dp, b.dx_dp) and np.array_equal(a.dx_dx0, b.dx_dx0)
    for key in ("steps", "accepted", "nfev", "njvp", "sens_iterations", "sens_slow"):
        assert a.stats[key] == b.stats[key], key


def test_radau_solves_keep_whole_rows_without_the_structure(cache):
    """The heavy top's kinematic equations are not q' = u (J's top rows are not [0 I]): its
    staggered solves keep whole rows, and S still matches central differences."""
    m = eomc.compile(str(EXAMPLES / "heavy_top.py"), functions=["rhs", "jac_x", "jac_p", "jvp"])
    x0 = np.array([0.1, 0.4, 0.0, 0.3, -0.2, 5.0])
    kw = dict(method="radau", rtol=1e-10, atol=1e-10, t_eval=T)
    res = m.simulate(x0, (0, 2), sensitivities=[m.param_names[0]], **kw)
    assert res.stats["sens_trimmed"] == 0 and res.stats["njvp"] > 0

    def run(sign, h=1e-6):
        p = m.param_defaults.copy()
        p[0] += sign * h * max(1.0, abs(p[0]))
        return m.simulate(x0, (0, 2), p=p, **dict(kw, method="dop853", rtol=1e-12, atol=1e-12)).x
    ref = (run(1) - run(-1)) / (2e-6 * max(1.0, abs(m.param_defaults[0])))
    assert np.max(np.abs(res.dx_dp[:, :, 0] - ref)) < 1e-6 * np.max(np.abs(ref))
