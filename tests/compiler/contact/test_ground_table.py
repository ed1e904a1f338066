"""The ground points as one loop (compiler/contact/ground_table.py) against their straight-line law.

A URDF trunk on one leg with its default ground (13 points; the loop's threshold lowered to 1 here),
built with the loop and without it, agrees at random states in touch and apart and through a sweep
of its height across the bodies' broad phase: NAME_rhs, NAME_outputs (every point's F_n, friction,
depth), NAME_events (depths and clips), jac_x (14 states: the analytic kernel, its block G the
slopes loop's records written into an[]) and NAME_implicit (its forcing and its contact entries,
the slopes loop's records written into out[]).  Bound 1e-12 of each state's largest entry (at least
1; jac_x: of the matrix's): the loop sums a body's forces in the world and turns them once, writes
δ^{3/2} as δ·sqrt(δ) and K, C in its own order -- rounding only (Solo12's 544 points at random
states: benchmarks/results/ground_run.md, sessions 27-28)."""
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.contact import ground_table as gt
from eomc.compiler.urdf.model import UrdfModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "urdf"))
from test_default_ground import FOOT, ONE_LEG  # noqa: E402

FUNCTIONS = ("rhs", "jac_x", "outputs", "events", "implicit")


def _build(tmp, tag, looped):
    path = tmp / "oneleg.urdf"
    path.write_text(ONE_LEG)
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mp.setattr(gt, "TABLE_FROM", 1)
        mp.setattr(gt, "GROUND_TABLE", looped)
        return eomc.compile(UrdfModel(path, floating_base=True, contacts=(FOOT,)), functions=FUNCTIONS,
                            cache_dir=tmp / tag, progress=False, name="oneleg")


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ground_table")
    return _build(tmp, "loop", True), _build(tmp, "straight", False), tmp


def _events(model, states):
    ffi = model.ffi
    n = len(model.metadata["events"])
    fn = ffi.cast("eomc_rhs_fn", getattr(model.model_lib, f"{model.name}_events"))
    out = np.zeros((len(states), n))
    r = model._default_r if model.ninput else ffi.NULL
    for k, x in enumerate(np.ascontiguousarray(states)):
        fn(0.0, ffi.from_buffer("double[]", x), model._default_p, r, ffi.from_buffer("double[]", out[k]), ffi.NULL)
    return out


def _implicit(model, states):
    layout = model.metadata["implicit"]["layout"]
    ffi, fp = model.ffi, model.ffi.addressof(model.model_lib, f"{model.name}_implicit")
    out = np.zeros((len(states), layout["size"]))
    r = model._default_r if model.ninput else ffi.NULL
    for k, x in enumerate(np.ascontiguousarray(states)):
        assert fp(0.0, ffi.from_buffer("double[]", x), model._default_p, r,
                  ffi.from_buffer("double[]", out[k]), ffi.NULL) == 0
    return out


def _close(a, b, whole=False):
    """|a - b| within 1e-12 of the state's largest entry (at least 1): a point's forces are summed
    in another order, and u' at a deep state (1e7) carries their rounding through M⁻¹.  ``whole``:
    ``a`` and ``b`` are one function's matrix at one state (jac_x), its largest entry the scale."""
    a, b = np.atleast_2d(np.asarray(a, float)), np.atleast_2d(np.asarray(b, float))
    assert np.all(np.isfinite(b))
    if whole:
        a, b = a.reshape(1, -1), b.reshape(1, -1)
    scale = np.maximum(1.0, np.abs(b).reshape(len(b), -1).max(axis=1))
    assert np.max(np.abs(a - b).reshape(len(b), -1).max(axis=1) / scale) <= 1e-12


def test_the_loop_is_the_straight_line_law_in_touch_and_apart(pair):
    loop, straight, tmp = pair
    source = next((tmp / "loop").rglob("oneleg.c")).read_text()
    assert "static double eomc_ground(" in source and "eomc_ground(" in source[source.index("int oneleg_rhs("):]
    assert "eomc_ground" not in next((tmp / "straight").rglob("oneleg.c")).read_text()
    # the slopes: one loop writing jac_x's block G and NAME_implicit's contact entries in place
    jac = source[source.index("int oneleg_jac_x("):source.index("int oneleg_outputs(")]
    imp = source[source.index("int oneleg_implicit_var("):]
    assert "eomc_ground_slopes(" in jac and ", 0, &GT_[0], &an[" in jac and "Kc" not in jac
    assert ", 1, &GT_[0], &out[" in imp and "GS_" not in source
    assert loop.output_names == straight.output_names
    rng = np.random.default_rng(27)
    z = loop.state_names.index("q_trunk_floating_z")
    X = rng.normal(scale=1.0, size=(400, loop.nx))
    X[:, z] = rng.uniform(-0.1, 0.8, size=len(X))
    sweep = np.repeat(X[:2], 400, axis=0)      # the height through every body's bound, both sides
    sweep[:, z] = np.tile(np.linspace(-0.05, 0.75, 400), 2)
    for states in (X, sweep):
        _close(loop.rhs_many(0.0, states), straight.rhs_many(0.0, states))
        _close(_events(loop, states), _events(straight, states))
        _close(_implicit(loop, states), _implicit(straight, states))
        for x in states[::8]:
            a, b = loop.outputs(0.0, x), straight.outputs(0.0, x)
            _close(list(a.values()), list(b.values()))
            _close(loop.jac_x(0.0, x), straight.jac_x(0.0, x), whole=True)
    # the sweep touched down: some point pressed, and airborne every force is 0
    fn = np.array([[v for k, v in loop.outputs(0.0, x).items() if k.startswith("Fn_")] for x in sweep[:400]])
    assert fn[0].max() > 1.0 and fn[-1].max() == 0.0


