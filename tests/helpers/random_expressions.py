"""Random SymPy expressions over four variables and two parameters, for the passes' property
tests (test_passes.py: every pass keeps values; test_adjoint.py: reverse mode vs SymPy)."""
import sympy as sm
from hypothesis import strategies as st

X = sm.symbols("x_0:4", real=True)
P = sm.symbols("p_0:2", real=True)
LEAVES = list(X) + list(P) + [sm.Integer(2), sm.Rational(1, 3), sm.Float(0.25)]
exprs = st.recursive(
    st.sampled_from(LEAVES),
    lambda sub: st.one_of(
        st.tuples(sub, sub).map(lambda a: a[0] + a[1]),
        st.tuples(sub, sub).map(lambda a: a[0] * a[1]),
        st.tuples(sub, sub).map(lambda a: a[0] - a[1]),
        st.tuples(sub, sub).map(lambda a: a[0] / (1 + a[1] ** 2)),
        sub.map(sm.sin), sub.map(sm.cos),
        st.tuples(sub, st.integers(-4, 9)).map(lambda a: a[0] ** a[1] if a[1] >= 0
                                                else 1 / (2 + a[0] ** 2) ** (-a[1])),
    ),
    max_leaves=12,
)
values = st.lists(st.floats(0.3, 1.7), min_size=6, max_size=6)
