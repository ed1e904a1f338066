"""Events located in C on the dense output (runtime/events.py, eomc_integrators.c).

Oracles: the simple pendulum's period 4 K(k) / w0 (complete elliptic integral,
k = sin(theta0 / 2)); a bouncing ball's impact times in closed form; a falling
inverted pendulum stopped where its angle reaches a limit.
"""
import textwrap

import numpy as np
import pytest
from scipy.special import ellipk

from helpers import model_files

import eomc
from eomc.runtime.errors import ModelFileError
from eomc.runtime.events import Event

PEND_EVENTS = model_files.PENDULUM + textwrap.dedent('''\
    events = {"up": {"expr": u, "direction": 1},
              "fallen": {"expr": q + sm.pi / 2 - 1.0, "terminal": True}}
    outputs["speed"] = u
    ''')

BALL = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import *

    y, v = dynamicsymbols("y v")
    m, g = sm.symbols("m g")
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", y * N.y)
    P.set_vel(N, v * N.y)
    kane = KanesMethod(N, q_ind=[y], u_ind=[v], kd_eqs=[y.diff() - v])
    kane.kanes_equations([Particle("ball", P, m)], [(P, -m * g * N.y)])
    system = kane
    parameters = {m: 1.0, g: 9.81}
    events = {"floor": {"expr": y, "direction": -1, "terminal": 1}}
    ''')


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d, cache = tmp_path_factory.mktemp("models"), tmp_path_factory.mktemp("cache")
    pend = eomc.compile(str(model_files.write(d, PEND_EVENTS, "pend")), cache_dir=cache, progress=False)
    ball = eomc.compile(str(model_files.write(d, BALL, "ball")), cache_dir=cache, progress=False)
    return pend, ball


def _period(theta0, l=0.5, g=9.81):
    return 4 * ellipk(np.sin(theta0 / 2) ** 2) / np.sqrt(g / l)


def test_pendulum_period_to_1e12_from_compiled_event(models):
    pend, _ = models
    theta0 = 0.5
    x0 = [-np.pi / 2 + theta0, 0.0]          # at rest, theta0 from the hanging position
    T = _period(theta0)
    res = pend.simulate(x0, (0, 3.2 * T), rtol=1e-13, atol=1e-13, events=["up"])
    up = res.t_events["up"]
    assert len(up) == 3                       # rising u at T/2, 3T/2, 5T/2
    assert abs(up[0] - T / 2) / T < 1e-12
    assert abs((up[1] - up[0]) - T) / T < 1e-12
    assert abs((up[2] - up[0]) - 2 * T) / T < 1e-12
    # the recorded state is the dense output there: u = 0 to rounding, q at the bottom of its swing
    np.testing.assert_allclose(res.x_events["up"][:, 1], 0.0, atol=1e-11)
    np.testing.assert_allclose(res.x_events["up"][:, 0], -np.pi / 2 - theta0, atol=1e-10)
    assert res.event_stop is None and res.t_final == pytest.approx(3.2 * T)


@pytest.mark.parametrize("method,kw,tol", [("dopri5", dict(rtol=1e-11, atol=1e-12), 1e-9),
                                            ("radau", dict(rtol=1e-10, atol=1e-12), 1e-8),
                                            ("bdf", dict(rtol=1e-10, atol=1e-12), 1e-7),
                                            ("rk4", dict(dt=1e-3), 1e-9)])
def test_every_method_locates_events_on_its_dense_output(models, method, kw, tol):
    pend, _ = models
    T = _period(0.5)
    res = pend.simulate([-np.pi / 2 + 0.5, 0.0], (0, 2.5 * T), method=method,
                        events={"speed": {"direction": -1}}, **kw)   # an output as event
    down = res.t_events["speed"]
    assert len(down) == 2
    # falling u at t = T and 2T (u = 0 at t = 0 itself is not a crossing)
    np.testing.assert_allclose(down, [T, 2 * T], rtol=tol)


def test_direction_selects_crossings_and_none_means_both(models):
    pend, _ = models
    T = _period(0.5)
    x0 = [-np.pi / 2 + 0.5, 0.0]
    both = pend.simulate(x0, (0, 2.2 * T), rtol=1e-12, atol=1e-12, events={"speed": {}})
    rising = pend.simulate(x0, (0, 2.2 * T), rtol=1e-12, atol=1e-12,
                           events=[Event("speed", direction=1)])
    assert len(both.t_events["speed"]) == 4 and len(rising.t_events["speed"]) == 2
    np.testing.assert_allclose(both.t_events["speed"][::2], rising.t_events["speed"], rtol=1e-12)


def test_terminal_event_stops_run_at_the_crossing(models):
    pend, _ = models
    # upright is q = pi/2; start near it and let it fall until q + pi/2 = 1 (terminal in the file)
    res = pend.simulate([np.pi / 2 - 1e-3, 0.0], (0, 20), rtol=1e-12, atol=1e-12,
                        events=None, t_eval=np.linspace(0, 20, 2001))
    assert res.event_stop == "fallen"
    tf = res.t_events["fallen"][0]
    assert res.t_final == tf and 0 < tf < 20
    assert res.x_final[0] + np.pi / 2 - 1.0 == pytest.approx(0.0, abs=1e-13)
    assert res.t[-1] <= tf < res.t[-1] + 0.01   # rows stop at the event
    # a terminal count: stop at the second rising crossing
    res2 = pend.simulate([-np.pi / 2 + 0.5, 0.0], (0, 10), rtol=1e-12, atol=1e-12,
                         events={"up": {"terminal": 2, "direction": 1}})
    assert res2.event_stop == "up" and len(res2.t_events["up"]) == 2
    assert res2.t_final == res2.t_events["up"][1]


def test_event_sets_on_one_model_do_not_share_their_slot_tables(models):
    """EventsBinding keeps each event set's slot tables on the model (_events_layouts): runs
    alternating between sets, differing only in direction or terminal, give exactly the results
    a model without any kept table gives."""
    pend, _ = models
    x0, span = [-np.pi / 2 + 0.5, 0.0], (0, 3.0)
    sets = [{"speed": {}}, {"speed": {"direction": 1}}, {"up": {"terminal": 2, "direction": 1}},
            ["up", "fallen"], None]

    def run(ev):
        r = pend.simulate(x0, span, rtol=1e-9, atol=1e-9, events=ev, n_points=5)
        return r.x, r.t_final, r.event_stop, r.t_events, r.x_events

    def fresh(ev):
        pend.__dict__.pop("_events_layouts", None)
        return run(ev)

    expected = [fresh(ev) for ev in sets]
    assert len(expected[0][3]["speed"]) == 2 * len(expected[1][3]["speed"]) > 0   # direction told apart
    assert expected[2][2] == "up" and expected[3][2] is None    # terminal told apart
    for _ in range(2):
        for ev, want in zip(sets, expected):
            got = run(ev)
            assert got[0].tobytes() == want[0].tobytes() and got[1:3] == want[1:3]
            assert got[3].keys() == want[3].keys()
            for name in want[3]:
                assert got[3][name].tobytes() == want[3][name].tobytes()
                assert got[4][name].tobytes() == want[4][name].tobytes()
    # ["up", "fallen"] takes the file's options, as None does: one table for the two
    assert len(pend.__dict__["_events_layouts"]) == len(sets) - 1


def test_bouncing_ball_terminal_event_and_restart(models):
    _, ball = models
    g, e, h0 = 9.81, 0.8, 1.0
    x, t0, impacts = np.array([h0, 0.0]), 0.0, []
    for _ in range(5):
        res = ball.simulate(x, (t0, t0 + 10), rtol=1e-12, atol=1e-12)   # the file's terminal event
        assert res.event_stop == "floor"
        impacts.append(res.t_final)
        x = res.x_final * [1.0, -e]            # bounce: restart from the event state
        t0 = res.t_final
    v1 = np.sqrt(2 * g * h0)
    expected = np.sqrt(2 * h0 / g) + np.concatenate([[0], np.cumsum(2 * v1 * e ** np.arange(1, 5) / g)])
    np.testing.assert_allclose(impacts, expected, rtol=1e-11)


def test_events_off_and_bad_event_names(models):
    pend, _ = models
    res = pend.simulate([0.1, 0.0], (0, 1), events=False)
    assert res.t_events is None
    with pytest.raises(ValueError, match="unknown event.*nope.*known: up, fallen, energy, speed"):
        pend.simulate([0.1, 0.0], (0, 1), events=["nope"])
    with pytest.raises(ValueError, match="direction must be -1, 0 or \\+1"):
        pend.simulate([0.1, 0.0], (0, 1), events={"up": {"direction": 2}})
    with pytest.raises(ValueError, match="mix compiled events and outputs"):
        pend.simulate([0.1, 0.0], (0, 1), events=["up", "speed"])


def test_event_with_unknown_symbol_is_a_model_file_error(tmp_path):
    text = model_files.PENDULUM + 'w = dynamicsymbols("w")\nevents = {"bad": w}\n'
    path = model_files.write(tmp_path, text, "badev")
    with pytest.raises(ModelFileError, match=r"badev\.py:\d+: .*event `bad` uses w"):
        eomc.compile(str(path), cache_dir=tmp_path / "cache", progress=False)


# ---- issue 24: NaN events and outputs are named; a parameter used only by an event ---------------
# bad and nanout are NaN beyond q = 5 (C checks every compiled event function, chosen or not)
NAN_EVENTS = model_files.PENDULUM.replace('parameters = {m: 2.0, l: 0.5, g: 9.81}\n',
                                          'R = sm.Symbol("R")\n'
                                          'parameters = {m: 2.0, l: 0.5, g: 9.81, R: 0.1}\n') \
    + textwrap.dedent('''\
    outputs["angle"] = q
    outputs["nanout"] = sm.sqrt(5 - q)
    events = {"bad": sm.sqrt(5 - q), "low": {"expr": q - R, "direction": -1}}
    ''')


@pytest.fixture(scope="module")
def nan_model(tmp_path_factory):
    d = tmp_path_factory.mktemp("nanev")
    return eomc.compile(str(model_files.write(d, NAN_EVENTS, "nanev")), progress=False)


def test_a_nan_event_function_is_named(nan_model):
    """N14: the state is finite; the message names the event function that is not."""
    from eomc.errors import SimulationError
    with pytest.raises(SimulationError, match=r"stopped at t=0: a non-finite value appeared.*state is "
                                              r"finite, but the event function bad is not finite there"):
        nan_model.simulate([6.0, 0.0], (0, 1), events=["bad"])


def test_a_nan_output_is_named_as_event_and_along_the_trajectory(nan_model):
    from eomc.errors import SimulationError
    with pytest.raises(SimulationError, match=r"the output \(outputs are evaluated as events\) nanout is "
                                              r"not finite there"):
        nan_model.simulate([6.0, 0.0], (0, 1), events=["angle"])
    with pytest.raises(SimulationError, match=r"evaluating outputs along the trajectory failed: .* at t=0: "
                                              r"nanout is not finite there"):
        nan_model.simulate([6.0, 0.0], (0, 1), events=False)


def test_a_parameter_used_only_by_an_event_is_a_parameter(nan_model):
    """First hour #4: `low` is q - R with R in `parameters` only for the event."""
    assert "R" in nan_model.param_names
    for R in (0.1, 0.2):
        res = nan_model.simulate([0.3, 0.0], (0, 2), events=["low"], p={"R": R}, rtol=1e-10, atol=1e-12)
        assert len(res.t_events["low"]) >= 1
        assert res.x_events["low"][0, 0] == pytest.approx(R, abs=1e-9)


def test_max_events_beyond_memory_is_refused(nan_model):
    """N12: max_events=10**10 reserved 74.5 GiB before (numpy's MemoryError); now a clear error."""
    with pytest.raises(ValueError, match=r"max_events=10000000000 would reserve \d+ GiB"):
        nan_model.simulate([0.3, 0.0], (0, 1), events=["low"], max_events=10 ** 10)


def test_a_nan_event_inside_a_step_is_named(nan_model):
    """N14: the event function turns NaN mid-run (q passes 5): the last accepted state is finite
    and the event there too; the stretch is rerun without events to find it."""
    from eomc.errors import SimulationError
    with pytest.raises(SimulationError, match=r"the event function bad is not finite (there|at t=[0-9.e-]+, "
                                              r"inside the next step)"):
        nan_model.simulate([4.5, 3.0], (0, 1), events=["bad"])
