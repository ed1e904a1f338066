"""eomc.rollout (runtime/rollout.py, runtime/c/eomc_rollout.c): every row equals simulate bit for bit.

Oracle: the scalar ``simulate`` path with the same method, step and span -- rollout rows are
eomc_integrate calls made from C threads, so anything but exact equality (a shared work
buffer, a wrong row stride, a parameter row mixed up between threads) is a bug.
"""
import re
import warnings

import numpy as np
import pytest

from helpers.stand_in import get_model

import eomc
from eomc.errors import SimulationError
from eomc.runtime.rollout import rollout
from eomc.runtime.simulate import simulate
from eomc.runtime.switching import PhysicsWarning


def _pendulum_starts(n, seed=0):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-3.0, 3.0, n), rng.uniform(-2.0, 2.0, n)])


@pytest.mark.parametrize("threads", [1, 2])
def test_rk4_final_states_equal_simulate_bit_for_bit(threads):
    m = get_model("pendulum")
    X0 = _pendulum_starts(13)
    res = rollout(m, X0, steps=250, dt=0.01, method="rk4", threads=threads)
    assert res.x.shape == (13, 2) and res.ok.all() and (res.steps == 250).all()
    assert res.t.tolist() == [2.5]
    for i in range(13):
        single = simulate(m, X0[i], (0.0, 2.5), method="rk4", dt=0.01)
        np.testing.assert_array_equal(res.x[i], single.x[-1])
    # the motion is not trivial: the final states differ from the starts and from each other
    assert np.abs(res.x - X0).min() > 1e-3 and len(np.unique(res.x[:, 0])) == 13


@pytest.mark.parametrize("method", ["dopri5", "dop853", "radau", "bdf"])
def test_adaptive_final_states_equal_simulate_bit_for_bit(method):
    """Adaptive rows (issue 31): one eomc_integrate per row with simulate's options, so the
    same accepted and rejected steps; per-row parameters too."""
    m = get_model("oscillator")
    X0 = np.column_stack([np.linspace(-1.0, 1.0, 9), np.linspace(0.5, -0.5, 9)])
    P = np.column_stack([np.linspace(1.0, 9.0, 9), np.full(9, 1.0), np.linspace(0.0, 0.4, 9)])
    res = rollout(m, X0, t_final=3.0, method=method, p=P, rtol=1e-9, atol=1e-11, threads=2)
    assert res.x.shape == (9, m.nx) and res.ok.all() and res.t.tolist() == [3.0]
    for i in range(9):
        single = simulate(m, X0[i], (0.0, 3.0), p=P[i], method=method, rtol=1e-9, atol=1e-11)
        np.testing.assert_array_equal(res.x[i], single.x_final)
        assert res.steps[i] == single.stats["steps"]
    assert len(np.unique(res.steps)) > 1         # the rows took their own step sequences


@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_control_sequences_per_row_equal_simulate_bit_for_bit(method):
    """r=(t_grid, values): one control sequence per trajectory on a shared time grid, linearly
    interpolated as simulate's input table (and held past its ends); constant rows too."""
    m = get_model("oscillator")
    n = 7
    X0 = np.column_stack([np.linspace(-1.0, 1.0, n), np.zeros(n)])
    t_grid = np.array([0.0, 0.3, 0.7, 1.2, 1.5])            # ends before t_final: held after 1.5
    values = np.random.default_rng(5).uniform(-2.0, 2.0, (n, t_grid.size, 1))
    kw = dict(dt=0.01, steps=200) if method == "rk4" else dict(t_final=2.0, rtol=1e-9, atol=1e-11)
    sim = dict(dt=0.01) if method == "rk4" else dict(rtol=1e-9, atol=1e-11)
    res = rollout(m, X0, method=method, r=(t_grid, values), threads=2, **kw)
    const = rollout(m, X0, method=method, r=values[:, 2], threads=2, **kw)
    assert res.ok.all() and const.ok.all()
    for i in range(n):
        single = simulate(m, X0[i], (0.0, 2.0), method=method, r=(t_grid, values[i]), **sim)
        np.testing.assert_array_equal(res.x[i], single.x_final)
        single = simulate(m, X0[i], (0.0, 2.0), method=method, r=values[i, 2], **sim)
        np.testing.assert_array_equal(const.x[i], single.x_final)
    shared = rollout(m, X0, method=method, r=(t_grid, values[0]), threads=2, **kw)
    np.testing.assert_array_equal(shared.x[0], res.x[0])
    assert np.abs(shared.x[1:] - res.x[1:]).max() > 1e-3     # the sequences mattered
    with pytest.raises(ValueError, match=r"values must have shape \(5, 1\).*or \(7, 5, 1\)"):
        rollout(m, X0, method=method, r=(t_grid, values[:, :3]), **kw)
    with pytest.raises(ValueError, match=r"r must have shape \(1,\).*\(7, 1\)"):
        rollout(m, X0, method=method, r=np.zeros((3, 1)), **kw)
    with pytest.raises(ValueError, match="has no inputs, but r was given"):
        rollout(get_model("pendulum"), X0, method=method, r=np.zeros(1), **kw)


