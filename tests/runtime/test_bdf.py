"""The variable-order BDF/NDF integrator (method="bdf", runtime/c/eomc_bdf.c) against closed
forms and independent solvers.

Oracles: the matrix exponential of the (linear) stiff chain, cos(2t) for the oscillator,
scipy's LSODA at rtol 1e-12 for Robertson's kinetics and van der Pol at mu = 1000 (with
scipy's own BDF at the same tolerance as the accuracy to match), Robertson's conserved
sum, and the failing stand-ins' known failure times.  The contact drop against Radau is
in test_switching.py, the events in test_events.py, the sanitizers in
test_integrators_sanitize.py.
"""
import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from helpers.stand_in import get_model

from eomc.errors import SimulationError
from eomc.runtime.simulate import simulate


@pytest.mark.parametrize("kappa", [1e3, 1e6, 1e8])
def test_stiff_linear_chain_matches_the_matrix_exponential(kappa):
    m = get_model("chain")
    p = np.array([1.0, kappa, 0.1, 2 * np.sqrt(kappa)])      # overdamped stiff link
    A = m.jacobian(0.0, np.zeros(4), p)
    x0 = np.array([1.0, 1.0, 0.0, 0.0])
    t = np.linspace(0, 10, 11)
    res = simulate(m, x0, (0, 10), p=p, method="bdf", rtol=1e-6, atol=1e-6, t_eval=t)
    exact = np.array([expm(A * s) @ x0 for s in t])
    assert np.max(np.abs(res.x - exact)) < 1e-5
    # stiff: the step follows the slow mode, not the fast one (an explicit method needs ~kappa^0.5 * 10 steps)
    assert res.stats["steps"] < 400
    # the Jacobian is kept across steps (linear: J never changes), the LU mostly too
    assert res.stats["njev"] <= 5 and res.stats["nlu"] < res.stats["accepted"] / 3


def test_error_follows_the_tolerance_and_dense_output_is_as_accurate():
    m = get_model("oscillator")                  # x'' = -4 x: cos(2t)
    t = np.linspace(0, 10, 101)                  # output between steps: the dense polynomial
    errors = []
    for tol in (1e-4, 1e-6, 1e-8):
        res = simulate(m, [1.0, 0.0], (0, 10), method="bdf", rtol=tol, atol=tol, t_eval=t)
        errors.append(np.max(np.abs(res.x[:, 0] - np.cos(2 * t))))
        assert errors[-1] < 30 * tol
    assert errors[1] < errors[0] / 10 and errors[2] < errors[1] / 10


def _robertson(t, y):
    return [-0.04 * y[0] + 1e4 * y[1] * y[2], 0.04 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2,
            3e7 * y[1] ** 2]


@pytest.mark.parametrize("tol", [1e-4, 1e-7])
def test_robertson_kinetics_to_the_tolerance_with_the_sum_conserved(tol):
    m = get_model("robertson")
    t = np.array([0, 0.4, 4, 40, 400, 4e3, 4e4, 4e5])
    ref = solve_ivp(_robertson, (0, 4e5), [1, 0, 0], method="LSODA", rtol=1e-12, atol=1e-16, t_eval=t)
    res = simulate(m, [1.0, 0.0, 0.0], (0, 4e5), method="bdf", rtol=tol, atol=tol * 1e-4, t_eval=t)
    rel = np.abs(res.x - ref.y.T) / (tol * 1e-4 + np.abs(ref.y.T))
    assert rel.max() < 10 * tol
    # a linear invariant: every BDF step keeps it to Newton's rounding
    assert np.max(np.abs(res.x.sum(axis=1) - 1.0)) < 1e-13
    assert res.stats["steps"] < 1000             # y2's fast transient does not set the step
    # Newton stops at 3 % of the local tolerance (NEWTON_TOL in eomc_bdf.c), not at scipy's
    # sqrt(rtol): 2.55 / 2.34 rhs calls a step here, 2.99 / 3.83 with scipy's rule
    assert res.stats["nfev"] < 2.8 * res.stats["steps"]


def _vdp(t, y, mu=1000.0):
    return [y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]]


def _vdp_jac(t, y, mu=1000.0):
    return [[0.0, 1.0], [-2 * mu * y[0] * y[1] - 1.0, mu * (1 - y[0] ** 2)]]


@functools.lru_cache(maxsize=None)
def _vdp_reference(t):
    """scipy's LSODA at 1e-12 (Fortran, so the reference costs well under a second)."""
    return solve_ivp(_vdp, (0, 3000), [2, 0], method="LSODA", rtol=1e-12, atol=1e-12, jac=_vdp_jac,
                     t_eval=np.array(t))


