"""The recursive rhs's joint angles' sin and cos in four lanes (``NAME_tree_sincos``).

Why: a floating-base humanoid's rhs takes sin and cos of every joint angle, one glibc
``sincos`` call each (G1 29, Talos 44): 17 % of G1's rhs time (perf, session 24), and each call
makes the caller keep its live values in memory across it.  Computed four angles at a time
with :data:`~eomc.compiler.emit.batch.VECTOR_TRIG`'s fdlibm reduction and kernels in GNU C
vectors (within 1 ulp of glibc's sin and cos; |q| >= 2^19 pi/2, inf and NaN lanes call libm),
G1's rhs ran 13 % faster, Talos' 14 % (benchmarks/results/free_joint.md, session 24).

How: on the printed scalar rhs (its body and its sub-functions, the limb routines' parts
included: compiler/tree/limbs.py), after the split and after the lanes twin
(compiler/emit/batch.py) has taken its copy.  In each function, the top-level statements
``const double tN = sin(A[k]);`` (or cos) of one array A (x, a limb's xq) whose indices k form
a run (gaps of at most :data:`GAP`) of at least :data:`MIN_ANGLES` angles become reads of a
local array that one call fills at the first of them: ``double SCj[2m];
NAME_tree_sincos(&A[k0], m, SCj);`` (SCj[i], SCj[m + i]: sin and cos of A[k0 + i]).  The
inputs are the function's own, so the values are ready wherever the call sits; the order of
every other statement is unchanged.  The lanes of NAME_rhs_batch take the same kernels
(VECTOR_TRIG), so its lanes now give the scalar rhs's bits; ``-DEOMC_BATCH_LIBM_TRIG`` sends
both to libm (the scalar rhs too: the lanes stay the scalar rhs bit for bit).  Compiled wherever
gcc builds, and clang for AVX2 (GNU C vectors: without AVX2 gcc does them as SSE2 pairs, with the same bits,
so the portable build and the machine build still give the same rhs bits:
tests/compiler/build/test_machine_flags.py); in the c99-f32 target and under ``-DEOMC_NO_SIMD``
the helper is libm's sin and cos per angle.
A looped rhs (compiler/tree/chain_loop.py) keeps its own helper and is left as it is.
"""
import re

from .chain_loop import _lane_kernels

__all__ = ["tree_trig", "TRIG_GUARD", "MIN_ANGLES", "GAP"]

TRIG_GUARD = "EOMC_TREE_VTRIG"
MIN_ANGLES = 2       # angles of one run: fewer keep their libm call
GAP = 2              # indices a run may skip (their lanes are computed and not read)

_TRIG = re.compile(r"^    const double (t\d+(?:_\d+)?) = (sin|cos)\(([A-Za-z_]\w*)\[(-?\d+)\]\);$")
_HEAD = re.compile(r"^(static [^\n]*\))\n\{\n", re.S)


