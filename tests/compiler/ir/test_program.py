"""The IR's single-assignment rules, names registry and printer."""
import pytest
import sympy as sm

from eomc.compiler.ir import IRError, Names, Program, c_names, count_ops, format_program, verify

x, y = sm.symbols("x_0 x_1", real=True)


def test_verify_accepts_well_formed():
    t = sm.Symbol("_t0", real=True)
    prog = Program(inputs=(x, y), assignments=((t, x + y),), results=((("o", 0), t * x),), ntemp=1)
    assert verify(prog) is prog
    assert c_names(prog) == {t: "t0"}
    text = format_program(prog)
    assert "t0 = x_0 + x_1" in text and "o[0] <- t0*x_0" in text


@pytest.mark.parametrize("assignments,results,msg", [
    (((sm.Symbol("a"), sm.Symbol("b")),), (), "undefined"),
    (((sm.Symbol("a"), x), (sm.Symbol("a"), y)), (), "twice"),
    (((x, y),), (), "shadows"),
    ((), ((("o", 0), sm.Symbol("zz")),), "undefined"),
    ((), ((("o", 0), x), (("o", 0), y)), "twice"),
])
def test_verify_rejects(assignments, results, msg):
    with pytest.raises(IRError, match=msg):
        verify(Program(inputs=(x, y), assignments=assignments, results=results))


def test_names_are_deterministic_and_fresh():
    prog = Program(inputs=(x,), ntemp=5)
    a, b = Names(prog), Names(prog)
    assert [a.fresh().name for _ in range(3)] == [b.fresh().name for _ in range(3)] == \
        ["_t5", "_t6", "_t7"]


def test_count_ops():
    c = count_ops(x * y + sm.sin(x) / (x + y) - 3 * x)
    assert c["calls"] == 1 and c["divs"] == 1 and c["adds"] == 3
    assert c["muls"] == 2
