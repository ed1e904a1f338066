"""Body–body contact pairs (eomc.compiler.contact.pairs) against MuJoCo's geometry and dynamics.

Two oracles, both independent of eomc's code: MuJoCo's ``mj_geomDistance`` (its analytic
sphere/capsule/box distances and nearest points) at random poses, and MuJoCo's dynamics with
the law's force applied by hand (``xfrc_applied``, contacts off): eomc's generated rhs at the
same states to 1e-12.  The filters: a pair MuJoCo's contype/conaffinity, parent–child rule or
``<exclude>`` leaves out is not emitted; ``<pair>`` adds one.
"""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.contact.pairs import closest_points  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.runtime.errors import EomcWarning  # noqa: E402

XML = """<mujoco model="pairs">
  <option gravity="0 0 0"/>
  <worldbody>
    <geom name="post" type="capsule" fromto="0.5 0 0 0.5 0 0.6" size="0.05"/>
    <body name="A" pos="0 0 0.3"><freejoint name="fa"/><geom name="ball" type="sphere" size="0.1" mass="1"/></body>
    <body name="B" pos="0.2 0.05 0.35" euler="20 30 0"><freejoint name="fb"/>
      <geom name="rod" type="capsule" size="0.04 0.15" pos="0.01 0.02 0" euler="5 0 10" mass="0.5"/></body>
    <body name="C" pos="-0.3 0 0.3" euler="10 0 40"><freejoint name="fc"/>
      <geom name="cube" type="box" size="0.1 0.08 0.06" mass="2" contype="2" conaffinity="2"/>
      <geom name="tag" type="sphere" size="0.03" pos="0 0 0.1" contype="2" conaffinity="1"/></body>
  </worldbody>
  <contact><pair geom1="ball" geom2="cube" margin="0.01"/></contact>
</mujoco>
"""
PAIRS = {"post__ball", "post__rod", "ball__rod", "ball__cube", "post__tag", "ball__tag", "rod__tag"}


@pytest.fixture(scope="module")
def pairs(tmp_path_factory):
    root = tmp_path_factory.mktemp("pairs")
    path = root / "pairs.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        # orientation="euler": the states pose the bodies by body-XYZ angles (q[9:12], q[15:18])
        model = eomc.compile(MjcfModel(path, orientation="euler"), functions=["rhs"], cache_dir=root / "c",
                             progress=False)
    return path, model


def _geom(m, name):
    return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)


def _placed(m, d, g):
    kind = {2: "sphere", 3: "capsule", 6: "box"}[int(m.geom_type[g])]
    R = np.array(d.geom_xmat[g]).reshape(3, 3)
    return {"kind": kind, "centre": list(d.geom_xpos[g]), "axes": [list(R[:, k]) for k in range(3)],
            "size": [float(x) for x in m.geom_size[g]]}


def _random_pose(m, d, rng):
    for j in range(m.njnt):
        a = int(m.jnt_qposadr[j])
        d.qpos[a:a + 3] = rng.uniform(-0.25, 0.25, 3) + [0.1, 0, 0.3]
        q = rng.normal(size=4)
        d.qpos[a + 3:a + 7] = q / np.linalg.norm(q)
    mujoco.mj_kinematics(m, d)


def _core_meets_box(a, b):
    """Does the sphere's centre or the capsule's segment of one shape meet the other, a box
    (slab test in the box frame)?"""
    shape, box = (a, b) if b["kind"] == "box" else (b, a)
    R, c, half = np.array(box["axes"]).T, np.array(box["centre"]), np.array(box["size"])
    h = shape["size"][1] if shape["kind"] == "capsule" else 0.0
    p0 = (np.array(shape["centre"]) - c) @ R
    v = (np.array(shape["axes"][2]) @ R) * h
    lo, hi = -1.0, 1.0                      # the segment p0 + s v, |s| <= 1
    for k in range(3):
        if abs(v[k]) < 1e-15:
            if abs(p0[k]) > half[k]:
                return False
            continue
        s1, s2 = sorted(((-half[k] - p0[k]) / v[k], (half[k] - p0[k]) / v[k]))
        lo, hi = max(lo, s1), min(hi, s2)
    return lo <= hi


@pytest.mark.parametrize("g1, g2", [("ball", "rod"), ("post", "ball"), ("post", "rod"), ("ball", "cube"),
                                    ("cube", "tag"), ("rod", "ball"), ("rod", "cube"), ("cube", "rod"),
                                    ("post", "cube")])