def helper_c(name):
    """``NAME_tree_sincos(q, n, sc)``: sc[k], sc[n + k] = sin and cos of q[k], k < n."""
    p = f"{name}_tv"
    kernels = _lane_kernels(p).replace("eomc_cvd", "eomc_tvd").replace("eomc_cvu", "eomc_tvu")
    return "\n".join([
        f"#ifndef {TRIG_GUARD}   /* the joint angles' sin and cos in four lanes (compiler/tree/trig.py) */",
        "#if defined(__GNUC__) && (defined(__AVX2__) || !defined(__clang__)) && !defined(EOMC_NO_SIMD) \\",
        "    && !defined(EOMC_BATCH_LIBM_TRIG)",
        f"#define {TRIG_GUARD} 1",
        "#else",
        f"#define {TRIG_GUARD} 0",
        "#endif",
        "#endif",
        f"#if {TRIG_GUARD} && !defined(__AVX__) && !defined(__clang__)   /* the vectors pass between inline functions only */",
        '#pragma GCC diagnostic ignored "-Wpsabi"',
        "#endif",
        f"#if {TRIG_GUARD}",
        "typedef double eomc_tvd __attribute__((vector_size(32)));",
        "typedef unsigned long long eomc_tvu __attribute__((vector_size(32)));",
        kernels,
        "",
        f"static int {name}_tree_vsincos(const double *restrict q, int n, double *restrict sc)",
        "{",
        "    int k, l;",
        "    eomc_tvd a, s, c;",
        "    if (n < 4) {      /* a short run: its last angle repeated in the other lanes */",
        "        for (l = 0; l < 4; l++) a[l] = q[l < n ? l : n - 1];",
        f"        {p}_vsincos(a, &s, &c);",
        "        for (l = 0; l < n; l++) {",
        "            sc[l] = s[l];",
        "            sc[n + l] = c[l];",
        "        }",
        "        return n;",
        "    }",
        "    for (k = 0;; k += 4) {",
        "        if (k > n - 4) k = n - 4;      /* the last group overlaps the one before it */",
        "        __builtin_memcpy(&a, q + k, sizeof a);",
        f"        {p}_vsincos(a, &s, &c);",
        "        __builtin_memcpy(sc + k, &s, sizeof s);",
        "        __builtin_memcpy(sc + n + k, &c, sizeof c);",
        "        if (k == n - 4) return n;",
        "    }",
        "}",
        "#endif",
        "",
        f"static void {name}_tree_sincos(const double *restrict q, int n, double *restrict sc)",
        "{",
        "    int k = 0;",
        f"#if {TRIG_GUARD}",
        f"    k = {name}_tree_vsincos(q, n, sc);",
        "#endif",
        "    for (; k < n; k++) {",
        "        const double s = sin(q[k]), c = cos(q[k]);",
        "        sc[k] = s;",
        "        sc[n + k] = c;",
        "    }",
        "}",
        ""])


def _runs(indices):
    """Maximal runs of the sorted indices with gaps of at most GAP."""
    out = []
    for k in sorted(set(indices)):
        if out and k - out[-1][-1] <= GAP + 1:
            out[-1].append(k)
        else:
            out.append([k])
    return out


def _rewrite(lines, name, counter):
    """``lines`` (one function's top-level lines) with their runs of angles from NAME_tree_sincos."""
    found = {}
    for i, line in enumerate(lines):
        m = _TRIG.match(line)
        if m:
            found.setdefault(m.group(3), []).append((i, int(m.group(4))))
    replace, insert = {}, {}
    for array, hits in sorted(found.items()):
        for run in _runs(k for _, k in hits):
            if len(run) < MIN_ANGLES:
                continue
            k0, m = run[0], run[-1] - run[0] + 1
            arr = f"SC{counter[0]}"
            counter[0] += 1
            at = [i for i, k in hits if run[0] <= k <= run[-1]]
            insert[min(at)] = [f"    double {arr}[{2 * m}];", f"    {name}_tree_sincos(&{array}[{k0}], {m}, {arr});"]
            for i in at:
                t, fn, _, k = _TRIG.match(lines[i]).groups()
                replace[i] = f"    const double {t} = {arr}[{int(k) - k0 + (m if fn == 'cos' else 0)}];"
    if not replace:
        return lines, False
    out = []
    for i, line in enumerate(lines):
        out += insert.get(i, [])
        out.append(replace.get(i, line))
    return out, True


def tree_trig(name, lines, parts):
    """(body lines, parts, helper text or "") of the scalar rhs with its angles' sin and cos
    from ``NAME_tree_sincos`` (module doc).  ``parts``: the texts of its static functions."""
    counter = [0]
    used = False
    new_parts = []
    for text in parts:
        m = _HEAD.match(text)
        if m is None or not text.endswith("\n}\n"):
            new_parts.append(text)
            continue
        body = text[m.end():-3].split("\n")
        counter[0] = 0
        body, changed = _rewrite(body, name, counter)
        used |= changed
        new_parts.append(text[:m.end()] + "\n".join(body) + "\n}\n" if changed else text)
    counter[0] = 0
    lines, changed = _rewrite(list(lines), name, counter)
    used |= changed
    return lines, new_parts, helper_c(name) if used else ""
