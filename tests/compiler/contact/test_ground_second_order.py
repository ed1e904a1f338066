"""Second derivatives through ground contacts (issue 30): hvp and hess_id of models with a floor.

The law's k δ₊^{3/2} has the second derivative (3/4) k δ₊^{-1/2}, ∞ at δ₊ = 0, times a zero out
of contact: the passes guard that factor (compiler/passes/diff.cusp_pow), so out of contact every
derivative of the law is 0 and in contact the formula is finite.  Oracles: hvp against Richardson
central differences of jac_x, hess_id against those of jac_id, at states with some contact points
in contact and some out (both asserted, every |δ| far from 0 against the differences' step), on a
capsule-and-sphere robot with a joint limit past its stop and sliding contacts, and on gymnasium's
hopper (its floor and its self-pairs).  At δ = 0 exactly the documented convention (the law's own
branch: δ ≤ 0 is out of contact, docs/derivatives.md): hvp and hess_id equal their values a hair
out of contact."""
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel  # noqa: E402

FUNCTIONS = ("rhs", "jac_x", "hvp", "jac_id", "hess_id", "outputs")
# a free capsule trunk (two contact spheres, one per end cap) and a limited hinge whose sphere foot
# reaches the floor; MJCF's angles are degrees: the limit is ±1°, passed at the states below
ROBOT = """<mujoco model="ground2"><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
<body name="base" pos="0 0 0.3"><freejoint/><geom name="trunk" type="capsule" fromto="-0.1 0 0 0.1 0 0" size="0.04"/>
 <body name="l1" pos="0.1 0 0"><joint name="j1" type="hinge" axis="0 1 0" range="-1 1" limited="true"/>
  <geom name="foot" type="sphere" pos="0.1 0 -0.05" size="0.03"/></body></body>
</worldbody></mujoco>"""
MARGIN = 2e-3       # every |δ| at a checked state: far from the law's kink against the step h·|v|


def _compile(source, name, cache):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(source), name=name, functions=FUNCTIONS, cache_dir=cache,
                            progress=False)


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    path = tmp_path_factory.mktemp("ground2") / "ground2.xml"
    path.write_text(ROBOT)
    return _compile(path, "ground2", path.parent / "cache")


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    gymnasium = pytest.importorskip("gymnasium")
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    return _compile(path, "hop2", tmp_path_factory.mktemp("hopper"))


def _ground_depths(model, x):
    """The ground contacts' depths δ (a body–body pair's depth names hold '__')."""
    return np.array([v for k, v in model.outputs(0.0, x).items() if k.startswith("depth_") and "__" not in k])


def _mixed(model, candidates, n):
    """The first n candidate states with some ground point in contact and some out (asserted), every
    |δ| ≥ MARGIN."""
    chosen = []
    for x in candidates:
        d = _ground_depths(model, x)
        if (d > MARGIN).any() and (d < -MARGIN).any() and np.abs(d).min() >= MARGIN:
            chosen.append(x)
    assert len(chosen) >= n
    return chosen[:n]


def _differences(f, x, v, h=1e-4):
    """d f(x + s v)/ds at 0: Richardson's central differences (error O(h⁴)); h large against
    rounding on the contacts' stiff entries (test_pair_reverse._differences)."""
    def central(step):
        return (f(x + step * v) - f(x - step * v)) / (2 * step)
    return (4 * central(h / 2) - central(h)) / 3


def _check(model, x, rng):
    """hvp and hess_id finite and equal to central differences of jac_x and jac_id; the largest
    relative errors."""
    w, v = rng.standard_normal(model.nx), rng.standard_normal(model.nx)
    hv = model.hvp(0.0, x, w, v)
    fd = _differences(lambda y: model.jac_x(0.0, y), x, v).T @ w
    assert np.isfinite(hv).all()
    e_hvp = np.abs(hv - fd).max() / np.abs(fd).max()
    a = rng.standard_normal(model.nu)
    H = model.hess_id(0.0, x, a)
    assert np.isfinite(H).all()
    fd = np.stack([_differences(lambda y: model.jac_id(0.0, y, a), x, e) for e in np.eye(model.nx)], axis=2)
    e_hess = np.abs(H - fd).max() / np.abs(fd).max()
    assert e_hvp <= 1e-6 and e_hess <= 1e-6, (e_hvp, e_hess)
    return e_hvp, e_hess


