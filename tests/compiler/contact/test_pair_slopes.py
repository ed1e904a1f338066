"""The body-body pairs' slopes in NAME_implicit (compiler/contact/pairs.law_slopes, the table's
"slopes" loop, compiler/formulations/recursive.implicit_metadata's signed chains): per pressed pair
point its depth, point, relative velocity v_B - v_A, K = -dF/dp and C = -dF/dv on that relative
motion, which the fixed step puts in its matrix as Jᵀ K J, Jᵀ C J with J = J_B - J_A
(runtime/c/eomc_fixedstep.c).

Oracles: the rhs's own outputs (depth, point, F_n, friction), J u against the law's v_rel (exact:
linear in u), and central differences of the pair's force (outputs) in the speeds (dF/du = -C J, every
column: the speeds of neither body, and those moving both, have none) and along the normal
(dF/dε = -K n when B moves by ε n), on a small scene with pairs on one path (trunk and arm), across
branches' roots (the arm against a free ball), table and inlined."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.compiler.contact.pairs as pairs  # noqa: E402
from helpers.implicit_call import implicit_terms_at  # noqa: E402

from .test_narrow import LIMBS  # noqa: E402


@pytest.fixture(scope="module", params=["table", "inlined"])
def limbs(request, tmp_path_factory):
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path_factory.mktemp("limbs") / "limbs.xml"
    path.write_text(LIMBS)
    saved = pairs.PAIR_TABLE, pairs.TABLE_FROM, pairs.INLINE_SLOPES
    # inlined: their slopes asked for (pairs.INLINE_SLOPES: off by default, see there)
    pairs.PAIR_TABLE, pairs.TABLE_FROM, pairs.INLINE_SLOPES = True, (1 if request.param == "table" else 100), True
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # orientation="euler": _states draws the poses as body-XYZ angles at this layout's
            # indices (the ball's position q 10-12)
            return eomc.compile(MjcfModel(path, pairs=True, orientation="euler"), "limbs",
                                functions=("rhs", "outputs", "implicit"),
                                cache_dir=path.parent / "cache", progress=False)
    finally:
        pairs.PAIR_TABLE, pairs.TABLE_FROM, pairs.INLINE_SLOPES = saved


def _d_by_speeds(total, x, nq, nu, h):
    """Central differences (step h) of the 3-vector total(x) with respect to each speed."""
    dFdu = np.zeros((3, nu))
    for k in range(nu):
        xp, xm = x.copy(), x.copy()
        xp[nq + k] += h
        xm[nq + k] -= h
        dFdu[:, k] = (total(xp) - total(xm)) / (2 * h)
    return dFdu


def jacobian(out, layout, item, nu):
    """J (3 x nu) of a contact's point from NAME_implicit's screws and the metadata's signed chain."""
    screws = out[layout["screw"]:layout["screw"] + 6 * nu].reshape(nu, 6)
    c = item["index"]
    p = out[layout["contact"] + 25 * c + 1:layout["contact"] + 25 * c + 4]
    J = np.zeros((3, nu))
    for s in item["speeds"]:
        k = ~s if s < 0 else s
        j = screws[k, 3:] + np.cross(screws[k, :3], p)
        J[:, k] = -j if s < 0 else j
    return J


def _force(model, x, name):
    o = dict(model.outputs(0.0, x))
    return o[f"Fn_{name}"], np.array([o[f"Ftx_{name}"], o[f"Fty_{name}"], o[f"Ftz_{name}"]])


def _states(model, count, seed=5):
    """Random poses and speeds, every other one with the ball (q 10-12) placed near the base's
    origin (q 0-2), where it presses on the trunk, the head or the arm."""
    rng = np.random.default_rng(seed)
    for k in range(count):
        x = rng.normal(scale=0.6, size=model.nx)
        x[2] += 0.3
        if k % 2:
            x[10:13] = x[0:3] + rng.normal(scale=0.08, size=3)
        yield x


