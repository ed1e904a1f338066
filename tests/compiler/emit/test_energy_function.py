"""NAME_energy (compiler/emit/generate.energy_program): the output named "energy" alone, in the
default set of a model that has one (rollout's per-step energy watch reads it instead of the whole
outputs call: eomc_options.watch_fn).  Oracle: the same library's NAME_outputs -- the value must
be its energy bit for bit (the watch's verdict is simulate's, which reads the outputs).  A model
without an energy output gets no such function (its C stays as it was: benchmarks/c_identity.py).
The contact tree's energy (gymnasium-style MJCF, compiler/tree/contacts.py) is checked the same
way in tests/runtime/test_rollout.py::test_implicitfast_rows_get_simulates_energy_verdict."""
from pathlib import Path

import numpy as np
import pytest
from eomc.compiler.driver import compile as compile_model, generate
from helpers import model_files

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
PENDULUM, CART = EXAMPLES / "double_pendulum.py", EXAMPLES / "cart_pole_system.py"
STRICT = "-O2 -std=c99 -fPIC -Wall -Wextra -Werror"


def energy_of(model, t, x, p):
    """NAME_energy's out[0] at (t, x, p), through the model's own cffi library."""
    ffi = model.ffi
    out = ffi.new("double[1]")
    work = ffi.new("double[]", max(1, model.c_model.work_size))
    status = getattr(model.model_lib, f"{model.name}_energy")(
        t, ffi.new("double[]", list(x)), ffi.new("double[]", list(p)), ffi.NULL, out, work)
    assert status == 0
    return out[0]


def test_energy_function_equals_the_outputs_energy_bit_for_bit(tmp_path):
    model = compile_model(str(PENDULUM), "en_kane", cache_dir=tmp_path, cflags=STRICT, progress=False)
    assert "energy" in model.metadata["functions"] and model.noutput > 1
    rng = np.random.default_rng(5)
    P = np.asarray(model.param_defaults, dtype=float)
    for k in range(20):
        x = rng.uniform(-3.0, 3.0, model.nx)
        p = P * rng.uniform(0.5, 2.0, P.size)
        want = model.outputs(0.1 * k, x, p=p)["energy"]
        assert energy_of(model, 0.1 * k, x, p) == want


def test_only_models_with_an_energy_output_get_it():
    pendulum = generate(str(PENDULUM), "en_pend")[1]
    assert "int en_pend_energy(double t," in pendulum.header
    assert "en_pend_energy" in pendulum.cdef
    cart = generate(str(CART), "en_cart")[1]          # outputs, none named energy
    assert cart.metadata["noutput"] > 0 and "energy" not in cart.metadata["output_names"]
    assert "energy" not in cart.metadata["functions"] and "_energy(" not in cart.c_source
    # asked alone it brings the outputs it is one of; asked without, neither is there
    alone = generate(str(PENDULUM), "en_alone", functions=("rhs", "energy"))[1]
    assert alone.metadata["functions"] == ["rhs", "outputs", "energy"]
    assert "energy" not in generate(str(PENDULUM), "en_none", functions=("rhs", "outputs"))[1].metadata["functions"]


# Two legs hanging from a torso on a planar root, a sphere foot each: the feet are one self-pair
# (siblings) and each touches the floor (tests/helpers/model_files.py).  With
# pairs.TABLE_FROM = 1 the pair goes through the table's C loop (eomc_pairs), as G1's 16 foot-sphere
# pairs and the humanoid's 109 pairs do by default.
TWO_LEGS = model_files.TWO_LEGS


def _function_text(source, name):
    start = source.index(f"int {name}(double t,")
    return source[start:source.index("\n}\n", start)]


