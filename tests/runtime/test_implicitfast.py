"""The fixed-step implicit integrator (method="implicitfast", runtime/c/eomc_fixedstep.c).

Oracles: the oscillator's closed form and energy, the matrix exponential of the stiff
chain, a tight-tolerance run of Radau (1e-10) on the bouncing
sphere and the standing Solo12, and energy (kinetic + potential + the contact spring's)
on the undamped bouncing sphere, which an implicit step must never create.
"""
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from helpers import shared_builds
from helpers.stand_in import get_model

import eomc
from eomc.runtime.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "compiler" / "contact"))
from sphere_model import sphere_model  # noqa: E402


def test_oscillator_first_order_and_never_gains_energy():
    """Implicit Euler on x'' = -4x: error ~ h (slope 1), amplitude shrinks every step."""
    m = get_model("oscillator")
    errs = []
    hs = (0.02, 0.01, 0.005, 0.0025)
    for h in hs:
        res = simulate(m, [1.0, 0.0], (0.0, 2.0), method="implicitfast", dt=h)
        assert res.status == 0
        errs.append(abs(res.x[-1, 0] - np.cos(4.0)))
        energy = 4.0 * res.x[:, 0] ** 2 + res.x[:, 1] ** 2          # k x^2 + m v^2, k = 4
        assert np.all(np.diff(energy) <= 1e-12 * energy[0])
    slopes = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert np.all((slopes > 0.85) & (slopes < 1.15)), (errs, slopes)


def test_stiff_chain_stable_far_beyond_the_explicit_limit():
    """k2 = 1e6 (omega 1.4e3): explicit methods need h < 1.4e-3; h = 0.01 stays stable and
    converges to the exact (matrix exponential) solution as h shrinks."""
    m = get_model("chain")
    p = np.array([1.0, 1e6, 0.1, 2e3])
    x0 = np.array([1.0, 1.0, 0.0, 0.0])
    J = m.jacobian(0.0, x0, p)
    exact = expm(J * 2.0) @ x0
    errs = []
    for h in (0.02, 0.01, 0.005):
        res = simulate(m, x0, (0.0, 2.0), p=p, method="implicitfast", dt=h, t_eval=[2.0])
        assert res.status == 0
        errs.append(np.abs(res.x[-1] - exact).max())
    assert errs[0] < 0.1 and errs[2] < errs[1] < errs[0], errs
    # the step's Jacobian is kept: a linear model needs it once
    assert res.stats["njev"] == 1 and res.stats["rejected"] == 0


def test_output_is_the_step_grid_and_linear_in_between():
    m = get_model("oscillator")
    res = simulate(m, [1.0, 0.0], (0.0, 0.1), method="implicitfast", dt=0.01)
    assert res.t.size == 11 and np.allclose(np.diff(res.t), 0.01)
    mid = simulate(m, [1.0, 0.0], (0.0, 0.1), method="implicitfast", dt=0.01, t_eval=[0.035])
    assert mid.x[0] == pytest.approx(0.5 * (res.x[3] + res.x[4]), abs=1e-14)


def test_arguments_checked():
    m = get_model("oscillator")
    with pytest.raises(ValueError, match="fixed-step: give the step size"):
        simulate(m, [1.0, 0.0], (0.0, 1.0), method="implicitfast")
    with pytest.raises(ValueError, match="dt must be"):
        simulate(m, [1.0, 0.0], (0.0, 1.0), method="implicitfast", dt=-1.0)
    with pytest.raises(ValueError, match="implicitfast with dt=1e-09 needs 1e\\+09 steps"):
        simulate(m, [1.0, 0.0], (0.0, 1.0), method="implicitfast", dt=1e-9)
    assert simulate(m, [1.0, 0.0], (0.0, 0.1), method="implicit_fast", dt=0.01).method == "implicitfast"


def test_a_missing_dt_names_the_files_own_step(monkeypatch):
    """Sweep s27: `eomc simulate hopper.xml --method implicitfast` was refused (after its build)
    with 'give the step size' and not a word of the 0.002 s its MJCF file is written for, which
    the built model carries (model.timestep, MJCF <option timestep>)."""
    m = get_model("oscillator")
    monkeypatch.setattr(m, "timestep", 0.002, raising=False)
    with pytest.raises(ValueError, match=r"steps at 0\.002 \(MJCF <option timestep>\): dt=0\.002, --dt 0\.002"):
        simulate(m, [1.0, 0.0], (0.0, 1.0), method="implicitfast")
    monkeypatch.setattr(m, "timestep", None, raising=False)
    with pytest.raises(ValueError, match=r"on the command line\)$"):       # no file step: as before
        simulate(m, [1.0, 0.0], (0.0, 1.0), method="implicitfast")


