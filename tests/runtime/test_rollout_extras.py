"""eomc.rollout with feedback, events, contacts and method="auto" (runtime/rollout_extras.py,
eomc_rollout_ex in runtime/c/eomc_rollout.c): every row equals simulate bit for bit.

Oracles: the scalar ``simulate`` with the same feedback, events and method (each row is one
eomc_integrate_ex call with simulate's options, so anything but exact equality is a bug), and,
for the gain schedule itself, a Python controller r(t, x) written from its definition.
"""
import warnings

import numpy as np
import pytest

from helpers import model_files
from helpers.stand_in import get_model

import eomc
from eomc.runtime.rollout import rollout
from eomc.runtime.simulate import simulate
from eomc.runtime.switching import PhysicsWarning

from .test_rollout import thrown_ball


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    d, cache = tmp_path_factory.mktemp("models"), tmp_path_factory.mktemp("cache")
    return eomc.compile(str(model_files.write(d, model_files.CART, "cart")), cache_dir=cache, progress=False)


UP = np.array([0.0, np.pi, 0.0, 0.0])


def _lqr(cart):
    from scipy.linalg import solve_continuous_are
    A, B = cart.linearize(0.0, UP)
    P = solve_continuous_are(A, B, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    return B.T @ P


def _starts(n, seed=0):
    rng = np.random.default_rng(seed)
    return UP + np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.2, n), np.zeros(n), np.zeros(n)])


@pytest.mark.parametrize("method", ["rk4", "dop853", "radau", "implicitfast"])
def test_constant_feedback_per_row_equals_simulate_bit_for_bit(cart, method):
    """K (x_ref - x) in C, one gain and reference per trajectory, on top of a per-row input."""
    K, n = _lqr(cart), 6
    X0 = _starts(n)
    Ks = K[None] * np.linspace(0.5, 1.5, n)[:, None, None]
    refs = UP + np.column_stack([np.linspace(-0.2, 0.2, n), np.zeros((n, 3))])
    r0 = np.linspace(-0.5, 0.5, n)[:, None]
    kw = dict(dt=0.01, steps=300) if method in ("rk4", "implicitfast") else dict(t_final=3.0, rtol=1e-9, atol=1e-11)
    sim = dict(dt=0.01) if method in ("rk4", "implicitfast") else dict(rtol=1e-9, atol=1e-11)
    res = rollout(cart, X0, method=method, K=Ks, x_ref=refs, r=r0, threads=2, **kw)
    assert res.ok.all()
    for i in range(n):
        one = simulate(cart, X0[i], (0.0, 3.0), method=method, K=Ks[i], x_ref=refs[i], r=r0[i], **sim)
        np.testing.assert_array_equal(res.x[i], one.x_final)
    # held near upright, at each row's own reference (the gains did something)
    assert np.abs(res.x[:, 1] - np.pi).max() < 0.05 and len(np.unique(np.round(res.x[:, 0], 3))) == n
    shared = rollout(cart, X0, method=method, K=K, x_ref=UP, threads=2, **kw)
    one = simulate(cart, X0[2], (0.0, 3.0), method=method, K=K, x_ref=UP, **sim)
    np.testing.assert_array_equal(shared.x[2], one.x_final)


@pytest.mark.parametrize("method", ["rk4", "bdf"])
def test_gain_schedule_per_row_equals_simulate_and_its_definition(cart, method):
    """K(t), x_ref(t) on a grid (an iLQR solver's K_k along its nominal x_k), linear between grid
    times and held after it: rollout == simulate(K=(t_grid, Ks)) bit for bit, and simulate's
    schedule == a Python controller evaluating the same definition (rk4: same steps, rounding only)."""
    K, n = _lqr(cart), 4
    X0 = _starts(n, seed=2)
    t_grid = np.array([0.0, 0.5, 1.1, 1.6])                  # ends before t_final: held after 1.6
    scale = 1.0 + 0.4 * np.sin(np.arange(n)[:, None] + 3.0 * t_grid[None, :])
    Ks = K[None, None] * scale[:, :, None, None]              # (n, k, 1, 4)
    refs = np.broadcast_to(UP, (n, t_grid.size, 4)).copy()
    refs[:, :, 0] = 0.1 * np.cos(t_grid)[None] * np.arange(1, n + 1)[:, None]
    kw = dict(dt=0.01, steps=200) if method == "rk4" else dict(t_final=2.0, rtol=1e-8, atol=1e-10)
    sim = dict(dt=0.01) if method == "rk4" else dict(rtol=1e-8, atol=1e-10)
    res = rollout(cart, X0, method=method, K=(t_grid, Ks), x_ref=refs, threads=2, **kw)
    assert res.ok.all()
    for i in range(n):
        one = simulate(cart, X0[i], (0.0, 2.0), method=method, K=(t_grid, Ks[i]), x_ref=refs[i], **sim)
        np.testing.assert_array_equal(res.x[i], one.x_final)
    if method == "rk4":
        def controller(i):
            def r(t, x):
                if t <= t_grid[0] or t >= t_grid[-1]:
                    j = 0 if t <= t_grid[0] else -1
                    return Ks[i, j] @ (refs[i, j] - x)
                lo = np.searchsorted(t_grid, t, side="right") - 1
                w = (t - t_grid[lo]) / (t_grid[lo + 1] - t_grid[lo])
                Kt = (1 - w) * Ks[i, lo] + w * Ks[i, lo + 1]
                return Kt @ ((1 - w) * refs[i, lo] + w * refs[i, lo + 1] - x)
            return r
        for i in range(n):
            by_python = simulate(cart, X0[i], (0.0, 2.0), method="rk4", dt=0.01, r=controller(i))
            assert np.abs(by_python.x_final - res.x[i]).max() < 1e-12
        const = rollout(cart, X0, method="rk4", K=Ks[:, 0], x_ref=refs[:, 0], threads=2, **kw)
        assert np.abs(const.x - res.x).max() > 1e-3          # the schedule mattered


