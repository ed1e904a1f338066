"""MuJoCo's fluid forces (<option density viscosity wind>) against mj_forward: the inertia-box
model and the ellipsoid model (fluidshape="ellipsoid")."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf import MjcfModel  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, qacc_of, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import load_mjmodel  # noqa: E402

FREE = """<mujoco model="drifter">
  <option density="1.2" viscosity="0.02" wind="0.5 -0.3 0.1" gravity="0 0 -1"/>
  <worldbody>
    <body name="hull" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="box" size="0.3 0.1 0.05" mass="2" pos="0.05 0.02 0" euler="0 0 15"/>
      <body name="fin" pos="0.3 0 0">
        <joint name="h" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.02" mass="0.3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _errors(model, m, nstates=8, scale=2.0):
    """Worst (qacc error relative to max(1, |qacc|), fluid force error relative to the largest
    fluid force on the same kinematic tree) over random states.  eomc's generalized fluid force
    is M(q) times its qacc with the fluid less its qacc without (fluid_density = fluid_viscosity
    = 0), against MuJoCo's qfrc_fluid (the fluid's share of qfrc_passive)."""
    m = prepared(m)
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(4)
    still = dict(zip(model.param_names, model.param_defaults), fluid_density=0.0, fluid_viscosity=0.0)
    M = np.zeros((m.nv, m.nv))
    worst, worst_force = 0.0, 0.0
    for _ in range(nstates):
        q, u = rng.uniform(-1, 1, model.nq), rng.uniform(-scale, scale, model.nx - model.nq)
        xd = model.rhs(0.0, np.concatenate([q, u]))
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_forward(m, d)
        assert np.max(np.abs(d.qfrc_fluid)) > 1e-3
        mine = qacc_of(m, built, q, u, xd[model.nq:])
        worst = max(worst, np.max(np.abs(mine - d.qacc)) / max(1.0, np.max(np.abs(d.qacc))))
        dry = qacc_of(m, built, q, u, model.rhs(0.0, np.concatenate([q, u]), p=still)[model.nq:])
        mujoco.mj_fullM(m, d, M)
        force = M @ (mine - dry)
        for tree in set(m.dof_treeid):
            dofs = m.dof_treeid == tree
            ref = d.qfrc_fluid[dofs]
            worst_force = max(worst_force, np.max(np.abs(force[dofs] - ref)) / max(1e-12, np.max(np.abs(ref))))
    return worst, worst_force


def _worst(model, m, nstates=8, scale=2.0):
    return _errors(model, m, nstates, scale)[0]


def test_free_body_with_wind_matches_mj_forward(tmp_path):
    path = tmp_path / "drifter.xml"
    path.write_text(FREE)
    model = eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    assert {"fluid_density", "fluid_viscosity"} <= set(model.param_names)
    assert _worst(model, load_mjmodel(path)) < 1e-9


def test_gymnasium_swimmer_matches_mj_forward(tmp_path):
    gymnasium = pytest.importorskip("gymnasium")
    from pathlib import Path
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "swimmer.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, limits=False, geoms=False), functions=["rhs"],
                             cache_dir=tmp_path / "c", progress=False)
    assert _worst(model, load_mjmodel(path)) < 1e-9


def test_gymnasium_swimmer_stroke_decays_as_in_mujoco(tmp_path):
    """The passive decay of a stroke over time, not only the rhs at states (issue 33): the
    no-flag build from a stroke (body joints at +-2 rad/s) against MuJoCo's RK4 at 1 ms
    (converged to ~1e-9 here: benchmarks/results/passive.md has 1e-4 s over 5 s)."""
    _stroke_against_rk4(_swimmer_path(), tmp_path)


def _swimmer_path():
    gymnasium = pytest.importorskip("gymnasium")
    from pathlib import Path
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "swimmer.xml"


def _stroke_against_rk4(path, tmp_path, timestep=1e-3):
    from eomc.compiler.mjcf.compare import from_mujoco
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(str(path), functions=["rhs"], cache_dir=tmp_path / "c", progress=False)
    m = load_mjmodel(path)
    m.opt.integrator, m.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, timestep
    built = tree_of(m, model)
    d = mujoco.MjData(m)
    d.qvel[m.jnt_dofadr[m.joint("motor1_rot").id]] = 2.0
    d.qvel[m.jnt_dofadr[m.joint("motor2_rot").id]] = -2.0
    q, u = from_mujoco(m, built, d.qpos.copy(), d.qvel.copy())
    times = np.linspace(0.0, 2.0, 21)
    res = model.simulate(np.concatenate([q, u]), (0.0, 2.0), t_eval=times, rtol=1e-12, atol=1e-12)
    assert res.status == 0
    ref = [d.qpos.copy()]
    for _ in range(20):
        for _ in range(int(round(0.1 / timestep))):
            mujoco.mj_step(m, d)
        ref.append(d.qpos.copy())
    got = np.array([to_mujoco(m, built, x[:model.nq], x[model.nq:])[0] for x in res.x])
    assert abs(ref[-1][0]) > 0.05          # the stroke moved the swimmer through the fluid
    assert np.max(np.abs(got - np.array(ref))) < 1e-8