def test_a_build_that_differentiates_in_reverse_keeps_the_straight_line_law():
    assert gt.wanted(("rhs", "jac_x", "outputs", "events", "implicit"))
    for fn in ("vjp", "hvp", "hess_id", "jvp", "jac_p", "rhs_batch", "implicit_batch"):
        assert not gt.wanted(("rhs", fn))


def test_a_lowered_threshold_is_not_served_the_default_build(tmp_path):
    """One cache, the default threshold (13 points: straight-line) then TABLE_FROM = 1: the second
    build is the loop's C, not the first build found in the cache (TABLE_FROM was not in the
    caches' keys before session 29)."""
    path = tmp_path / "oneleg.urdf"
    path.write_text(ONE_LEG)

    def build(table_from):
        with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mp.setattr(gt, "TABLE_FROM", table_from)
            model = eomc.compile(UrdfModel(path, floating_base=True, contacts=(FOOT,)), functions=("rhs",),
                                 cache_dir=tmp_path / "cache", progress=False, name="oneleg")
        return Path(model.source_path).read_text()

    assert "eomc_ground(" not in build(gt.TABLE_FROM_DEFAULT)
    assert "eomc_ground(" in build(1)


# a chain closed by a joint equality (MJCF <equality><joint>) over the floor: its jac_x is the
# tangent path's (constrained trees never take the analytic kernel), differentiating the loop's
# outputs through their straight-line twins
COUPLED = """<mujoco model="coupled">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="upper" pos="0 0 0.03">
      <joint name="shoulder" type="hinge" axis="0 1 0" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1"/>
      <body name="lower" pos="0.5 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0.1" size="0.04" mass="0.7"/>
        <body name="tip" pos="0.4 0 0.1">
          <joint name="wrist" type="hinge" axis="0 0 1"/>
          <geom type="box" size="0.1 0.05 0.02" mass="0.3"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><joint name="lin" joint1="elbow" joint2="shoulder" polycoef="0.1 0.5 0 0 0"/></equality>
</mujoco>
"""


def test_a_constrained_trees_jac_x_differentiates_the_loops_points(tmp_path):
    """The tangent path's jac_x (a tree closed by a constraint) read the loop's outputs' slopes
    as 0: the forward pass differentiated only the temporaries the results' free symbols reach,
    and a loop output's twin is not among its arguments (passes/diff._needed_by, fixed with
    GroundOut.tangent_reads).  Against the straight-line build and central differences of rhs."""
    (tmp_path / "coupled.xml").write_text(COUPLED)

    def build(looped):
        with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mp.setattr(gt, "TABLE_FROM", 1)
            mp.setattr(gt, "GROUND_TABLE", looped)
            return eomc.compile(str(tmp_path / "coupled.xml"), functions=("rhs", "jac_x"),
                                cache_dir=tmp_path / f"c{int(looped)}", progress=False)

    loop, straight = build(True), build(False)
    assert "eomc_ground(" in Path(loop.source_path).read_text()
    assert "eomc_ground(" not in Path(straight.source_path).read_text()
    rng = np.random.default_rng(3)
    for _ in range(6):      # (these states press the floor: main's jac_x differed from the straight-line one's)
        x = np.concatenate([rng.uniform(-0.3, 0.3, loop.nq), rng.uniform(-2, 2, loop.nx - loop.nq)])
        J, Js = loop.jacobian(0.0, x), straight.jacobian(0.0, x)
        scale = max(1.0, np.max(np.abs(Js)))
        assert np.max(np.abs(J - Js)) < 1e-12 * scale
        h = 1e-7
        fd = np.column_stack([(loop.rhs(0.0, x + h * e) - loop.rhs(0.0, x - h * e)) / (2 * h)
                              for e in np.eye(loop.nx)])
        assert np.max(np.abs(J - fd)) < 1e-5 * scale