def test_chains_are_signed_and_cancel_the_common_speeds(limbs):
    info = limbs.metadata["implicit"]
    pair_items = [c for c in info["contacts"] if c.get("pair")]
    assert len(pair_items) == 9 and len(info["contacts"]) == 9      # no floor: pairs only
    chains = {c["name"]: c["speeds"] for c in pair_items}
    # trunk (base: free joint 0-5) against arm2 (l2 under l1: ball joint 6-8, hinge 9): the base's
    # speeds move both and cancel
    assert chains["trunk__arm2"] == [6, 7, 8, 9]
    # the arm against the free ball (speeds 10-15): the arm's whole chain with a minus
    assert chains["arm2__ball"] == list(range(10, 16)) + [~s for s in range(10)]
    assert info["layout"]["size"] == info["layout"]["contact"] + 25 * 9


def test_pressed_points_are_the_rhs_points_and_move_with_j_u(limbs):
    m = limbs
    info = m.metadata["implicit"]
    nq, nu = m.nq, m.nu
    pressed = set()
    for x in _states(m, 200):
        out, at = implicit_terms_at(m, x)
        o = dict(m.outputs(0.0, x))
        for c, item in enumerate(info["contacts"]):
            e = out[at["contact"] + 25 * c:at["contact"] + 25 * (c + 1)]
            name = item["name"]
            K, C = e[7:16], e[16:25]
            if o[f"Fn_{name}"] > 0:
                pressed.add(name)
                assert e[0] == o[f"depth_{name}"] > 0
                assert np.array_equal(e[1:4], [o[f"px_{name}"], o[f"py_{name}"], o[f"pz_{name}"]])
                J = jacobian(out, at, {**item, "index": c}, nu)
                vp = e[4:7]
                assert np.allclose(J @ x[nq:], vp, rtol=0, atol=1e-12 * (1 + np.abs(vp).max()))
                assert K.any() and C.any()
            elif e[0] != 0:     # the narrow phase ran (the broad phase skips a far pair: all 0)
                assert e[0] == o[f"depth_{name}"]
            if not (o[f"Fn_{name}"] > 0):
                assert not K.any() and not C.any()       # no force, no slope
    assert {"trunk__arm2", "head__hand", "trunk__ball", "arm1__ball"} <= pressed, pressed


def test_slopes_are_the_central_differences_of_the_pair_force(limbs):
    """dF/du = -C J over every speed, and -K n = dF/dε with the ball (B) moved by ε n (its free
    joint's translation: q_joint3_x..z are its world position), at pressed states of the ball's
    pairs (K with the bodies not turning)."""
    m = limbs
    info = m.metadata["implicit"]
    nq, nu = m.nq, m.nu
    names = list(m.state_names)
    ball = [names.index(f"q_joint3_{a}") for a in "xyz"]
    checked = 0
    for x in _states(m, 400):
        out, at = implicit_terms_at(m, x)
        for c, item in enumerate(info["contacts"]):
            name = item["name"]
            fn, _ = _force(m, x, name)
            e = out[at["contact"] + 25 * c:at["contact"] + 25 * (c + 1)]
            if not (name.endswith("__ball") and fn > 1.0 and e[0] > 1e-4):
                continue
            K, C = e[7:16].reshape(3, 3), e[16:25].reshape(3, 3)
            # n: the ball's translation lowers the depth along n (δ's gradient in B's position is -n)
            h = 1e-7
            grad = []
            for k in ball:
                xp, xm = x.copy(), x.copy()
                xp[k] += h
                xm[k] -= h
                grad.append((dict(m.outputs(0.0, xp))[f"depth_{name}"] - dict(m.outputs(0.0, xm))[f"depth_{name}"]) / (2 * h))
            n = -np.array(grad)
            assert abs(np.linalg.norm(n) - 1) < 1e-6
            J = jacobian(out, at, {**item, "index": c}, nu)

            def total(xx):
                f, ft = _force(m, xx, name)
                return f * n + ft          # n does not move with u, nor with B moved along n
            dFdu = _d_by_speeds(total, x, nq, nu, h)
            scale = np.abs(C @ J).max()
            assert np.allclose(dFdu, -C @ J, rtol=0, atol=1e-5 * scale), (name, dFdu, -C @ J)
            # K at fixed v_rel: with the bodies not turning (only the free joints' linear speeds
            # kept: u 0-2, 10-12), v_rel is the same at the moved point (implicitfast leaves that
            # change, J's with q, out: 2e-4 of K here with the speeds turning)
            still = x.copy()
            still[nq + 3:nq + 10] = 0.0
            still[nq + 13:] = 0.0
            K = implicit_terms_at(m, still)[0][at["contact"] + 25 * c + 7:at["contact"] + 25 * c + 16].reshape(3, 3)
            xp, xm = still.copy(), still.copy()
            xp[ball] += h * n
            xm[ball] -= h * n
            dFdn = (total(xp) - total(xm)) / (2 * h)
            assert np.allclose(dFdn, -K @ n, rtol=0, atol=1e-5 * np.abs(K).max()), (name, dFdn, -K @ n)
            checked += 1
        if checked >= 6:
            break
    assert checked >= 6


