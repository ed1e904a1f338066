"""The body–body pairs' broad phase (compiler/contact/pairs.pair_clearance, pair_guards): a pair's
narrow phase and law run only when the two shapes' bounding balls meet, each contact point's law
only at depth ≥ 0, and the guarded rhs is the straight-line one at every state (NAME_implicit is
built for ground contacts only).

Why (issue 33): every self-collision pair of a many-geom model (gymnasium's humanoid: 109) ran its
narrow phase at every call, so they were left out by default "for cost"."""
import re
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.compiler.contact.pairs as pairs  # noqa: E402
import eomc.compiler.formulations.recursive as recursive  # noqa: E402
import eomc.compiler.tree.emit as tree_emit  # noqa: E402
from eomc.compiler.contact.pairs import bounding_radius  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel  # noqa: E402


@pytest.fixture(autouse=True)
def _not_the_table(monkeypatch):
    """This module checks the inlined and called narrow phases (and compares the table against
    them): each test starts without pairs.PAIR_TABLE (the default since session 11), and the ones
    about the table set it themselves."""
    monkeypatch.setattr(pairs, "PAIR_TABLE", False)

# a static box (the table), a sphere, a body with a capsule and a sphere off its mass centre, a
# turned box: sphere–sphere, sphere–capsule, sphere–box, capsule–box and box–box (88 points)
XML = """<mujoco model="pg"><worldbody>
<geom name="table" type="box" pos="0 0 -0.05" size="0.4 0.4 0.05"/>
<body name="A" pos="0 0 0.3"><freejoint/><geom name="ball" type="sphere" size="0.1"/></body>
<body name="B" pos="0.25 0 0.3"><freejoint/><geom name="rod" type="capsule" size="0.04 0.1" pos="0.02 0 0"/>
  <geom name="bead" type="sphere" size="0.03" pos="-0.05 0.06 0.01"/></body>
<body name="C" pos="0 0.25 0.3"><freejoint/><geom name="cube" type="box" size="0.06 0.05 0.04" euler="0 0 30"/></body>
</worldbody></mujoco>"""
PAIRS, POINTS = 9, 8 + 88     # the table with four geoms, the ball with three, rod and bead with the cube


def _no_thresholds(program, guards=()):
    """compiler/tree/zero_guards.py off: the straight-line build has no branch at all (a pair's
    choice between its candidate points is a step() that guard would otherwise take)."""
    return program, list(guards)


def _build(tmp_path, tag):
    path = tmp_path / "pg.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # orientation="euler": the states pose the bodies by body-XYZ angles (X[:, 6 b + 3:6 b + 6])
        return eomc.compile(MjcfModel(path, orientation="euler"), functions=("rhs", "outputs"),
                            cache_dir=tmp_path / tag, progress=False, name="pg")


def _functions(tmp_path, tag, function, name="pg"):
    """The C of NAME_function's sub-functions (the split puts guard blocks there too), then its own."""
    source = next((tmp_path / tag).rglob(f"{name}.c")).read_text()
    parts = re.findall(rf"^static \w+ void {name}_{function}_part\d+_\d+\(.*?^}}\n", source, re.M | re.S)
    if function == "implicit" and f"int {name}_implicit_var(" in source:
        function = "implicit_var"   # NAME_implicit = its constant outputs, then this (d6f2a5a)
    start = source.index(f"int {name}_{function}(")
    return parts + [source[start:source.index("\n}\n", start)]]


def _body(tmp_path, tag, function, name="pg"):
    return "".join(_functions(tmp_path, tag, function, name))


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
    monkeypatch.setattr(tree_emit, "with_threshold_guards", _no_thresholds)   # straight: no limit or choice guards
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
    # every point but the table's own sample points (table__cube_0-43: its corners, edges'
    # midpoints and face points, far from where the cube goes)
    far = {f"depth_table__cube_{i}" for i in range(pairs.BOX_POINTS)}
    assert all(p > 0 for name, p in zip(depths, pressed) if name not in far)
    ball_rod = [guarded.outputs(0.0, x)["depth_ball__rod"] for x in sweep[:400]]
    assert ball_rod[0] < -0.05 and ball_rod[-1] > 0



