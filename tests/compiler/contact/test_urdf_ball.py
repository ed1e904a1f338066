"""A URDF ball with a <collision><sphere>: contacts from the file (@collision) and from the
command line (--contact), the ball dropped onto the ground through the tree route."""
import numpy as np
import pytest

import eomc
from eomc.compiler.contact.tree import collision_spheres, parse_contact
from eomc.compiler.urdf.model import UrdfModel

BALL = """<?xml version="1.0"?>
<robot name="ball">
  <link name="ball">
    <inertial><origin xyz="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.002" iyy="0.002" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
</robot>
"""


@pytest.fixture(scope="module")
def ball_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("urdf") / "ball.urdf"
    path.write_text(BALL)
    return path


def test_collision_spheres_are_read(ball_path):
    from eomc.compiler.urdf.model import read_model
    (spec,) = collision_spheres(read_model(UrdfModel(ball_path, floating_base=True)).collisions, ball_path)
    assert (spec.link, spec.point, spec.radius, spec.name) == ("ball", (0.0, 0.0, 0.0), 0.05, "ball")
    assert parse_contact("FL_FOOT:0,0.01,-0.02:0.016").point == (0.0, 0.01, -0.02)
    for bad in ("", "a:1,2", "a:1,2,3:x", "a:1:2:3"):
        with pytest.raises(ValueError, match="--contact"):
            parse_contact(bad)


def test_ball_from_collision_sphere_comes_to_rest(ball_path, tmp_path):
    model = eomc.compile(UrdfModel(ball_path, floating_base=True), contacts="@collision",
                         functions=("rhs", "outputs", "events"), cache_dir=tmp_path)
    assert {"k_ball", "c_ball", "mu_ball", "vs_ball", "r_ball"} <= set(model.param_names)
    assert model.param_defaults[model.param_names.index("r_ball")] == 0.05
    x0 = np.zeros(len(model.state_names))
    x0[model.state_names.index("q_ball_floating_z")] = 0.3
    p = model.param_defaults.copy()
    p[model.param_names.index("c_ball")] = 20.0          # damped: it settles within the run
    res = model.simulate(x0, (0, 3.0), p=p, method="dop853", rtol=1e-8, atol=1e-10)
    assert res.t_events["contact_ball"][0] == pytest.approx(np.sqrt(2 * 0.25 / 9.81), rel=1e-6)
    depth = (2.0 * 9.81 / 1e6) ** (2 / 3)                 # k δ^1.5 = m g, the default k
    assert res["q_ball_floating_z"][-1] == pytest.approx(0.05 - depth, abs=1e-7)
    assert res.outputs["Fn_ball"][-1] == pytest.approx(2.0 * 9.81, rel=1e-6)


def test_cli_contact_option(ball_path, tmp_path, capsys):
    from eomc.cli import main
    out = tmp_path / "traj.csv"
    status = main(["simulate", str(ball_path), "--floating-base", "--contact", "ball:0,0,0:0.05",
                   "--t-final", "0.4", "-o", str(out), "--x0", "q_ball_floating_z=0.3", "-q"])
    assert status in (0, None)
    header = out.read_text().splitlines()[0].split(",")
    assert "Fn_ball" in header and "depth_ball" in header
    capsys.readouterr()
    status = main(["build", str(ball_path), "--floating-base", "--contact", "nolink", "-o",
                   str(tmp_path / "b"), "-q"])
    assert status != 0
    assert "contact on link 'nolink': the robot has no such link (links: ball)" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


def test_generation_cache_tells_contacts_apart(ball_path, tmp_path):
    """The generation cache's key holds the contact's point (and body, normal, height): a
    contact moved elsewhere is generated again, never served from the other's entry."""
    from eomc.compiler.driver import generate
    model = UrdfModel(ball_path, floating_base=True)
    seen = []
    for point in ("0,0,0", "0,0,-0.01", "0,0,0"):
        _, generated = generate(model, contacts=[f"ball:{point}:0.05"], functions=("rhs",),
                                cache_dir=tmp_path)
        seen.append(generated.c_source)
    assert seen[0] != seen[1] and seen[0] == seen[2]


def test_plane_normal_and_height(ball_path, tmp_path):
    """A tilted plane n·x = h: the depth is r - (n·c - h) and the force pushes along n."""
    n = np.array([0.0, 0.6, 0.8])
    model = eomc.compile(UrdfModel(ball_path, floating_base=True), name="ball_tilted",
                         contacts=[dict(link="ball", radius=0.05, normal=(0, 3, 4), height=0.1)],
                         functions=("rhs", "outputs"), cache_dir=tmp_path)
    x = np.zeros(len(model.state_names))
    centre = np.array([0.3, -0.2, 0.0])
    centre[2] = (0.1 + 0.05 - 0.004 - n[1] * centre[1]) / n[2]        # 4 mm into the plane
    x[:3] = centre
    out = model.outputs(0.0, x)
    assert out["depth_ball"] == pytest.approx(0.004, abs=1e-12)
    fn = 1e6 * 0.004 ** 1.5
    assert out["Fn_ball"] == pytest.approx(fn, rel=1e-12)
    ud = model.rhs(0.0, x)[model.nq:model.nq + 3]                      # at rest, unrotated: v'
    assert ud == pytest.approx(fn * n / 2.0 - np.array([0, 0, 9.81]), rel=1e-12, abs=1e-12)
