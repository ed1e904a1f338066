"""Unrolled LU for a non-symmetric A (multipliers, motion constraints), with a safety net.

At compile time a row order is chosen by partial pivoting on A evaluated at
a random point; the structural nonzeros of the reordered A and their fill-in
give an unrolled, pivot-free elimination.  At run time every pivot is checked
against its column (threshold pivoting, |pivot| >= 0.1·max|column|) and
against the matrix scale; if the check fails for this state, the factor falls
back to the dense LU with partial pivoting (:mod:`.linsolve`), so the result
never depends on the random point, only the speed does.

Storage: ``F[0:n²]`` holds A as loaded by the caller (dense, row-major),
``F[n²:2n²]`` the factors, ``F[2n²:2n²+n]`` the inverse pivots;
``piv[0:n]`` the dense path's pivots and ``piv[n]`` the path taken (0 unrolled, 1 dense).
"""
import math
import random
from collections import Counter

import sympy as sm

from .linsolve import Solver, dense_lu_code, forward_substitution, minus_terms

__all__ = ["static_row_order", "sparse_lu_solver"]

THRESHOLD = 0.1


_FLOAT_FUNCS = {sm.sin: math.sin, sm.cos: math.cos, sm.tan: math.tan, sm.exp: math.exp,
                sm.log: math.log, sm.atan: math.atan, sm.asin: math.asin, sm.acos: math.acos,
                sm.sinh: math.sinh, sm.cosh: math.cosh, sm.tanh: math.tanh, sm.Abs: abs}


def _value(expr, vals, memo):
    """float(expr) at ``vals`` in double arithmetic, each shared subtree once.

    Substituting SymPy Floats and letting SymPy evaluate rebuilt every node of the
    (unshared, often huge) entries symbolically: most of the bicycle's generation time
    outside the passes.  Anything this does not know falls back to SymPy."""
    hit = memo.get(id(expr))
    if hit is not None:
        return hit[1]
    try:
        if expr.is_Symbol:
            v = float(vals[expr])
        elif expr.is_Number or expr.is_NumberSymbol:
            v = float(expr)
        elif expr.is_Add:
            v = math.fsum(_value(a, vals, memo) for a in expr.args)
        elif expr.is_Mul:
            v = 1.0
            for a in expr.args:
                v *= _value(a, vals, memo)
        elif expr.is_Pow:
            v = _value(expr.base, vals, memo) ** _value(expr.exp, vals, memo)
        elif expr.func in _FLOAT_FUNCS and len(expr.args) == 1:
            v = _FLOAT_FUNCS[expr.func](_value(expr.args[0], vals, memo))
        else:
            raise TypeError
        if isinstance(v, complex):
            raise TypeError
    except (TypeError, ValueError, ZeroDivisionError, OverflowError, KeyError):
        v = float(expr.xreplace({s: sm.Float(x) for s, x in vals.items()}))
    memo[id(expr)] = (expr, v)
    return v


def static_row_order(A, pattern, seed=0):
    """Row order chosen by partial pivoting on A at a random point (compile time)."""
    n = A.shape[0]
    rng = random.Random(seed)
    syms = sorted(A.free_symbols, key=lambda s: s.name)
    vals = {s: rng.uniform(0.3, 1.7) for s in syms}
    memo = {}
    M = [[_value(A[i, j], vals, memo) if (i, j) in pattern else 0.0 for j in range(n)]
         for i in range(n)]
    rows = list(range(n))
    for k in range(n):
        m = max(range(k, n), key=lambda i: (abs(M[i][k]), -i))
        M[k], M[m] = M[m], M[k]
        rows[k], rows[m] = rows[m], rows[k]
        if M[k][k] != 0.0:
            for i in range(k + 1, n):
                f = M[i][k] / M[k][k]
                for j in range(k, n):
                    M[i][j] -= f * M[k][j]
    return tuple(rows)


def _structure(n, pattern, rows):
    S = {(i, j) for i in range(n) for j in range(n) if (rows[i], j) in pattern}
    orig = set(S)
    for k in range(n):
        below = [i for i in range(k + 1, n) if (i, k) in S]
        right = [j for j in range(k + 1, n) if (k, j) in S]
        for i in below:
            for j in right:
                S.add((i, j))
    return S, orig


