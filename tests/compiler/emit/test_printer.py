"""The C printer: slot names, literal rules and precedence, as exact strings."""
import pytest
import sympy as sm

from eomc.compiler.emit.printer import CPrinter
from eomc.compiler.ir import IMul

x, y, z = sm.symbols("x_0 x_1 p_0", real=True)
P = CPrinter({x: "x[0]", y: "x[1]", z: "p[0]"})


@pytest.mark.parametrize("expr,text", [
    (x + y, "x[0] + x[1]"),
    (x * y, "x[0]*x[1]"),
    (x - y, "x[0] - x[1]"),
    (x * (y + z), "x[0]*(p[0] + x[1])"),
    (x / (y + z), "x[0]/(p[0] + x[1])"),
    (1 / x, "1.0/x[0]"),
    (sm.Rational(1, 3) * x, "(1.0/3.0)*x[0]"),
    (sm.Integer(2) * x, "2.0*x[0]"),
    (sm.Float(0.1) * x, "0.1*x[0]"),
    (sm.pi * x, "3.141592653589793*x[0]"),
    (sm.sin(x + y), "sin(x[0] + x[1])"),
    (sm.sqrt(x), "sqrt(x[0])"),
    (-x, "-x[0]"),
    (-(x + y), "-x[0] - x[1]"),
    (IMul(x, x), "(x[0]*x[0])"),
    (IMul(x + y, x), "((x[0] + x[1])*x[0])"),
    (-x * sm.Pow(IMul(y, y), -1, evaluate=False), "-x[0]/(x[1]*x[1])"),
    (-x * IMul(y, y), "-x[0]*(x[1]*x[1])"),
    (y * sm.Pow(IMul(x, x), -1, evaluate=False), "x[1]/(x[0]*x[0])"),
    (sm.Pow(IMul(x, x), -1, evaluate=False), "1.0/(x[0]*x[0])"),
    (-IMul(x, y), "-(x[0]*x[1])"),
    (IMul(x, y) + z, "p[0] + (x[0]*x[1])"),
    (sm.tanh(1000.0 * x), "eomc_tanh0(1000.0*x[0])"),     # libm's tanh but at ±0 (printer.MINMAX_C)
])
def test_exact_strings(expr, text):
    assert P.doprint(expr) == text


def test_integer_division_cannot_happen():
    # every rational and integer literal is a double literal
    assert P.doprint(sm.Rational(3, 2) + x) == "3.0/2.0 + x[0]"


def test_unknown_symbol_is_a_compiler_bug():
    with pytest.raises(KeyError, match="no C name"):
        P.doprint(sm.Symbol("stray"))


def test_floats_round_trip():
    v = 0.1 + 0.2
    assert float(P.doprint(sm.Float(v))) == v


MEMO_CASES = [(x * (y + z), "x[0]*(p[0] + x[1])"), (-(x + y), "-x[0] - x[1]"), (IMul(x + y, x), "((x[0] + x[1])*x[0])"),
              (sm.sin(x + y) / sm.sqrt(z), "sin(x[0] + x[1])/sqrt(p[0])")]


@pytest.mark.parametrize("expr,text", MEMO_CASES)
def test_print_memo_fills_each_printers_names(expr, text):
    """Inside print_memo an expression is printed from its template: the same text as without
    it, the second time too, and with another printer's names where they differ."""
    from eomc.compiler.emit.printer import print_memo
    other = CPrinter({x: "t3", y: "P[1]", z: "p[7]"})
    with print_memo():
        assert P.doprint(expr) == text
        assert P.doprint(expr) == text
        assert other.doprint(expr) == other.doprint(expr) == text.replace("x[0]", "t3").replace(
            "x[1]", "P[1]").replace("p[0]", "p[7]")
        with pytest.raises(KeyError, match="no C name"):
            CPrinter({x: "x[0]"}).doprint(expr)