def test_blowup_fails_loudly():
    """x' = x^2 from 1 is infinite at t = 1: implicit Euler has no solution past it, so the
    run must not end quietly with status 0: a failure, or a warning naming the unsolved steps."""
    from eomc.runtime.switching import PhysicsWarning
    m = get_model("blowup")
    with pytest.warns(PhysicsWarning, match="was not solved to tolerance"):
        res = simulate(m, [1.0], (0.0, 2.0), method="implicitfast", dt=0.01, raise_on_failure=False)
    assert res.status == 0 and res.stats["rejected"] > 0


# ------------------------------------------------------------ generated models

@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    spec, _ = sphere_model(radius=0.1, k=1e5, c=0.0, mu=0.5, vs=1e-3)
    system = spec.pop("system")
    return eomc.compile(system, name="implicitfast_sphere", formulation="kane",
                        cache_dir=tmp_path_factory.mktemp("cache"), **spec)


def _p(model, **values):
    p = np.array(model.param_defaults, dtype=float)
    for k, v in values.items():
        p[model.param_names.index(k)] = v
    return p


@pytest.mark.parametrize("k", [1e3, 1e5, 1e8, 1e10, 1e12])
@pytest.mark.parametrize("dt", [5e-3, 1e-3, 2e-4])
def test_bouncing_sphere_never_creates_energy(sphere, k, dt):
    """c = 0: kinetic + potential + the spring's k delta^2.5 / 2.5 never exceeds the start's,
    at every step, for soft to very stiff ground; the sphere ends resting on the ground,
    not below it (static penetration (m g / k)^(2/3)); no step left unsolved."""
    x0 = np.zeros(12)
    x0[2] = 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")           # k = 1e3 is too soft: a penetration warning
        warnings.filterwarnings("error", message=".*not solved to tolerance")   # none unsolved
        res = sphere.simulate(x0, (0, 2.0), p=_p(sphere, k_ball=k, c_ball=0.0),
                              method="implicitfast", dt=dt)
    assert res.status == 0
    d = res.outputs["depth_ball"]
    total = res.outputs["energy"] + k * np.maximum(d, 0) ** 2.5 / 2.5
    assert total.max() <= total[0] * (1 + 1e-9), total.max() - total[0]
    static = (9.81 / k) ** (2 / 3)
    assert d.max() < max(0.4, 3 * static)            # never tunnels through the floor
    if k >= 1e8:                                       # stiff: implicit Euler ends the bounce
        assert d[-1] == pytest.approx(static, rel=0.05)


def test_bouncing_sphere_converges_to_the_tight_reference(sphere):
    """Soft damped ground (k = 1e5, c = 2): the final state approaches DOP853 at 1e-10 as dt
    shrinks (first order: halving dt about halves the error) against Radau at 1e-10, and the touch-down event is
    found within one step of the reference's."""
    x0 = np.zeros(12)
    x0[2] = 0.5
    x0[sphere.state_names.index("vx")] = 0.3
    p = _p(sphere, k_ball=1e5, c_ball=2.0)
    ref = sphere.simulate(x0, (0, 0.6), p=p, method="radau", rtol=1e-10, atol=1e-10, t_eval=[0.6])
    errs = []
    dts = (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4)
    warned = []
    for dt in dts:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = sphere.simulate(x0, (0, 0.6), p=p, method="implicitfast", dt=dt)
        if any("not solved to tolerance" in str(w.message) for w in caught):
            warned.append(dt)
        assert res.status == 0
        errs.append(np.abs(res.x[-1] - ref.x[-1]).max())
        touch = res.t_events["contact_ball"][0]
        assert touch == pytest.approx(ref.t_events["contact_ball"][0], abs=dt)
    # the touch-down at the coarsest steps may leave sub-steps unsolved (said by a warning);
    # from 1 ms down every step is solved
    assert all(dt > 1e-3 for dt in warned), warned
    assert all(b < a for a, b in zip(errs, errs[1:])), errs
    slope = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert 0.7 < slope < 1.5, (errs, slope)


@pytest.fixture(scope="module")
def solo():
    """The one Solo12 build of the test process (tests/compiler/contact/test_quadruped.py uses it too)."""
    return shared_builds.quadruped_stand(), shared_builds.solo12_stand()


