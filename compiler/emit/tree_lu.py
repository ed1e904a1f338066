"""``NAME_tree_lu``, ``NAME_tree_solve``, ``NAME_tree_residual``: the fixed step's factorisation of M's
tree pattern, its solves and its product with M as straight-line C.

Why: implicitfast factors ``A = M + h C~ + h^2 K~`` once per model call (runtime/c/eomc_fixedstep.c,
fs_tree_lu), eliminating from the leaves up over each speed's ancestor list.  The generic loop
reads its lists and row pointers at run time, and on gymnasium's humanoid (23 speeds, a free root:
1394 updates) it was half of the step's assembly and a sixth of a whole call (perf, session 45:
1.4 of 8.3 us).  The pattern is fixed by the model's tree, so the compiler knows every index: the
same eliminations written out, with constant offsets the C compiler can schedule and keep in
registers, run the humanoid's factorisation 2.4x faster in a harness (AVX2 build: 700 -> 290 ns).

The same operations in the same order as fs_tree_lu (its scale test, each pivot's test, u = A[i][k]
/ d as A[i][k] * (1 / d), a row whose u is 0 skipped, row k scaled last), each entry's sequence of
updates unchanged, so the same bits (tests/compiler/emit/test_tree_lu.py: against the loop in C on
random matrices of random trees; the lanes rollout, whose own factorisation is the loop's, still
equals the scalar rows bit for bit: tests/runtime/test_rollout_lanes*.py).  The step uses it only
where it factors M's own tree pattern (no pressed body-body pair across two branches: their fill
goes through the loop).

The solves with that factor (fs_tree_solve, two right sides at once in fs_tree_solve2: three to four a
call) were ~80 % of a try's own time outside the model (perf, the humanoid: 590 of 746 ns a call): a
chain of loads and stores through b[] in the loop, 23 values in registers here.
"""

__all__ = ["tree_lu_function", "tree_solve_function", "tree_residual_function", "tree_functions", "tree_lists",
           "TREE_LU_MAX_UPDATES", "TREE_LU_MAX_SPEEDS"]

# Speeds past this the step has no per-step pattern (eomc_fixedstep.c: "dyn", at most 64 speeds:
# every pair's fill at every step instead), so the function would never be called.
TREE_LU_MAX_SPEEDS = 64
# Updates (sum over speeds of their ancestors squared) past which the text is left out: a long
# chain's straight-line factorisation grows as n^3 (a 60-link chain: 70 000 lines), the loop's
# code does not.  The humanoid has 1394, G1 (35 speeds) about 3000.
TREE_LU_MAX_UPDATES = 6000


def tree_lists(parents):
    """Each speed's ancestors, nearest first (fs_ancestors' lists for a tree), or None when
    ``parents`` is not a tree ordered parent before child."""
    n = len(parents)
    if n == 0 or any(not isinstance(p, int) or not -1 <= p < s for s, p in enumerate(parents)):
        return None
    lists = []
    for k in range(n):
        a, i = [], parents[k]
        while i >= 0:
            a.append(i)
            i = parents[i]
        lists.append(a)
    return lists


def _written_lists(parents):
    """tree_lists(parents) where the step would use the written-out functions, else None (not a
    tree, more than TREE_LU_MAX_SPEEDS speeds, or more than TREE_LU_MAX_UPDATES updates)."""
    lists = tree_lists(parents)
    if lists is None or len(parents) > TREE_LU_MAX_SPEEDS or sum(len(a) ** 2 for a in lists) > TREE_LU_MAX_UPDATES:
        return None
    return lists