def test_input_tables_are_checked_alike_by_simulate_and_rollout():
    """One validator (simulate.input_grid) for both entry points: the same table is refused with
    the same message, and the shapes simulate takes ((k,) for one input) rollout takes too."""
    m = get_model("oscillator")
    X0 = np.array([[0.5, 0.0], [-0.5, 0.0]])
    bad = [((np.array([0.0, 0.5, 0.5, 1.0]), np.zeros(4)), r"t_grid must be strictly increasing; t_grid\[2\]"),
           ((np.array([0.0, 1.0]), np.array([0.0, np.nan])), r"non-finite values: values\[1, 0\]"),
           ((np.array([[0.0, 1.0]]), np.zeros(2)), r"t_grid must be 1-d with at least 2 times"),
           ((np.linspace(0, 1, 5), np.zeros((4, 1))), r"values must have shape \(5, 1\)")]
    for r, match in bad:
        with pytest.raises(ValueError, match=match) as from_simulate:
            simulate(m, X0[0], (0.0, 1.0), method="rk4", dt=0.01, r=r)
        with pytest.raises(ValueError, match=match) as from_rollout:
            rollout(m, X0, dt=0.01, steps=100, r=r)
        if "shape" not in match:     # rollout's shape message also offers (rows, k, ninput)
            assert str(from_simulate.value) == str(from_rollout.value)
    t_grid, u = np.array([0.0, 0.4, 1.0]), np.array([1.0, -2.0, 0.5])
    flat = rollout(m, X0, dt=0.01, steps=100, r=(t_grid, u))
    np.testing.assert_array_equal(flat.x, rollout(m, X0, dt=0.01, steps=100, r=(t_grid, u[:, None])).x)
    np.testing.assert_array_equal(flat.x[0], simulate(m, X0[0], (0.0, 1.0), method="rk4", dt=0.01,
                                                      r=(t_grid, u)).x_final)


@pytest.mark.parametrize("threads", [1, 2])
def test_rk4_every_step_recorded_equals_simulate(threads):
    m = get_model("pendulum")
    X0 = _pendulum_starts(5, seed=1)
    res = rollout(m, X0, t_final=1.234, dt=0.01, record="steps", threads=threads)
    single0 = simulate(m, X0[0], (0.0, 1.234), method="rk4", dt=0.01)
    assert res.x.shape == (5, single0.t.size, 2)
    np.testing.assert_array_equal(res.t, single0.t)     # the shortened last step ends on 1.234
    for i in range(5):
        np.testing.assert_array_equal(res.x[i], simulate(m, X0[i], (0.0, 1.234), method="rk4", dt=0.01).x)


@pytest.mark.parametrize("threads", [1, 2])
def test_implicitfast_with_one_parameter_row_per_trajectory(threads):
    m = get_model("chain")
    X0 = np.array([[1.0, 1.0, 0.0, 0.0], [0.5, -0.2, 0.1, 0.0], [0.0, 0.3, -1.0, 2.0], [2.0, 0.0, 0.0, 0.0]])
    P = np.array([[1.0, 1e6, 0.1, 2e3], [1.0, 1e3, 0.1, 10.0], [2.0, 1e4, 0.5, 1.0], [1.0, 50.0, 0.0, 0.0]])
    res = rollout(m, X0, steps=200, dt=0.01, method="implicitfast", p=P, threads=threads)
    for i in range(4):
        single = simulate(m, X0[i], (0.0, 2.0), p=P[i], method="implicitfast", dt=0.01)
        np.testing.assert_array_equal(res.x[i], single.x[-1])
    # the rows really got their own parameters: the same start under row 0's p differs
    other = simulate(m, X0[1], (0.0, 2.0), p=P[0], method="implicitfast", dt=0.01)
    assert np.abs(other.x[-1] - res.x[1]).max() > 1e-3


