"""MuJoCo's collision filters and contact parameters, as eomc reads them (compiler/mjcf/collision.py)."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from eomc.compiler.mjcf.collision import ground_geoms, law_parameters, resting_depth  # noqa: E402
from eomc.runtime.errors import EomcWarning  # noqa: E402

FILTERS = """<mujoco model="filters">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="deco" type="box" size="1 1 0.01" pos="0 0 -1"/>
    <body name="a" pos="0 0 1">
      <freejoint/>
      <geom name="a_touch" type="sphere" size="0.1"/>
      <geom name="a_ghost" type="sphere" size="0.1" contype="0" conaffinity="0"/>
      <geom name="a_one_way" type="box" size="0.1 0.1 0.1" contype="2" conaffinity="0"/>
      <body name="b" pos="0 0 -0.5">
        <joint type="hinge"/>
        <geom name="b_capsule" type="capsule" size="0.05 0.2"/>
        <body name="c" pos="0 0 -0.5">
          <joint type="hinge"/>
          <geom name="c_cyl" type="cylinder" size="0.05 0.1"/>
        </body>
      </body>
    </body>
    <body name="e" pos="2 0 1">
      <freejoint/>
      <geom name="e_ellipsoid" type="ellipsoid" size="0.1 0.2 0.3" contype="4" conaffinity="4"/>
    </body>
  </worldbody>
  <contact>
    <exclude body1="world" body2="c"/>
    <pair geom1="floor" geom2="e_ellipsoid" friction="0.3 0.3 0.005 0.0001 0.0001" solref="0.01 0.5"/>
  </contact>
</mujoco>
"""


def _model(tmp_path, text):
    path = tmp_path / "m.xml"
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path))


def test_filters_as_mujoco(tmp_path):
    m = _model(tmp_path, FILTERS)
    found = {g.name: g for g in ground_geoms(m)}
    # a_ghost: contype 0; a_one_way: its contype 2 meets no conaffinity 1 of the floor and its own
    # conaffinity is 0; c_cyl: <exclude>; e_ellipsoid: contype 4, but its explicit <pair>
    assert set(found) == {"a_touch", "b_capsule", "e_ellipsoid"}
    assert found["e_ellipsoid"].mu == 0.3
    assert found["a_touch"].mu == 1.0
    # the pair's solref (0.01 0.5) is its own: stiffer than the defaults (0.02 1)
    assert found["e_ellipsoid"].k > 4 * found["a_touch"].k


def test_mujoco_collides_the_same_geoms(tmp_path):
    """Every geom placed into the floor: MuJoCo's contacts are between the floor and exactly ours."""
    m = _model(tmp_path, FILTERS.replace('pos="0 0 1"', 'pos="0 0 0.05"').replace('pos="2 0 1"', 'pos="2 0 0.1"')
               .replace('pos="0 0 -0.5"', 'pos="0.5 0 0" euler="1.5708 0 0"'))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    theirs = set()
    for c in d.contact[:d.ncon]:
        if floor in (c.geom1, c.geom2):
            other = c.geom2 if c.geom1 == floor else c.geom1
            theirs.add(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, other))
    mine = {g.name for g in ground_geoms(m)}
    assert theirs and theirs <= mine
    # the ones MuJoCo does not report here are not touching in this pose
    for name in mine - theirs:
        g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
        assert mujoco.mj_geomDistance(m, d, floor, g, 10.0, None) > 0


def test_contact_disabled_and_height_fields(tmp_path):
    m = _model(tmp_path, FILTERS.replace("<worldbody>", '<option><flag contact="disable"/></option><worldbody>'))
    assert ground_geoms(m) == []
    m = _model(tmp_path, FILTERS.replace('<worldbody>', '<asset><hfield name="hf" nrow="3" ncol="3" '
                                         'size="1 1 0.1 0.1"/></asset><worldbody>')
               .replace('<geom name="b_capsule"', '<geom name="bumpy" type="hfield" hfield="hf"/><geom name="b_capsule"'))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        names = {g.name for g in ground_geoms(m)}
    assert "bumpy" not in names and "b_capsule" in names
    assert any("geom bumpy (hfield) on a moving body" in str(w.message) for w in caught)


