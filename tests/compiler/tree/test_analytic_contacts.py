"""The analytic jac_x with ground contacts (compiler/tree/analytic.py, block G).

The kernel holds each contact's force as a body-fixed load and adds what that misses: the
law's slopes K, C (compiler/contact/law.ground_jacobians) along the point's motion and the
point's own motion on its body.  Checked against the tangent jac_x (the unrolled forward
mode the analytic path replaces, itself a differentiation of the same rhs) to 1e-10 and
against central differences of the compiled rhs, with contacts touching (asserted: the rhs
changes when their stiffness is set to 0) and clear of the ground, on a free sphere with a
radius (the contact point is not its centre; MJCF) and a URDF arm whose default ground has a
box and a sphere on a welded link.  Gymnasium's hopper and ant (and Solo12, Go2) are compared
the same way by benchmarks/bench_contact_jac.py, which also times them: their builds are too
dear for CI.

Small models: the sphere and the arm have 12 states or fewer, where jac_x keeps the unrolled
columns (TANGENT_MIN_STATES), so the analytic path is forced there.
"""
import sys
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.tree import analytic as an
from eomc.compiler.tree import lower

HERE = Path(__file__).resolve().parents[2]

FNS = ["rhs", "jac_x"]


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


def both(source, name, monkeypatch, tmp_path, functions=FNS, **kw):
    """(analytic, tangent) builds of ``source``: the analytic path forced at any size, the
    tangent path by refusing the contacts to the plan."""
    with monkeypatch.context() as m:
        m.setattr(lower, "TANGENT_MIN_STATES", 0)
        fast = eomc.compile(source, f"{name}_an", functions=functions, formulation="recursive",
                            progress=False, cache_dir=tmp_path / "an", **kw)
    plan = an.analytic_plan
    with monkeypatch.context() as m:
        m.setattr(an, "analytic_plan", lambda *a: plan(*a[:5], None))
        slow = eomc.compile(source, f"{name}_tg", functions=functions, formulation="recursive",
                            progress=False, cache_dir=tmp_path / "tg", **kw)
    assert "ground contacts:" in fast.source_path.read_text()
    assert "_rnea_derivs(" not in slow.source_path.read_text()
    return fast, slow


def central(model, x):
    cols = []
    for k in range(model.nx):
        h = 1e-6 * max(1.0, abs(x[k]))
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        cols.append((np.asarray(model.rhs(0.0, up)) - np.asarray(model.rhs(0.0, dn))) / (2 * h))
    return np.array(cols).T


def touching(model, x):
    """Does a contact push at x?  The rhs with every contact stiffness set to 0 differs."""
    p = np.array(model.param_defaults, dtype=float)
    soft = p.copy()
    for i, n in enumerate(model.param_names):
        if n.startswith("k_"):
            soft[i] = 0.0
    assert np.any(soft != p), "no contact stiffness among the parameters"
    return not np.array_equal(np.asarray(model.rhs(0.0, x, p=p)), np.asarray(model.rhs(0.0, x, p=soft)))


def check(fast, slow, states):
    touched = clear = 0
    for x in states:
        J, ref = fast.jac_x(0.0, x), slow.jac_x(0.0, x)
        scale = max(1.0, np.max(np.abs(ref)))
        assert np.max(np.abs(J - ref)) / scale < 1e-10
        assert np.max(np.abs(J - central(fast, x))) / scale < 1e-6
        if touching(fast, x):
            touched += 1
        else:
            clear += 1
    assert touched >= 2 and clear >= 1


BALL = """<mujoco model="ball">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="ball" pos="0 0 0.3">
      <freejoint name="root"/>
      <geom name="ball" type="sphere" size="0.1" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_free_sphere_with_a_radius(monkeypatch, tmp_path):
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.compiler.mjcf.treeir import quat_matrix
    path = tmp_path / "ball.xml"
    path.write_text(BALL)
    fast, slow = both(MjcfModel(path), "ball", monkeypatch, tmp_path,
                      functions=FNS + ["inverse_dynamics", "jac_id"])
    rng = np.random.default_rng(5)
    iz = fast.state_names.index("q_root_z")
    states = []
    for z in (0.098, 0.09, 0.5):       # radius 0.1: pressed in, deeper, in the air
        x = np.concatenate([rng.normal(size=fast.nq), 0.2 * rng.normal(size=fast.nu)])
        x[iz] = z
        w = fast.quaternions[0]            # a random orientation: the quaternion (the MJCF default) unit
        x[w:w + 4] /= np.linalg.norm(x[w:w + 4])
        R = quat_matrix(x[w:w + 4])         # the speeds are the body's: sinking slowly in the world's z
        v = R @ x[fast.nq:fast.nq + 3]
        v[2] = -0.01                        # (the damped law does not pull: no clip)
        x[fast.nq:fast.nq + 3] = R.T @ v
        states.append(x)
    check(fast, slow, states)
    for x in states:        # jac_id: the same kernel and contact terms at given accelerations
        ud = rng.normal(size=fast.nu)
        J, ref = fast.jac_id(0.0, x, ud), slow.jac_id(0.0, x, ud)
        assert np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-10


def test_urdf_default_ground_on_a_welded_link(monkeypatch, tmp_path):
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.urdf_arm import ARM
    path = tmp_path / "arm.urdf"
    path.write_text(ARM.replace("</robot>", """  <link name="tool0"><collision><origin xyz="0 0 0.3" rpy="0 0.2 0"/>
    <geometry><box size="0.05 0.05 0.1"/></geometry></collision><collision><origin xyz="0.01 0 0.3"/>
    <geometry><sphere radius="0.03"/></geometry></collision></link>
  <joint name="flange" type="fixed"><parent link="lower"/><child link="tool0"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/></joint>