@pytest.mark.parametrize("tol", [1e-4, 1e-6])
def test_van_der_pol_mu_1000_at_least_as_accurate_as_scipys_bdf(tol):
    t = np.linspace(0, 3000, 7)                  # across two relaxation jumps
    ref = _vdp_reference(tuple(t))
    peer = solve_ivp(_vdp, (0, 3000), [2, 0], method="BDF", rtol=tol, atol=tol, jac=_vdp_jac, t_eval=t)
    res = simulate(get_model("vdp"), [2.0, 0.0], (0, 3000), method="bdf", rtol=tol, atol=tol, t_eval=t)
    ours, theirs = np.abs(res.x[:, 0] - ref.y[0]).max(), np.abs(peer.y[0] - ref.y[0]).max()
    assert ours <= 1.5 * theirs and ours < 1e3 * tol
    assert res.stats["steps"] < 4000


def test_a_model_failure_inside_newton_is_the_runs_status_at_its_time():
    m = get_model("decay_fail")                  # x' = -x; singular mass matrix once t > 0.5
    with pytest.raises(SimulationError, match="the mass matrix is singular"):
        simulate(m, [1.0], (0, 1), method="bdf")
    res = simulate(m, [1.0], (0, 1), method="bdf", raise_on_failure=False)
    assert res.status == 1 and 0.5 - 1e-9 < res.t_final <= 0.5
    assert res.x_final[0] == pytest.approx(np.exp(-res.t_final), rel=1e-4)
    assert np.all(res.t <= res.t_final) and np.all(np.isfinite(res.x))


def test_blowup_stops_near_the_singularity_with_a_failure_status():
    res = simulate(get_model("blowup"), [1.0], (0, 2), method="bdf", raise_on_failure=False)
    assert res.status in (3, 5) and 0.99 < res.t_final < 1.001   # x' = x^2: infinite at t = 1
    assert np.all(np.isfinite(res.x))


def test_max_steps_and_missing_jacobian_are_reported():
    with pytest.raises(SimulationError, match="maximum number of steps"):
        simulate(get_model("vdp"), [2.0, 0.0], (0, 3000), method="bdf", max_steps=50)
    with pytest.raises(ValueError, match="needs the Jacobian jac_x"):
        simulate(get_model("singular"), [0.0], (0, 1), method="bdf")


@functools.lru_cache(maxsize=None)
def _newton_harness():
    import tempfile
    from pathlib import Path

    import cffi

    from helpers.stand_in import MODELS_DIR, compile_shared
    so = compile_shared(Path(tempfile.mkdtemp(prefix="eomc_bdfnewton_")) / "libbdfnewton.so",
                        [MODELS_DIR / "bdf_newton.c"])
    ffi = cffi.FFI()
    ffi.cdef("int bdf_newton_solve(int n, int nsplit, const double *J, double c, double *r);")
    return ffi, ffi.dlopen(str(so))


def _multibody_jacobian(rng, nfree, nhinge, extra=0, ndep=3):
    """J of x = (q, v, extra) with nq = nfree + nhinge: a floating base's rates (positions
    turn with its ndep angles, the angles' rates depend on themselves) as the ant's and
    Solo12's generated jac_x have them, hinges' q_i' = v_i, dense speed and extra rows."""
    m = nfree + nhinge
    n = 2 * m + extra
    J = np.zeros((n, n))
    dep = list(range(nfree - ndep, nfree))
    for i in range(nfree):               # base rows: its angles and its speeds only
        J[i, dep] = rng.normal(size=ndep)
        J[i, m + np.arange(nfree)] = rng.normal(size=nfree) * (rng.random(nfree) < 0.6)
    for i in range(nfree, m):
        J[i, m + i] = 1.0
    J[m:, :] = rng.normal(size=(n - m, n))
    J[m:, :nfree - ndep] *= rng.random((n - m, nfree - ndep)) < 0.3   # positions: ground only
    return J