SPHERE = """<mujoco>
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" {extra}/>
    <body pos="0 0 0.12"><freejoint/><geom name="ball" type="sphere" size="0.1" mass="{mass}" {extra}/></body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("extra", ["", 'solref="0.01 1"', 'solimp="0.8 0.8 0.01"', 'solref="-20000 -100"'])
@pytest.mark.parametrize("mass", [0.5, 20.0])
def test_resting_depth_is_mujocos(tmp_path, extra, mass):
    """MuJoCo's sphere at rest sinks by resting_depth (whatever its mass), and eomc's law with
    the mapped k sinks the same under the sphere's weight."""
    m = _model(tmp_path, SPHERE.format(extra=extra, mass=mass))
    d = mujoco.MjData(m)
    for _ in range(4000):
        mujoco.mj_step(m, d)
    sunk = 0.1 - d.qpos[2]
    g = 9.81
    expected, _ = resting_depth(m.geom_solref[1], m.geom_solimp[1], g, m.opt.timestep)
    assert sunk == pytest.approx(expected, rel=0.02)
    (found,) = ground_geoms(m)
    assert (mass * g / found.k) ** (2 / 3) == pytest.approx(expected, rel=1e-12)


def test_parameter_rule():
    k, c, mu = law_parameters((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0), (0.7, 0.005, 1e-4), 3, 9.81, 10.0)
    depth, ratio = resting_depth((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0), 9.81)
    assert ratio == 1.0 and mu == 0.7
    assert k == pytest.approx(10.0 / depth ** 1.5, rel=1e-15)
    omega = np.sqrt(1.5 * 9.81 / depth)
    # the law linearised at rest, F ≈ W + 1.5 W/δ (x) + 1.5 c W (v), per unit mass W/g: ratio z
    assert 1.5 * c * 9.81 == pytest.approx(2 * omega, rel=1e-12)
    assert law_parameters((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0), (0.7, 0, 0), 1, 9.81, 10.0)[2] == 0.0


def test_margin_is_mujocos(tmp_path):
    """The plane is raised by the margin MuJoCo includes in the contact (the two geoms' added)."""
    m = _model(tmp_path, SPHERE.format(extra='margin="0.01"', mass=1.0).replace('pos="0 0 0.12"', 'pos="0 0 0.115"'))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    (found,) = ground_geoms(m)
    assert d.ncon == 1 and found.height == pytest.approx(d.contact[0].includemargin, abs=1e-15)


@pytest.mark.parametrize("where", ["geoms", "pair"])
def test_gap_changes_no_force(tmp_path, where):
    """MuJoCo's gap widens the detection only: contacts between margin and margin + gap are
    recorded but left out of the constraint (exclude), and an included one's reference is the
    margin (efc_margin).  So the plane raised by the margin alone is MuJoCo's force onset at
    every height, and a gap is no cause for a warning."""
    if where == "geoms":
        extra = SPHERE.format(extra="", mass=1.0).replace('mass="1.0" ', 'mass="1.0" margin="0.02" gap="0.01" ')
    else:
        extra = SPHERE.format(extra="", mass=1.0).replace(
            "</worldbody>", '</worldbody><contact><pair geom1="floor" geom2="ball" margin="0.02" gap="0.01"/></contact>')
    for z, state in ((0.135, "none"), (0.125, "excluded"), (0.115, "active"), (0.095, "active")):
        m = _model(tmp_path, extra.replace('pos="0 0 0.12"', f'pos="0 0 {z}"'))
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            (found,) = ground_geoms(m, "f.xml")
        assert found.height == pytest.approx(0.02, abs=1e-15)
        dist = z - 0.1
        assert (d.ncon, d.nefc > 0) == {"none": (0, False), "excluded": (1, False), "active": (1, True)}[state]
        assert (dist < found.height) == (d.nefc > 0)            # eomc's law presses exactly where MuJoCo's does
        if d.nefc:
            assert d.contact[0].includemargin == d.efc_margin[0] == pytest.approx(found.height, abs=1e-15)