def test_facade_name_and_more_rows_than_threads():
    m = get_model("pendulum")
    X0 = _pendulum_starts(101, seed=2)
    res = eomc.rollout(m, X0, steps=50, dt=0.02, threads=7)
    ref = rollout(m, X0, steps=50, dt=0.02, threads=1)
    np.testing.assert_array_equal(res.x, ref.x)


def test_failed_row_is_named_and_the_others_kept():
    m = get_model("singular")
    P = np.array([[2.0], [0.5], [3.0]])
    with pytest.raises(SimulationError, match="row 1 of 3 failed.*singular"):
        rollout(m, np.zeros((3, m.nx)), steps=100, dt=0.01, p=P, threads=2)
    res = rollout(m, np.zeros((3, m.nx)), steps=100, dt=0.01, p=P, threads=2, raise_on_failure=False)
    assert res.status.tolist()[0] == 0 and res.status[1] != 0 and res.status[2] == 0
    np.testing.assert_array_equal(res.x[2], simulate(m, np.zeros(m.nx), (0, 1.0), p=P[2], method="rk4",
                                                     dt=0.01).x[-1])


def test_bad_input_says_what_is_wrong():
    m = get_model("pendulum")
    good = np.zeros((3, 2))
    with pytest.raises(ValueError, match=r"x0s must have shape \(n, 2\).*got shape \(3, 3\)"):
        rollout(m, np.zeros((3, 3)), steps=10, dt=0.01)
    with pytest.raises(ValueError, match=r"x0s must have shape \(n, 2\).*got shape \(2,\)"):
        rollout(m, np.zeros(2), steps=10, dt=0.01)
    bad = good.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=f"x0s row 2 has a non-finite {m.state_names[1]}"):
        rollout(m, bad, steps=10, dt=0.01)
    with pytest.raises(ValueError, match="unknown integration method 'rk5'"):
        rollout(m, good, steps=10, dt=0.01, method="rk5")
    with pytest.raises(ValueError, match="method 'dop853' is adaptive: give t_final="):
        rollout(m, good, steps=10, dt=0.01, method="dop853")
    with pytest.raises(ValueError, match="record='steps' is the fixed-step grid"):
        rollout(m, good, t_final=0.1, method="dop853", record="steps")
    with pytest.raises(ValueError, match="method 'auto' is adaptive: give t_final="):
        rollout(m, good, steps=10, dt=0.01, method="auto")
    with pytest.raises(ValueError, match="exactly one of t_final= or steps="):
        rollout(m, good, dt=0.01)
    with pytest.raises(ValueError, match="dt must be a finite step > 0"):
        rollout(m, good, steps=10, dt=0.0)
    with pytest.raises(ValueError, match="threads must be a whole number >= 1"):
        rollout(m, good, steps=10, dt=0.01, threads=0)
    with pytest.raises(ValueError, match=r"p must have shape \(2,\) or \(3, 2\)"):
        rollout(m, good, steps=10, dt=0.01, p=np.ones((2, 2)))
    with pytest.raises(ValueError, match="record must be 'final' or 'steps'"):
        rollout(m, good, steps=10, dt=0.01, record="all")


def test_model_with_a_terminal_event_runs_past_it_only_when_told():
    """simulate ends such a run at the event, and so does rollout (test_rollout_extras.py, on a
    compiled model); events=False runs every row to t_final, as simulate(events=False)."""
    m = get_model("pendulum")
    m.metadata = {**m.metadata, "events": [{"name": "fallen", "terminal": 1, "direction": 1}]}
    assert rollout(m, np.zeros((2, 2)), steps=10, dt=0.01, events=False).ok.all()
    m.metadata = {**m.metadata, "events": [{"name": "crossing", "terminal": 0}]}
    assert rollout(m, np.zeros((2, 2)), steps=10, dt=0.01).ok.all()