def test_solo12_stands_at_real_time_steps(solo):
    """Solo12 on four compliant feet (friction regularised at v_s = 1e-4 m/s: stiff in the
    velocities) under joint PD, 1 s: stable at 5, 2 and 1 ms, within 1e-5 of Radau at 1e-10
    (error shrinking with dt), every step's implicit equation solved (no unconverged steps),
    the feet carrying m g at the end."""
    qs, m = solo
    x0, K, x_ref = qs.stance(m)
    ref = m.simulate(x0, (0, 1), K=K, x_ref=x_ref, method="radau", rtol=1e-10, atol=1e-10,
                     t_eval=[1.0])
    weight = sum(ref.outputs[f"Fn_{leg}_FOOT"][-1] for leg in qs.LEGS)   # m g, standing still
    errs = []
    for dt in (5e-3, 1e-3, 2.5e-4):
        res = m.simulate(x0, (0, 1), K=K, x_ref=x_ref, method="implicitfast", dt=dt)
        assert res.status == 0 and res.stats["rejected"] == 0
        errs.append(np.abs(res.x[-1] - ref.x[-1])[:m.nq].max())
        fn = sum(res.outputs[f"Fn_{leg}_FOOT"][-1] for leg in qs.LEGS)
        assert fn == pytest.approx(weight, rel=1e-4)
    assert errs[0] < 1e-5 and errs[2] < errs[0], errs