def test_print_memo_prints_each_shape_once():
    """Expressions that differ only in their symbols' names are printed by SymPy once and filled
    with each one's names (printer._shaped): the texts equal the uncached printer's, symbols that
    repeat or trade places included; a symbol with other assumptions, another number or another
    function is another shape."""
    from eomc.compiler.emit import printer
    syms = sm.symbols("a_0:6", real=True)
    a, b, c, d, e, f = syms
    pos = sm.Symbol("g", positive=True)
    exprs = [sm.sin(a) * b + c / (d + a), sm.sin(e) * f + b / (c + e), sm.sin(c) * a + d / (f + c),
             sm.sin(a) * b + c / (d + b),             # b twice, not a: another pattern
             sm.sin(a) * b + 2.5 * c / (d + a),       # another number
             sm.cos(a) * b + c / (d + a),             # another function
             sm.sin(pos) * b + c / (d + pos),         # other assumptions
             -(a + b) * c, -(d + e) * f, IMul(a, b) - c, IMul(e, f) - a, sm.Abs(a - b) ** 1.5, sm.Abs(f - e) ** 1.5]
    names = {s: f"v[{k}]" for k, s in enumerate(syms)} | {pos: "w[0]"}
    want = [CPrinter(names).doprint(x) for x in exprs]
    calls = []
    template = printer._template

    def counted(expr):
        calls.append(expr)
        return template(expr)
    printer._template = counted
    try:
        with printer.print_memo():
            got = [CPrinter(names).doprint(x) for x in exprs]
            again = [CPrinter(names).doprint(x) for x in exprs]
    finally:
        printer._template = template
    assert got == want and again == want
    shapes = {printer._shape(x)[0] for x in exprs}
    assert len(calls) == len(shapes) < len(exprs)


def test_print_memo_leaves_name_reading_code_uncached():
    """A _ccode method that reads its arguments' printed names (CPrinter.reads_names, as the pair
    table's parameter array does) is printed as without the memo, under each printer's names."""
    from eomc.compiler.emit.printer import print_memo

    class Reads(sm.Function):
        def _ccode(self, printer):
            printer.reads_names()
            text = printer._print(self.args[0])
            return "SLOT" if text == "x[0]" else f"f({text})"
    with print_memo():
        assert P.doprint(Reads(x) + y) == "x[1] + SLOT"
        assert CPrinter({x: "t1", y: "x[1]"}).doprint(Reads(x) + y) == "x[1] + f(t1)"


def test_print_memo_per_thread():
    """Models generated at once in threads: each thread's memo and template printer are its
    own, so a template is never filled with another thread's slots (the texts equal the
    uncached printer's under a tiny switch interval, which interleaves the threads' prints)."""
    import sys
    import threading

    from eomc.compiler.emit.printer import print_memo

    syms = sm.symbols("a_0:12", real=True)
    exprs = [sm.sin(syms[i]) * syms[(i + 1) % 12] + syms[(i + 5) % 12] ** 2 / (1 + syms[(i + 7) % 12])
             for i in range(12)]
    failures = []

    def work(tag):
        names = {s: f"{tag}[{k}]" for k, s in enumerate(syms)}
        want = [CPrinter(names).doprint(e) for e in exprs]
        for _ in range(30):
            with print_memo():
                got = [CPrinter(names).doprint(e) for e in exprs]
            if got != want:
                failures.append((tag, got, want))
                return

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=work, args=(f"w{i}",)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    assert not failures, failures[0]


