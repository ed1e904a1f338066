"""Solo12 with a floating base on four foot contacts: the contact points agree with
Pinocchio's frame placements and velocities, the robot stands under joint PD feedback
(base height steady to 1 mm, feet carrying m·g), and bad contacts are refused by name."""
import sys
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.errors import ModelError

sys.path.insert(0, str(Path(__file__).parents[3] / "examples"))
import quadruped_stand as qs  # noqa: E402

pin = pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def solo(tmp_path_factory):
    return qs.build(cache_dir=tmp_path_factory.mktemp("cache"))


def test_contact_points_match_pinocchio_frames(solo):
    from tests.helpers.robots import rotation_xyz  # noqa: F401  (the floating joint's convention)
    pm = pin.buildModelFromUrdf(str(qs.solo12_path()), pin.JointModelFreeFlyer())
    pd = pm.createData()
    rng = np.random.default_rng(2)
    x = rng.uniform(-0.6, 0.6, len(solo.state_names))
    x[solo.state_names.index("q_base_link_floating_z")] = 0.2
    out = solo.outputs(0.0, x)
    # Pinocchio state: free-flyer position, quaternion of R = Rx Ry Rz, joints in its order
    nq6 = 6
    R = rotation_xyz(*x[3:6])
    q = np.concatenate([x[:3], pin.Quaternion(R).coeffs(), np.zeros(pm.nq - 7)])
    for j in range(2, pm.njoints):
        q[pm.joints[j].idx_q] = x[solo.state_names.index(f"q_{pm.names[j]}")]
    pin.framesForwardKinematics(pm, pd, q)
    for leg in qs.LEGS:
        z = pd.oMf[pm.getFrameId(f"{leg}_FOOT")].translation[2]
        assert out[f"depth_{leg}_FOOT"] == pytest.approx(qs.FOOT_RADIUS - z, abs=1e-12)
    assert nq6 == 6


def test_solo12_stands_under_joint_pd(solo):
    res = qs.stand(solo, t_final=3.0)
    z = res["q_base_link_floating_z"]
    late = res.t >= 1.5
    assert np.ptp(z[late]) < 1e-3                        # steady to 1 mm
    assert z[-1] > 0.2                                   # standing, not collapsed
    mg = qs.total_mass(solo) * 9.81
    fn = [res.outputs[f"Fn_{leg}_FOOT"][-1] for leg in qs.LEGS]
    assert sum(fn) == pytest.approx(mg, rel=1e-4)
    assert min(fn) > 0.15 * mg                           # every foot carries its share
    for leg in qs.LEGS:                                  # feet stay put (friction holds)
        assert abs(res.outputs[f"Ftx_{leg}_FOOT"][-1]) < fn[0]


def test_bad_contacts_are_refused(tmp_path):
    path = qs.solo12_path()
    with pytest.raises(ModelError, match="contact on link 'NO_SUCH_FOOT': the robot has no such link"):
        eomc.compile(UrdfModel(path, floating_base=True), contacts=["NO_SUCH_FOOT"], cache_dir=tmp_path)
    with pytest.raises(ModelError, match=r"contact 'FL_FOOT' \(link FL_FOOT\): stiffness k = -5 must be >= 0"):
        eomc.compile(UrdfModel(path, floating_base=True), contacts=[dict(link="FL_FOOT", k=-5)],
                     cache_dir=tmp_path)
    with pytest.raises(ModelError, match="radius r = -0.1"):
        eomc.compile(path, contacts=["FL_FOOT:0,0,0:-0.1"], cache_dir=tmp_path)
    with pytest.raises(ModelError, match="contacts= applies to URDF robots"):
        eomc.compile("examples/double_pendulum.py", contacts=["FL_FOOT"], cache_dir=tmp_path)
