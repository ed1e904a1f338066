"""from_urdf's System: extend it before compiling; parameters, folding and byte-identical C."""
import numpy as np
import sympy as sm

import eomc
from eomc.compiler.driver import generate
from eomc.compiler.urdf import from_urdf
from eomc.mechanics import Torque, dynamicsymbols
from sympy.physics.mechanics import PinJoint, System

from helpers.urdf_arm import ARM


def _arm(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    return path


def test_the_system_is_sympys_and_built_from_its_joints(tmp_path):
    system = from_urdf(_arm(tmp_path))
    assert isinstance(system, System)
    assert [type(j) for j in system.joints] == [PinJoint, PinJoint]
    assert [j.name for j in system.joints] == ["shoulder", "elbow"]
    assert [b.name for b in system.bodies] == ["world", "upper", "lower"]
    params = {str(k): v for k, v in system.urdf.parameters.items()}
    assert params["m_upper"] == 1.5 and params["cz_upper"] == 0.2 and params["z_elbow"] == 0.4
    assert "cx_upper" not in params            # zero in the file: a structural zero, not a parameter


def test_user_loads_and_parameters_join_the_urdf_ones(tmp_path):
    """A viscous damper added to the elbow: tau_id grows by c u_elbow; URDF defaults stay."""
    path = _arm(tmp_path)
    plain = eomc.compile(path, cache_dir=tmp_path / "cache", progress=False)
    system = from_urdf(path)
    c = sm.Symbol("c_elbow")
    elbow = system.joints[1]
    u = elbow.speeds[0]
    system.add_loads(Torque(elbow.child.frame, -c * u * elbow.joint_axis),
                     Torque(elbow.parent.frame, c * u * elbow.joint_axis))
    damped = eomc.compile(system, "damped", parameters={"c_elbow": 0.7}, cache_dir=tmp_path / "cache",
                          progress=False)
    assert "c_elbow" in damped.param_names and "m_upper" in damped.param_names
    assert damped.input_names == ("tau_shoulder", "tau_elbow")
    x, a = np.array([0.3, -0.4, 1.1, -2.0]), np.array([0.5, 0.25])
    diff = damped.inverse_dynamics(0.0, x, a, r=[0, 0]) - plain.inverse_dynamics(0.0, x, a, r=[0, 0])
    np.testing.assert_allclose(diff, [0.0, 0.7 * -2.0], atol=1e-12)


def test_fold_parameters_and_identical_c(tmp_path):
    path = _arm(tmp_path)
    _, first = generate(str(path), use_cache=False, progress=False, functions=["rhs"])
    _, again = generate(str(path), use_cache=False, progress=False, functions=["rhs"])
    assert first.c_source == again.c_source and first.header == again.header
    assert first.metadata["nparam"] > 5
    _, folded = generate(str(path), use_cache=False, progress=False, functions=["rhs"], fold_parameters=True)
    assert folded.metadata["nparam"] == 0
    unfolded = eomc.compile(path, cache_dir=tmp_path / "cache", progress=False, functions=["rhs"])
    literal = eomc.compile(path, "arm_folded", cache_dir=tmp_path / "cache", progress=False, functions=["rhs"],
                           fold_parameters=True)
    early = eomc.compile(from_urdf(path, fold_parameters=True), "arm_early", cache_dir=tmp_path / "cache",
                         progress=False, functions=["rhs"])     # numbers from the start of the derivation
    assert early.nparam == 0
    x = np.array([0.2, 0.9, -0.3, 0.4])
    for other in (literal, early):
        np.testing.assert_allclose(other.rhs(0.0, x, r=[0.1, 0.2]), unfolded.rhs(0.0, x, r=[0.1, 0.2]),
                                   rtol=1e-13, atol=1e-13)


def test_gravity_off_and_inputs_named_after_joints(tmp_path):
    system = from_urdf(_arm(tmp_path), gravity=0)
    model = eomc.compile(system, "weightless", cache_dir=tmp_path / "cache", progress=False,
                         functions=["rhs"])
    assert "g" not in model.param_names
    assert model.input_names == ("tau_shoulder", "tau_elbow")
    np.testing.assert_allclose(model.rhs(0.0, [0.3, 0.2, 0.0, 0.0], r=[0, 0]), 0.0, atol=1e-14)
    assert dynamicsymbols("tau_shoulder") in system.urdf.inputs