def test_feedback_arguments_are_checked(cart):
    X0, K = _starts(3), _lqr(cart)
    with pytest.raises(ValueError, match=r"gain K must have shape \(ninput, nx\) = \(1, 4\) or \(3, 1, 4\)"):
        rollout(cart, X0, dt=0.01, steps=5, K=np.ones((2, 4)))
    with pytest.raises(ValueError, match=r"\(k, ninput, nx\) = \(3, 1, 4\) or \(3, 3, 1, 4\)"):
        rollout(cart, X0, dt=0.01, steps=5, K=([0.0, 1.0, 2.0], np.ones((2, 1, 4))))
    with pytest.raises(ValueError, match="strictly increasing"):
        rollout(cart, X0, dt=0.01, steps=5, K=([0.0, 1.0, 1.0], np.ones((3, 1, 4))))
    with pytest.raises(ValueError, match=r"x_ref must have shape \(4,\) or \(3, 4\)"):
        rollout(cart, X0, dt=0.01, steps=5, K=K, x_ref=np.zeros(3))
    with pytest.raises(ValueError, match="pass K= too"):
        rollout(cart, X0, dt=0.01, steps=5, x_ref=UP)
    with pytest.raises(ValueError, match="r cannot be a callable.*K=, x_ref="):
        rollout(cart, X0, dt=0.01, steps=5, r=lambda t, x: [0.0])
    with pytest.raises(ValueError, match="non-finite"):
        rollout(cart, X0, dt=0.01, steps=5, K=K * np.nan)


def test_terminal_event_on_a_compiled_model(tmp_path):
    """examples/cartpole_lqr.py has a terminal event "fallen": uncontrolled rows end there (as
    simulate ends them), rows held by the feedback run to t_final."""
    from pathlib import Path
    example = Path(__file__).resolve().parents[2] / "examples" / "cartpole_lqr.py"
    m = eomc.compile(str(example), cache_dir=tmp_path, progress=False)
    K, up = _lqr_of(m)
    X0 = np.array([m.initial_state] * 4)
    X0[:, 1] += [0.0, 0.05, -0.05, 0.1]
    gains = K[None] * np.array([0.0, 1.0, 0.0, 1.0])[:, None, None]    # rows 0 and 2 uncontrolled
    for method, kw, sim in (("rk4", dict(dt=0.01, steps=400), dict(dt=0.01)),
                            ("dop853", dict(t_final=4.0, rtol=1e-9, atol=1e-9), dict(rtol=1e-9, atol=1e-9))):
        res = rollout(m, X0, method=method, K=gains, x_ref=up, threads=2, **kw)
        assert res.ok.all()
        assert list(res.event_stop) == ["fallen", None, "fallen", None]
        for i in range(4):
            one = simulate(m, X0[i], (0.0, 4.0), method=method, K=gains[i], x_ref=up, t_eval=[4.0] if method != "rk4" else None, **sim)
            np.testing.assert_array_equal(res.x[i], one.x_final)
            assert res.event_stop[i] == one.event_stop
            for name, t in one.t_events.items():
                np.testing.assert_array_equal(res.t_events[i][name], t)
        assert res.t_events[0]["fallen"].size == 1 and res.t_events[0]["fallen"][0] < 4.0
    off = rollout(m, X0, method="rk4", dt=0.01, steps=400, events=False)
    assert all(s is None for s in off.event_stop)          # events=False: run past it, as simulate(events=False)