@pytest.mark.parametrize("expr,text", [
    (sm.Abs(x) ** sm.Rational(3, 2), "(fabs(x[0])*sqrt(fabs(x[0])))"),
    (z * sm.Abs(x) ** sm.Rational(3, 2), "p[0]*(fabs(x[0])*sqrt(fabs(x[0])))"),
    (z / sm.Abs(x) ** sm.Rational(3, 2), "p[0]/(fabs(x[0])*sqrt(fabs(x[0])))"),
    (sm.Abs(x) ** sm.Rational(5, 2), "(fabs(x[0])*fabs(x[0])*sqrt(fabs(x[0])))"),
    (sm.Pow(sm.Abs(x), -sm.Rational(1, 2), evaluate=False), "(1.0/sqrt(fabs(x[0])))"),
    (sm.Abs(x + y) ** sm.Rational(3, 2), "(fabs(x[0] + x[1])*sqrt(fabs(x[0] + x[1])))"),
    (y ** sm.Rational(3, 2), "pow(x[1], 3.0/2.0)"),                    # no fabs: pow (x = -inf, -0)
    ((sm.Abs(x) + 1) ** sm.Rational(3, 2), "pow(1.0 + fabs(x[0]), 3.0/2.0)"),
    (sm.Abs(x) ** sm.Rational(7, 2), "pow(fabs(x[0]), 7.0/2.0)"),      # more roundings than wanted
    (sm.Abs(x) ** sm.Rational(-3, 2), "pow(fabs(x[0]), -3.0/2.0)"),
])
def test_half_powers_of_a_fabs_are_products_with_sqrt(expr, text):
    """printer.half_power: |x|^(3/2), |x|^(5/2), |x|^(-1/2) as products with one sqrt (the contact
    laws' d^(3/2); gcc keeps pow(x, 1.5) a libm call without -ffast-math); other bases and powers
    stay pow.  NAME_energy's HalfPow of a fabs prints the same text."""
    from eomc.compiler.emit.printer import HalfPow
    assert P.doprint(expr) == text
    if expr.is_Pow and expr.exp > 1:
        half = P.doprint(HalfPow(expr.base, expr.exp))
        assert half == text if text.startswith("(") else half.startswith("eomc_pow0(")


def test_half_powers_against_libm_pow(tmp_path):
    """The printed products against libm's pow of the same fabs, compiled as the model library is
    (-O2, no FMA): the same value at every special input (±0, ±inf, NaN, subnormals, powers of 4),
    and within 1 ulp (3/2, -1/2) or 2 ulp (5/2) elsewhere (the largest doubles, whose 3/2 and 5/2
    overflow on both sides, 20 decades each way, the contact depths' range); most give pow's bits."""
    import ctypes
    import subprocess

    import numpy as np
    rows = []
    for p in (3, 5, -1):
        e = sm.Pow(sm.Abs(x), sm.Rational(p, 2), evaluate=False)
        rows.append(f"o[3*k + {len(rows)}] = {P.doprint(e)}; "
                    f"r[3*k + {len(rows)}] = pow(fabs(x[0]), {p}.0/2.0);")
    src = tmp_path / "hp.c"
    src.write_text("#include <math.h>\nvoid run(int n, const double *xs, double *o, double *r)\n{\n"
                   "    for (int k = 0; k < n; k++) {\n        const double *x = xs + k;\n        "
                   + "\n        ".join(rows) + "\n    }\n}\n")
    lib = tmp_path / "libhp.so"
    subprocess.run(["gcc", "-O2", "-std=c99", "-fPIC", "-shared", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror",
                    str(src), "-o", str(lib), "-lm"], check=True)
    rng = np.random.default_rng(3)
    special = [0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, 5e-324, -5e-324, 2.2250738585072014e-308, 1.0, -1.0,
               4.0, -0.25]
    xs = np.concatenate([special, [1.7976931348623157e308, -1.7976931348623157e308, 1e-100],
                         10 ** rng.uniform(-20, 20, 100_000), -rng.uniform(0, 0.05, 100_000)])
    o, r = np.empty(3 * len(xs)), np.empty(3 * len(xs))
    ptr = ctypes.POINTER(ctypes.c_double)
    ctypes.CDLL(str(lib)).run(ctypes.c_int(len(xs)), xs.ctypes.data_as(ptr), o.ctypes.data_as(ptr), r.ctypes.data_as(ptr))
    o, r = o.reshape(-1, 3), r.reshape(-1, 3)
    s = len(special)
    assert np.array_equal(o[:s], r[:s], equal_nan=True) and not np.signbit(o[:s][~np.isnan(o[:s])]).any()
    ulps = np.abs(o[s:].view(np.int64) - r[s:].view(np.int64))
    assert np.array_equal(np.isfinite(o[s:]), np.isfinite(r[s:])) and ulps.max(axis=0).tolist() == [1, 2, 1], ulps.max(axis=0)
    assert (ulps == 0).mean() > 0.6