def tree_lu_function(name, parents):
    """The rendered function (prototype, body, parts) of ``int NAME_tree_lu(double *A)`` for the
    tree ``parents`` (per speed its parent, -1 at a root), or None (_written_lists)."""
    lists = _written_lists(parents)
    n = len(parents)
    if lists is None:
        return None
    # inv only where a speed has ancestors (a tree of roots alone, a hinge's: no update, and an
    # unused variable under -Wall -Wextra -Werror)
    out = [f"    double scale = 0.0, d{', inv' if any(lists) else ''};",
           f"    for (int k = 0; k < {n}; k++)",
           f"        if (fabs(A[k * {n} + k]) > scale) scale = fabs(A[k * {n} + k]);",
           "    if (!isfinite(scale)) return 1;"]
    for k in range(n - 1, -1, -1):
        a = lists[k]
        out.append(f"    d = A[{k * n + k}];")
        out.append("    if (!(fabs(d) > 64 * DBL_EPSILON * scale) || !isfinite(d)) return 1;")
        if not a:
            continue
        out.append("    inv = 1.0 / d;")
        out.append("    {")
        out.append("        double " + ", ".join(f"u{x} = A[{x * n + k}] * inv" for x in a) + ";")
        for x in a:
            updates = " ".join(f"A[{x * n + y}] -= u{x} * A[{k * n + y}];" for y in a)
            out.append(f"        if (u{x} != 0.0) {{ {updates} }}")
            out.append(f"        A[{x * n + k}] = u{x};")
        out.append("        " + " ".join(f"A[{k * n + y}] *= inv;" for y in a))
        out.append("    }")
    out.append("    return 0;")
    return {"prototype": f"int {name}_tree_lu(double *restrict A)", "body": "\n".join(out), "parts": []}


def _solve_lines(n, lists, vecs):
    """fs_tree_solve_n's operations on the vectors ``vecs`` (C names), each alone as the loop does
    it, interleaved: b[i] -= A[i][k] b[k] up the tree, b[k] /= A[k][k], b[k] -= A[k][i] b[i] down."""
    out = ["    double " + ", ".join(f"{v}{k} = {v}[{k}]" for v in vecs for k in range(n)) + ";"]
    for k in range(n - 1, -1, -1):
        for i in lists[k]:
            out.append("    " + " ".join(f"{v}{i} -= A[{i * n + k}] * {v}{k};" for v in vecs))
    for k in range(n):
        out.append("    " + " ".join(f"{v}{k} /= A[{k * n + k}];" for v in vecs))
    for k in range(n):
        for i in lists[k]:
            out.append("    " + " ".join(f"{v}{k} -= A[{k * n + i}] * {v}{i};" for v in vecs))
    out += ["    " + " ".join(f"{v}[{k}] = {v}{k};" for v in vecs) for k in range(n)]
    return out


def tree_solve_function(name, parents):
    """The rendered ``void NAME_tree_solve(const double *A, double *b, double *c)``: b := A^-1 b with
    A factored by NAME_tree_lu, and c := A^-1 c too unless c is NULL (fs_tree_solve, fs_tree_solve2:
    the same operations, so the same bits), or None (_written_lists)."""
    lists = _written_lists(parents)
    if lists is None:
        return None
    n = len(parents)
    body = ["    if (c == NULL) {", *("    " + line for line in _solve_lines(n, lists, ["b"])),
            "        return;", "    }", *_solve_lines(n, lists, ["b", "c"])]
    return {"prototype": f"void {name}_tree_solve(const double *restrict A, double *restrict b, double *restrict c)",
            "body": "\n".join(body), "parts": []}


def tree_residual_function(name, parents):
    """The rendered ``void NAME_tree_residual(const double *M, const double *f, const double *du, double h,
    double *r)``: r = M du - h f over M's tree pattern (a speed's ancestors, itself, its descendants),
    ascending, each row's sum in fs_residual's order (the same bits), or None (_written_lists).  Why: the fixed step's implicit Euler residual at each try's end, one product a call
    (perf, the humanoid: 254 ns a call in the loop over its column lists)."""
    lists = _written_lists(parents)
    if lists is None:
        return None
    n = len(parents)
    linked = [sorted({i, *lists[i], *(k for k in range(n) if i in lists[k])}) for i in range(n)]
    body = [f"    r[{i}] = -h * f[{i}]" + "".join(f" + M[{i * n + k}] * du[{k}]" for k in linked[i]) + ";"
            for i in range(n)]
    return {"prototype": f"void {name}_tree_residual(const double *restrict M, const double *restrict f, "
                         f"const double *restrict du, double h, double *restrict r)",
            "body": "\n".join(body), "parts": []}


def tree_functions(name, parents):
    """[NAME_tree_lu, NAME_tree_solve, NAME_tree_residual] rendered for the tree ``parents``, or []
    (_written_lists)."""
    if _written_lists(parents) is None:
        return []
    return [tree_lu_function(name, parents), tree_solve_function(name, parents), tree_residual_function(name, parents)]