def _factor_lines(p, n, S, orig, rows, ops):
    nn = n * n
    lines = [f"static int {p}_lu_factor(double *F, int *piv)", "{",
             f"    double *U = F + {nn};", "    double scale = 0.0, tol, cmax, a;", "    int i;",
             f"    for (i = 0; i < {nn}; i++) {{", "        a = fabs(F[i]);",
             "        if (!(a < HUGE_VAL)) return EOMC_NONFINITE;",
             "        if (a > scale) scale = a;", "    }",
             "    tol = 64.0 * DBL_EPSILON * scale;"]
    lines += [f"    U[{i * n + j}] = F[{rows[i] * n + j}];" for (i, j) in sorted(orig)]
    init = set(orig)
    for k in range(n):
        below = [i for i in range(k + 1, n) if (i, k) in S]
        right = [j for j in range(k + 1, n) if (k, j) in S]
        if (k, k) not in S:
            lines.append("    goto dense;")
            break
        lines.append("    cmax = 0.0;")
        for i in below:
            lines.append(f"    a = fabs(U[{i * n + k}]); if (a > cmax) cmax = a;")
        lines += [f"    a = fabs(U[{k * n + k}]);",
                  f"    if (!(a > tol) || a < {THRESHOLD!r} * cmax) goto dense;",
                  f"    U[{nn + k}] = 1.0 / U[{k * n + k}];"]
        ops["divs"] += 1
        for i in below:
            lines.append(f"    U[{i * n + k}] *= U[{nn + k}];")
            ops["muls"] += 1
            for j in right:
                lhs, prod = f"U[{i * n + j}]", f"U[{i * n + k}] * U[{k * n + j}]"
                if (i, j) in init:
                    lines.append(f"    {lhs} -= {prod};")
                    ops["adds"] += 1
                else:
                    lines.append(f"    {lhs} = -{prod};")
                    init.add((i, j))
                ops["muls"] += 1
    lines += [f"    piv[{n}] = 0;", "    return EOMC_OK;", "dense:",
              f"    for (i = 0; i < {nn}; i++) U[i] = F[i];",
              f"    piv[{n}] = 1;", f"    return {p}_lu_dense_factor(U, piv);", "}", ""]
    return lines


def _solve_lines(p, n, S, rows, ops):
    nn = n * n
    lines = [f"static void {p}_lu_solve(const double *F, const int *piv, double *b)", "{",
             f"    const double *U = F + {nn};", f"    double y[{n}];",
             f"    if (piv[{n}]) {{", f"        {p}_lu_dense_solve(U, piv, b);", "        return;",
             "    }"]
    lines += [f"    y[{i}] = b[{rows[i]}];" for i in range(n)]
    lines += forward_substitution("U", "y", n, S, ops)
    for i in reversed(range(n)):
        # newest value (b[i + 1]) last: products leave the dependency chain early
        terms = [f"U[{i * n + k}] * b[{k}]" for k in reversed(range(i + 1, n)) if (i, k) in S]
        rhs = f"y[{i}]" + minus_terms(terms)
        lines.append(f"    b[{i}] = ({rhs}) * U[{nn + i}];")
        ops["muls"] += len(terms) + 1
        ops["adds"] += len(terms)
    lines += ["}", ""]
    return lines


def sparse_lu_solver(prefix, n, pattern, rows):
    """Solver for a non-symmetric A with structural ``pattern`` and compile-time row order ``rows``."""
    S, orig = _structure(n, pattern, rows)
    fo, so = Counter(), Counter()
    code = dense_lu_code(prefix, n)
    code += "\n".join(_factor_lines(prefix, n, S, orig, rows, fo)) + "\n"
    code += "\n".join(_solve_lines(prefix, n, S, rows, so))
    return Solver(f"{prefix}_lu_factor", f"{prefix}_lu_solve", code, fo, so,
                  2 * n * n + n, True, n + 1)