# ---- the ellipsoid model (MuJoCo's mj_ellipsoidFluidModel) ----------------------------------

SHAPES = {"ellipsoid": "0.3 0.1 0.05", "capsule": "0.05 0.2", "box": "0.3 0.1 0.05", "cylinder": "0.06 0.2",
          "sphere": "0.1"}


def _shapes_file(tmp_path, viscosity, wind):
    """Five free bodies, one per geom type, each geom off the body's mass centre and turned,
    fluidshape="ellipsoid" with non-default fluidcoef (one per body)."""
    bodies = []
    for k, (kind, size) in enumerate(SHAPES.items()):
        coef = " ".join(f"{c + 0.1 * k:g}" for c in (0.3, 0.2, 1.1, 0.7, 0.9))
        bodies.append(f"""    <body name="{kind}" pos="{k} 0 1" euler="{10 * k} 20 30">
      <freejoint/>
      <geom type="{kind}" size="{size}" mass="{1 + k}" pos="0.05 0.02 -0.01" euler="20 -10 {15 * k}"
            fluidshape="ellipsoid" fluidcoef="{coef}"/>
    </body>""")
    path = tmp_path / "shapes.xml"
    path.write_text(f"""<mujoco model="shapes">
  <option density="1.3" viscosity="{viscosity}" wind="{wind}" gravity="0 0 -1"/>
  <worldbody>
{chr(10).join(bodies)}
  </worldbody>
</mujoco>
""")
    return path


@pytest.mark.parametrize("viscosity, wind", [(0.0, "0 0 0"), (0.02, "0.5 -0.3 0.1")])
def test_ellipsoid_model_free_shapes_match_mj_forward(tmp_path, viscosity, wind):
    """Added mass (velocity part), Magnus and Kutta lift, blunt/slender/angular drag and Stokes
    drag of an ellipsoid, capsule, box, cylinder and sphere, each with its own fluidcoef:
    qacc and each body's fluid force (qfrc_fluid) as mj_forward's."""
    path = _shapes_file(tmp_path, viscosity, wind)
    model = eomc.compile(MjcfModel(path, geoms=False), functions=["rhs"], cache_dir=tmp_path / "c",
                         progress=False)      # no contacts: mj_forward's are off (compare.prepared)
    worst, force = _errors(model, load_mjmodel(path))
    assert worst < 1e-9 and force < 1e-9


def _ellipsoid_swimmer(tmp_path):
    path = tmp_path / "swimmer_ellipsoid.xml"
    path.write_text(_swimmer_path().read_text().replace('<geom conaffinity="0"',
                                                         '<geom fluidshape="ellipsoid" conaffinity="0"'))
    return path


def test_ellipsoid_swimmer_matches_mj_forward(tmp_path):
    """Gymnasium's swimmer with fluidshape="ellipsoid" on its geoms (MuJoCo's default
    fluidcoef): three capsules on a slide-slide-hinge base and two hinges."""
    path = _ellipsoid_swimmer(tmp_path)
    m = load_mjmodel(path)
    assert np.all(m.geom_fluid[1:, 0] == 1) and m.geom_fluid[0, 0] == 1      # the floor too (world: no force)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, limits=False, geoms=False), functions=["rhs"],
                             cache_dir=tmp_path / "c", progress=False)
    worst, force = _errors(model, m)
    assert worst < 1e-9 and force < 1e-9


def test_ellipsoid_swimmer_stroke_as_in_mujoco(tmp_path):
    """The ellipsoid swimmer's stroke over 2 s against MuJoCo's RK4 at 0.25 ms (at 1 ms RK4 is
    itself 1.5e-8 off here: 1 ms vs 0.5 ms differ by 1.47e-8, 0.5 vs 0.25 ms by 9.0e-10)."""
    _stroke_against_rk4(_ellipsoid_swimmer(tmp_path), tmp_path, timestep=2.5e-4)