def test_the_implicit_terms_keep_the_pairs_broad_phase(tmp_path, monkeypatch):
    """NAME_implicit (implicitfast's terms) holds the pairs' forces in its forcing f.  Its broad
    phase had the ground contacts' guards only, so every inlined pair's narrow phase ran at every
    call (gymnasium's hopper and its 3 self-pairs: 17 % of the call).  Now it has the rhs's pair
    guards too, and its terms are the straight-line ones near, far and pressed, but for a pair
    point's entries where it is not pressed (its slopes and velocity 0; its depth and point 0 where
    the broad phase skipped the pair)."""
    monkeypatch.setattr(pairs, "INLINE_SLOPES", True)       # the inlined pairs' slopes exported too
    path = tmp_path / "pf.xml"        # the scene above over a floor: NAME_implicit needs ground contacts
    path.write_text(XML.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="2 2 0.1" '
                                               'pos="0 0 -0.6"/>'))

    def build(tag):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # orientation="euler": the states pose the bodies by body-XYZ angles (X[:, 6 b + 3:6 b + 6])
            return eomc.compile(MjcfModel(path, orientation="euler"), functions=("rhs", "outputs", "implicit"),
                                cache_dir=tmp_path / tag, progress=False, name="pf")

    guarded = build("guarded")
    body = _body(tmp_path, "guarded", "implicit", "pf")
    assert body.count("} else {") == _body(tmp_path, "guarded", "rhs", "pf").count("} else {") > PAIRS + POINTS
    plain = recursive.tree_implicit_body
    monkeypatch.setattr(recursive, "tree_implicit_body", lambda ctx, prog, guards, size: plain(ctx, prog, (), size))
    monkeypatch.setattr(tree_emit, "with_threshold_guards", _no_thresholds)   # straight: no limit or choice guards
    straight = build("straight")
    assert "} else {" not in _body(tmp_path, "straight", "implicit", "pf")
    rng = np.random.default_rng(34)
    n = 400
    X = np.zeros((n, guarded.nx))
    centres = np.array([[0, 0, 0.12], [0.15, 0, 0.12], [0, 0.15, 0.12]])
    for b in range(3):       # apart, near and pressed, as above
        X[:, 6 * b:6 * b + 3] = centres[b] + rng.uniform(-0.12, 0.12, (n, 3)) * rng.uniform(0.2, 1.5, (n, 1))
        X[:, 6 * b + 3:6 * b + 6] = rng.uniform(-np.pi, np.pi, (n, 3))
    X[:, guarded.nq:] = rng.normal(size=(n, guarded.nx - guarded.nq))

    def terms(model, x):
        out = np.zeros(model.metadata["implicit"]["layout"]["size"])
        ffi = model.ffi
        fp = ffi.addressof(model.model_lib, "pf_implicit")
        assert fp(0.0, ffi.from_buffer("double[]", x), model._default_p, ffi.NULL,
                  ffi.from_buffer("double[]", out), ffi.NULL) == 0
        return out

    a = np.array([terms(guarded, x) for x in X])
    b = np.array([terms(straight, x) for x in X])
    assert np.all(np.isfinite(b))
    # the pairs' points (after the floor's contacts): where a point is not pressed its slopes and
    # relative velocity are 0 (its depth's guard), and its depth and point are 0 where the pair's
    # broad phase skipped it (NAME_implicit's "not in contact"), else the same
    info = guarded.metadata["implicit"]
    at = info["layout"]["contact"]
    apart = 0
    for c, item in enumerate(info["contacts"]):
        if not item.get("pair"):
            continue
        e = slice(at + 25 * c, at + 25 * (c + 1))
        ea, eb = a[:, e].copy(), b[:, e].copy()
        off = ~(eb[:, 0] > 0)
        assert not ea[off, 4:].any()
        skipped = off & ~ea[:, :4].any(axis=1)
        apart += skipped.sum()
        ea[off, 4:] = eb[off, 4:]
        ea[skipped, :4] = eb[skipped, :4]
        a[:, e], b[:, e] = ea, eb
    assert apart > 0
    assert np.array_equal(a, b)      # 0.0 == -0.0
    pressed = np.array([[guarded.outputs(0.0, x)[k] > 0 for k in guarded.output_names
                         if k.startswith("depth_") and "__" in k] for x in X[:200]])
    assert pressed.any(axis=0).sum() >= 6 and (~pressed).any(axis=0).all()      # pairs pressed and apart


# a planar scene (slide x, slide z, hinge y): the pairs' out-of-plane wrench components are read by
# nothing, so dead-code elimination drops them; table–ball (box–sphere), table–cube (box–box, 88
# points), ball–cube (sphere–box)
PLANAR = """<mujoco model="pl"><worldbody>
<geom name="table" type="box" pos="0 0 -0.05" size="0.4 0.4 0.05"/>
<body name="A" pos="0 0 0.1"><joint name="ax" type="slide" axis="1 0 0"/><joint name="az" type="slide" axis="0 0 1"/>
  <joint name="ay" type="hinge" axis="0 1 0"/><geom name="ball" type="sphere" size="0.05"/></body>
<body name="B" pos="0.15 0 0.1"><joint name="bx" type="slide" axis="1 0 0"/><joint name="bz" type="slide" axis="0 0 1"/>
  <joint name="by" type="hinge" axis="0 1 0"/><geom name="cube" type="box" size="0.06 0.05 0.04"/></body>
</worldbody></mujoco>"""


def _build_planar(tmp_path, tag):
    path = tmp_path / "pl.xml"
    path.write_text(PLANAR)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(path, functions=("rhs", "outputs"), cache_dir=tmp_path / tag, progress=False, name="pl")