@pytest.fixture(scope="module")
def humanoid(tmp_path_factory):
    gymnasium = pytest.importorskip("gymnasium")
    from pathlib import Path
    from eomc.compiler.mjcf.model import MjcfModel
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "humanoid.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path), "ps_humanoid", functions=("rhs", "outputs", "implicit"),
                            cache_dir=tmp_path_factory.mktemp("humanoid"), progress=False)


def test_humanoid_pressed_self_pairs(humanoid):
    """gymnasium's humanoid (109 self-pairs, the table) at the pressed states of its fall from qpos0
    (implicitfast, 1 s): each pressed pair point's depth and point are the rhs's, J u its v_rel,
    and dF/du = -C J (n from K's rows, its sign from the depth's rate: δ̇ = -n·v_rel)."""
    m = humanoid
    info = m.metadata["implicit"]
    items = [(c, item) for c, item in enumerate(info["contacts"]) if item.get("pair")]
    assert len(items) == 109
    nq, nu = m.nq, m.nu
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = m.simulate(np.array(m.initial_state, float), (0.0, 1.0), method="implicitfast", dt=0.003,
                         n_points=101)
    checked, pairs_seen = 0, set()
    for x in run.x[::2]:
        out, at = implicit_terms_at(m, x)
        o = dict(m.outputs(0.0, x))
        for c, item in items:
            name = item["name"]
            if not (o[f"Fn_{name}"] > 1.0):
                continue
            e = out[at["contact"] + 25 * c:at["contact"] + 25 * (c + 1)]
            assert e[0] == o[f"depth_{name}"] > 0
            assert np.array_equal(e[1:4], [o[f"px_{name}"], o[f"py_{name}"], o[f"pz_{name}"]])
            J = jacobian(out, at, {**item, "index": c}, nu)
            vp = e[4:7]
            assert np.allclose(J @ x[nq:], vp, rtol=0, atol=1e-12 * (1 + np.abs(vp).max()))
            K, C = e[7:16].reshape(3, 3), e[16:25].reshape(3, 3)
            row = K[np.argmax(np.abs(K).sum(axis=1))]
            n = row / np.linalg.norm(row)
            h = 1e-7
            qd = m.rhs(0.0, x)[:nq]
            xp, xm = x.copy(), x.copy()
            xp[:nq] += h * qd
            xm[:nq] -= h * qd
            rate = (dict(m.outputs(0.0, xp))[f"depth_{name}"] - dict(m.outputs(0.0, xm))[f"depth_{name}"]) / (2 * h)
            if abs(rate) < 1e-3 * (1 + np.abs(vp).max()):
                continue                       # n's sign unknown at a standstill along n
            n *= -np.sign(rate) * np.sign(n @ vp)
            assert abs(n @ vp + rate) <= 1e-5 * (1 + np.abs(vp).max())

            def total(xx):
                f, ft = _force(m, xx, name)
                return f * n + ft
            dFdu = _d_by_speeds(total, x, nq, nu, h)
            assert np.allclose(dFdu, -C @ J, rtol=0, atol=1e-5 * np.abs(C @ J).max()), name
            checked += 1
            pairs_seen.add(name)
    assert checked >= 5 and len(pairs_seen) >= 2, (checked, pairs_seen)
