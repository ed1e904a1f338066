"""The rhs's broad phase (compiler/emit/guards.py, bounds from compiler/tree/contacts.body_guards):
a body's contact block runs only when its bounding sphere can reach the ground, and the rhs is
the straight-line rhs wherever that holds or not.

Why (issues 29, 33): the default ground of a URDF robot has 108-232 contact points and the
straight-line code evaluated every one at every call (rhs 2.5-2.8x the feet-only rhs)."""
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.compiler.formulations.recursive as recursive
import eomc.compiler.tree.emit as tree_emit
from eomc.compiler.emit.guards import guarded_temps
from eomc.compiler.emit.printer import CPrinter
from eomc.compiler.ir import Program
from eomc.compiler.urdf.model import UrdfModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "urdf"))
from test_default_ground import FOOT, ONE_LEG  # noqa: E402


def _program():
    x = sm.symbols("x0:3", real=True)
    t = sm.symbols("_t0:7", real=True)
    assignments = [(t[0], sm.cos(x[0])),            # shared: read by the block and by the result
                   (t[5], x[2] + 1),                # a clearance's input
                   (t[1], x[1] * t[0]),             # the block's own
                   (t[2], sm.sqrt(t[1] ** 2 + 1)),   # the block's own
                   (t[3], t[2] * t[1]),             # export
                   (t[4], t[3] + t[0]),             # outside reader of the export
                   (t[6], t[5] * 2)]                # read by nothing but the result
    program = Program(inputs=x, assignments=tuple(assignments), results=((("ud", 0), t[4] + t[6]),))
    names = {s: f"x[{i}]" for i, s in enumerate(x)}
    names.update({s: f"t{i}" for i, s in enumerate(t)})
    return program, t, CPrinter(names)


def test_a_block_holds_only_what_its_exports_need_and_zeroes_them_when_skipped():
    program, t, pr = _program()
    lines, pr2 = guarded_temps(program, pr, [(t[5] - 3, (t[3],), ())])
    text = "\n".join(lines)
    assert lines[0].strip() == "double G_[1];"
    start, other = text.index("if (!(-3.0 + t5 > 0.0)) {"), text.index("} else {")
    block = text[start:other]
    assert "t1 = " in block and "t2 = " in block and "G_[0] = " in block
    assert "t0 = " not in block                 # also read outside: computed before the block
    assert text.index("const double t0") < start and text.index("const double t5") < start
    assert "G_[0] = 0.0;" in text[other:]
    assert text.index("const double t4 = t0 + G_[0];") > other
    assert pr2.doprint(t[3]) == "G_[0]"


def test_a_guard_the_program_cannot_honour_is_printed_straight():
    program, t, pr = _program()
    gone = sm.Symbol("_t99", real=True)        # a clearance reading a dropped temporary
    lines, _ = guarded_temps(program, pr, [(gone - 1, (t[3],), ())])
    assert not any("if (" in line for line in lines)
    lines, _ = guarded_temps(program, pr, [(t[6], (t[3],), ())])    # its clearance comes after the export's reader
    assert not any("if (" in line for line in lines)


def test_an_export_the_passes_dropped_leaves_the_guard_to_the_others():
    """An export no assignment defines (dead-code elimination removed it: nothing read it) is
    left out; the guard holds with the exports that remain, and a guard left with none is
    printed straight.  Before, one missing export printed the whole block straight (every pair
    of a planar model)."""
    program, t, pr = _program()
    gone = sm.Symbol("_t99", real=True)
    lines, _ = guarded_temps(program, pr, [(t[5] - 3, (gone, t[3]), ((-t[2], (gone, t[3]), ()),))])
    text = "\n".join(lines)
    assert lines[0].strip() == "double G_[1];"
    assert text.count("} else {") == 2 and "G_[0] = 0.0;" in text
    lines, _ = guarded_temps(program, pr, [(t[5] - 3, (gone,), ())])
    assert not any("if (" in line for line in lines)


def _build(tmp_path, tag):
    path = tmp_path / "oneleg.urdf"
    path.write_text(ONE_LEG)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(path, floating_base=True, contacts=(FOOT,)),
                            functions=("rhs", "outputs", "implicit"), cache_dir=tmp_path / tag, progress=False,
                            name="oneleg")


@pytest.fixture(scope="module")
def oneleg(tmp_path_factory):
    """(guarded, straight, their cache dir): the one-leg robot built as the compiler builds it,
    and with the rhs's and NAME_implicit's straight-line bodies (no broad phase, no limit guards).  One pair of
    builds serves both tests below (each read only its own function: rhs, or implicit), where
    each test built its own pair (4 builds -> 2)."""
    tmp = tmp_path_factory.mktemp("guards")
    guarded = _build(tmp, "guarded")
    plain_rhs = recursive.tree_rhs_body
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(recursive, "tree_rhs_body", lambda ctx, prog, guards=(): plain_rhs(ctx, prog))
        mp.setattr(tree_emit, "with_threshold_guards", lambda program, guards=(): (program, list(guards)))
        mp.setattr(recursive, "tree_implicit_body", lambda ctx, prog, guards, size:
                   recursive.plain_body(ctx, prog, "imp", (size,), "out"))
        straight = _build(tmp, "straight")
    return guarded, straight, tmp


