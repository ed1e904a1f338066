"""C code for solving the dynamics ``A·w = b`` numerically.

* Symmetric A (Kane without motion constraints, Lagrange without
  multipliers: A = M is SPD): an LDLᵀ factorization unrolled over the
  structural nonzeros of A and the fill-in they cause, known at compile time.
* Otherwise (multipliers, motion constraints): an unrolled LU in a row
  order fixed at compile time, checked at run time, with this module's dense
  LU with partial pivoting as the fallback (see :mod:`.sparse_lu`).

Both store the factors in ``F`` (n*n doubles, then n more) and report a pivot
that is not larger than ``64·DBL_EPSILON·scale`` (scale: the largest |diagonal| entry
of A for LDLᵀ, the largest |entry| for LU) as EOMC_SINGULAR_MASS_MATRIX,
and a non-finite scale as EOMC_NONFINITE.  Each emitter also returns
operation counts for the metadata.
"""
import re
from collections import Counter
from dataclasses import dataclass

import sympy as sm

__all__ = ["PIVOT_TOL", "Solver", "minus_terms", "forward_substitution", "ldlt_solver", "ldlt_loop_solver", "choose_ldlt", "dense_lu_code", "dense_lu_ops"]


# The singularity threshold of both formulations: 64·DBL_EPSILON (times the scale), the test
# the C below makes at run time; the recursive formulation bakes it into its expressions
# (eomc.compiler.tree.aba), which the float target retargets (emit/target.py).
PIVOT_TOL = sm.Float(2.0 ** -46, 17)       # 64 * DBL_EPSILON, exactly


@dataclass(frozen=True)
class Solver:
    factor_name: str
    solve_name: str
    code: str               # static C functions
    factor_ops: Counter
    solve_ops: Counter
    fsize: int              # doubles in F
    pivots: bool            # LU needs an int pivot array
    npiv: int = 0           # its length
    reads_lower: bool = False  # the factor reads every lower-triangle entry, structural zeros too
    solve_body: tuple = ()  # the unrolled solve's statements on b[i] (lanes_code), or none

    def factor_call(self, F="F"):
        return f"{self.factor_name}({F}, piv)" if self.pivots else f"{self.factor_name}({F})"

    def solve_call(self, vec, F="F"):
        return f"{self.solve_name}({F}, piv, {vec})" if self.pivots else f"{self.solve_name}({F}, {vec})"

    def lanes_code(self, lanes):
        """(name, C function) solving ``lanes`` right-hand sides side by side, B[row][lane], or
        None (only the unrolled LDLᵀ has one).  Why: a jvp's lanes of directions
        (emit/bodies.lane_directions) each need one solve with the same factor; every
        statement of the scalar solve becomes a loop over the lanes, which gcc -O2 turns into
        one vector operation (restrict: no alias check; trip count = vector width).  Each lane
        takes the scalar solve's operations in its order, so its bits are the scalar solve's.
        Out of line: inlined into the jvp, gcc left the loops scalar.  8-link cart, jvp with
        four directions: 609 -> 551 ns a call (four scalar solves overlap their latency chains,
        but pay their arithmetic four times)."""
        if not self.solve_body:
            return None
        name = f"{self.solve_name}_lanes"
        body = [f"    for (l = 0; l < {lanes}; l++) " + re.sub(r"\bb\[(\d+)\]", r"B[\1][l]", st.strip())
                for st in self.solve_body]
        code = ["#if defined(__GNUC__)", "__attribute__((noinline))", "#endif",
                f"static void {name}(const double *restrict F, double (*restrict B)[{lanes}])", "{",
                "    int l;", *body, "}", ""]
        return name, "\n".join(code)


def _fill_pattern(n, pattern):
    """Lower-triangle nonzeros of L (strictly below the diagonal), fill-in included."""
    L = {(i, j) for (i, j) in pattern if i > j}
    for j in range(n):
        rows_j = [k for k in range(j) if (j, k) in L]
        for i in range(j + 1, n):
            if (i, j) not in L and any((i, k) in L for k in rows_j):
                L.add((i, j))
    return L


def _sum(terms):
    return " + ".join(terms)


def minus_terms(terms):
    """`` - t0 - t1 ...``: C subtracts left to right, so each product leaves the
    dependency chain as soon as it is ready and the last term (the newest
    value) costs one multiply and one subtract of latency."""
    return "".join(f" - {t}" for t in terms)


def forward_substitution(matrix, vec, n, pattern, ops):
    """C lines of ``vec[i] -= Σ_{k<i} matrix[i][k]·vec[k]`` over the unit lower triangle's
    structural nonzeros ``pattern``, products in column order (newest value last);
    adds the operations to ``ops``."""
    lines = []
    for i in range(n):
        terms = [f"{matrix}[{i * n + k}] * {vec}[{k}]" for k in range(i) if (i, k) in pattern]
        if terms:
            lines.append(f"    {vec}[{i}] = {vec}[{i}]{minus_terms(terms)};")
            ops["muls"] += len(terms)
            ops["adds"] += len(terms)
    return lines