def test_torsional_and_rolling_friction_against_a_plane(tmp_path):
    """condim 4/6 against a plane: torsional (friction[1]) and rolling (friction[2]) friction are
    modelled (law.spin_moment), with no warning; an explicit <pair>'s five numbers give its own
    (slide, slide, torsion, roll, roll); MuJoCo's mixing (the larger condim and friction) and its
    floor of 1e-5 (mjMINMU).  Between two bodies too (the smaller geom's bounding radius as rho)."""
    from eomc.compiler.mjcf.collision import body_pairs
    xml = """<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1" friction="1 0.004 0"/>
      <body pos="0 0 .2"><freejoint/><geom name="ball" type="sphere" size=".1" condim="{c}" friction="0.8 {t} 0.002"/>
      </body><body pos="0 0 .5"><freejoint/><geom name="top" type="box" size=".1 .1 .1" condim="{c}"/></body>
      </worldbody>{pair}</mujoco>"""
    for condim, t, want in ((6, 0.003, (0.004, 0.002)), (4, 0.003, (0.004, None)), (6, 0.0, (0.004, 0.002))):
        m = _model(tmp_path, xml.format(c=condim, t=t, pair=""))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            found = {g.name: g for g in ground_geoms(m, "f.xml")}
            (pair,), _ = body_pairs(m, "f.xml")
        assert (found["ball"].mut, found["ball"].mur) == want
        assert found["ball"].rho == pytest.approx(0.1)
        assert found["ball"].mu == 1.0
        assert (pair.name, pair.mut, pair.mur) == ("ball__top", 0.005,
                                                   (0.002 if condim == 6 else None))
        assert pair.rho == pytest.approx(0.1)
    pair = '<contact><pair geom1="floor" geom2="ball" condim="6" friction="0.5 0.5 0.007 0.0 0.0"/></contact>'
    m = _model(tmp_path, xml.format(c=1, t=0.003, pair=pair))
    (g,) = [g for g in ground_geoms(m, "f.xml") if g.name == "ball"]
    assert (g.mu, g.mut, g.mur) == (0.5, 0.007, 1e-5)
    m = _model(tmp_path, xml.format(c=3, t=0.003, pair=""))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert all(g.mut is None and g.mur is None and g.rho is None for g in ground_geoms(m))


def test_pairs_that_can_never_touch_are_not_emitted():
    """dm_control's finger: the hinge-axis cylinders of the finger and the spinner sit 0.4 m apart and
    the finger's first link cannot reach the spinner: those pairs are left out (their reach balls never
    meet); the fingertip's pairs stay.  Sound: at 200 random joint angles every left-out pair is apart
    in MuJoCo."""
    dm_control = pytest.importorskip("dm_control")
    from pathlib import Path
    from eomc.compiler.mjcf.collision import _reach, body_pairs
    path = Path(dm_control.__file__).parent / "suite" / "finger.xml"
    m = mujoco.MjModel.from_xml_path(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found, _ = body_pairs(m)
    names = {p.name for p in found}
    assert names == {"fingertip__cap1", "fingertip__cap2", "fingertip__spinner_decoration"}
    reach = _reach(m)
    ids = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g): g for g in range(m.ngeom)}
    left = [("proximal_decoration", "spinner_decoration"), ("proximal_decoration", "cap1"), ("proximal", "cap2"),
            ("proximal", "spinner_decoration")]
    assert all(ids[a] in reach and ids[b] in reach for a, b in left)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    for _ in range(200):
        d.qpos[:] = rng.uniform(-np.pi, np.pi, m.nq)
        mujoco.mj_kinematics(m, d)
        for a, b in left:
            assert mujoco.mj_geomDistance(m, d, ids[a], ids[b], 10.0, None) > 0