BALL = """<mujoco model="ball">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 0.2">
      <freejoint name="root"/>
      <geom name="ball" type="sphere" size="0.05" mass="1" friction="0.8"/>
    </body>
  </worldbody>
</mujoco>
"""


def thrown_ball(cache_dir, name, functions=None):
    """(model, 16 starts): the ball of BALL built into cache_dir (functions: eomc.compile's),
    thrown from 16 random heights (6-36 cm) with random speeds; it lands, bounces, slides with
    friction and spins."""
    from eomc.compiler.mjcf.model import MjcfModel
    path = cache_dir / "ball.xml"
    path.write_text(BALL)
    m = eomc.compile(MjcfModel(path), name=name, cache_dir=cache_dir, progress=False,
                     **({"functions": functions} if functions else {}))
    rng = np.random.default_rng(3)
    x0 = np.zeros((16, m.nx))
    x0[:, list(m.quaternions)] = 1.0          # upright: a quaternion's w (none in an Euler build)
    x0[:, list(m.state_names).index("q_root_z")] = 0.06 + 0.3 * rng.random(16)
    x0[:, m.nq:] = rng.normal(size=(16, m.nu))
    return m, x0

def test_rollout_with_contacts_equals_simulate_bit_for_bit(tmp_path):
    """Contacts in rollout (issue 31 item 2): a ball thrown onto the floor from 16 starts (it
    lands, bounces, slides with friction, spins), implicitfast's fast path in C threads: each
    row equals the scalar simulate bit for bit (same method, same code); a row whose
    parameters make the contact 1e5 times too soft fails alone with status 10 (its contact
    past its radius); rk4 refuses the contact model, naming the method that takes it."""
    from eomc.runtime.errors import SimulationError
    m, x0 = thrown_ball(tmp_path, "ro_ball")
    names = list(m.state_names)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", PhysicsWarning)
        res = eomc.rollout(m, x0, dt=0.002, steps=300, method="implicitfast", threads=2)
    # a landing's touch-down cell (the ball out of touch at its start, in touch at its end) is
    # not counted as unsolved: its Newton correction is the new contact's end force over the
    # whole cell, which no step size shrinks (eomc_fixedstep.c, fs_fast_advance)
    assert np.all(res.ok) and np.all(res.clean) and not np.any(res.unsolved)
    # the only warning: rows whose total energy rose above its running minimum in contact (session 23:
    # the C watch keeps that rise, so record="final" rows warn as simulate does; until then this
    # rollout warned of nothing, being blind to it) -- and exactly those rows warn in simulate
    said = [str(w.message) for w in said if issubclass(w.category, PhysicsWarning)]
    assert len(said) <= 1 and all("above its lowest value" in w for w in said), said
    warned = {int(k) for k in re.findall(r"\d+", re.search(r"\(rows ([\d, ]+)\)", said[0]).group(1))} if said else set()
    for i in sorted({0, 7, 15} | warned):
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always", PhysicsWarning)
            one = m.simulate(x0[i], (0.0, 0.6), method="implicitfast", dt=0.002)
        assert np.array_equal(one.x[-1], res.x[i])
        assert any("above its lowest value" in str(w.message) for w in seen) == (i in warned), i
    z = res.x[:, names.index("q_root_z")]
    assert np.all(z > 0.04) and np.all(z < 0.5)                       # on the floor, not through it
    # rows carry what simulate says: each row's status and unsolved (sub-)steps equal simulate's.
    # A contact 1e4 times stiffer at 5 ms: a row that creates energy in contact fails with simulate's
    # status (its energy verdict, read at every step).  (3000 times stiffer until session 21: since a
    # touch-down is located instead of bisected, no row of that ball gains energy any more, so it had
    # no failing row to check; measured: 1e4 fails rows 0, 5, 9, 13, 15.)  Until session 26 it also left
    # sub-steps in touch unsolved in rows 2, 6, 8, 10, 12, 13 (ok but not clean); since the last-resort
    # h/64 cell is solved by Newton (eomc_fixedstep.c, fs_last_cell) none is left (measured: rows 0, 5, 9,
    # 12, 15 fail, every other row clean), and no warning of unsolved sub-steps comes
    P = np.tile(np.asarray(m.param_defaults, dtype=float), (16, 1))
    P[:, m.param_names.index("k_ball")] *= 1e4
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", PhysicsWarning)
        stiff = eomc.rollout(m, x0, dt=0.005, steps=120, method="implicitfast", p=P, threads=2,
                             raise_on_failure=False)
    assert not any("left unsolved" in str(w.message) for w in said)
    assert not np.any(stiff.unsolved) and np.any(stiff.clean) and not np.all(stiff.ok)
    assert np.array_equal(stiff.clean, stiff.ok & (stiff.unsolved == 0))
    for i in (int(np.flatnonzero(stiff.clean)[0]), int(np.flatnonzero(~stiff.ok)[0])):
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            one = m.simulate(x0[i], (0.0, 0.6), method="implicitfast", dt=0.005, p=P[i], raise_on_failure=False)
        assert np.array_equal(one.x[-1], stiff.x[i]) and one.status == stiff.status[i]
        assert one.stats["rejected"] == stiff.unsolved[i] == 0
        assert not [w for w in seen if "still missed implicit Euler" in str(w.message)]
    P = np.tile(np.asarray(m.param_defaults, dtype=float), (16, 1))
    P[4, m.param_names.index("k_ball")] *= 1e-5
    bad = eomc.rollout(m, x0, dt=0.002, steps=300, method="implicitfast", p=P, threads=2,
                       raise_on_failure=False)
    assert bad.status[4] == 10 and np.sum(bad.status != 0) == 1
    assert not bad.clean[4]
    with pytest.raises(SimulationError, match="row 4 of 16 failed.*contact ball went"):
        eomc.rollout(m, x0, dt=0.002, steps=300, method="implicitfast", p=P, threads=2)
    # other methods end their steps at touch-down and lift-off, as simulate's (tests/runtime/
    # test_rollout_extras.py: the adaptive ones)
    rk4 = eomc.rollout(m, x0[:3], dt=0.002, steps=10, method="rk4", raise_on_failure=False)
    for i in range(3):
        one = m.simulate(x0[i], (0.0, 0.02), method="rk4", dt=0.002, raise_on_failure=False)
        assert np.array_equal(one.x[-1], rk4.x[i]) and one.status == rk4.status[i]