def ldlt_solver(prefix, n, pattern):
    """Unrolled LDLᵀ for a symmetric A with lower-triangle ``pattern`` (set of (i, j))."""
    L = _fill_pattern(n, pattern)
    D = n * n
    fo, so = Counter(), Counter()
    lines = [f"static int {prefix}_ldlt_factor(double *F)", "{",
             "    double scale = 0.0, tol, d;", "    int i;",
             f"    for (i = 0; i < {n}; i++) {{",
             f"        const double a = fabs(F[i * {n + 1}]);",
             "        if (!(a < HUGE_VAL)) return EOMC_NONFINITE;",
             "        if (a > scale) scale = a;", "    }",
             "    tol = 64.0 * DBL_EPSILON * scale;"]
    for j in range(n):
        ks = [k for k in range(j) if (j, k) in L]
        lines.append("    {")
        for k in ks:
            lines.append(f"        const double e{k} = F[{j * n + k}] * F[{k * n + k}];")
        fo["muls"] += len(ks)
        diag = f"F[{j * n + j}]" + minus_terms(f"F[{j * n + k}] * e{k}" for k in ks)
        fo["muls"] += len(ks)
        fo["adds"] += len(ks)
        lines += [f"        d = {diag};",
                  "        if (!(d > tol)) return EOMC_SINGULAR_MASS_MATRIX;",
                  f"        F[{j * n + j}] = d;",
                  f"        F[{D + j}] = 1.0 / d;"]
        fo["divs"] += 1
        for i in range(j + 1, n):
            if (i, j) not in L:
                continue
            terms = [f"F[{i * n + k}] * e{k}" for k in ks if (i, k) in L]
            fo["muls"] += len(terms) + 1
            fo["adds"] += len(terms)
            head = f"F[{i * n + j}]" if (i, j) in pattern or (j, i) in pattern else "0.0"
            if head == "0.0":
                fo["adds"] -= 1
                expr = f"-({_sum(terms)})"
            else:
                expr = head + minus_terms(terms)
            lines.append(f"        F[{i * n + j}] = ({expr}) * F[{D + j}];")
        lines.append("    }")
    lines += ["    return EOMC_OK;", "}", ""]
    body = forward_substitution("F", "b", n, L, so)
    for i in range(n):
        body.append(f"    b[{i}] *= F[{D + i}];")
    so["muls"] += n
    for i in reversed(range(n)):
        # k descending: the newest value, b[i + 1], enters the sum last, so the
        # other products need not wait for it (a chain of n, not n² latencies)
        terms = [f"F[{k * n + i}] * b[{k}]" for k in reversed(range(i + 1, n)) if (k, i) in L]
        if terms:
            body.append(f"    b[{i}] = b[{i}]{minus_terms(terms)};")
            so["muls"] += len(terms)
            so["adds"] += len(terms)
    lines += [f"static void {prefix}_ldlt_solve(const double *F, double *b)", "{", *body, "}", ""]
    return Solver(f"{prefix}_ldlt_factor", f"{prefix}_ldlt_solve", "\n".join(lines),
                  fo, so, n * n + n, False, solve_body=tuple(body))


_LDLT_LOOP = """\
static int {p}_ldlt_factor(double *F)
{{
    double scale = 0.0, tol;
    double e[{n}] = {{0.0}};
    int i, j, k;
    for (i = 0; i < {n}; i++) {{
        const double a = fabs(F[i * {n1}]);
        if (!(a < HUGE_VAL)) return EOMC_NONFINITE;
        if (a > scale) scale = a;
    }}
    tol = 64.0 * DBL_EPSILON * scale;
    for (j = 0; j < {n}; j++) {{
        double d = F[j * {n} + j];
        for (k = 0; k < j; k++) {{
            e[k] = F[j * {n} + k] * F[k * {n1}];
            d -= F[j * {n} + k] * e[k];
        }}
        if (!(d > tol)) return EOMC_SINGULAR_MASS_MATRIX;
        F[j * {n1}] = d;
        F[{nn} + j] = 1.0 / d;
        for (i = j + 1; i < {n}; i++) {{
            double s = F[i * {n} + j];
            for (k = 0; k < j; k++) s -= F[i * {n} + k] * e[k];
            F[i * {n} + j] = s * F[{nn} + j];
        }}
    }}
    return EOMC_OK;
}}

static void {p}_ldlt_solve(const double *F, double *b)
{{
    int i, k;
    for (i = 1; i < {n}; i++) {{
        double s = b[i];
        for (k = 0; k < i; k++) s -= F[i * {n} + k] * b[k];
        b[i] = s;
    }}
    for (i = 0; i < {n}; i++) b[i] *= F[{nn} + i];
    for (i = {n} - 2; i >= 0; i--) {{
        double s = b[i];
        for (k = {n} - 1; k > i; k--) s -= F[k * {n} + i] * b[k];  /* newest b[i + 1] last */
        b[i] = s;
    }}
}}
"""