def _with_parts(source, function, start):
    """The C of the function starting at ``start`` with the sub-functions of ``function`` (the
    split puts the guard blocks there too)."""
    parts = re.findall(rf"^static \w+ void oneleg_{function}_part\d+_\d+\(.*?^}}\n", source, re.M | re.S)
    return "".join(parts) + source[start:source.index("\n}\n", start)]


def _rhs_text(cache):
    source = next(cache.rglob("oneleg.c")).read_text()
    return _with_parts(source, "rhs", source.index("int oneleg_rhs("))


def test_the_guarded_rhs_is_the_straight_line_rhs_near_and_far_from_the_ground(oneleg):
    guarded, straight, tmp_path = oneleg
    # one block per body (the trunk's 8 corners; the leg's foot and far end), one per point inside
    points = sum(n.startswith("depth_") for n in guarded.output_names)
    assert points == 13
    # and one per side of the hip's limit (compiler/tree/zero_guards.py)
    assert _rhs_text(tmp_path / "guarded").count("} else {") == 2 + points + 2
    assert "} else {" not in _rhs_text(tmp_path / "straight")
    rng = np.random.default_rng(33)
    z = guarded.state_names.index("q_trunk_floating_z")
    X = rng.normal(scale=1.0, size=(2000, guarded.nx))
    X[:, z] = rng.uniform(-0.1, 0.8, size=len(X))
    # and a sweep of the height through the bound: the trunk's sphere (|corner| = 0.229 m)
    # and the leg's reach the plane at every height in between, on both sides of each bound
    sweep = np.repeat(X[:4], 1500, axis=0)
    sweep[:, z] = np.tile(np.linspace(-0.05, 0.75, 1500), 4)
    for states in (X, sweep):
        a, b = guarded.rhs_many(0.0, states), straight.rhs_many(0.0, states)
        assert np.all(np.isfinite(b))
        assert np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))) <= 1e-12
    # the sweep did cross: airborne, the rhs does not depend on the height; on the ground it does
    first = straight.rhs_many(0.0, sweep[:1500])
    assert np.array_equal(first[-1], first[-2])
    assert np.max(np.abs(first[0] - first[-1])) > 1.0


def _implicit(model, states):
    """NAME_implicit's out[] at each state (status 0 asked: every state here is finite)."""
    layout = model.metadata["implicit"]["layout"]
    ffi, fp = model.ffi, model.ffi.addressof(model.model_lib, f"{model.name}_implicit")
    out = np.zeros((len(states), layout["size"]))
    r = model._default_r if model.ninput else ffi.NULL
    for k, x in enumerate(np.ascontiguousarray(states)):
        row = out[k]
        assert fp(0.0, ffi.from_buffer("double[]", x), model._default_p, r,
                  ffi.from_buffer("double[]", row), ffi.NULL) == 0
    return out


def test_the_guarded_implicit_terms_are_the_straight_line_ones_near_and_far_from_the_ground(oneleg):
    """NAME_implicit (the implicitfast step's terms) skips a body's forces and its points' K and
    C slopes with the same bounds; depth, point and velocity are written for every contact (the
    runtime's depth limit and regime test read them)."""
    guarded, straight, tmp_path = oneleg
    source = next((tmp_path / "guarded").rglob("oneleg.c")).read_text()
    # NAME_implicit writes its constant outputs, then calls NAME_implicit_var: the body (d6f2a5a)
    start = source.index("int oneleg_implicit_var(" if "int oneleg_implicit_var(" in source else "int oneleg_implicit(")
    # and the hip's limit (compiler/tree/zero_guards.py): each side's torque and its slopes
    assert _with_parts(source, "implicit", start).count("} else {") == 2 + 13 + 2 * 2
    rng = np.random.default_rng(29)
    z = guarded.state_names.index("q_trunk_floating_z")
    X = rng.normal(scale=1.0, size=(300, guarded.nx))
    X[:, z] = rng.uniform(-0.1, 0.8, size=len(X))
    sweep = np.repeat(X[:2], 600, axis=0)
    sweep[:, z] = np.tile(np.linspace(-0.05, 0.75, 600), 2)
    for states in (X, sweep):
        a, b = _implicit(guarded, states), _implicit(straight, states)
        assert np.all(np.isfinite(b))
        assert np.array_equal(np.abs(a), np.abs(b))      # equal but for the sign of a zero
    # the sweep did cross: some contact's K was nonzero at the low end and every one at the high
    at = guarded.metadata["implicit"]["layout"]["contact"]
    K = np.array([b[at + 25 * c + 7:at + 25 * c + 16] for b in _implicit(straight, sweep[[0, 599]])
                  for c in range(13)]).reshape(2, 13, 9)
    assert np.any(K[0] != 0) and not np.any(K[1] != 0)
