"""compiler/tree/contacts.py: a body-body pair's energy reads |(δ + |δ|)/2|, built once per kind of depth."""
import sympy as sm

from eomc.compiler.contact.table import PairTableOut
from eomc.compiler.tree import contacts


def test_abs_of_a_depths_positive_part_is_sympys_own():
    """For the table's outputs and for symbols, the Abs built as it stands after the first one of
    its kind is the one SymPy's evaluation builds; other depths are evaluated."""
    call = sm.Symbol("_t7", real=True)
    x = sm.Symbol("x", real=True)
    depths = ([PairTableOut(call, 0, k) for k in (82, 91, 100)] + [sm.Symbol(f"_d{k}", real=True) for k in range(3)]
              + [sm.Symbol("n", negative=True), sm.Symbol("m", nonnegative=True), sm.Symbol("w"), x - 1, sm.Integer(-2)])
    kept = {}
    for d in depths + depths:
        dpos = (d + sm.Abs(d)) / 2
        got = contacts._abs_of_part(d, dpos, kept)
        want = sm.Abs(dpos)
        assert got == want and type(got) is type(want) and got.args == want.args, d
    assert kept[(PairTableOut, tuple(sorted(depths[0].assumptions0.items())))] is True
    assert kept[(sm.Symbol, tuple(sorted(sm.Symbol("m", nonnegative=True).assumptions0.items())))] is False
