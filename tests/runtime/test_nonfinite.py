"""A run stopped by a non-finite value says where it went non-finite (runtime/nonfinite.py).

Oracles: a pendulum whose torque sqrt(5 - q) is NaN past q = 5 (the rhs names u'); the same
pendulum from a state where every function is finite but one RK4 step overflows (named as a
step that fails again); a healthy state's step (ends finite); NAME_implicit's layout read back
by name on a stand-in."""
import types

import numpy as np
import pytest

import eomc
from eomc.errors import SimulationError
from eomc.runtime import nonfinite
from helpers import model_files

ROOT = model_files.PENDULUM.replace("kane.kanes_equations([bob], [(P, -m * g * N.y)])",
                                    "kane.kanes_equations([bob], [(P, -m * g * N.y), (A, sm.sqrt(5 - q) * N.z)])")


@pytest.fixture(scope="module")
def pend(tmp_path_factory):
    d = tmp_path_factory.mktemp("nonfinite")
    return eomc.compile(str(model_files.write(d, ROOT, "rootpend")), cache_dir=d / "cache", progress=False)


def test_a_nan_derivative_is_named(pend):
    with pytest.raises(SimulationError, match=r"a non-finite value appeared.*at that state the rhs is not "
                                              r"finite: u'$"):
        pend.simulate([6.0, 0.0], (0, 1), method="rk4", dt=0.01, events=False)


def test_a_step_that_overflows_from_a_finite_state_is_named_as_the_step(pend):
    """u = 1e300, dt = 1e10: the rhs is finite there, the step's q overflows; taken again, it fails again."""
    x = [0.3, 1e300]
    assert np.all(np.isfinite(pend.rhs(0.0, x)))
    with pytest.raises(SimulationError, match=r"functions are finite at that state: the value went non-finite "
                                              r"inside the step from it; that step, taken again from the same "
                                              r"state, fails again"):
        pend.simulate(x, (0, 3e10), method="rk4", dt=1e10, events=False)


def test_a_step_that_does_not_fail_again_is_said_so(pend):
    """What the message says when the step, taken again, ends finite (a failure that did not repeat),
    and when it fails again: the step given is run, and its result is what the message reports."""
    x, p = np.array([0.3, 0.0]), np.array(pend.param_defaults)
    taken = []

    def step(dt):
        def run():
            res = pend.simulate(x, (0.0, dt), method="rk4", dt=dt, events=False, raise_on_failure=False, t_eval=[dt])
            taken.append(res.status)
            return res.status, res.x_final
        return run
    said = nonfinite.nonfinite_source(pend, "rk4", 0.0, x, p, np.zeros(0), step(0.01))
    assert said.endswith("ended finite: the failure did not repeat (not a property of the model at this "
                         "state; please report it with this message)")
    x = np.array([0.3, 1e300])
    assert nonfinite.nonfinite_source(pend, "rk4", 0.0, x, p, np.zeros(0), step(1e10)).endswith("fails again "
                                                                                              "(a step too long for the model here: a smaller dt)")
    assert taken == [0, 3]
    assert nonfinite.nonfinite_source(pend, "rk4", 0.0, np.array([0.3, np.nan]), p, np.zeros(0), step(0.01)) == ""


def test_the_implicit_terms_are_named_by_their_layout():
    """NAME_implicit's entries by name: M's rows, f's speeds, the contacts (25 entries each), joint laws."""
    layout = {"M": 0, "f": 4, "qd": 6, "N": 8, "screw": 12, "joint": 24, "contact": 28, "size": 78}
    stand_in = types.SimpleNamespace(nu=2, nq=2, state_names=("q_a", "q_b", "u_a", "u_b"), metadata={
        "implicit": {"layout": layout, "contacts": [{"name": "foot_0"}, {"name": "hand_1"}]}})
    said = nonfinite._implicit_names(stand_in, [1, 2, 5, 25, 28 + 25 + 3, 28 + 24])
    assert said == ("the mass matrix's rows u_a, u_b; the forces on u_b; the joint laws' slopes of u_a; "
                    "the contacts hand_1, foot_0")