TUMBLER = """<mujoco model="tumbler">
  <option timestep="0.005" gravity="0 0 0"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="box" pos="0 0 5">
      <freejoint name="root"/>
      <geom name="box" type="box" size="0.3 0.1 0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def _rotation(x, names):
    """The body's rotation from its body-fixed XYZ angles (eomc's free joint)."""
    rx, ry, rz = (x[names.index(f"q_root_r{a}")] for a in "xyz")
    c, s = np.cos, np.sin
    Rx = np.array([[1, 0, 0], [0, c(rx), -s(rx)], [0, s(rx), c(rx)]])
    Ry = np.array([[c(ry), 0, s(ry)], [0, 1, 0], [-s(ry), 0, c(ry)]])
    Rz = np.array([[c(rz), -s(rz), 0], [s(rz), c(rz), 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def _tumbling(names, ry0, w):
    """A free body 5 m up, pitched ry0 towards the gimbal lock, spinning at w (body frame)."""
    x0 = np.zeros(len(names))
    x0[names.index("q_root_z")] = 5.0
    x0[names.index("q_root_ry")] = ry0
    x0[[names.index(f"u_root_w{a}") for a in "xyz"]] = w
    return x0


@pytest.mark.parametrize("ry0, w", [(1.3, (0.05, 2.0, 0.05)), (1.0, (0.02, 4.0, 0.5))])
def test_free_joint_tumbling_past_gimbal_lock_keeps_its_orientation(tmp_path, ry0, w):
    """The step moves q by h N(q) u1 with N (the Euler angles' rates, 1/cos(ry) in it) taken at
    the step's start; near ry = +-pi/2 N changes many times over within a step, and the speeds'
    residual cannot see it (a free box tumbling in space has no stiff term at all).  The checked
    step also measures the configuration's own implicit Euler residual over the root free
    joint's columns of N (eomc_fixedstep.c fs_chart_ratio) and splits there.  Oracle: Radau at
    1e-11.  Measured at 5 ms over 1 s (cos(ry) down to 0.005 and 0.03): rotation error 5.7e-3
    and 4.1e-3 with that check, 4.9e-2 and 3.8e-2 without it (gymnasium's humanoid rows that
    gained 284 and 588 J in session 16 went that way)."""
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path / "tumbler.xml"
    path.write_text(TUMBLER)
    # orientation="euler": the chart check is for body-XYZ angles (a quaternion has no lock)
    m = eomc.compile(MjcfModel(path, orientation="euler"), name="tumbler", cache_dir=tmp_path, progress=False)
    names = list(m.state_names)
    x0 = _tumbling(names, ry0, w)
    ref = m.simulate(x0, (0.0, 1.0), method="radau", rtol=1e-11, atol=1e-11)
    assert np.abs(np.cos(ref.x[:, names.index("q_root_ry")])).min() < 0.05     # it passes near the lock
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # implicit Euler's energy drift in free flight, said
        fs = m.simulate(x0, (0.0, 1.0), method="implicitfast", dt=0.005)
    assert np.abs(_rotation(fs.x[-1], names) - _rotation(ref.x[-1], names)).max() < 0.015


TUMBLER_ARM = TUMBLER.replace('model="tumbler"', 'model="tumbler_arm"').replace(
    '      <geom name="box" type="box" size="0.3 0.1 0.05" mass="1"/>\n',
    '      <geom name="box" type="box" size="0.3 0.1 0.05" mass="1"/>\n'
    '      <body name="arm" pos="0.3 0 0">\n'
    '        <joint name="elbow" type="hinge" axis="0 1 0"/>\n'
    '        <geom name="arm" type="capsule" fromto="0 0 0 0.25 0 0" size="0.02" mass="0.2"/>\n'
    '      </body>\n')


def test_n_products_skip_only_the_constant_zeros_of_n(tmp_path):
    """The fast path's rate qd + N du and fs_chart_ratio's N(q) - N(q1) read only the entries of N
    that are not constant zeros (eomc_fixedstep.c fs_nlists: found once per run from
    NAME_implicit_const's outputs; a term left out is exactly +-0).  Oracle: the same run with
    NAME_implicit whole and no terms_const (every output then counts as varying: the dense
    sums): the same trajectory bit for bit and the same calls, on a box with a hinged arm tumbling
    past gimbal lock at 5 ms (the chart ratio splits steps there).  A list that also left out N's
    constant ones (the hinge's row: one entry, 1) or the varying entries of the free joint's
    columns would change the trajectory or the calls."""
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.runtime.simulate import implicit_terms
    path = tmp_path / "tumbler_arm.xml"
    path.write_text(TUMBLER_ARM)
    # orientation="euler": the chart ratio's N(q) varies with body-XYZ angles (pinned: the lock)
    m = eomc.compile(MjcfModel(path, orientation="euler"), name="tumbler_arm", cache_dir=tmp_path,
                     progress=False)
    names = list(m.state_names)
    ffi, lib = m.ffi, m.model_lib
    layout = m.metadata["implicit"]["layout"]
    base = implicit_terms(m)
    assert base.nfree == 1 and base.terms_const != ffi.NULL
    marked = np.full(layout["size"], np.nan)
    getattr(lib, f"{m.name}_implicit_const")(ffi.from_buffer("double[]", marked))
    N = marked[layout["N"]:layout["N"] + m.nq * m.nu].reshape(m.nq, m.nu)
    free = slice(base.free[0], base.free[0] + 6)
    elbow = N[names.index("q_elbow")]
    assert np.count_nonzero(elbow) == 1 and not np.isnan(elbow).any()       # one constant 1, the rest 0
    assert np.isnan(N[names.index("q_root_rx"), free]).any()                 # varying: summed
    x0 = _tumbling(names, 1.3, (0.05, 2.0, 0.05))
    x0[names.index("u_elbow")] = 1.0
    runs = []
    for whole in (False, True):
        if whole:
            keep = m.__dict__["_implicit_struct"]
            st = ffi.new("eomc_implicit *")
            st.terms = ffi.cast("eomc_mat_fn", ffi.addressof(lib, f"{m.name}_implicit"))
            st.terms_const = ffi.NULL
            st.ncontact, st.chain_start, st.chain, st.parent = base.ncontact, base.chain_start, base.chain, base.parent
            st.nfree, st.free, st.work_len, st.split = base.nfree, base.free, base.work_len, base.split
            m._implicit_struct = (st, keep, keep[-1])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")            # implicit Euler's energy drift in free flight
            runs.append(m.simulate(x0, (0.0, 1.0), method="implicitfast", dt=0.005))
    a, b = runs
    assert a.stats["nfev"] > 201                       # split steps: the ratio decides here
    assert a.stats["nfev"] == b.stats["nfev"] and a.stats["nlu"] == b.stats["nlu"]
    assert np.array_equal(a.x.view(np.int64), b.x.view(np.int64))


# a light rod on a vertical hinge (no gravity torque) with a large joint friction, over a floor (its
# contacts make the fast path NAME_implicit): f / I ~ 1e6 rad/s^2, so friction stops it within a
# microsecond from 0.5-5 rad/s
FRICTION_ROD = """<mujoco><option timestep="0.002"/><worldbody><geom name="floor" type="plane" size="1 1 0.1"/>
<body pos="0 0 1"><joint name="hinge" type="hinge" axis="0 0 1" frictionloss="10"/>
<geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.005" mass="0.01"/></body></worldbody></mujoco>"""


@pytest.mark.parametrize("u0", [0.5, 5.0])
def test_joint_friction_stops_a_light_joint_and_never_pushes_it(tmp_path, u0):
    """The fast path's matrix takes the joint friction -f tanh(u/v) by its secant slope f tanh(u/v)/u
    (compiler/tree/joint_laws.secant_tanh).  With the tangent, nil in a fast slip, the friction was
    an explicit force: on this rod the step split to its smallest sub-steps (131 model calls for 10
    steps) and the rod turned on at 0.5 rad/s with status 0, though friction stops it within a
    microsecond (Radau at 1e-9: 1.1e-7 rad travelled).  Oracles: Coulomb friction only slows a joint
    (|u| falls, its sign stays, the energy never rises), Radau's final angle, and the slope in
    NAME_implicit's out[] against its closed form, f/v at rest."""
    from helpers.implicit_call import implicit_terms_at
    from helpers.mjcf_builds import text_model
    m = text_model(FRICTION_ROD, "frod", tmp_path, ("rhs", "jac_x", "outputs", "energy", "implicit"))
    names, pn = list(m.state_names), list(m.param_names)
    f, v = (float(m.param_defaults[pn.index(n)]) for n in ("friction_hinge", "friction_v_hinge"))
    for u in (0.0, 1e-3, -0.02, u0):
        out, layout = implicit_terms_at(m, np.array([0.0, u]))
        want = f / v if u == 0 else f * np.tanh(u / v) / u
        assert out[layout["joint"]] == pytest.approx(want, rel=1e-13)     # -dtau/du: the secant
    x0 = np.array([0.0, u0])
    run = m.simulate(x0, (0.0, 0.02), method="implicitfast", dt=0.002)
    u = run.x[:, names.index("u_hinge")]
    assert run.stats["nfev"] <= 15 and np.all(np.diff(np.abs(u)) <= 0) and np.all(u >= 0)
    assert abs(u[1]) < 0.05 * u0                        # stopped within the first step
    assert np.all(np.diff(run.outputs["energy"]) <= 1e-15)
    ref = m.simulate(x0, (0.0, 0.02), method="radau", rtol=1e-9, atol=1e-12)
    # the angle travelled: Radau's 1.1e-7 rad; the step's end speed held over the first step, 2x that
    # (first order at a stop 1e5 times shorter than the step); free of friction it would be u0 t = 0.01
    assert 0 < ref.x[-1, 0] < run.x[-1, 0] < 4 * ref.x[-1, 0]


def test_friction_secant_in_lanes_and_in_float(tmp_path):
    """eomc_tanhc (the secant's helper) has its lanes twin (compiler/emit/batch.py: the rows' slopes
    the scalar helper's bits, so the lanes rollout equals the scalar one with libm's sin/cos) and its
    float twin (the c99-f32 target); both targets' C is clean under the strict flags."""
    from eomc.compiler.driver import generate
    from helpers.mjcf_builds import text_model
    m = text_model(FRICTION_ROD, "frod_lanes", tmp_path, ("rhs", "jac_x", "implicit", "implicit_batch"),
                   cflags="-O2 -std=c99 -fPIC -DEOMC_BATCH_LIBM_TRIG")
    X0 = np.column_stack([np.zeros(11), np.linspace(-5.0, 5.0, 11)])      # one row at rest
    kw = dict(dt=0.002, steps=10, method="implicitfast", threads=1)
    scalar, lanes = eomc.rollout(m, X0, **kw), eomc.rollout(m, X0, lanes=True, **kw)
    assert scalar.ok.all() and np.array_equal(scalar.x, lanes.x)
    assert np.all(np.abs(scalar.x[:, 1]) < 1e-9)       # every row stopped
    from eomc.compiler.mjcf.model import MjcfModel
    from helpers.emit_support import compile_shared
    path = tmp_path / "frod32.xml"
    path.write_text(FRICTION_ROD)
    for target, name in (("c99-f64", "frod64"), ("c99-f32", "frod32")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, gm = generate(MjcfModel(path), name, functions=("rhs", "implicit"), target=target,
                             cache_dir=tmp_path / name, progress=False)
        real = "float" if target == "c99-f32" else "double"
        assert f"static inline {real} eomc_tanhc({real} x)" in gm.c_source
        # strict flags, -Werror (gcc's message if not); a one-speed tree's NAME_tree_lu declared an
        # unused variable until session 53
        compile_shared(gm, tmp_path)
