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

from helpers import shared_builds

sys.path.insert(0, str(Path(__file__).parents[3] / "examples"))
import quadruped_stand as qs  # noqa: E402

pin = pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def solo():
    """The one Solo12 build of the test process (tests/runtime/test_implicitfast.py uses it too)."""
    return shared_builds.solo12_stand()


def _law(depth, rate, vt, k, c, mu, vs):
    """The contact law in numpy (README, Ground contact)."""
    fn = k * max(depth, 0.0) ** 1.5 * (1 + 1.5 * c * rate) if depth > 0 else 0.0
    fn = max(fn, 0.0)
    return fn, -mu * fn * vt / np.sqrt(vt @ vt + vs ** 2)


def test_contact_forces_and_dynamics_match_pinocchio(solo):
    """Independent of the tree lowering: Pinocchio's foot placements and velocities, the law
    in numpy, the forces applied as Pinocchio external forces in its ABA."""
    from eomc.compiler.urdf import build_tree, read_urdf
    from tests.helpers.robots import PinRef
    path = qs.solo12_path()
    joints = [(j.name, j.type) for j in build_tree(read_urdf(path), floating_base=True).joints]
    ref = PinRef(path, joints, floating=True)
    pm, pd = ref.model, ref.data
    p = dict(zip(solo.param_names, solo.param_defaults))
    nq = solo.nq
    rng = np.random.default_rng(2)
    checked = 0
    for trial in range(6):
        x = qs.stance(solo)[0] + rng.uniform(-0.05, 0.05, len(solo.state_names))   # near the stance
        x[nq:] = rng.uniform(-0.3, 0.3, solo.nu)
        qv = ref.q(x[:nq])
        pin.framesForwardKinematics(pm, pd, qv)
        feet_z = [pd.oMf[pm.getFrameId(f"{leg}_FOOT")].translation[2] - x[2] for leg in qs.LEGS]
        x[2] = qs.FOOT_RADIUS - np.mean(feet_z) - 0.002   # about 2 mm into the ground on average
        qv, vv = ref.q(x[:nq]), ref.v(x[nq:])
        pin.forwardKinematics(pm, pd, qv, vv)
        pin.updateFramePlacements(pm, pd)
        out = solo.outputs(0.0, x)
        fext = [pin.Force.Zero() for _ in range(pm.njoints)]
        n = np.array([0.0, 0.0, 1.0])
        for leg in qs.LEGS:
            fid = pm.getFrameId(f"{leg}_FOOT")
            oMf = pd.oMf[fid]
            r = p[f"r_{leg}_FOOT"]
            centre = oMf.translation
            vel = pin.getFrameVelocity(pm, pd, fid, pin.LOCAL_WORLD_ALIGNED)
            v_c, w = vel.linear, vel.angular
            vp = v_c + np.cross(w, -r * n)
            vt = vp - (vp @ n) * n
            depth = r - centre[2]
            fn, ft = _law(depth, -v_c[2], vt, *(p[f"{k}_{leg}_FOOT"] for k in ("k", "c", "mu", "vs")))
            assert out[f"depth_{leg}_FOOT"] == pytest.approx(depth, abs=1e-12)
            assert out[f"Fn_{leg}_FOOT"] == pytest.approx(fn, rel=1e-10, abs=1e-10)
            assert [out[f"Ft{a}_{leg}_FOOT"] for a in "xyz"] == pytest.approx(ft, rel=1e-10, abs=1e-10)
            checked += fn > 0
            F = fn * n + ft
            at = centre - r * n                                   # the contact point, world
            jid = pm.frames[fid].parentJoint
            oMi = pd.oMi[jid]
            f_local = oMi.rotation.T @ F
            n_local = oMi.rotation.T @ np.cross(at - oMi.translation, F)
            fext[jid] = fext[jid] + pin.Force(f_local, n_local)
        ddq = pin.aba(pm, pd, qv, vv, np.zeros(pm.nv), fext)[ref.iv]
        udot = solo.rhs(0.0, x)[nq:]
        assert np.max(np.abs(udot - ddq)) < 1e-10 * max(1.0, np.max(np.abs(ddq)))
    assert checked >= 12           # most feet were in contact: the forces were compared, not zeros


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
    # a comma-list of feet (the commas are the centre's x,y,z) is told to repeat --contact
    with pytest.raises(ModelError, match="one link per --contact; for several, repeat it: "
                                         "--contact FL_FOOT --contact HR_FOOT"):
        eomc.compile(UrdfModel(path, floating_base=True), contacts=["FL_FOOT,HR_FOOT"], cache_dir=tmp_path)
    with pytest.raises(ModelError, match=r"contact 'FL_FOOT' \(link FL_FOOT\): stiffness k = -5 must be >= 0"):
        eomc.compile(UrdfModel(path, floating_base=True), contacts=[dict(link="FL_FOOT", k=-5)],
                     cache_dir=tmp_path)
    with pytest.raises(ModelError, match="radius r = -0.1"):
        eomc.compile(path, contacts=["FL_FOOT:0,0,0:-0.1"], cache_dir=tmp_path)
    with pytest.raises(ModelError, match="contacts= applies to URDF and MJCF robots"):
        eomc.compile(str(shared_builds.EXAMPLES / "double_pendulum.py"), contacts=["FL_FOOT"], cache_dir=tmp_path)