# Unroll LDLᵀ only while the factor is small or sparse enough for unrolling to pay:
# a dense unrolled factor of a large M is thousands of lines that C compilers
# optimize slowly, for no fewer operations than the loops.  Measured on the
# n-link cart (gcc -O2, medians on a loaded machine): at 13x13 the unrolled
# factor makes the whole rhs ~25% faster (655 vs 890 ns) but triples that
# model's C compile (0.14 -> 0.43 s); at 21x21 it adds ~1 s.  16 is the compromise.
UNROLL_MAX_DENSE = 16


def ldlt_loop_solver(prefix, n):
    """Dense LDLᵀ in loops (n literal) for large, dense symmetric A."""
    fo = Counter(divs=n, muls=sum(2 * j + j * (n - j - 1) + (n - j - 1) for j in range(n)),
                 adds=sum(j + j * (n - j - 1) for j in range(n)))
    so = Counter(muls=n * n, adds=n * (n - 1))
    code = _LDLT_LOOP.format(p=prefix, n=n, n1=n + 1, nn=n * n)
    return Solver(f"{prefix}_ldlt_factor", f"{prefix}_ldlt_solve", code, fo, so,
                  n * n + n, False, reads_lower=True)


def choose_ldlt(prefix, n, pattern):
    """Unrolled sparse LDLᵀ, or the loop version for a large matrix that is nearly dense."""
    fill = len(_fill_pattern(n, pattern))
    if n > UNROLL_MAX_DENSE and fill > 0.6 * n * (n - 1) / 2:
        return ldlt_loop_solver(prefix, n)
    return ldlt_solver(prefix, n, pattern)


_LU = """\
static int {p}_lu_dense_factor(double *F, int *piv)
{{
    double scale = 0.0, tol;
    int i, j, k;
    for (i = 0; i < {nn}; i++) {{
        const double a = fabs(F[i]);
        if (!(a < HUGE_VAL)) return EOMC_NONFINITE;
        if (a > scale) scale = a;
    }}
    tol = 64.0 * DBL_EPSILON * scale;
    for (k = 0; k < {n}; k++) {{
        int m = k;
        double amax = fabs(F[k * {n} + k]), inv;
        for (i = k + 1; i < {n}; i++) {{
            const double a = fabs(F[i * {n} + k]);
            if (a > amax) {{ amax = a; m = i; }}
        }}
        if (!(amax > tol)) return EOMC_SINGULAR_MASS_MATRIX;
        piv[k] = m;
        if (m != k) {{
            for (j = 0; j < {n}; j++) {{
                const double s = F[k * {n} + j];
                F[k * {n} + j] = F[m * {n} + j];
                F[m * {n} + j] = s;
            }}
        }}
        inv = 1.0 / F[k * {n} + k];
        F[{nn} + k] = inv;
        for (i = k + 1; i < {n}; i++) {{
            const double l = F[i * {n} + k] * inv;
            F[i * {n} + k] = l;
            if (l != 0.0) {{
                for (j = k + 1; j < {n}; j++) F[i * {n} + j] -= l * F[k * {n} + j];
            }}
        }}
    }}
    return EOMC_OK;
}}

static void {p}_lu_dense_solve(const double *F, const int *piv, double *b)
{{
    int i, j;
    for (i = 0; i < {n}; i++) {{
        const double s = b[piv[i]];
        b[piv[i]] = b[i];
        b[i] = s;
        for (j = 0; j < i; j++) b[i] -= F[i * {n} + j] * b[j];
    }}
    for (i = {n} - 1; i >= 0; i--) {{
        for (j = {n} - 1; j > i; j--) b[i] -= F[i * {n} + j] * b[j];  /* newest b[i + 1] last */
        b[i] *= F[{nn} + i];
    }}
}}
"""


def dense_lu_code(prefix, n):
    """Static C functions ``<prefix>_lu_dense_factor`` / ``_lu_dense_solve`` (loops; n literal)."""
    return _LU.format(p=prefix, n=n, nn=n * n) + "\n"


def dense_lu_ops(n):
    fo = Counter(divs=n, muls=sum((n - k - 1) * (n - k) for k in range(n)),
                 adds=sum((n - k - 1) ** 2 for k in range(n)))
    so = Counter(muls=n * n, adds=n * (n - 1))
    return fo, so
