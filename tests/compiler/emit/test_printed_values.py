"""Printed C evaluates to what SymPy evaluates: random expressions through the passes,
printed, compiled and called (catches precedence slips no string test anticipates)."""
import random

import numpy as np
import sympy as sm

from helpers import emit_support as es
from eomc.compiler.emit.printer import CPrinter
from eomc.compiler.ir import Program, c_names, evaluate
from eomc.compiler.passes import finish_function, optimize_shared

X = sm.symbols("x_0:4", real=True)


def _random_expr(rng, depth):
    if depth == 0 or rng.random() < 0.2:
        return rng.choice(list(X) + [sm.Integer(rng.randint(1, 5)), sm.Rational(rng.randint(1, 7), 3)])
    a, b = _random_expr(rng, depth - 1), _random_expr(rng, depth - 1)
    op = rng.randrange(8)
    return [a + b, a - b, a * b, -a * b, a / (2 + b**2), sm.sin(a) * sm.cos(b),
            a ** rng.randint(2, 9), -a / (1 + b**2) ** rng.randint(1, 4)][op]


def test_printed_c_matches_sympy(tmp_path):
    rng = random.Random(7)
    exprs = [_random_expr(rng, 4) for _ in range(150)]
    prog = Program(inputs=X, results=tuple((("o", i), e) for i, e in enumerate(exprs)))
    prog = finish_function(optimize_shared(prog), ["o"])
    names = {s: f"x[{i}]" for i, s in enumerate(X)}
    names.update(c_names(prog))
    pr = CPrinter(names)
    body = [f"    const double {names[s]} = {pr.doprint(e)};" for s, e in prog.assignments]
    body += [f"    out[{k[1]}] = {pr.doprint(e)};" for k, e in prog.results]
    src = tmp_path / "vals.c"
    src.write_text("#include <math.h>\nvoid f(const double *x, double *out);\n"
                   "void f(const double *x, double *out)\n{\n" + "\n".join(body) + "\n}\n")
    lib = tmp_path / "libvals.so"
    import subprocess
    proc = subprocess.run(["gcc", *es.STRICT, "-O0", "-fPIC", "-shared", str(src), "-o", str(lib),
                           "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    import cffi
    ffi = cffi.FFI()
    ffi.cdef("void f(const double *x, double *out);")
    so = ffi.dlopen(str(lib))
    for _ in range(3):
        xv = np.array([rng.uniform(0.4, 1.6) for _ in X])
        out = np.zeros(len(exprs))
        so.f(ffi.cast("double *", ffi.from_buffer(xv)), ffi.cast("double *", ffi.from_buffer(out)))
        ref = evaluate(prog, dict(zip(X, xv)))
        for i in range(len(exprs)):
            want = ref[("o", i)].real
            # a precedence slip is an O(1) error; 1e-9 leaves room for sin of a large
            # argument such as (x + 2)**9, where double rounding alone reaches 1e-12
            assert abs(out[i] - want) <= 1e-9 * max(1.0, abs(want)), (i, exprs[i])
