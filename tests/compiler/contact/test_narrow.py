"""The body–body pairs' narrow phase as called C routines (compiler/contact/narrow.py): rhs, jac_x
and the outputs equal the schemes inlined as SymPy (pairs.INLINE_NARROW, what the generated code
is by default) to 1e-12 at random states -- near, apart and pressed -- for every kind of pair the routines
serve here: sphere–sphere, sphere–capsule, sphere–box, capsule–box, box–box (88 points),
box–cylinder (25), sphere–cylinder and sphere–ellipsoid; jac_x's tangent through the routines'
forward-mode derivative.

Why (issue 33): inlined, each pair was generated, differentiated and compiled on its own (the
humanoid's self-pairs: 28.9 s CPU to build the rhs; dm_control's stacker ~103 s)."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.compiler.contact.pairs as pairs  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel  # noqa: E402


@pytest.fixture(autouse=True)
def _not_the_table(monkeypatch):
    """This module checks the inlined and called narrow phases (and compares the table against
    them): each test starts without pairs.PAIR_TABLE (the default since session 11), and the ones
    about the table set it themselves, for any number of pairs: TABLE_FROM 1)."""
    monkeypatch.setattr(pairs, "PAIR_TABLE", False)
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)

# a static box (the table), a turned box, a ball: box–box (88 points) and sphere–box (the kinds
# with a cylinder are compiled and checked against the signed distances in test_solid_pairs_built)
XML = """<mujoco model="nw"><worldbody>
<geom name="table" type="box" pos="0 0 -0.05" size="0.4 0.4 0.05"/>
<body name="C" pos="0 0 0.1"><freejoint/><geom name="cube" type="box" size="0.06 0.05 0.04" euler="0 0 30"/></body>
<body name="A" pos="0 0.15 0.1"><freejoint/><geom name="ball" type="sphere" size="0.05"/></body>
</worldbody></mujoco>"""
KINDS = {("box", "box"), ("sphere", "box")}
SHALLOW = 0.01      # m: states compared have no point deeper (deeper, a centre inside a box has no direction)


def _build(tmp_path, tag, functions=("rhs", "jac_x", "outputs")):
    path = tmp_path / "nw.xml"
    path.write_text(XML)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # orientation="euler": _states poses the bodies by body-XYZ angles (X[:, 3:6], X[:, 9:12]),
        # and the C text asserted (jac_x's sizes 24, 12) is this layout's
        return eomc.compile(MjcfModel(path, orientation="euler"), functions=functions, cache_dir=tmp_path / tag,
                            progress=False, name="nw")


FOUR = ("rhs", "jac_x", "jac_p", "outputs")


@pytest.fixture(scope="module")
def inline4(tmp_path_factory):
    """The schemes inlined, with rhs, jac_x, jac_p and outputs: the oracle of the law routines and
    of the pair table, built once for both (the same C: 3.3 MB, ~45 s CPU to generate and compile)."""
    patch = pytest.MonkeyPatch()
    for name, value in (("PAIR_TABLE", False), ("TABLE_FROM", 1), ("LAW_ROUTINES", False), ("INLINE_NARROW", True)):
        patch.setattr(pairs, name, value)
    try:
        yield _build(tmp_path_factory.mktemp("inline4"), "inline", FOUR)
    finally:
        patch.undo()


def _states(model, n, rng):
    X = np.zeros((n, model.nx))
    X[:, 0:3] = [0.0, 0.0, 0.04] + rng.uniform(-0.08, 0.08, (n, 3))
    X[:, 6:9] = [0.0, 0.08, 0.06] + rng.uniform(-0.08, 0.08, (n, 3))
    for b in (3, 9):
        X[:, b:b + 3] = rng.uniform(-np.pi, np.pi, (n, 3))
    X[:, model.nq:] = rng.normal(size=(n, model.nx - model.nq))
    return X


def _function(source, name):
    """The C text of function ``name`` and its sub-functions (``name_part...``, compiler/emit/split.py)."""
    found = [d for d in source.split("\n}\n") if f" {name}(" in d or f" {name}_part" in d]
    assert found, name
    return "\n".join(found)


def test_called_routines_are_the_inlined_schemes(tmp_path, monkeypatch):
    monkeypatch.setattr(pairs, "INLINE_NARROW", False)
    called = _build(tmp_path, "called")
    source = next((tmp_path / "called").rglob("nw.c")).read_text()
    for a, b in KINDS:          # every kind through its routine, with jac_x's derivative
        assert f"eomc_narrow_{a}_{b}(" in source or f"eomc_narrow_{b}_{a}(" in source, (a, b)
        assert f"eomc_narrow_{a}_{b}_dot(" in source or f"eomc_narrow_{b}_{a}_dot(" in source, (a, b)
    # jac_x runs the narrow phase once, writing the tape its columns' _dot calls read; rhs writes none
    rhs, jac = _function(source, "nw_rhs"), _function(source, "nw_jac_x")
    assert "_tape(" not in rhs and "eomc_narrow_box_box(" in rhs
    assert "eomc_narrow_box_box(" not in jac and jac.count("eomc_narrow_box_box_tape(") == 1
    assert "eomc_narrow_box_box_dot(&NP" in jac
    monkeypatch.setattr(pairs, "INLINE_NARROW", True)
    inline = _build(tmp_path, "inline")
    assert "eomc_narrow_" not in next((tmp_path / "inline").rglob("nw.c")).read_text()
    _agree(called, inline)


def test_law_routines_are_the_inlined_schemes(tmp_path, monkeypatch, inline4):
    """pairs.LAW_ROUTINES: each pair's narrow routine, then per contact point the law routine
    (the law and both bodies' wrenches; the table is a world geom: its body inputs are 0, its
    wrench is dropped) inside the point's depth guard; rhs, jac_x (through the routines'
    tangents), jac_p (the law's parameters are its inputs) and outputs equal the inlined schemes'."""
    monkeypatch.setattr(pairs, "LAW_ROUTINES", True)
    called = _build(tmp_path, "law", FOUR)
    source = next((tmp_path / "law").rglob("nw.c")).read_text()
    rhs, jac = _function(source, "nw_rhs"), _function(source, "nw_jac_x")
    for a, b in KINDS:
        assert f"eomc_narrow_{a}_{b}(" in rhs or f"eomc_narrow_{b}_{a}(" in rhs, (a, b)
        assert f"eomc_narrow_{a}_{b}_dot(" in jac or f"eomc_narrow_{b}_{a}_dot(" in jac, (a, b)
    points = len([k for k in called.output_names if k.startswith("depth_")])
    assert rhs.count("eomc_pair_law(") == points and "eomc_pair_law_dot(" in jac
    # each law call sits in its point's depth guard: the nearest enclosing test is on -depth
    for piece in rhs.split("eomc_pair_law(")[:-1]:
        assert piece[piece.rindex("if ("):].startswith("if (!(-t"), piece[piece.rindex("if ("):][:80]
    assert "_tape(" not in rhs and jac.count("eomc_narrow_box_box_tape(") == 1
    _agree_jac_p(called, inline4, _agree(called, inline4))


def _agree_jac_p(called, inline, X):
    """Assert ``called``'s jac_p equals ``inline``'s (not all zero) at the first 50 of states X."""
    for x in X[:50]:
        ja, jb = called.jac_p(0.0, x), inline.jac_p(0.0, x)
        assert np.all(np.isfinite(jb)) and np.abs(jb).max() > 0
        assert np.abs(ja - jb).max() <= 1e-12 * (1 + np.abs(jb).max())


def _agree(called, inline, bounded=False):
    """Assert ``called``'s rhs, outputs and jac_x equal ``inline``'s at random states, near, apart
    and pressed (every point pressed somewhere); return the states.  ``bounded``: ``called`` is the
    pair table, whose outputs give a pair its broad phase skips the bounds :func:`_outputs_agree` checks."""
    names = list(inline.output_names)
    assert names == list(called.output_names)
    depths = [names.index(k) for k in names if k.startswith("depth_")]
    X = _states(called, 1500, np.random.default_rng(8))
    out = np.array([list(inline.outputs(0.0, x).values()) for x in X])
    keep = out[:, depths].max(axis=1) < SHALLOW
    X, out = X[keep], out[keep]
    assert len(X) >= 100
    pressed = (out[:, depths] > 0).mean(axis=0)
    # every point pressed in some state (and apart in others) but the table's own sample points
    # (table__cube_0-43: its corners, edges' midpoints and face points, far from where the cube goes)
    # and the cube's edges' midpoints and face points (table__cube_52-87: pressed only with an edge
    # or a face nearly flat on the table, which these random turns rarely make shallow -- 3 of 12
    # midpoints and 12 of 24 face points never in the 187 states; the routine computes them as it
    # does the corners, with other constants, and test_pair_guards' states press each of them)
    far = {names.index(f"depth_table__cube_{i}") for i in range(pairs.BOX_POINTS)}
    far |= {names.index(f"depth_table__cube_{pairs.BOX_POINTS + i}") for i in range(8, pairs.BOX_POINTS)}
    assert all(p > 0 for i, p in zip(depths, pressed) if i not in far) and pressed.max() < 1, [(names[i], p) for i, p in zip(depths, pressed)]
    a, b = called.rhs_many(0.0, X), inline.rhs_many(0.0, X)
    assert np.all(np.isfinite(b))
    assert np.abs(a - b).max() <= 1e-12 * (1 + np.abs(b).max())
    skipped = 0
    for x, ob in zip(X[:100], out):
        oa = np.array(list(called.outputs(0.0, x).values()))
        skipped += _outputs_agree(oa, ob, names, bounded)
        ja, jb = called.jac_x(0.0, x), inline.jac_x(0.0, x)
        assert np.all(np.isfinite(jb))
        assert np.abs(ja - jb).max() <= 1e-12 * (1 + np.abs(jb).max())
    assert skipped > 0 if bounded else skipped == 0
    return X


POINT_OUTPUTS = ("Fn_", "Ftx_", "Fty_", "Ftz_", "depth_", "px_", "py_", "pz_")


def _outputs_agree(oa, ob, names, bounded):
    """Assert the outputs ``oa`` equal ``ob`` (the inlined pairs', exact) to 1e-12 but, when
    ``bounded``, a pair point's outputs where the table skipped its pair (compiler/contact/table.py:
    full = 2): its forces still equal (0: apart), its depth the bounding balls' bound, at most
    -BROAD_PAD and at least the exact depth, its point finite; return how many points were skipped."""
    tol = 1e-12 * (1 + np.abs(ob).max())
    close = np.abs(oa - ob) <= tol
    if not bounded:
        assert close.all(), [names[i] for i in np.flatnonzero(~close)]
        return 0
    label = {i: next((n[len(k):] for k in POINT_OUTPUTS if n.startswith(k)), None) for i, n in enumerate(names)}
    assert all(close[i] for i in range(len(names)) if label[i] is None or "__" not in label[i])
    skipped = 0
    for point in {v for v in label.values() if v and "__" in v}:
        col = {k: names.index(k + point) for k in POINT_OUTPUTS}
        if all(close[i] for i in col.values()):
            continue
        skipped += 1
        assert all(close[col[k]] and oa[col[k]] == 0 for k in ("Fn_", "Ftx_", "Fty_", "Ftz_")), point
        assert ob[col["depth_"]] - tol <= oa[col["depth_"]] <= -pairs.BROAD_PAD, point
        assert all(np.isfinite(oa[col[k]]) for k in ("px_", "py_", "pz_")), point
    return skipped


def test_pair_table_is_the_inlined_schemes(tmp_path, monkeypatch, inline4):
    """pairs.PAIR_TABLE: every pair in one call of the table-driven loop (compiler/contact/table.py:
    the kinds' narrow routines and the law routine called from a loop over static tables); rhs,
    outputs (the loop's full = 1 variant: every point, exact), jac_x and jac_p (the loop's
    tangent twin) equal the inlined schemes'."""
    monkeypatch.setattr(pairs, "PAIR_TABLE", True)
    called = _build(tmp_path, "table", FOUR)
    source = next((tmp_path / "table").rglob("nw.c")).read_text()
    rhs, jac = _function(source, "nw_rhs"), _function(source, "nw_jac_x")
    assert rhs.count("eomc_pairs(") == 1 and "eomc_narrow_box_box(" not in rhs and "eomc_pair_law(" not in rhs
    assert ", 0, &PT_[0])" in rhs                         # the rhs skips far pairs and points
    # jac_x tapes the call; its analytic kernel, handed the tape, calls the twin per column
    assert "eomc_pairs_tape(" in jac and "_rnea_derivs(an, u, ud, out, 24, 12, -1.0, 1, &PT_[" in jac
    assert "eomc_pairs_dot(pt, din, 0, 0, dw);" in source
    assert ", 1, &PT_[0])" in _function(source, "nw_outputs")     # outputs: every point, exact
    _agree_jac_p(called, inline4, _agree(called, inline4))


# a chain's limbs (one tree: self-pairs, pairs=True) and a free ball: capsule–capsule, sphere–capsule,
# capsule–sphere and sphere–sphere pairs, as gymnasium's humanoid has them, several per kind
LIMBS = """<mujoco model="limbs"><worldbody>
<body name="base" pos="0 0 0.3"><freejoint/><geom name="trunk" type="capsule" fromto="-0.1 0 0 0.1 0 0" size="0.04"/>
 <geom name="head" type="sphere" pos="0.15 0 0" size="0.04"/>
 <body name="l1" pos="0.1 0 0"><joint name="j1" type="ball"/><geom name="arm1" type="capsule" fromto="0 0 0 0.1 0.1 0" size="0.03"/>
  <body name="l2" pos="0.1 0.1 0"><joint name="j2" type="hinge" axis="0 0 1"/><geom name="arm2" type="capsule" fromto="0 0 0 -0.15 0 0" size="0.03"/>
   <geom name="hand" type="sphere" pos="-0.15 0 0" size="0.035"/></body></body></body>
<body name="ball" pos="0 0.1 0.3"><freejoint/><geom name="ball" type="sphere" size="0.05"/></body>
</worldbody></mujoco>"""


def _limbs(tmp_path, monkeypatch, functions):
    """The limbs model built with the pairs' table and with the pairs inlined."""
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path / "limbs.xml"
    path.write_text(LIMBS)
    built = {}
    for table in (True, False):
        monkeypatch.setattr(pairs, "PAIR_TABLE", table)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            built[table] = eomc.compile(MjcfModel(path, pairs=True), "limbs", functions=functions,
                                        cache_dir=tmp_path / str(table), progress=False)
    return built[True], built[False]


def test_pair_table_on_limbs(tmp_path, monkeypatch):
    """The table-driven loop on a tree's self-pairs (capsules and spheres, several pairs per kind,
    the humanoid's kinds): rhs and jac_x equal the inlined pairs' at random poses, some pressed,
    some apart; outputs exactly; events too, but for the pairs the broad phase skips (full = 2), whose
    contact event is bounded (-BROAD_PAD or below, at least the exact depth) and
    whose clip event is at least BROAD_PAD and at most the exact one: each on its exact value's
    side, outside the runtime's noise band."""
    called, inline = _limbs(tmp_path, monkeypatch, ("rhs", "jac_x", "outputs", "events"))
    # the default (quaternion) build's jac_x takes the taped path as the Euler build's does
    # (test_pair_table_is_the_inlined_schemes): it tapes the table call, and its analytic kernel
    # reads the tape and calls the twin per column (benchmarks/results/orientation_derivatives.md)
    assert called.quaternions
    source = next((tmp_path / "True").rglob("limbs.c")).read_text()
    jac = _function(source, "limbs_jac_x")
    assert "eomc_pairs_tape(" in jac and "eomc_pairs(" not in jac, jac[:2000]
    assert f"_rnea_derivs(an, u, ud, out, {called.nx}, {called.nq}, -1.0, 1, &PT_[" in jac
    assert "eomc_pairs_dot(pt, din, 0, 0, dw);" in source
    names = list(inline.output_names)
    assert names == list(called.output_names)
    self_pairs = [i for i, k in enumerate(names) if k.startswith("Fn_") and "__" in k]
    assert len(self_pairs) >= 6
    rng = np.random.default_rng(5)
    X = rng.normal(scale=0.6, size=(400, called.nx))
    X[:, 2] += 0.3
    for w in called.quaternions:        # random orientations: each quaternion (the MJCF default) unit
        X[:, w:w + 4] /= np.linalg.norm(X[:, w:w + 4], axis=1, keepdims=True)
    a, b = called.rhs_many(0.0, X), inline.rhs_many(0.0, X)
    assert np.all(np.isfinite(b))
    assert np.abs(a - b).max() <= 1e-12 * (1 + np.abs(b).max())
    events = [d["name"] for d in called.metadata["events"]]
    assert events == [d["name"] for d in inline.metadata["events"]]
    pressed = skipped = exact = 0
    for x in X[:150]:
        oa, ob = (np.array(list(m.outputs(0.0, x).values())) for m in (called, inline))
        _outputs_agree(oa, ob, names, False)      # outputs: exact (the table without skips, full = 1)
        pressed += np.count_nonzero(ob[self_pairs] > 0)
        ja, jb = called.jac_x(0.0, x), inline.jac_x(0.0, x)
        assert np.abs(ja - jb).max() <= 1e-12 * (1 + np.abs(jb).max())
        ea, eb = _events(called, x), _events(inline, x)
        tol = 1e-12 * (1 + np.abs(eb).max())
        for i, name in enumerate(events):
            if abs(ea[i] - eb[i]) <= tol:
                exact += "__" in name
                continue
            assert "__" in name, name          # ground contacts and limits: never bounded
            skipped += 1
            if name.startswith("contact_"):
                assert eb[i] - tol <= ea[i] <= -pairs.BROAD_PAD, (name, ea[i], eb[i])
            else:
                assert name.startswith("clip_") and pairs.BROAD_PAD <= ea[i] <= eb[i] + tol, (name, ea[i], eb[i])
    assert 20 <= pressed < 150 * len(self_pairs) / 2, pressed      # pressed and apart both met
    assert skipped > 100 and exact > 100, (skipped, exact)          # both branches of the events met


def _events(model, x):
    """The model's compiled event functions at state ``x`` (its C ``NAME_events``)."""
    ffi = model.ffi
    n = len(model.metadata["events"])
    out = np.empty(n)
    work = np.empty(int(model.c_model.work_size) + 1)
    fn = getattr(model.model_lib, f"{model.name}_events")
    status = fn(0.0, ffi.from_buffer("double[]", np.ascontiguousarray(x, dtype=float)),
                ffi.from_buffer("double[]", np.asarray(model.param_defaults, dtype=float)),
                ffi.new("double[1]"), ffi.from_buffer("double[]", out), ffi.from_buffer("double[]", work))
    assert status == 0
    return out


def test_pair_table_tapes_past_their_room(tmp_path, monkeypatch):
    """jac_x's taped call keeps the narrow and law tapes of the pairs in contact while
    table.TAPE_ROOM has room and flags the others, whose tangents re-run their routines: with
    room for one pair's tapes, at states with several pairs pressed, jac_x still equals the
    inlined pairs' (and the kernel's zero columns: at states with none pressed too)."""
    from eomc.compiler.contact import table
    monkeypatch.setattr(table, "TAPE_ROOM", 130)        # one pair: 125 (capsules) .. 107 (spheres) each
    called, inline = _limbs(tmp_path, monkeypatch, ("jac_x", "outputs"))
    source = next((tmp_path / "True").rglob("limbs.c")).read_text()
    assert "used + 125 <= 130" in source
    names = list(inline.output_names)
    self_pairs = [i for i, k in enumerate(names) if k.startswith("Fn_") and "__" in k]
    rng = np.random.default_rng(11)
    X = rng.normal(scale=0.6, size=(300, called.nx))
    X[:, 2] += 0.3
    seen = {0: 0, 1: 0, 2: 0}
    for x in X:
        n = np.count_nonzero(np.array(list(inline.outputs(0.0, x).values()))[self_pairs] > 0)
        seen[min(n, 2)] += 1
        ja, jb = called.jac_x(0.0, x), inline.jac_x(0.0, x)
        assert np.all(np.isfinite(jb))
        assert np.abs(ja - jb).max() <= 1e-12 * (1 + np.abs(jb).max())
    assert min(seen.values()) >= 10, seen