# a free trunk (capsule, sphere) with a hinged forearm between the floor and a wall tilted 45°
# (MJCF zaxis): each geom's points on both planes
WALLED = """<mujoco model="walled"><worldbody>
<geom name="floor" type="plane" size="5 5 0.1"/>
<geom name="wall" type="plane" pos="0.3 0 0" zaxis="-1 0 1" size="5 5 0.1"/>
<body name="trunk" pos="0 0 0.3"><freejoint name="root"/>
 <geom name="core" type="capsule" fromto="-0.1 0 0 0.1 0 0" size="0.05"/>
 <geom name="head" type="sphere" pos="0.15 0 0.05" size="0.04"/>
 <body name="arm" pos="0.1 0 0"><joint name="hinge" type="hinge" axis="0 1 0"/>
  <geom name="fore" type="capsule" fromto="0 0 0 0.15 0 0" size="0.03"/></body>
</body></worldbody></mujoco>"""


@pytest.fixture(scope="module")
def walled(tmp_path_factory):
    from eomc.compiler.mjcf.model import MjcfModel
    tmp = tmp_path_factory.mktemp("walled")
    (tmp / "walled.xml").write_text(WALLED)
    built = {}
    for tag, looped in (("loop", True), ("straight", False)):
        with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mp.setattr(gt, "TABLE_FROM", 1)
            mp.setattr(gt, "GROUND_TABLE", looped)
            built[tag] = eomc.compile(MjcfModel(tmp / "walled.xml"), functions=FUNCTIONS, cache_dir=tmp / tag,
                                      progress=False, name="walled")
    return built["loop"], built["straight"], tmp


def test_a_tilted_plane_takes_the_loop_in_its_own_frame(walled):
    """Points on a tilted wall (n = (-1, 0, 1)/√2, height -0.21) go through the loop with the floor's
    (one entry per body and plane, in the plane's frame: ground_table.plane_frame) and equal the
    straight-line law in the rhs, every point's outputs (F_n, the friction's world components,
    depth), the events, jac_x and NAME_implicit, at random states pressing the wall, the floor, both
    and neither.  The records of jac_x's block G and NAME_implicit stay straight-line (the slopes loop
    writes world records: planes z = 0 only).  The depths agree to 2e-16 m: the loop measures them
    in the plane's frame, the straight-line law as n·c, and that rounding, relative to a grazing
    depth (measured: 1.4e-17 m of 1.6e-6 m), makes δ^{3/2} differ by 1e-11 of itself -- so the
    functions are compared at 1e-12 where no point grazes (0 < δ < 1e-4 m)."""
    loop, straight, tmp = walled
    source = next((tmp / "loop").rglob("walled.c")).read_text()
    rhs = source[source.index("int walled_rhs("):]
    assert "static double eomc_ground(" in source and "eomc_ground(" in rhs and "eomc_ground_slopes(" not in source
    assert "eomc_ground" not in next((tmp / "straight").rglob("walled.c")).read_text()
    assert loop.output_names == straight.output_names
    names, outs = list(loop.state_names), list(loop.output_names)
    depth = [k for k, n in enumerate(outs) if n.startswith("depth_")]
    rng = np.random.default_rng(31)
    X = np.zeros((600, loop.nx))
    X[:, names.index("q_root_x")] = rng.uniform(-0.1, 0.45, len(X))
    X[:, names.index("q_root_y")] = rng.uniform(-0.2, 0.2, len(X))
    X[:, names.index("q_root_z")] = rng.uniform(-0.02, 0.4, len(X))
    quat = rng.normal(size=(len(X), 4))
    X[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    X[:, names.index("q_hinge")] = rng.uniform(-1.5, 1.5, len(X))
    X[:, loop.nq:] = rng.normal(scale=0.8, size=(len(X), loop.nu))
    d_loop = np.array([np.array(list(loop.outputs(0.0, x).values()))[depth] for x in X])
    d = np.array([np.array(list(straight.outputs(0.0, x).values()))[depth] for x in X])
    assert np.abs(d_loop - d).max() <= 2e-16
    X = X[~((d > 0) & (d < 1e-4)).any(axis=1)]
    _close(loop.rhs_many(0.0, X), straight.rhs_many(0.0, X))
    _close(_events(loop, X), _events(straight, X))
    _close(_implicit(loop, X), _implicit(straight, X))
    pressed = {"floor": 0, "wall": 0, "both": 0}
    n = np.array([-1.0, 0.0, 1.0]) / np.sqrt(2.0)
    for x in X[::3]:
        a, b = loop.outputs(0.0, x), straight.outputs(0.0, x)
        _close(list(a.values()), list(b.values()))
        _close(loop.jac_x(0.0, x), straight.jac_x(0.0, x), whole=True)
        on = {plane for plane in ("floor", "wall") if any(v > 0 for k, v in b.items() if k.startswith("Fn_")
                                                           and f"_{plane}" in k)}
        for plane in on:
            pressed[plane] += 1
        pressed["both"] += len(on) == 2
        for name in a:          # the wall's friction: along the wall (F · n = 0), in world components
            if name.startswith("Ftx_") and "_wall" in name:
                ft = np.array([a[name], a[name.replace("Ftx_", "Fty_")], a[name.replace("Ftx_", "Ftz_")]])
                assert abs(ft @ n) <= 1e-12 * (1.0 + np.abs(ft).max())
    assert len(X) >= 300 and min(pressed.values()) >= 5, (len(X), pressed)