def _robot_states(model, rng, count):
    X = rng.normal(scale=0.15, size=(count, model.nx))
    X[:, 2] += 0.04                 # the trunk's height about its radius: some caps down, some up
    X[:, model.nq:] *= 5            # slips of order 0.5 m/s ≫ v_s: the friction slides
    return X


def test_robot_hvp_and_hess_id_with_points_in_and_out_of_contact(robot):
    """Capsule ends and a sphere foot on the floor, a hinge past its limit: hvp and hess_id are
    finite and match central differences at states with points both in and out of contact."""
    rng = np.random.default_rng(1)
    names = list(robot.state_names)
    hi = dict(zip(robot.param_names, robot.param_defaults))["limit_hi_j1"]
    states = _mixed(robot, _robot_states(robot, rng, 400), 4)
    assert any(abs(x[names.index("q_j1")]) > 2 * hi for x in states)       # the limit's law is active
    for x in states:
        _check(robot, x, rng)


def test_hopper_hvp_and_hess_id_on_its_floor(hopper):
    """gymnasium's hopper with its floor (and its self-pairs): the foot pressed, the torso in the
    air."""
    rng = np.random.default_rng(2)
    z = list(hopper.state_names).index("q_rootz")
    X = np.tile(np.asarray(hopper.initial_state, dtype=float), (200, 1))
    X[:, z] -= 0.11                                   # the foot starts 0.1 m up
    X[:, :hopper.nq] += 0.02 * rng.normal(size=(200, hopper.nq))
    X[:, hopper.nq:] = 0.3 * rng.normal(size=(200, hopper.nu))
    for x in _mixed(hopper, X, 3):
        _check(hopper, x, rng)


def test_exactly_at_the_ground_is_out_of_contact(robot):
    """δ = 0 exactly (the trunk level, its caps' centres one radius up): the one-sided second
    derivative is +∞; the convention is the law's branch δ ≤ 0, out of contact.  hvp and hess_id
    are finite there and equal to their values 1e-12 m out of contact; 1e-6 m in contact they
    are not (the δ₊^{-1/2} term), so the comparison can tell the two sides apart."""
    rng = np.random.default_rng(3)
    names = list(robot.state_names)
    x = np.zeros(robot.nx)
    x[list(robot.quaternions)] = 1.0                # upright (the MJCF default: the quaternion's w)
    x[names.index("q_joint0_z")] = 0.04             # the capsule's radius
    x[names.index("q_j1")] = -0.5                   # the foot lifted
    x[robot.nq:] = 0.1 * rng.normal(size=robot.nu)
    x[robot.nq + names.index("q_joint0_z")] = -0.3       # pressing (rising, the clip F_n ≥ 0 would hold F_n at 0)
    z = names.index("q_joint0_z")
    for _ in range(64):             # the floating-point height whose depth rounds to 0 exactly
        d = _ground_depths(robot, x)
        if d[0] == 0.0:
            break
        x[z] = np.nextafter(x[z], np.inf if d[0] > 0 else -np.inf)
    assert d[0] == 0.0 and (d[1:] <= 0).all()      # one cap exactly at the floor, the rest out
    w, v, a = rng.standard_normal(robot.nx), rng.standard_normal(robot.nx), rng.standard_normal(robot.nu)
    up, down = x.copy(), x.copy()
    up[z] += 1e-12
    down[z] -= 1e-6
    assert (_ground_depths(robot, up)[:2] < 0).all() and (_ground_depths(robot, down)[:2] > 0).all()
    hv, H = robot.hvp(0.0, x, w, v), robot.hess_id(0.0, x, a)
    assert np.isfinite(hv).all() and np.isfinite(H).all()
    scale_hv, scale_H = np.abs(hv).max(), np.abs(H).max()
    assert np.abs(hv - robot.hvp(0.0, up, w, v)).max() <= 1e-6 * scale_hv
    assert np.abs(H - robot.hess_id(0.0, up, a)).max() <= 1e-6 * scale_H
    assert np.abs(hv - robot.hvp(0.0, down, w, v)).max() > 1e-3 * scale_hv
