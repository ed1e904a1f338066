"""Shapes resting on a plane in closed form, and their deepest points against MuJoCo's distances.

A free body carrying one geom rests on the ground plane: at rest the contact points that
touch share m·g equally (symmetry), each sinks by Hertz's δ = (m·g/(N·k))^(2/3), and the
rhs's accelerations vanish there.  The deepest point of each shape at random poses is
MuJoCo's own plane distance (``mj_geomDistance``): the contacts touch where MuJoCo's would.
"""
import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.contact.geometry import CYLINDER_RIM  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel  # noqa: E402

MASS = 2.5
SHAPES = {   # name: (geom attributes, orientation of the body, points touching at rest, height of the origin)
    "ball": ('type="sphere" size="0.1"', "0 0 0", 1, 0.1),
    "pill": ('type="capsule" size="0.05 0.2"', "0 90 0", 2, 0.05),
    "brick": ('type="box" size="0.2 0.1 0.05"', "0 0 0", 4, 0.05),
    "can": ('type="cylinder" size="0.08 0.12"', "0 0 0", CYLINDER_RIM, 0.12),
    "egg": ('type="ellipsoid" size="0.1 0.07 0.04"', "0 0 0", 1, 0.04),
}


def _xml(name, geom, euler, z):
    return f"""<mujoco model="{name}">
  <compiler angle="degree"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="{name}" pos="0 0 {z + 0.05}" euler="{euler}">
      <freejoint name="root"/>
      <geom name="{name}" {geom} mass="{MASS}"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("shapes")
    out = {}
    for name, (geom, euler, _, z) in SHAPES.items():
        path = root / f"{name}.xml"
        path.write_text(_xml(name, geom, euler, z))
        # orientation="euler": the shapes are posed by body-XYZ angles (q_root_rx, ry, rz)
        out[name] = (path, eomc.compile(MjcfModel(path, orientation="euler"), name, functions=("rhs", "outputs"),
                                        cache_dir=root / "c", progress=False))
    return out


def _state(model, values):
    x = np.zeros(model.nx)
    for key, v in values.items():
        x[model.state_names.index(key)] = v
    return x


@pytest.mark.parametrize("name", list(SHAPES))
def test_resting_in_closed_form(built, name):
    path, model = built[name]
    _, euler, touching, z = SHAPES[name]
    p = dict(zip(model.param_names, model.param_defaults))
    k = p[f"k_{name}"]
    g = 9.81
    depth = (MASS * g / (touching * k)) ** (2.0 / 3.0)
    rx, ry, rz = (np.radians(float(a)) for a in euler.split())
    x = _state(model, {"q_root_z": z - depth, "q_root_rx": rx, "q_root_ry": ry, "q_root_rz": rz})
    du = model.rhs(0.0, x)[model.nq:]
    assert np.max(np.abs(du)) < 1e-9 * g
    out = model.outputs(0.0, x)
    forces = sorted((v for key, v in out.items() if key.startswith("Fn_")), reverse=True)
    assert forces[:touching] == pytest.approx([MASS * g / touching] * touching, rel=1e-9)
    assert all(f < 1e-9 * MASS * g for f in forces[touching:])
    depths = sorted((v for key, v in out.items() if key.startswith("depth_")), reverse=True)
    assert depths[:touching] == pytest.approx([depth] * touching, rel=1e-9)
    # and it comes to rest there from a drop: the load is shared (Hertz), not carried by one point
    res = model.simulate(_state(model, {"q_root_z": z + 0.02, "q_root_rx": rx, "q_root_ry": ry,
                                        "q_root_rz": rz}), (0.0, 1.5), method="dop853", events=False,
                         rtol=1e-8, atol=1e-10, n_points=11)
    assert res.x[-1][model.state_names.index("q_root_z")] == pytest.approx(z - depth, abs=0.05 * depth)


@pytest.mark.parametrize("name", list(SHAPES))
def test_deepest_point_is_mujocos_distance(built, name):
    """At random poses the largest depth among a shape's points is MuJoCo's plane distance
    (a cylinder's rim points: up to R(1 - cos(pi/CYLINDER_RIM)) less deep)."""
    from eomc.compiler.mjcf.model import load_mjmodel
    path, model = built[name]
    m = load_mjmodel(path)
    d = mujoco.MjData(m)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
    rng = np.random.default_rng(3)
    slack = 0.08 * (1 - np.cos(np.pi / CYLINDER_RIM)) if name == "can" else 0.0
    for _ in range(20):
        angles = rng.uniform(-np.pi, np.pi, 3)
        zc = rng.uniform(-0.05, 0.3)
        x = _state(model, {"q_root_z": zc, "q_root_rx": angles[0], "q_root_ry": angles[1],
                           "q_root_rz": angles[2]})
        from eomc.compiler.mjcf.compare import to_mujoco, tree_of
        d.qpos[:], d.qvel[:] = to_mujoco(m, tree_of(m, model), x[:model.nq], x[model.nq:])
        mujoco.mj_kinematics(m, d)
        dist = mujoco.mj_geomDistance(m, d, floor, geom, 10.0, None)
        deepest = max(v for key, v in model.outputs(0.0, x).items() if key.startswith("depth_"))
        if slack:
            assert -dist - 1e-12 <= deepest + slack and deepest <= -dist + 1e-12
        else:
            assert deepest == pytest.approx(-dist, abs=1e-9)


def test_thinned_meshes_share_one_warning():
    """Every mesh thinned to MESH_POINTS points is named in one warning with its shortfall, the
    largest stated up front (example-robot-data's Go2 under --ground printed eleven lines); one
    mesh keeps its own sentence."""
    import warnings
    from eomc.compiler.contact import geometry
    from eomc.runtime.errors import EomcWarning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        geometry._warn_thinned([("go2.urdf:903: link 'RR_calf' <collision>", 7.4e-3),
                                ("go2.urdf:970: link 'RR_foot' <collision>", 3.1e-3)])
        geometry._warn_thinned([("a.urdf:5: link 'x' <collision>", 2e-3)])
        geometry._warn_thinned([])
    texts = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    assert texts == [
        "2 meshes' convex hulls are thinned to 32 contact points each (a contact may start up to 7.4 mm late): "
        "go2.urdf:903: link 'RR_calf' <collision> (7.4 mm); go2.urdf:970: link 'RR_foot' <collision> (3.1 mm)",
        "a.urdf:5: link 'x' <collision>: its mesh's convex hull is thinned to 32 contact points (a contact may "
        "start up to 2 mm late)"]


def test_thinned_meshes_name_their_directory_once_and_the_largest_three():
    """Many meshes of one URDF under a long directory (example-robot-data's Go2 under --ground: the
    full path 19-24 times on one line): the directory is named once, each named mesh by its file's
    name, line and link.  Only the three largest shortfalls are named, the rest counted with
    their largest (G1 under --ground: all 24 in one 1.3 kB line, first hour s26); a second
    directory gets its own group, a where without a path is kept whole."""
    import warnings
    from eomc.compiler.contact import geometry
    from eomc.runtime.errors import EomcWarning
    root = "/opt/openrobots/share/example-robot-data/robots/go2_description/urdf"
    thinned = [(f"{root}/go2.urdf:{900 + i}: link 'L{i}' <collision>", 1e-3 * (i + 1)) for i in range(19)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        geometry._warn_thinned(thinned)
        geometry._warn_thinned(thinned[:1] + [("/elsewhere/b.urdf:7: link 'y' <collision>", 20e-3),
                                              ("geom foot", 30e-3)])
    first, second = [str(w.message) for w in caught if issubclass(w.category, EomcWarning)]
    assert first == ("19 meshes' convex hulls are thinned to 32 contact points each (a contact may start up to "
                     "19 mm late): files under " + root + ": go2.urdf:918: link 'L18' <collision> (19 mm); "
                     "go2.urdf:917: link 'L17' <collision> (18 mm); go2.urdf:916: link 'L16' <collision> (17 mm); "
                     "16 more, up to 16 mm each")
    assert second == ("3 meshes' convex hulls are thinned to 32 contact points each (a contact may start up to "
                      "30 mm late): geom foot (30 mm); files under /elsewhere: b.urdf:7: link 'y' <collision> "
                      "(20 mm); files under " + root + ": go2.urdf:900: link 'L0' <collision> (1 mm)")