def test_nearest_points_match_mj_geom_distance(g1, g2):
    """Signed distance and normal of eomc's nearest points vs mj_geomDistance at 40 random poses (1e-12)."""
    m = mujoco.MjModel.from_xml_string(XML.replace('"cube" type="box"', '"cube" type="box"'))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(11)
    a, b = _geom(m, g1), _geom(m, g2)
    checked = 0
    for _ in range(40):
        _random_pose(m, d, rng)
        fromto = np.zeros(6)
        dist = mujoco.mj_geomDistance(m, d, a, b, 10.0, fromto)
        if "cube" in (g1, g2) and _core_meets_box(_placed(m, d, a), _placed(m, d, b)):
            continue       # a sphere's centre or a segment inside the box: no nearest points (eomc's docstring)
        xa, xb, ra, rb = closest_points(_placed(m, d, a), _placed(m, d, b))
        xa, xb = np.array(xa, dtype=float), np.array(xb, dtype=float)
        gap = np.linalg.norm(xb - xa) - ra - rb
        assert gap == pytest.approx(dist, abs=1e-12)
        if abs(dist) > 1e-6:
            n = (xb - xa) / np.linalg.norm(xb - xa)
            mj_n = (fromto[3:] - fromto[:3]) / dist
            assert np.max(np.abs(n - mj_n)) < 1e-9
            assert np.max(np.abs(xa + ra * n - fromto[:3])) < 1e-12 * 1e3
        checked += 1
    assert checked >= 20


def test_filters_decide_which_pairs_exist(pairs):
    """contype/conaffinity (cube: 2/2 meets only tag's contype 2), the world's capsule, the explicit
    <pair> (ball–cube, with its margin); the cube and the tag share a body: no pair."""
    path, model = pairs
    made = {p[2:] for p in model.param_names if p.startswith("k_")}
    assert made == PAIRS


def _law_force(m, d, model, name, a, b, margin=0.0):
    """(force on b's body at p, p) of eomc's law from MuJoCo's own nearest points (world)."""
    p = dict(zip(model.param_names, model.param_defaults))
    k, c, mu, vs = (p[f"{x}_{name}"] for x in ("k", "c", "mu", "vs"))
    fromto = np.zeros(6)
    dist = mujoco.mj_geomDistance(m, d, a, b, 10.0, fromto)
    n = (fromto[3:] - fromto[:3]) / np.linalg.norm(fromto[3:] - fromto[:3]) * np.sign(dist)
    ra = m.geom_size[a][0] if m.geom_type[a] != 6 else 0.0
    rb = m.geom_size[b][0] if m.geom_type[b] != 6 else 0.0
    xa, xb = fromto[:3] - ra * n, fromto[3:] + rb * n          # the cores' nearest points
    depth = ra + rb + margin - np.linalg.norm(xb - xa)
    point = xa + (ra - depth / 2) * n

    def velocity(g):
        body = m.geom_bodyid[g]
        if m.body_weldid[body] == 0:
            return np.zeros(3)
        out = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, out, 0)
        return out[3:] + np.cross(out[:3], point - d.xpos[body])
    vrel = velocity(b) - velocity(a)
    dpos = max(depth, 0.0)
    fn = max(k * dpos ** 1.5 * (1 + 1.5 * c * -(n @ vrel)), 0.0)
    vt = vrel - (n @ vrel) * n
    return fn * n - mu * fn * vt / np.sqrt(vt @ vt + vs * vs), point


def test_rhs_matches_mujoco_with_the_law_applied_by_hand(pairs):
    """Ball pressed into the rod and the post with the bodies moving (ω = 0 keeps MuJoCo's and
    eomc's speeds aligned): eomc's rhs vs MuJoCo's qacc with the law's forces as xfrc_applied."""
    path, model = pairs
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    touching = 0
    for trial in range(30):
        q = np.zeros(model.nq)
        q[0:3] = [0.0, 0.0, 0.3]                             # ball
        q[6:9] = [0.0, 0.0, 0.3] + rng.uniform(-0.2, 0.2, 3)    # rod near it
        q[9:12] = rng.uniform(-1, 1, 3)
        q[12:15] = [0.4, 0.0, 0.3] + rng.uniform(-0.1, 0.1, 3)  # cube near the post
        q[15:18] = rng.uniform(-1, 1, 3)
        u = np.zeros(model.nq)
        for body in range(3):
            u[6 * body:6 * body + 3] = rng.uniform(-0.5, 0.5, 3)   # linear speeds only
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        d.xfrc_applied[:] = 0
        count = 0
        for name in sorted(PAIRS):
            g1, g2 = (_geom(m, x) for x in name.split("__"))
            margin = 0.01 if name == "ball__cube" else 0.0
            fromto = np.zeros(6)
            if mujoco.mj_geomDistance(m, d, g1, g2, 10.0, fromto) - margin >= 0:
                continue
            f, point = _law_force(m, d, model, name, g1, g2, margin)
            for g, sign in ((g2, 1.0), (g1, -1.0)):
                body = m.geom_bodyid[g]
                if m.body_weldid[body]:
                    d.xfrc_applied[body, :3] += sign * f
                    d.xfrc_applied[body, 3:] += sign * np.cross(point - d.xipos[body], f)
            count += 1
        if count == 0:
            continue
        touching += 1
        mujoco.mj_forward(m, d)
        xd = model.rhs(0.0, np.concatenate([q, u]))
        mine = qacc_of(m, built, q, u, xd[model.nq:])
        assert np.max(np.abs(mine - d.qacc)) < 1e-12 * max(1.0, np.max(np.abs(d.qacc)))
    assert touching >= 5