@pytest.mark.parametrize("table", [True, False])
def test_energy_skips_far_pairs_and_zero_powers_with_the_outputs_bits(tmp_path, monkeypatch, table):
    """NAME_energy reads a pair's depth only through its positive part, so the pair's far states skip
    it: through the pairs' table loop (table: pairs.TABLE_FROM = 1) the loop's broad phase (full =
    DEPTHS, 4: the rhs's skips, far pairs' δ 0, no law; the outputs' call is full = 1, every pair's
    narrow phase and law: G1's energy spent 41 % of its time there); the pair inlined (the default for
    fewer than 8 pairs) under the rhs's broad-phase guard (its depth 0 where the pair's bounding
    balls are apart, the hopper's three pairs: 106 -> 81 ns a call), as are the ground points'
    depths under their bodies' guards.  Its contact powers δ₊^(3/2), δ₊^(5/2) take no libm pow
    (printer.half_power: products with sqrt, as the outputs print them).  The value stays the
    outputs' bit for bit at states with the feet pressed together, apart (the pair skipped) and in
    the floor or not."""
    import eomc
    from eomc.compiler.contact import pairs
    from eomc.compiler.mjcf.model import MjcfModel
    if table:
        monkeypatch.setattr(pairs, "TABLE_FROM", 1)
    path = tmp_path / "twolegs.xml"
    path.write_text(TWO_LEGS)
    model = eomc.compile(MjcfModel(path), name="enpt", functions=("rhs", "outputs", "energy"),
                         cache_dir=tmp_path / "cache", cflags=STRICT, progress=False)
    assert "energy" in model.metadata["functions"]
    source = next((tmp_path / "cache").rglob("enpt.c")).read_text()
    energy, outputs = _function_text(source, "enpt_energy"), _function_text(source, "enpt_outputs")
    if table:
        assert "eomc_pairs(" in energy and ", 4, &PT_[0])" in energy and ", 1, &PT_[0])" in outputs   # (DEPTHS)
    else:
        assert "eomc_pairs(" not in energy and "if (!(" not in outputs
        assert energy.count("if (!(") == 1 and "G_[" in energy      # the pair (the feet's ground depths straight)
    assert "eomc_pow0(" not in energy and "pow(fabs(" not in energy and "*sqrt(fabs(" in energy   # (the
    # guards' clearances print squares as pow(d, 2.0), as the rhs's)
    rng = np.random.default_rng(7)
    names = list(model.state_names)
    P = np.asarray(model.param_defaults, dtype=float)
    pressed = apart = floor = 0
    for k in range(300):
        x = np.zeros(model.nx)
        x[names.index("q_rootz")] = rng.uniform(-0.08, 0.05)     # the feet 1-4 cm into the floor or above
        x[names.index("q_hip_l")] = rng.uniform(-0.3, 0.1)       # towards each other, or apart
        x[names.index("q_hip_r")] = rng.uniform(-0.1, 0.3)
        x[model.nq:] = rng.normal(size=model.nu)
        out = model.outputs(0.0, x)
        got = energy_of(model, 0.0, x, P)
        assert got == out["energy"] and np.signbit(got) == np.signbit(out["energy"]), (k, got, out["energy"])
        depth = out["depth_foot_l__foot_r"]
        pressed += depth > 0
        apart += depth < -0.05           # beyond the bounding balls' reach: skipped
        floor += out["depth_foot_l"] > 0
    assert pressed > 10 and apart > 10 and 10 < floor < 290, (pressed, apart, floor)