def _lqr_of(m):
    from scipy.linalg import solve_continuous_are
    up = np.array([0.0, np.pi, 0.0, 0.0])
    A, B = m.linearize(0.0, up)
    P = solve_continuous_are(A, B, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    return B.T @ P, up


@pytest.mark.parametrize("method", ["dop853", "radau", "bdf", "auto"])
def test_contacts_with_adaptive_methods_equal_simulate(tmp_path, method):
    """The thrown ball (lands, bounces, slides, spins): every adaptive method ends its steps at
    touch-down and lift-off as simulate does, so rows equal simulate's final states bit for bit,
    with its verdicts per row (status, messages)."""
    m, x0 = thrown_ball(tmp_path, f"ball_{method}")
    x0 = x0[:6]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        res = rollout(m, x0, t_final=0.4, method=method, rtol=1e-6, atol=1e-8, threads=2, raise_on_failure=False)
        for i in range(6):
            one = simulate(m, x0[i], (0.0, 0.4), method=method, rtol=1e-6, atol=1e-8, t_eval=[0.4],
                           raise_on_failure=False)
            np.testing.assert_array_equal(res.x[i], one.x_final)
            assert res.status[i] == one.status
            # simulate's t_eval row at t_final is the method's interpolant there: the state to
            # rounding, 1 ulp of its largest component (docs/sweeps.md; first hour s28 found radau and
            # bdf rows off it, so the doc's claim of t_eval=[t_final] rows bit for bit was wrong)
            assert np.abs(one.x[-1] - one.x_final).max() <= np.spacing(np.abs(one.x_final).max())
    z = list(m.state_names).index("q_root_z")
    assert (res.x[res.ok, z] < 0.2).all() and res.ok.sum() >= 4     # they came down and rest on the floor


def test_auto_rows_equal_simulate_auto():
    """method="auto" on a model without contacts: DOP853 with the stiffness test, each row as
    simulate(method="auto") runs it (a row found stiff is continued with Radau, as simulate does)."""
    m = get_model("vdp")
    X0 = np.array([[2.0, 0.0], [1.0, 0.5], [-1.5, 0.2]])
    P = np.array([[1.0], [1000.0], [5.0]]) if m.nparam == 1 else None
    res = rollout(m, X0, t_final=3.0, method="auto", p=P, rtol=1e-6, atol=1e-8)
    assert res.ok.all()
    for i in range(3):
        one = simulate(m, X0[i], (0.0, 3.0), method="auto", p=None if P is None else P[i], rtol=1e-6, atol=1e-8,
                       t_eval=[3.0])
        np.testing.assert_array_equal(res.x[i], one.x_final)


def test_allegro_with_its_implicit_terms_runs_clean(tmp_path):
    """The rows below that jac_x's fixed step fails for created energy (the fingers' joint friction,
    f = 10 N m on links of grams, linearised by its tangent: nil in a slip) run clean with the
    model's NAME_implicit, asked for (a tree without contacts has it on request since session 53):
    the fast path takes the friction by its secant.  Oracle: the energy (no source in the hand)
    never rises over any row's steps, and the statuses of the same starts without it."""
    from helpers.robots import robot_path
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    path = str(robot_path("allegro_hand_description/urdf/allegro_left_hand.urdf"))
    default = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = eomc.compile(path, name="allegro_imp", cache_dir=tmp_path, functions=default + ("implicit",), progress=False)
    assert "implicit" in m.metadata and not m.metadata["implicit"]["contacts"]
    X0 = np.tile(np.array(m.initial_state, dtype=float), (16, 1))
    X0[:, m.nq:] = np.random.default_rng(0).uniform(-0.5, 0.5, (16, m.nu))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = rollout(m, X0, steps=200, dt=0.001, threads=2, raise_on_failure=False)
        assert res.method == "implicitfast" and res.clean.all()
        for i in (0, 4, 11):
            one = simulate(m, X0[i], (0.0, 0.2), method="implicitfast", dt=0.001)
            E = one.outputs["energy"]
            assert np.all(E <= E[0] * (1 + 1e-12)) and one.stats["nfev"] <= 260
            np.testing.assert_array_equal(one.x[-1], res.x[i])


def test_rows_judged_with_record_final_get_simulates_energy_verdict(tmp_path):
    """Session 52 (rollout_sweep.py --urdf): example-robot-data's Allegro hand at 1 ms runs
    implicitfast without its fast path (joint limits, no ground contacts) through this module.  With
    record="final" (the default) the rows' one output row, the end, was labelled with the prepared
    grid's first time, t0, so the verdict took the end's energy for the start's and no row ever
    failed for created energy: 0 of 16 here, where simulate fails 5.  And simulate's C energy watch
    (the energy's range over every step) was off, so a rise between the start and the end went
    unseen too.  Oracle: simulate of each start, statuses and messages, with either record."""
    from helpers.robots import robot_path
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = eomc.compile(str(robot_path("allegro_hand_description/urdf/allegro_left_hand.urdf")), cache_dir=tmp_path,
                         progress=False)
    X0 = np.tile(np.array(m.initial_state, dtype=float), (16, 1))    # the file's start, speeds uniform in +-0.5
    X0[:, m.nq:] = np.random.default_rng(0).uniform(-0.5, 0.5, (16, m.nu))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = [simulate(m, x, (0.0, 0.2), method="implicitfast", dt=0.001, raise_on_failure=False) for x in X0]
        want = np.array([r.status for r in one])
        assert (want == 20).sum() >= 2 and (want == 0).sum() >= 2     # rows that create energy, rows that do not
        for record in ("final", "steps"):
            got = rollout(m, X0, steps=200, dt=0.001, method="implicitfast", record=record, threads=2,
                          raise_on_failure=False)
            np.testing.assert_array_equal(got.status, want)
            assert got.messages == {i: r.message for i, r in enumerate(one) if r.status}
            np.testing.assert_array_equal(got.x if record == "final" else got.x[:, -1], [r.x_final for r in one])