def _event_values(model, x):
    """The generated NAME_events at (0, x) (no Python wrapper: the integrators call it)."""
    ffi = model.ffi
    fn = ffi.cast("eomc_rhs_fn", getattr(model.model_lib, f"{model.name}_events"))
    out = np.full(len(model.metadata["events"]), np.nan)
    work = np.zeros(max(1, model.integrators.eomc_integrate_work_size(model.c_model, 0)))
    x = np.ascontiguousarray(x, dtype=np.float64)
    p = np.ascontiguousarray(model.param_defaults, dtype=np.float64)
    r = np.zeros(1)
    fn(0.0, *(ffi.from_buffer("double[]", a) for a in (x, p, r, out, work)))
    return out


def test_pair_outputs_and_events_are_the_law_at_mujocos_nearest_points(tmp_path):
    """Each pair has the ground contacts' outputs Fn_/Ftx_/Fty_/Ftz_/depth_<pair> and events
    contact_<pair> (its depth: the runtime's touch-down switch) and clip_<pair>: at random states
    they are the law's force at MuJoCo's own nearest points (mj_geomDistance), to 1e-12; a pair
    out of contact has no force and a negative depth."""
    path = tmp_path / "pairs.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        # orientation="euler": the states pose the bodies by body-XYZ angles (q[9:12], q[15:18])
        model = eomc.compile(MjcfModel(path, orientation="euler"), functions=["rhs", "outputs", "events"],
                             cache_dir=tmp_path / "c", progress=False)
    events = {e["name"] for e in model.metadata["events"]}
    for name in PAIRS:
        assert {f"contact_{name}", f"clip_{name}"} <= events
        assert all(f"{w}_{name}" in model.output_names for w in ("Fn", "Ftx", "Fty", "Ftz", "depth", "px", "py", "pz"))
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    pressed = apart = 0
    names = [e["name"] for e in model.metadata["events"]]
    for trial in range(30):
        q = np.zeros(model.nq)
        q[0:3] = [0.0, 0.0, 0.3]
        q[6:9] = [0.0, 0.0, 0.3] + rng.uniform(-0.2, 0.2, 3)
        q[9:12] = rng.uniform(-1, 1, 3)
        q[12:15] = [0.4, 0.0, 0.3] + rng.uniform(-0.1, 0.1, 3)
        q[15:18] = rng.uniform(-1, 1, 3)
        u = np.zeros(model.nq)
        for body in range(3):
            u[6 * body:6 * body + 3] = rng.uniform(-0.5, 0.5, 3)   # linear speeds only (as above)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        x = np.concatenate([q, u])
        out = model.outputs(0.0, x)
        ev = dict(zip(names, _event_values(model, x)))
        for name in sorted(PAIRS):
            g1, g2 = (_geom(m, s) for s in name.split("__"))
            margin = 0.01 if name == "ball__cube" else 0.0
            fromto = np.zeros(6)
            dist = mujoco.mj_geomDistance(m, d, g1, g2, 10.0, fromto)
            if "cube" in name and dist < 0:
                continue              # a centre inside the box: no nearest point (module docstring)
            assert out[f"depth_{name}"] == pytest.approx(margin - dist, abs=1e-12)
            assert ev[f"contact_{name}"] == out[f"depth_{name}"]
            if margin - dist <= 0:
                assert out[f"Fn_{name}"] == 0.0
                apart += 1
                continue
            f, _ = _law_force(m, d, model, name, g1, g2, margin)
            n = (fromto[3:] - fromto[:3]) / np.linalg.norm(fromto[3:] - fromto[:3]) * np.sign(dist)
            mine = out[f"Fn_{name}"] * n + np.array([out[f"{w}_{name}"] for w in ("Ftx", "Fty", "Ftz")])
            assert np.max(np.abs(mine - f)) < 1e-12 * max(1.0, np.max(np.abs(f)))
            assert out[f"Fn_{name}"] == pytest.approx(f @ n, rel=1e-12, abs=1e-12)
            point = np.array([out[f"{w}_{name}"] for w in ("px", "py", "pz")])
            assert np.max(np.abs(point - (fromto[:3] + fromto[3:]) / 2)) < 1e-12    # midway between the surfaces
            pressed += 1
    assert pressed >= 5 and apart >= 20