MIXED = """<mujoco model="mixed">
  <option density="2.5" viscosity="0.05" wind="0.2 0.4 -0.1" gravity="0 0 -1"/>
  <worldbody>
    <body name="hull" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom name="shell" type="ellipsoid" size="0.3 0.1 0.05" mass="2" pos="0.05 0.02 0" euler="0 0 15"
            fluidshape="ellipsoid" fluidcoef="0.6 0.2 1.4 1.2 0.8"/>
      <geom name="keel" type="box" size="0.2 0.02 0.1" mass="1" pos="-0.1 0 -0.1"/>
      <geom name="mast" type="cylinder" size="0.01 0.3" mass="0.1" pos="0 0 0.3"
            fluidshape="ellipsoid"/>
      <body name="fin" pos="0.3 0 0">
        <joint name="h" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.02" mass="0.3"/>
        <body name="tip" pos="0.2 0 0.1">
          <joint name="k" type="hinge" axis="1 0 0"/>
          <geom type="box" size="0.05 0.04 0.01" mass="0.1" pos="0.05 0 0" fluidshape="ellipsoid"/>
        </body>
      </body>
    </body>
    <body name="mote" pos="1 0 1" euler="30 10 50">
      <freejoint/>
      <geom type="ellipsoid" size="0.003 0.002 0.001" mass="1e-4" fluidshape="ellipsoid"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_mixed_body_uses_ellipsoid_geoms_only(tmp_path):
    """A body with two ellipsoid-model geoms and one that does not ask (MuJoCo: the ellipsoid
    model on that body, from those two geoms only; the keel adds nothing), a box-model child
    and an ellipsoid-model grandchild; and a millimetre mote (MuJoCo 3.x's mjMINVAL floors on
    the dimensional N and |u|·D, which MuJoCo 4 dropped, would cut its Kutta lift: 3e-2 off)."""
    path = tmp_path / "mixed.xml"
    path.write_text(MIXED)
    model = eomc.compile(MjcfModel(path, geoms=False), functions=["rhs"], cache_dir=tmp_path / "c",
                         progress=False)      # no contacts: mj_forward's are off (compare.prepared)
    worst, force = _errors(model, load_mjmodel(path))
    assert worst < 1e-9 and force < 1e-9


def test_ellipsoid_swimmer_jac_x_at_rest_and_moving(tmp_path):
    """jac_x of the ellipsoid model: finite at rest (|u| = sqrt(u·u) differentiates to u/|u|,
    0/0 there; fluid_ellipsoid.root takes it as 0, the one-sided limit of |u|·u's slope) and
    central differences of the rhs elsewhere.  At rest the differences of |u|·u are O(h) off."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(_ellipsoid_swimmer(tmp_path), limits=False, geoms=False),
                             functions=["rhs", "jac_x"], cache_dir=tmp_path / "c", progress=False)
    rng = np.random.default_rng(1)
    for x, h, bound in ((np.zeros(model.nx), 1e-8, 1e-6), (rng.uniform(-1, 1, model.nx), 1e-6, 1e-8)):
        J = model.jac_x(0.0, x)
        assert np.all(np.isfinite(J))
        diff = np.array([(model.rhs(0.0, x + h * e) - model.rhs(0.0, x - h * e)) / (2 * h)
                         for e in np.eye(model.nx)]).T
        assert np.max(np.abs(J - diff)) / max(1.0, np.max(np.abs(diff))) < bound


@pytest.mark.parametrize("size, u, w", [
    ("0.3 0.2 0.1", (1.0, -0.7, 0.4), (0.5, 0.2, -1.0)),
    ("0.003 0.002 0.001", (1e-3, -0.7e-3, 0.4e-3), (0.0, 0.0, 0.0)),      # MuJoCo 3's floors would act
    ("0.003 0.002 0.001", (1e-16, -0.7e-16, 0.4e-16), (0.0, 0.0, 0.0)),   # |u| < 1e-15: no Kutta lift
    ("1 1e-5 1e-5", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)),                     # N' < 1e-15: A_proj = 0
    ("1 1e-5 1e-5", (1.0, 0.3, -0.2), (0.1, 0.0, 0.3)),
    ("0.3 0.2 0.1", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
])
def test_geom_forces_match_mj_forward_at_the_edges(size, u, w):
    """The geom's (τ, f) in numbers against a free body's qfrc_fluid (the geom at its origin,
    unturned: MuJoCo's free-joint force is world = geom components, its torque body = geom)."""
    from eomc.compiler.mjcf.fluid_ellipsoid import geom_fluid_forces, semi_axes
    m = mujoco.MjModel.from_xml_string(f"""<mujoco><option density="1.7" viscosity="0.01" gravity="0 0 0"/>
      <worldbody><body><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
      <geom type="ellipsoid" size="{size}" mass="0" fluidshape="ellipsoid" fluidcoef="0.4 0.3 1.2 0.8 1.1"/>
      </body></worldbody></mujoco>""")
    d = mujoco.MjData(m)
    d.qvel[:3], d.qvel[3:] = u, w
    mujoco.mj_forward(m, d)
    import sympy as sm
    torque, force = geom_fluid_forces([sm.Float(x) for x in w], [sm.Float(x) for x in u], 1.7, 0.01,
                                      semi_axes(m.geom_size[0], int(m.geom_type[0])), m.geom_fluid[0])
    mine = np.array([float(x) for x in force + torque])
    ref = d.qfrc_fluid
    assert np.max(np.abs(mine - ref)) <= 1e-12 * max(1e-300, np.max(np.abs(ref)))