</robot>"""))
    fast, slow = both(UrdfModel(path, ground=True), "armg", monkeypatch, tmp_path)
    rng = np.random.default_rng(7)
    states = []
    for _ in range(40):
        x = np.concatenate([rng.uniform(-np.pi, np.pi, fast.nq), rng.normal(size=fast.nu)])
        states.append(x)
    on = [x for x in states if touching(fast, x)][:3]
    off = [x for x in states if not touching(fast, x)][:2]
    check(fast, slow, on + off)


def test_body_body_pairs_through_the_table(monkeypatch, tmp_path):
    """Self-pairs as one table call (pairs.PAIR_TABLE): the kernel holds their wrenches as
    body-fixed loads and adds their components' tangents per column, beside the ground contacts'
    block G: the tangents from the table's tangent loop called by the kernel itself with the
    inputs' tangents it forms (analytic._kernel_pair_lines, the default), or filled per state
    column from generated tangent code (block W: where a shape's offset or a law's parameter
    reads the state; forced here).  Both against the tangent jac_x of the same table rhs (the plan
    refused the pairs) and central differences, with self-pairs pressed and apart; jac_id likewise."""
    import warnings
    import eomc.compiler.contact.pairs as pairs
    from eomc.compiler.mjcf.model import MjcfModel
    sys.path.insert(0, str(HERE / "compiler" / "contact"))
    from test_narrow import LIMBS
    path = tmp_path / "limbs.xml"
    path.write_text(LIMBS.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>'))
    monkeypatch.setattr(pairs, "PAIR_TABLE", True)
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)         # the table for any number of pairs
    fns = FNS + ["outputs", "jac_id"]
    plan = an.analytic_plan
    built = {}
    for tag in ("an", "w", "tg"):
        with monkeypatch.context() as m, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if tag == "tg":
                m.setattr(an, "analytic_plan", lambda *a: plan(*a[:7], None))
            if tag == "w":
                m.setattr(lower, "_kernel_table", lambda *a: None)
            built[tag] = eomc.compile(MjcfModel(path, pairs=True), f"limbs_{tag}", functions=fns,
                                      progress=False, cache_dir=tmp_path / tag)
    slow = built["tg"]
    assert "from the table's tangent loop" in built["an"].source_path.read_text()
    assert "block W" not in built["an"].source_path.read_text()
    assert "block W" in built["w"].source_path.read_text()
    assert "_rnea_derivs(" not in slow.source_path.read_text()
    for fast in (built["an"], built["w"]):
        _pairs_agree(fast, slow)


def _pairs_agree(fast, slow):
    """``fast``'s jac_x and jac_id equal ``slow``'s (1e-10) and jac_x central differences (1e-6)
    at 60 random states, at least 5 with a self-pair pressed and 5 with all apart."""
    names = list(fast.output_names)
    self_pairs = [i for i, k in enumerate(names) if k.startswith("Fn_") and "__" in k]
    rng = np.random.default_rng(5)
    X = rng.normal(scale=0.6, size=(60, fast.nx))
    X[:, 2] += 0.3
    pressed = apart = 0
    for x in X:
        J, ref = fast.jac_x(0.0, x), slow.jac_x(0.0, x)
        scale = max(1.0, np.max(np.abs(ref)))
        assert np.max(np.abs(J - ref)) / scale < 1e-10
        assert np.max(np.abs(J - central(fast, x))) / scale < 1e-6
        ud = rng.normal(size=fast.nu)
        J, ref = fast.jac_id(0.0, x, ud), slow.jac_id(0.0, x, ud)
        assert np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-10
        if np.any(np.array(list(fast.outputs(0.0, x).values()))[self_pairs] > 0):
            pressed += 1
        else:
            apart += 1
    assert pressed >= 5 and apart >= 5, (pressed, apart)


ELLIPSOID = """<mujoco model="egg">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="egg" pos="0 0 0.3">
      <freejoint name="root"/>
      <geom name="egg" type="ellipsoid" size="0.12 0.07 0.04" pos="0.03 -0.02 0.01" euler="20 35 -10" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_ellipsoid_support_point_moving_on_its_body(monkeypatch, tmp_path):
    """A ground-touching ellipsoid (dm_control's humanoid_CMU: its hands): its contact point is
    its support point, which moves on the body as the body turns (contacts.support_motion, anx
    block GM).  The kernel against the tangent jac_x (the plan refused the contacts) and central
    differences, touching and clear, on a free ellipsoid with its geom turned and off the body's
    origin; jac_id likewise."""
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.compiler.tree import contacts
    monkeypatch.setattr(contacts, "PLAN_SHAPES", True)
    path = tmp_path / "egg.xml"
    path.write_text(ELLIPSOID)
    fast, slow = both(MjcfModel(path), "egg", monkeypatch, tmp_path,
                      functions=FNS + ["inverse_dynamics", "jac_id"])
    assert "support point moves on its body" in fast.source_path.read_text()
    rng = np.random.default_rng(11)
    iz = fast.state_names.index("q_root_z")
    states = []
    for _ in range(200):
        x = np.concatenate([rng.uniform(-np.pi, np.pi, fast.nq), 0.3 * rng.normal(size=fast.nu)])
        x[iz] = rng.uniform(0.0, 0.15)
        states.append(x)
    on = [x for x in states if touching(fast, x)][:4]
    off = [x for x in states if not touching(fast, x)][:2]
    check(fast, slow, on + off)
    for x in on + off:
        ud = rng.normal(size=fast.nu)
        J, ref = fast.jac_id(0.0, x, ud), slow.jac_id(0.0, x, ud)
        assert np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-10