def test_a_stepped_rollout_on_contacts_defaults_to_implicitfast(tmp_path):
    """rollout(model, X0, t_final=1, dt=0.008) on gymnasium's hopper (first hour s28) ran RK4, its
    default with dt=, and 10 of 16 rows stopped on "a non-finite value appeared": RK4 diverges on
    stiff contact at MuJoCo's steps.  With dt= and no method, a model with contacts' fast path
    (NAME_implicit) runs implicitfast, row for row what method="implicitfast" gives."""
    m, x0 = thrown_ball(tmp_path, "ro_default")
    default = eomc.rollout(m, x0[:4], dt=0.005, steps=60, threads=1, raise_on_failure=False)
    fast = eomc.rollout(m, x0[:4], dt=0.005, steps=60, method="implicitfast", threads=1, raise_on_failure=False)
    rk4 = eomc.rollout(m, x0[:4], dt=0.005, steps=60, method="rk4", threads=1, raise_on_failure=False)
    assert np.array_equal(default.x, fast.x) and np.array_equal(default.status, fast.status)
    assert not np.array_equal(default.x, rk4.x)
    assert np.all(default.status == 0)
    # lanes=True follows the same rule: implicitfast's lanes (which need implicit_batch), not RK4's
    with pytest.raises(ValueError, match="does not take method 'implicitfast' on a model built without implicit_batch"):
        eomc.rollout(m, x0[:2], dt=0.005, steps=2, lanes=True)


