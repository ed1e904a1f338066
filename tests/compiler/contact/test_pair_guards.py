"""The body–body pairs' broad phase (compiler/contact/pairs.pair_clearance, pair_guards): a pair's
narrow phase and law run only when the two shapes' bounding balls meet, each contact point's law
only at depth ≥ 0, and the guarded rhs is the straight-line one at every state (NAME_implicit is
built for ground contacts only).

Why (issue 33): every self-collision pair of a many-geom model (gymnasium's humanoid: 109) ran its
narrow phase at every call, so they were left out by default "for cost"."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.compiler.formulations.recursive as recursive  # noqa: E402
from eomc.compiler.contact.pairs import bounding_radius  # noqa: E402

# a static box (the table), a sphere, a body with a capsule and a sphere off its mass centre, a
# turned box: sphere–sphere, sphere–capsule, sphere–box, capsule–box and box–box (16 corners)
XML = """<mujoco model="pg"><worldbody>
<geom name="table" type="box" pos="0 0 -0.05" size="0.4 0.4 0.05"/>
<body name="A" pos="0 0 0.3"><freejoint/><geom name="ball" type="sphere" size="0.1"/></body>
<body name="B" pos="0.25 0 0.3"><freejoint/><geom name="rod" type="capsule" size="0.04 0.1" pos="0.02 0 0"/>
  <geom name="bead" type="sphere" size="0.03" pos="-0.05 0.06 0.01"/></body>
<body name="C" pos="0 0.25 0.3"><freejoint/><geom name="cube" type="box" size="0.06 0.05 0.04" euler="0 0 30"/></body>
</worldbody></mujoco>"""
PAIRS, POINTS = 9, 8 + 16     # the table with four geoms, the ball with three, rod and bead with the cube


def _build(tmp_path, tag):
    path = tmp_path / "pg.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(path, functions=("rhs", "outputs"), cache_dir=tmp_path / tag,
                            progress=False, name="pg")


def _body(tmp_path, tag, function):
    source = next((tmp_path / tag).rglob("pg.c")).read_text()
    start = source.index(f"int pg_{function}(")
    return source[start:source.index("\n}\n", start)]


def test_bounding_radii_hold_the_shapes():
    rng = np.random.default_rng(0)
    for kind, size in (("sphere", (0.1,)), ("capsule", (0.04, 0.1)), ("box", (0.06, 0.05, 0.04)),
                       ("cylinder", (0.08, 0.1)), ("ellipsoid", (0.03, 0.07, 0.05))):
        u = rng.uniform(-1, 1, size=(20000, 3))
        if kind == "box":
            pts = u * size
        elif kind == "ellipsoid":
            pts = u / np.maximum(1.0, np.linalg.norm(u, axis=1))[:, None] * size
        elif kind == "cylinder":
            pts = np.c_[u[:, :2] / np.maximum(1.0, np.linalg.norm(u[:, :2], axis=1))[:, None] * size[0], u[:, 2] * size[1]]
        elif kind == "capsule":
            pts = np.c_[u[:, :2] * 0, u[:, 2] * size[1]] + u / np.maximum(1.0, np.linalg.norm(u, axis=1))[:, None] * size[0]
        else:
            pts = u / np.maximum(1.0, np.linalg.norm(u, axis=1))[:, None] * size[0]
        reach = np.linalg.norm(pts, axis=1).max()
        assert reach <= bounding_radius(kind, size) + 1e-15
        assert reach >= 0.8 * bounding_radius(kind, size)       # and not far beyond


def test_guarded_pairs_are_the_straight_line_pairs_near_far_and_pressed(tmp_path, monkeypatch):
    guarded = _build(tmp_path, "guarded")
    depths = [n for n in guarded.output_names if n.startswith("depth_")]
    assert len(depths) == POINTS
    # one block per pair, one per contact point inside it
    assert _body(tmp_path, "guarded", "rhs").count("} else {") == PAIRS + POINTS
    plain_rhs = recursive.tree_rhs_body
    monkeypatch.setattr(recursive, "tree_rhs_body", lambda ctx, prog, guards=(): plain_rhs(ctx, prog))
    straight = _build(tmp_path, "straight")
    assert "} else {" not in _body(tmp_path, "straight", "rhs")
    rng = np.random.default_rng(33)
    n = 600
    X = np.zeros((n, guarded.nx))
    centres = np.array([[0, 0, 0.12], [0.15, 0, 0.12], [0, 0.15, 0.12]])
    for b in range(3):       # scattered about a cluster: apart, near and pressed, some into the table
        X[:, 6 * b:6 * b + 3] = centres[b] + rng.uniform(-0.12, 0.12, (n, 3)) * rng.uniform(0.2, 1.5, (n, 1))
        X[:, 6 * b + 3:6 * b + 6] = rng.uniform(-np.pi, np.pi, (n, 3))
    X[:, guarded.nq:] = rng.normal(size=(n, guarded.nx - guarded.nq))
    # and a sweep of the ball towards the rod along x, through the bounds (0.1 + 0.02 + 0.14 m)
    sweep = np.repeat(X[:3], 400, axis=0)
    sweep[:, :3] = [0.0, 0.0, 0.6]
    sweep[:, 6:9] = [0.0, 0.0, 0.6]
    sweep[:, 0] = np.tile(np.linspace(-0.4, -0.05, 400), 3)
    for states in (X, sweep):
        a, b = guarded.rhs_many(0.0, states), straight.rhs_many(0.0, states)
        assert np.all(np.isfinite(b))
        assert np.array_equal(a, b)            # 0.0 == -0.0: equal but for the sign of a zero
    # the states did cover each case: every contact point pressed somewhere, apart elsewhere
    out = np.array([[guarded.outputs(0.0, x)[k] for k in depths] for x in X[:300]])
    pressed = (out > 0).mean(axis=0)
    assert pressed.max() > 0.2 and (out < -0.05).any(axis=0).all()
    # every point but the table's own corners (table__cube_0-7, far from where the cube goes)
    far = {f"depth_table__cube_{i}" for i in range(8)}
    assert all(p > 0 for name, p in zip(depths, pressed) if name not in far)
    ball_rod = [guarded.outputs(0.0, x)["depth_ball__rod"] for x in sweep[:400]]
    assert ball_rod[0] < -0.05 and ball_rod[-1] > 0