@pytest.mark.parametrize("nfree, nhinge, extra, ndep, kept", [
    (6, 8, 0, 3, 14),      # gymnasium's ant: 14 of 28 rows kept (20 with the hinges' alone)
    (6, 12, 0, 3, 18),     # Solo12: 18 of 36 (24)
    (0, 6, 0, 0, 6),       # a planar hopper: the speeds only
    (6, 4, 3, 3, 13),      # actuator states after the speeds stay in the LU
    (12, 2, 0, 10, 24),    # more than EOMC_BDF_MAX_DEP such coordinates: those stay in the LU
])
def test_newton_solve_eliminating_the_coordinates_rows_is_the_dense_solve(nfree, nhinge, extra,
                                                                          ndep, kept):
    """BDF's Newton LU eliminates every coordinate's row whose rate depends on the speeds and on
    at most EOMC_BDF_MAX_DEP coordinates (factor_lu); its x must be numpy's dense solve of
    (I - c J) x = r, for small and stiff c, and the LU must hold only the kept rows."""
    ffi, lib = _newton_harness()
    rng = np.random.default_rng(7 + nfree + nhinge)
    for trial in range(6):
        J = _multibody_jacobian(rng, nfree, nhinge, extra, ndep)
        n, m = J.shape[0], nfree + nhinge
        for c in (1e-4, 0.05, 0.7):
            A = np.eye(n) - c * J
            r = rng.normal(size=n)
            x = r.copy()
            k = lib.bdf_newton_solve(n, m, ffi.cast("double *", ffi.from_buffer(J)), c,
                                     ffi.cast("double *", ffi.from_buffer(x)))
            assert k == kept
            want = np.linalg.solve(A, r)
            assert np.max(np.abs(x - want)) <= 1e-11 * np.linalg.cond(A) * np.max(np.abs(want))


@functools.lru_cache(maxsize=None)
def _step_harness():
    ffi, lib = _newton_harness()
    ffi.cdef("int bdf_one_step(const double *y0, double h, double rtol, double c_pre, double *ynew,"
             " double *tn, long *counts);")
    return ffi, lib


def _step_rhs(x, m=3, k=4e4, d=40.0, g=9.81, s=2e5):
    """The harness's system (bdf_newton.c, bdf_one_step): q' = v, v_i' = -k q_i - d v_i
    - g sin q_i - s (q_i - q_{i+1})^3 + s (q_{i-1} - q_i)^3 (q_4 = 0; no q_0 term)."""
    q, v = x[:m], x[m:]
    dq = q - np.append(q[1:], 0.0)
    dp = np.insert(q[:-1] - q[1:], 0, 0.0)
    return np.concatenate([v, -k * q - d * v - g * np.sin(q) - s * dq ** 3 + s * dp ** 3])


def _step_jac(x, eps=1e-7):
    return np.array([(_step_rhs(x + eps * e) - _step_rhs(x - eps * e)) / (2 * eps)
                     for e in np.eye(len(x))]).T


def _bdf1_solution(y0, h):
    """The first (order-1 NDF) step's implicit equation d - c f(ypred + d) + psi = 0, with
    ypred = y0 + h f0, psi = h f0 / alpha_1, c = h / alpha_1 (alpha_1 = 1 + 0.185), solved by
    full Newton to rounding: the y = ypred + d BDF's Newton approximates."""
    alpha1 = 1.185
    f0 = _step_rhs(y0)
    ypred, psi, c = y0 + h * f0, h * f0 / alpha1, h / alpha1
    d = np.zeros_like(y0)
    for _ in range(30):
        residual = d - c * _step_rhs(ypred + d) + psi
        d -= np.linalg.solve(np.eye(len(y0)) - c * _step_jac(ypred + d), residual)
    return ypred + d


@pytest.mark.parametrize("y0", [[0.05, -0.03, 0.02, 0.0, 0.0, 0.0],
                                [0.08, 0.0, -0.08, 3.0, -2.0, 1.0]])
@pytest.mark.parametrize("ratio", [0.75, 0.9, 1.1, 1.25, 0.6, 1.5])
def test_newton_keeps_its_lu_across_a_small_change_of_h_and_converges_to_the_same_step(y0, ratio):
    """Newton's matrix I - c J (c = h / alpha) is refactored only when c moved more than 30 %
    from the c of its LU (eomc_bdf.c LU_BAND, as CVODE and LSODA do); in between the old LU is
    used and each correction scaled by 2 / (1 + c / c_lu).  One step of a nonlinear (q, v)
    system (three joints, springs of 4e4, cubic couplings) with the LU left from c / ratio:
    within the band no new LU, no rejected try, the step as long as asked, and its y within
    Newton's tolerance (3 % of the local error allowed, in the error test's scaled norm) of the
    exact solution of the step's implicit equation, as the step with a fresh LU is; outside the
    band a new LU."""
    ffi, lib = _step_harness()
    y0 = np.array(y0, dtype=float)
    h, rtol = 3e-4, 1e-3
    c = h / 1.185
    exact = _bdf1_solution(y0, h)

    def step(c_pre):
        y, out, tn, counts = y0.copy(), np.zeros(6), ffi.new("double *"), ffi.new("long[3]")
        status = lib.bdf_one_step(ffi.cast("double *", ffi.from_buffer(y)), h, rtol, c_pre,
                                  ffi.cast("double *", ffi.from_buffer(out)), tn, counts)
        assert status == 0
        assert tn[0] == h and counts[2] == 0          # taken at once, as asked
        return out, counts[0]

    def scaled(y):
        return np.sqrt(np.mean(((y - exact) / (rtol + rtol * np.abs(exact))) ** 2))

    fresh, nlu_fresh = step(0.0)
    assert nlu_fresh == 1 and scaled(fresh) < 0.03
    kept, nlu = step(c / ratio)
    if abs(ratio - 1.0) <= 0.3:
        assert nlu == 1                  # the pre-factored LU only: kept for this step
        assert 0.0 < scaled(kept) < 0.03   # another matrix than the fresh one, Newton's tolerance
    else:
        assert nlu == 2                  # refactored for this c
        np.testing.assert_array_equal(kept, fresh)