def test_a_program_reading_more_than_the_depths_positive_part_keeps_every_pair():
    """reads_depths_positive_only: only (δ + |δ|)/2 of a point's δ lets the loop skip far pairs; a
    program reading δ itself, or a point's normal force, keeps the exact loop (full = 1)."""
    from types import SimpleNamespace
    import sympy as sm
    from eomc.compiler.contact import table
    from eomc.compiler.ir.program import Program
    tid = 987654
    table._TABLES[tid] = SimpleNamespace(nwrench=6, noutput=6 + 9, ninput=2, pairs=(), room=0, npoints=1)
    try:
        a, b, c, s = sm.symbols("a b c s")
        call = table.PairTableCall(sm.Integer(tid), sm.Integer(1), a, b)
        depth = table.PairTableOut(c, sm.Integer(0), sm.Integer(6 + 4))
        force = table.PairTableOut(c, sm.Integer(0), sm.Integer(6 + 0))
        wrench = table.PairTableOut(c, sm.Integer(0), sm.Integer(2))

        def prog(*exprs, alias=False):
            body = ((c, call),) + (((s, depth),) if alias else ())
            return Program(inputs=(a, b), assignments=body, results=tuple((("en", k), e) for k, e in enumerate(exprs)))
        positive = 3 * sm.Abs((depth + sm.Abs(depth)) / 2) ** sm.Rational(5, 2)
        assert table.reads_depths_positive_only(prog(positive, wrench))
        assert table.reads_depths_positive_only(prog(3 * ((s + sm.Abs(s)) / 2) ** 2, alias=True))
        assert not table.reads_depths_positive_only(prog(positive + depth))
        assert not table.reads_depths_positive_only(prog(positive, force))
        assert not table.reads_depths_positive_only(prog(s * 2, alias=True))
        reads = {6 + 4, 2}
        assert int(call.for_program(reads, table.DEPTHS_POSITIVE).args[1]) == 2
        assert int(call.for_program(reads | {6}, table.DEPTHS_POSITIVE).args[1]) == 1
        assert int(call.for_program(reads, True).args[1]) == 1
    finally:
        del table._TABLES[tid]


def test_energy_guards_only_depths_read_as_their_positive_part():
    """energy_guards: a guard's point depth δ goes under the broad phase only where the program reads
    it as (δ + |δ|)/2 alone (then a skipped δ of 0 gives the same +0); a δ read otherwise keeps the
    point computed (its guard dropped), and a guard left with no depth is not printed."""
    import sympy as sm
    from eomc.compiler.emit.generate import energy_guards
    from eomc.compiler.ir.program import Program
    a, b, d1, d2, e, c = sm.symbols("a b d1 d2 e c")
    prog = Program(inputs=(a, b), assignments=((d1, sm.sqrt(a) - b), (d2, b - sm.sqrt(a)), (e, d1 / 2 + sm.Abs(d1) / 2)),
                   results=((("en", 0), 3 * e ** 2 + d2 + sm.Abs(d2 / 2 + sm.Abs(d2) / 2) ** sm.Rational(5, 2)),))
    guards = [(a + 1, (), ((-d1, (), ()),)), (b + 1, (), ((-d2, (), ()),)), (c, (), ((-d1, (), ()), (-d2, (), ())))]
    assert energy_guards(prog, guards) == [(a + 1, (d1,), ()), (c, (d1,), ())]
    # a depth without a square root (a ground point's height less its reach) is not worth a guard
    linear = prog.with_(assignments=((d1, a - b),) + prog.assignments[1:])
    assert energy_guards(linear, guards) == []


def test_outputs_that_are_the_energy_alone_call_it(tmp_path):
    """A URDF robot with limits (recursive: its one default output is the energy): NAME_outputs is
    one call of NAME_energy (generate.outputs_by_energy: the copy was 67 kB of G1's C), with the
    same bits; with a frame among the outputs they keep their own code."""
    from helpers.urdf_arm import LAW_ARM
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    model = compile_model(str(path), "en_call", cache_dir=tmp_path, cflags=STRICT, progress=False,
                          formulation="recursive")
    assert model.output_names == ("energy",) and "energy" in model.metadata["functions"]
    c = model.source_path.read_text()
    body = c[c.index("int en_call_outputs("):]
    assert body[:body.index("\n}\n")].splitlines()[2:] == ["    return en_call_energy(t, x, p, r, out, work);"]
    assert "en_call_outputs_part" not in c
    assert model.metadata["op_counts"]["outputs"] == model.metadata["op_counts"]["energy"]
    rng = np.random.default_rng(3)
    P = np.asarray(model.param_defaults, dtype=float)
    for k in range(10):
        x = rng.uniform(-1.5, 1.5, model.nx)
        assert model.outputs(0.0, x)["energy"] == energy_of(model, 0.0, x, P)
    framed = generate(str(path), "en_framed", formulation="recursive", frames=["l3"], use_cache=False,
                      progress=False)[1]
    assert len(framed.metadata["output_names"]) > 1
    assert "return en_framed_energy(" not in framed.c_source