def test_implicitfast_rows_get_simulates_energy_verdict(tmp_path, monkeypatch):
    """Issue 29 item 1 / issue 31: a rollout row on implicitfast's fast path is judged by
    simulate's energy verdict (switching.energy_verdict), not only by status 10 and its unsolved
    count.  The thrown ball with a contact 1e4 times stiffer at 5 ms: several rows spin up in
    contact and create energy (simulate: status 20), then slide to rest.  The energy's range over
    every step is kept in C (eomc_options.watch_output), so record="steps" and record="final"
    (scalar and lanes) both give each row simulate's status and message, also for a gain
    dissipated again before the end (session 15's record="final" compared only the start and the
    end: simulate over those two points fails fewer rows, checked below); the passive rows stay 0;
    a failed row raises naming it.  (Before session 15: every row status 0.)  The watch reads the
    model's NAME_energy (the energy output alone, eomc_options.watch_fn): its value is the
    outputs' energy bit for bit along the rows, and the watch through the whole outputs call (a
    model built before NAME_energy) gives the same statuses and messages."""
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    m, x0 = thrown_ball(tmp_path, "rv_ball",
                        functions=tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",))
    P = np.tile(np.asarray(m.param_defaults, dtype=float), (16, 1))
    P[:, m.param_names.index("k_ball")] *= 1e4
    # 1 s (1.125 s until session 21: with a touch-down located instead of bisected, scalar row 12 gains
    # 2.35 J between 1.0 and 1.125 s and its lanes row, whose path differs in the sin/cos digits, does not)
    T, kw = 1.0, dict(dt=0.005, steps=200, method="implicitfast", p=P, threads=2, raise_on_failure=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)      # landings leave sub-steps unsolved
        steps = eomc.rollout(m, x0, record="steps", **kw)
        final = eomc.rollout(m, x0, **kw)
        lanes = eomc.rollout(m, x0, lanes=True, **kw)
        one, ends = [], []
        for i in range(16):
            one.append(m.simulate(x0[i], (0.0, T), method="implicitfast", dt=0.005, p=P[i], raise_on_failure=False))
            ends.append(m.simulate(x0[i], (0.0, T), method="implicitfast", dt=0.005, p=P[i], t_eval=[0.0, T],
                                   raise_on_failure=False))
    want = np.array([r.status for r in one])
    assert set(want) == {0, 20}                             # rows that create energy, and passive ones
    assert np.array_equal(lanes.status, want)       # its sin/cos in vector code: the gains' last digits vary
    for r in (steps, final):
        assert np.array_equal(r.status, want)
        for i in range(16):
            assert r.messages.get(i) == (one[i].message if want[i] else None)
    for i in range(16):
        assert np.array_equal(one[i].x, steps.x[i])         # the same trajectory, bit for bit
        assert np.array_equal(one[i].x[-1], final.x[i])
    assert "energy" in m.metadata["functions"]
    ffi, out, work = m.ffi, m.ffi.new("double[1]"), m.ffi.new("double[]", max(1, m.c_model.work_size))
    for i in (0, i20 := int(np.flatnonzero(want == 20)[0])):
        for x in steps.x[i][::15]:
            assert getattr(m.model_lib, "rv_ball_energy")(0.0, ffi.new("double[]", list(x)), ffi.new("double[]", list(P[i])),
                                                          ffi.NULL, out, work) == 0
            assert out[0] == m.outputs(0.0, x, p=P[i])["energy"]
    import eomc.runtime.rollout as rollout_module
    monkeypatch.setattr(rollout_module, "_energy_fn", lambda model, f: f.NULL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        via_outputs = eomc.rollout(m, x0, **kw)
    assert np.array_equal(via_outputs.status, want) and via_outputs.messages == final.messages
    monkeypatch.undo()
    # simulate with t_eval at the start and the end only judges every step too (the C watch, session
    # 23; until then it compared the start and the end alone and missed some gains: fewer rows failed)
    assert np.array_equal([r.status for r in ends], want)
    for i in range(16):
        assert ends[i].message == one[i].message
    i = int(np.flatnonzero(want == 20)[0])
    with pytest.raises(SimulationError, match=f"row {i} of 16 failed.*the energy rose by"), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        eomc.rollout(m, x0, **{**kw, "raise_on_failure": True})


def _spring(tmp_path, name):
    """A mass on a spring with a damper, x'' = -(k x + c x') / m: stiff at a step as k grows."""
    import sympy as sm

    import eomc.mechanics as me
    q, u = me.dynamicsymbols("q u")
    k, c, mass = sm.symbols("k c m")
    N, O, P = me.ReferenceFrame("N"), me.Point("O"), me.Point("P")
    P.set_pos(O, q * N.x)
    P.set_vel(N, u * N.x)
    kane = me.KanesMethod(N, [q], [u], kd_eqs=[q.diff() - u])
    kane.kanes_equations([me.Particle("pa", P, mass)], [(P, (-k * q - c * u) * N.x)])
    return eomc.compile(kane, name, parameters={k: 4.0, c: 0.5, mass: 1.0}, cache_dir=tmp_path, progress=False)


def test_a_stepped_rollout_runs_implicitfast_where_rk4_would_diverge(tmp_path):
    """Session 52's rollout sweep over the 31 MJCF files at each file's timestep: the default with
    dt=, RK4, failed every row on dm_control's manipulator and stacker (contacts without a ground
    plane), 12 of 16 on fish, and on dm_control's reacher (|dt lambda| = 4.5) ended 70 rad from the
    truth with status 0.  Now RK4 only where it is stable at dt (every eigenvalue of jac_x at the
    first rows within |dt lambda| <= 2) and the model has no contacts; result.method says which ran."""
    m = _spring(tmp_path, "ro_spring")
    X0 = np.column_stack([np.linspace(-1.0, 1.0, 6), np.zeros(6)])
    soft = eomc.rollout(m, X0, dt=0.01, steps=100, threads=1)
    assert soft.method == "rk4"
    np.testing.assert_array_equal(soft.x, eomc.rollout(m, X0, dt=0.01, steps=100, method="rk4", threads=1).x)
    stiff = [1e6, 0.5, 1.0]                       # |dt lambda| = 10 at dt = 0.01
    default = eomc.rollout(m, X0, dt=0.01, steps=100, p=stiff, threads=1, raise_on_failure=False)
    assert default.method == "implicitfast" and default.ok.all()
    fast = eomc.rollout(m, X0, dt=0.01, steps=100, p=stiff, method="implicitfast", threads=1)
    np.testing.assert_array_equal(default.x, fast.x)
    assert np.abs(default.x).max() <= 1.0          # damped, as the spring is
    rk4 = eomc.rollout(m, X0, dt=0.01, steps=100, p=stiff, method="rk4", threads=1, raise_on_failure=False)
    assert not (rk4.ok.all() and np.abs(rk4.x).max() < 1e3)     # what the default no longer runs
    P = np.tile([4.0, 0.5, 1.0], (6, 1))
    P[3, 0] = 1e6                                 # one stiff row among the first: its own parameters count
    assert eomc.rollout(m, X0, dt=0.01, steps=3, p=P, threads=1).method == "implicitfast"
    assert eomc.rollout(m, X0, t_final=0.1, threads=1).method in ("dop853", "bdf", "radau")   # "auto"'s pick


def test_a_stepped_rollout_of_a_robot_with_joint_limits_runs_implicitfast(tmp_path):
    """example-robot-data's double pendulum with joint limits (a file nobody here wrote): at 1 ms its
    jac_x is soft at the start (|dt lambda| = 0.14), and RK4, the default before, failed 9-10 of 16
    rows once the limits engaged ("a non-finite value appeared").  A model with joint limits now
    runs implicitfast by default, every row to the end."""
    from helpers.robots import robot_path
    m = eomc.compile(str(robot_path("double_pendulum_description/urdf/double_pendulum.urdf")), cache_dir=tmp_path,
                     progress=False)
    X0 = np.zeros((16, m.nx))                 # the file's zero pose, speeds uniform in +-0.5
    X0[:, m.nq:] = np.random.default_rng(0).uniform(-0.5, 0.5, (16, m.nu))
    default = eomc.rollout(m, X0, dt=0.001, steps=200, threads=1, raise_on_failure=False)
    assert default.method == "implicitfast" and default.ok.all()
    rk4 = eomc.rollout(m, X0, dt=0.001, steps=200, method="rk4", threads=1, raise_on_failure=False)
    assert not rk4.ok.all()                   # what the default no longer runs