def test_a_planar_models_pairs_keep_their_guards(tmp_path, monkeypatch):
    """Before, a pair whose wrench lost a component to dead-code elimination (every pair of a
    planar model: dm_control's stacker, manipulator) was printed straight, its narrow phase run at
    every call (compiler/emit/guards._present).  Inlined and as called routines, each pair and
    each of its points is guarded, and the rhs is the straight-line one."""
    pairs_, points = 3, 1 + 88 + 1
    guarded = _build_planar(tmp_path, "guarded")
    assert _body(tmp_path, "guarded", "rhs", "pl").count("} else {") == pairs_ + points
    monkeypatch.setattr(pairs, "INLINE_NARROW", False)
    called = _build_planar(tmp_path, "called")
    rhs = _body(tmp_path, "called", "rhs", "pl")
    assert rhs.count("} else {") == pairs_ + points
    assert rhs.count("eomc_narrow_") == pairs_ and _unguarded_calls(_functions(tmp_path, "called", "rhs", "pl")) == 0
    monkeypatch.setattr(pairs, "INLINE_NARROW", True)
    plain_rhs = recursive.tree_rhs_body
    monkeypatch.setattr(recursive, "tree_rhs_body", lambda ctx, prog, guards=(): plain_rhs(ctx, prog))
    monkeypatch.setattr(tree_emit, "with_threshold_guards", _no_thresholds)   # straight: no limit or choice guards
    straight = _build_planar(tmp_path, "straight")
    assert "} else {" not in _body(tmp_path, "straight", "rhs", "pl")
    rng = np.random.default_rng(5)
    n = 1500
    X = np.zeros((n, guarded.nx))
    X[:, [0, 1]] = [0.0, 0.06] + rng.uniform(-0.15, 0.15, (n, 2)) * rng.uniform(0.2, 1.5, (n, 1))
    X[:, [3, 4]] = [0.1, 0.06] + rng.uniform(-0.15, 0.15, (n, 2)) * rng.uniform(0.2, 1.5, (n, 1))
    X[:, [2, 5]] = rng.uniform(-np.pi, np.pi, (n, 2))
    X[:, guarded.nq:] = rng.normal(size=(n, guarded.nx - guarded.nq))
    depths = [k for k in guarded.output_names if k.startswith("depth_")]
    out = np.array([[guarded.outputs(0.0, x)[k] for k in depths] for x in X])
    X = X[out.max(axis=1) < 0.01]          # no point deeper (a centre inside a box has no direction)
    assert len(X) > 300
    a, b, c = guarded.rhs_many(0.0, X), straight.rhs_many(0.0, X), called.rhs_many(0.0, X)
    assert np.all(np.isfinite(b))
    assert np.array_equal(a, b)
    assert np.abs(c - b).max() <= 1e-12 * (1 + np.abs(b).max())
    # the states did cover each case: each pair pressed somewhere, apart elsewhere
    out = np.array([[guarded.outputs(0.0, x)[k] for k in depths] for x in X])
    for pair in ("table__ball", "table__cube", "ball__cube"):
        cols = [i for i, k in enumerate(depths) if k.startswith(f"depth_{pair}")]
        assert (out[:, cols].max(axis=1) > 0).any() and (out[:, cols].max(axis=1) < -0.05).any(), pair


def _unguarded_calls(texts):
    """How many narrow-phase calls (compiler/contact/narrow.py) run outside every ``if`` block of a
    function: ``texts``, the function and its sub-functions (compiler/emit/split.py), each from its
    head on.  A sub-function called inside a block runs under that block's guard: only the calls
    outside every block of the function, and of the sub-functions it calls outside every block,
    count."""
    bodies = {}
    for text in texts:
        head = text[:text.index("\n{\n")].rsplit("\n", 1)[-1]
        bodies[re.search(r"(\w+)\(", head).group(1)] = text[text.index("\n{\n") + 3:]
    called = {n for n in bodies for body in bodies.values() if re.search(rf"\b{n}\(", body)}
    todo, seen, count = [n for n in bodies if n not in called], set(), 0
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        depth = 0
        for line in bodies[name].split("\n"):
            if depth == 0:
                count += line.count("eomc_narrow_")
                todo += [n for n in bodies if re.search(rf"\b{n}\(", line)]
            depth += line.count("{") - line.count("}")
    return count


@pytest.mark.slow
@pytest.mark.parametrize("name", ["stacker", "manipulator"])
def test_dm_control_pairs_run_their_narrow_phase_only_inside_their_guards(name, monkeypatch):
    """Generated, not compiled: with the narrow phase as called routines, each of dm_control's
    stacker's and manipulator's pair calls in the rhs sits inside its pair's broad-phase guard
    (before: stacker 0 of 62, manipulator 0 of 185)."""
    dm_control = pytest.importorskip("dm_control")
    from pathlib import Path
    from eomc.compiler.driver import generate
    monkeypatch.setattr(pairs, "INLINE_NARROW", False)
    path = Path(dm_control.__file__).parent / "suite" / f"{name}.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, generated = generate(path, "m", functions=("rhs",), use_cache=False, progress=False)
    # the rhs and its sub-functions (compiler/emit/split.py), each on its own
    rhs = [d for d in generated.c_source.split("\n}\n") if " m_rhs(" in d or " m_rhs_part" in d]
    calls = sum(d.count("eomc_narrow_") for d in rhs)
    assert calls > 50
    assert _unguarded_calls(rhs) == 0
    assert sum(d.count("} else {") for d in rhs) >= calls