@pytest.mark.parametrize("h, cuts", [(3e-3, 1), (1e-2, 2), (3e-2, 3)])
def test_a_newton_failure_with_a_fresh_jacobian_cuts_the_step_to_three_tenths(h, cuts):
    """After Newton fails with a Jacobian taken in this step (at the predictor, then again at
    Newton's last iterate), the step is retried at 0.3 of its length (eomc_bdf.c NEWTON_CUT;
    CVODE and DLSODE cut to 0.25, this code halved before).  The harness's step with J = 0:
    Newton is then a fixed-point iteration that diverges while c |lambda| >~ 1 (springs of 4e4),
    so each too-long step fails with a fresh J and nothing else rejects it at rtol 1e-2: the step
    taken is h * 0.3^m after m such failures (with halving it was h * 0.5^m)."""
    ffi, lib = _step_harness()
    ffi.cdef("void bdf_step_zero_jacobian(int on);", override=True)
    y0 = np.array([0.05, -0.03, 0.02, 0.0, 0.0, 0.0])
    y, out, tn, counts = y0.copy(), np.zeros(6), ffi.new("double *"), ffi.new("long[3]")
    lib.bdf_step_zero_jacobian(1)
    try:
        status = lib.bdf_one_step(ffi.cast("double *", ffi.from_buffer(y)), h, 1e-2, 0.0,
                                  ffi.cast("double *", ffi.from_buffer(out)), tn, counts)
    finally:
        lib.bdf_step_zero_jacobian(0)
    assert status == 0 and np.isfinite(out).all()
    assert counts[2] == cuts                       # tries rejected: Newton's failures only
    assert tn[0] == pytest.approx(h * 0.3 ** cuts, rel=1e-12)
    # the step it took is the BDF step of that length (Newton within its tolerance)
    exact = _bdf1_solution(y0, tn[0])
    assert np.sqrt(np.mean(((out - exact) / (1e-2 + 1e-2 * np.abs(exact))) ** 2)) < 0.03


def test_a_step_after_a_jacobian_that_failed_takes_a_new_one(tmp_path):
    """A failed J evaluation leaves J half written: if the LU of (I - cJ) then fails too, Newton
    never runs to ask for another, so the rejected step must take one at its next predictor.
    Found with a sphere dropped on a plane from 1.2 m, its free joint a quaternion (the MJCF
    default; n = 13, so the LU is not split): the step from t = 0.27 to 0.72 predicted the
    sphere deep in the plane, the rhs and then the J there failed, and every smaller step failed
    the same LU down to h = 3e-16 (status 3).  Now it lands and rests on the plane, as Radau's
    run and the Euler build's (whose step sequence never met the failing J)."""
    pytest.importorskip("mujoco")
    import warnings

    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path / "drop.xml"
    path.write_text('<mujoco><worldbody><geom type="plane" size="5 5 .1" pos="0 0 -0.2"/>'
                    '<body name="ball" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>'
                    '</worldbody></mujoco>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, orientation="quaternion"), "drop", cache_dir=tmp_path / "c",
                             progress=False)
        res = simulate(model, model.initial_state, (0.0, 2.0), method="bdf", raise_on_failure=False)
        ref = simulate(model, model.initial_state, (0.0, 2.0), method="radau", raise_on_failure=False)
    assert res.status == 0, res.message
    assert abs(res.x[-1][2] - ref.x[-1][2]) < 1e-4 and abs(ref.x[-1][2] + 0.1) < 1e-2