def test_self_pairs_carry_the_lighter_branch():
    """A self-collision's law carries what one side can rest on the other with: the lighter of the
    two branches below the geoms' lowest common ancestor (collision.branch_masses), not the whole
    tree.  gymnasium's humanoid (42.1 kg): the left hand against the left thigh and against the
    torso (its ancestor) carry the left arm (2.89 kg), the pelvis's butt against the right foot the
    right leg (9.28 kg); a pair between two trees keeps the lighter tree's weight.  Why: with the
    whole tree's weight its resting self-contacts sat 4-10x shallower than MuJoCo's and BDF held
    2-6e-4 s steps through its rest (benchmarks/results/passive.md)."""
    import gymnasium
    from pathlib import Path
    from eomc.compiler.mjcf.collision import body_pairs, branch_masses
    m = mujoco.MjModel.from_xml_path(str(Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
                                         / "humanoid.xml"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = {p.name: p for p in body_pairs(m)[0]}
    body = lambda name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)   # noqa: E731
    arm, leg = m.body_subtreemass[body("left_upper_arm")], m.body_subtreemass[body("right_thigh")]
    assert arm == pytest.approx(2.891, abs=1e-3) and leg == pytest.approx(9.275, abs=1e-3)
    g = 9.81
    for name, carried in (("left_thigh1__left_hand", arm), ("torso1__left_hand", arm), ("butt__right_foot", leg)):
        pair = found[name]
        g1, g2 = pair.geoms
        assert min(branch_masses(m, m.geom_bodyid[g1], m.geom_bodyid[g2])) == pytest.approx(carried, rel=1e-12)
        k, c, _ = law_parameters(m.geom_solref[g1], m.geom_solimp[g1], m.geom_friction[g1], 1, g, g * carried,
                                 m.opt.timestep)
        assert pair.same_tree and pair.k == pytest.approx(k, rel=1e-12) and pair.c == pytest.approx(c, rel=1e-12)
    two = mujoco.MjModel.from_xml_string("""<mujoco><worldbody><geom type="plane" size="5 5 .1"/>
        <body pos="0 0 .3"><freejoint/><geom name="heavy" size=".1" mass="5"/></body>
        <body pos="0 .15 .3"><freejoint/><geom name="light" size=".05" mass=".5"/></body></worldbody></mujoco>""")
    (pair,) = body_pairs(two)[0]
    assert not pair.same_tree
    assert pair.k == pytest.approx(law_parameters(two.geom_solref[1], two.geom_solimp[1], two.geom_friction[1], 3,
                                                  g, g * 0.5, two.opt.timestep)[0], rel=1e-12)


@pytest.mark.slow
def test_humanoid_at_rest_with_its_self_pairs(tmp_path):
    """gymnasium's humanoid, default build (its 109 self-pairs on), 10 s passive fall with the
    default method: its self-contacts rest about as deep as MuJoCo's (the deepest within 0.3-1.5
    of MuJoCo's resting depth δ_ref; with the whole tree's weight in their law it was 0.21 δ_ref)
    and the integrator does not crawl through the rest: at most 2500 steps from 6 s to 10 s (with
    the whole tree's weight: 10265, steps of 2-6e-4 s; with the branch's: ~900; benchmarks/
    results/passive.md).  A count, not a time: steps are what the law's stiffness decides."""
    import gymnasium
    from pathlib import Path
    import eomc
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "humanoid.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(path, functions=("rhs", "jac_x", "events", "outputs"), cache_dir=tmp_path,
                             progress=False)
        m = mujoco.MjModel.from_xml_path(str(path))
        runs = {T: model.simulate(model.initial_state, (0.0, T)) for T in (6.0, 10.0)}
    assert all(r.status == 0 for r in runs.values())
    late = runs[10.0].stats["steps"] - runs[6.0].stats["steps"]
    assert late <= 2500, late
    ref, _ = resting_depth(m.geom_solref[1], m.geom_solimp[1], 9.81, m.opt.timestep)
    deepest = max(v[-1] for k, v in runs[10.0].outputs.items() if k.startswith("depth_") and "__" in k)
    assert 0.3 * ref <= deepest <= 1.5 * ref, (deepest, ref)
