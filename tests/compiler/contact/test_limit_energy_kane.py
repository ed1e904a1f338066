"""Kane's form of a URDF robot with joint limits and no contact has the ``energy`` output the
recursive form has (kinetic + gravity + the limits' springs: eomc.compiler.urdf.model._kane_energy),
with the same values, and the run's energy verdict reads it as it reads the recursive one.

Why: the output was the recursive side's only, so auto kept the recursive form of every such
robot (select._kane_lacks) and lost Kane's faster rhs on the double pendulum URDF and TwoDofs;
a ``formulation="kane"`` build ran with no energy verdict at all."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.switching import PhysicsWarning
from helpers.robots import robot_path
from helpers.urdf_arm import LIMITED_HINGE, check_limited_hinge_energy_verdict

# limited URDF robots of 1-3 joints where auto now takes Kane's rhs by cost, and Bolt (6 speeds, two
# 3-joint legs), where it keeps the recursive one by cost (benchmarks/results/auto_choice.md)
ROBOTS = {
    "hinge": None,      # helpers.urdf_arm.LIMITED_HINGE, written to tmp
    "double_pendulum": "double_pendulum_description/urdf/double_pendulum.urdf",
    "twodofs": "asr_twodof_description/urdf/TwoDofs.urdf",
    "finger_edu": "finger_edu",
    "bolt": "bolt_description/robots/bolt.urdf",
}


def _path(name, tmp):
    if ROBOTS[name] is None:
        path = tmp / "hinge.urdf"
        path.write_text(LIMITED_HINGE)
        return path
    return robot_path(ROBOTS[name])


def _both(path, tmp, functions=("rhs", "outputs", "energy")):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {form: eomc.compile(UrdfModel(path), functions=functions, formulation=form,
                                   cache_dir=tmp / form, progress=False)
                for form in ("kane", "recursive")}


@pytest.mark.parametrize("name", list(ROBOTS))
def test_both_forms_have_the_same_outputs_with_the_same_values(name, tmp_path):
    """At random states (the joints across and past their limits, so the springs hold energy)
    and at the file's parameters and random ones (by name: Kane's form has fewer, those the
    recursive form keeps that no equation reads), every output and the rhs agree to rounding."""
    models = _both(_path(name, tmp_path), tmp_path)
    kane, rec = models["kane"], models["recursive"]
    assert kane.output_names == rec.output_names == ("energy",)
    assert "energy" in kane.metadata["functions"] and "energy" in rec.metadata["functions"]
    assert kane.metadata["energy"] == rec.metadata["energy"]
    assert "joint limits" in kane.metadata["energy"]
    assert set(kane.param_names) <= set(rec.param_names)
    rng = np.random.default_rng(7)
    defaults = dict(zip(rec.param_names, rec.param_defaults))
    # each limited joint sampled across its range and 0.3 past either side, the others in [-3, 3]
    span = [(defaults[f"limit_lo_{s[2:]}"] - 0.3, defaults[f"limit_hi_{s[2:]}"] + 0.3)
            if f"limit_lo_{s[2:]}" in defaults else (-3.0, 3.0) for s in rec.state_names[:rec.nq]]
    past = 0
    for trial in range(24):
        q = np.array([rng.uniform(lo, hi) for lo, hi in span])
        x = np.concatenate([q, rng.uniform(-3.0, 3.0, rec.nu)])
        p_rec = np.array(rec.param_defaults) * (1 + (trial % 2) * 0.2 * rng.uniform(-1, 1, rec.nparam))
        by_name = dict(zip(rec.param_names, p_rec))
        p_kane = np.array([by_name[n] for n in kane.param_names])
        out_k, out_r = kane.outputs(0.0, x, p=p_kane), rec.outputs(0.0, x, p=p_rec)
        for out in rec.output_names:
            assert out_k[out] == pytest.approx(out_r[out], rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(kane.rhs(0.0, x, p=p_kane), rec.rhs(0.0, x, p=p_rec), rtol=1e-11, atol=1e-11)
        past += any(v < lo + 0.3 or v > hi - 0.3 for v, (lo, hi) in zip(q, span) if (lo, hi) != (-3.0, 3.0))
    assert past > 0          # some states were past a limit: the springs' energy was compared


@pytest.mark.parametrize("form", ["kane", "recursive"])
def test_the_energy_verdict_is_there_with_either_form(form, tmp_path):
    """The one-hinge arm with no contact, built as Kane's form or the recursive one: RK4 at
    10 ms on an undamped stiff limit creates energy at the impact and fails the run (status
    20); Radau keeps it; a start 0.5 rad past the limit is no energy gain (its spring's energy
    is counted).  Before, Kane's form had no energy output: status 0 for the RK4 run."""
    path = tmp_path / "arm.urdf"
    path.write_text(LIMITED_HINGE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = eomc.compile(UrdfModel(path), functions=("rhs", "jac_x", "outputs"), formulation=form,
                           cache_dir=tmp_path / "c", progress=False)
    assert arm.metadata["formulation"] == form and arm.output_names == ("energy",)
    check_limited_hinge_energy_verdict(arm)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = arm.simulate(np.array([0.8, 0.0]), (0.0, 2.0), method="radau", rtol=1e-8, atol=1e-10)
    E = np.asarray(res.outputs["energy"])
    assert res.status == 0 and E[0] > 100.0 and E.max() <= E[0] * (1 + 1e-6)
    assert not [w for w in caught if issubclass(w.category, PhysicsWarning) and "energy rose" in str(w.message)]
