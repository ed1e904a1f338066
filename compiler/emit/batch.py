"""``NAME_rhs_batch``: the rhs at many states per call, several states per instruction (SIMD lanes).

Why: users who need the most rhs evaluations (Monte Carlo, sampling MPC, RL, many shooting
nodes) evaluate thousands of states at once, and one scalar call uses one of the 4 (AVX2) or
8 (AVX-512) double lanes of the machine (issue 31, item 1).

How: the lowering rewrites the printed, already split scalar rhs (its body lines and its
``NAME_rhs_partK`` sub-functions) into the same statements over GNU C vector types
(``eomc_vd``: ``EOMC_BATCH_LANES`` doubles, 4 unless the build defines it as 2 or 8).  A
temporary is a vector when its expression reads a state, an input, the scratch array or a
vector temporary; one made of parameters and literals stays a scalar double (computed once
for all lanes).  The same expressions in the same order, with no FMA contraction (the
target is ``avx2``/``avx512f`` without ``fma``), give the scalar rhs's bits lane by lane.
The exceptions are sin and cos: they go through :data:`VECTOR_TRIG` (fdlibm's reduction by
pi/2 in three parts and its kernels, vectorized: within 1 ulp of glibc's ``sin``/``cos``,
measured in tests/compiler/emit/test_batch.py), as a per-lane libm call would cost more than
the rest of a small model; a function that takes both sin and cos of one angle computes them
together (NAME_vsincos: one reduction, one pair of kernels, the same bits).  fabs, fmax and
fmin (joint limits) are vector bit operations and compares with libm's results bit for bit,
sqrt the vector instruction (correctly rounded, as libm's).
Other calls (pow, tanh, ...) are made lane by lane with the scalar libm function, so they are
exact (tanh, printed as eomc_tanh0, in the lanes that are not ±0).  Branches become per-lane: the singular-mass-matrix
guard and the finiteness check set a status per state; a block under a state-dependent test
(a contact's depth, a contact pair's broad phase: ``if (!(a > 0.0)) { ... } else { ... }``)
becomes a mask per lane (:meth:`_Rewriter.branch`): the block runs when one lane takes it, its
temporaries in every lane, its stores blended so the other lanes keep their values -- each
lane gets the scalar code's bits, and a contact out of reach in every lane skips its law.
``NAME_implicit_batch`` (the fixed-step implicit step's terms) takes the parameters shared: what
depends on them alone is one double for all lanes.  Kane's form computes A and b (its
NAME_dynamics helper, rewritten the same way) in lanes, then factors and solves each state's
A with the scalar LDLᵀ/LU code, one lane at a time: its pivoting and singularity test stay
per state, and the solve is a small part of the rhs.

A looped rhs (compiler/tree/chain_loop.py: ABA's three passes as loops over a chain's links,
the default from a run of 4 identical links) is rewritten the same way: its carried values,
per-link arrays and the pivots' sum and least become vectors, pass 2's backward loop and the
links' sin and cos (``NAME_chain_sincos``: in lanes ``NAME_vsincos_chain`` per link, the kernels
or libm exactly as the scalar helper takes them) are known shapes, so each lane gets the
looped rhs's bits but through the straight-line blocks' own sin and cos.  Its lanes also come as
``NAME_rhs_lanes2``: every statement written for two groups of lanes in turn (:func:`_pair_lanes`),
which ``NAME_rhs_groups`` calls on pairs of groups.  Why: a pass carries each link's values to
the next, a chain of dependent operations whose latency (pass 2's pivot division on it) bounds
one group; two groups' chains overlap (cart n = 40, 4 lanes: 442 -> 336 ns a state).

The limb routines' rhs (compiler/tree/limbs.py: a humanoid's twin legs and arms, one pair of
routines per limb shape running its limbs in turns) is rewritten the same way: each routine
``NAME_limbK_in``/``_out`` and its parts become ``NAME_vlimbK_*`` over vectors (a limb's slots,
its parent's velocity and acceleration, its T, f, pivots and stored values; its table of numbers,
``kk``, stays doubles), and the rhs's pivot sum and threshold are vectors, its per-pivot test a
guard per lane.  Why: on G1 the routines are what made the scalar rhs faster than the
straight-line one (instruction cache), and the lanes of the straight-line rhs sat at the 3x line
(2.67-3.26x); with the routines in lanes 3.1-3.6x (benchmarks/results/rhs_batch.md).

Where a C compiler lacks GNU vectors (``__GNUC__`` undefined), or the CPU lacks the lanes'
instruction set (``__builtin_cpu_supports``), or the body has a statement shape this
rewrite does not know, ``NAME_rhs_batch`` loops the scalar ``NAME_rhs`` over the states: the
same results, no lanes; the metadata's ``rhs_batch.vectorized`` says which (and ``why``).
States past the last full group of lanes (the tail) always take the scalar rhs, in tiles of up
to 8 states (:func:`scalar_tile`), as does the whole loop when the rhs is not vectorized.

Layout: states are columns, structure of arrays: ``X[i*n + k]`` is component i of state k,
the inputs likewise (``R[j*n + k]``, or NULL for zero inputs), the parameters shared.  A
state whose status is not EOMC_OK gets NaN rows (EOMC_NONFINITE: the rows as computed).  The
lanes take the states in tiles of up to 32 (``NAME_rhs_groups``): each row's part of a tile is
copied into a local array before the tile and its outputs out after it, whole cache lines at a
time, as rows a power of two apart share the L1 cache's sets (:data:`TILE_BYTES`).
"""
import re

from .printer import MINMAX_NAMES
from .target import without_cpu_dispatch

__all__ = ["batch_code", "batch_rhs", "Unsupported", "SIMD_PRELUDE", "VECTOR_TRIG", "TILE_BYTES", "SCALAR_TILE_BYTES"]

# t<k>_<i>: limb i's copy of a temporary (tree/limbs.py: a limb shape's routine runs its limbs line by line in turns)
_TEMP_LINE = re.compile(r"^(\s+)const double (t\d+(?:_\d+)?|o\d+|piv) = (.*);$")
_STORE_LINE = re.compile(r"^(\s+)([A-Za-z_]\w*)\[(-?\d+|\d+ \+ k|k|\d+ \* k \+ \d+)\] = (.*);$")
# the looped rhs (compiler/tree/chain_loop.py: ABA's passes as loops over a chain's links): its
# carried values and the pivots' sum and least, declared with their start values and assigned
# in every pass (vectors in lanes); pass 2 runs its links backwards; the links' sin and cos
# come from NAME_chain_sincos into an array before the passes
# (thr: the limb routines' rhs's pivot threshold, assigned once: tree/limbs.py)
_VAR_NAME = r"(?:c[vTfa]\d+|dsum|dmin|thr)"
_VAR_DECLS = re.compile(rf"^(\s+)double ((?:{_VAR_NAME} = [^,;]+, )*{_VAR_NAME} = [^,;]+);$")
_VAR_SET = re.compile(rf"^(\s+)({_VAR_NAME}) (=|\+=) (.*);$")
_RUNNING_MIN = re.compile(r"^(\s+)(dmin) = (\w+) < \2 \? \3 : \2;$")
_LOOP_DOWN = re.compile(r"^(\s+)for \(k = (\d+); k >= 0; k--\) \{$")
_CHAIN_SINCOS = re.compile(r"^(\s+)[A-Za-z_]\w*_chain_sincos\(x \+ (\d+), (\d+), ([A-Za-z_]\w*)\);$")
# jac_x's tangent form (compiler/emit/generated.py): a loop over the tangent columns, G pointing
# at column k of Gm, runs of zero stores as loops; k and G's offset are the same in every lane
_LOOP_HEAD = re.compile(r"^(\s+)for \(k = (\d+); k < (\d+); k\+\+\) \{$")
_ZERO_RUN = re.compile(r"^(\s+)for \(k = (\d+); k < (\d+); k\+\+\) ([A-Za-z_]\w*)\[k\] = (-?[0-9.e+-]+);$")
_INT_DECL = re.compile(r"^\s+(?:int [a-z_]\w*;|static const int [A-Za-z_]\w*\[\d+\] = \{[-\d, ]*\};)$")
_GATHER = re.compile(r"^(\s+)for \(e = 0; e < \d+; e\+\+\) ([A-Za-z_]\w*)\[e\] = ([A-Za-z_]\w*)\[\d+ \+ sp\[e\]\];$")
_GATHER_HEAD = re.compile(r"^\s+for \(e = 0; e < \d+; e\+\+\) \{$")
_GATHER_ITEM = re.compile(r"^(\s+)([A-Za-z_]\w*)\[e\] = ([A-Za-z_]\w*)\[(?:\d+ \+ )?sp\[e\]\];$")
_SCRATCH_DECLS = re.compile(r"^(\s+)double ((?:[A-Za-z_]\w*\[\d+\], )+[A-Za-z_]\w*\[\d+\]);$")
_POINTER_DECL = re.compile(r"^(\s+)const double \*([A-Za-z_]\w*);$")
_POINTER_SET = re.compile(r"^(\s+)([A-Za-z_]\w*) = ([A-Za-z_]\w*) \+ k \* (\d+);$")
_SCRATCH_DECL = re.compile(r"^(\s+)double ([A-Za-z_]\w*)\[(\d+)\];$")
_CALL_LINE = re.compile(r"^(\s+)([A-Za-z_]\w*)\((.*)\);$")
# the body-body pairs' table loop (compiler/contact/table.py; NAME_implicit's: its slopes variant):
# one call on a compound literal of its inputs, the law parameters, full, and the output array;
# NAME_implicit's then the slope block's place in out[], its length and whether the loop keeps it
# (table.PairTableSlopesInto, KEPT_BLOCK: the lanes' loop is called with 0, each lane's block zeroed)
_PAIRS_LINE = re.compile(r"^(\s+)const double (t\d+) = (eomc_pairs|eomc_pairs_slopes)\(\(const double\[(\d+)\]\)\{(.*)\}, "
                         r"&([A-Za-z_]\w*)\[(\d+)\], (0|1), &([A-Za-z_]\w*)\[(\d+)\]"
                         r"(?:, &([A-Za-z_]\w*)\[(\d+)\], (\d+), (?:0|1))?\);$")
_VOID_TEMP = re.compile(r"^\s+\(void\)t\d+;$")
_GUARD_LINE = re.compile(r"^(\s+)if \((.*)\) return (EOMC_[A-Z_]+);$")
# (or NAME_implicit's short form when its pairs' loop sums what it wrote: compiler/tree/emit.finite_return)
_FINITE_RETURN = re.compile(r"^(\s+)return (?:(t\d+|S_\[\d+\]) - \2 == 0\.0 \? (?:[A-Za-z_]\w*_finite_wide\(out, \d+\)"
                            r"|\([A-Za-z_]\w*_finite_wide\(out, \d+\) == EOMC_OK \? [A-Za-z_]\w*_finite_wide\(out \+ \d+, \d+\)"
                            r" : EOMC_NONFINITE\)) : )?"
                            r"[A-Za-z_]\w*_finite(?:_wide)?\((?:xdot|out), \d+\);$")
# a branch of the scalar code (a contact's depth test, a pair's broad phase): in lanes, a mask
_IF_LINE = re.compile(r"^(\s+)if \((.*)\) \{$")
_ELSE_LINE = re.compile(r"^(\s+)\} else \{$")
_RELATION = re.compile(r" (>=|<=|>|<) ")
_PART_HEAD = re.compile(r"^static (?:EOMC_NOINLINE|EOMC_NEAR) void ([A-Za-z_]\w*)\((.*)\)$")
# the limb routines (compiler/tree/limbs.py): a shape's routine running its limbs in turns, its table of numbers
_LIMB_HEAD = re.compile(r"^static void ([A-Za-z_]\w*_limb\d+_(?:in|out))\((.*)\)$")
_LIMB_TABLE = re.compile(r"^static const double [A-Za-z_]\w*_limb_k\d+\[\d+\] = \{[^}]*\};\s*$")
# the limb routines' rhs: its arrays (the limbs' velocities, accelerations, T, f, pivots, stored values,
# the pivots' sum) and threshold; the pivots summed in a loop
_LIMB_DECLS = re.compile(r"^(\s+)double ((?:l[A-Za-z]+\[\d+\], )+)lS\[1\] = \{0\.0\}, thr;$")
_SUM_LOOP = re.compile(r"^(\s+)for \(k = 0; k < \d+; k\+\+\) ([A-Za-z_]\w*)\[0\] \+= ([A-Za-z_]\w*)\[k\];$")
_VOID_NAME = re.compile(r"^\s+\(void\)[A-Za-z_]\w*;$")
_ARRAY_REF = re.compile(r"\b([A-Za-z_]\w*)\[")
_TEMP = re.compile(rf"\b(?:t\d+(?:_\d+)?|o\d+|piv|{_VAR_NAME})\b")     # a temporary (or the looped rhs's variable)
_CALL = re.compile(r"\b([A-Za-z_]\w*)\(")
_IDENT = re.compile(r"\b([A-Za-z_]\w*)\b")

# calls made lane by lane with libm's own function (exact); sin and cos have vector kernels
MATH1 = ("sqrt", "fabs", "exp", "log", "tan", "tanh", "sinh", "cosh", "atan", "asin", "acos", "cbrt",
         "expm1", "log1p", "floor", "ceil", "erf", "asinh", "acosh", "atanh", "log10", "log2", "exp2")
MATH2 = ("pow", "atan2", "fmin", "fmax", "hypot", "fmod", "copysign")
# the printer's inline fmax/fmin (printer.MINMAX_C) -> their libm names, whose lane helpers follow
_LIBM = {inline: libm for libm, inline in MINMAX_NAMES.items()}

SIMD_PRELUDE = r"""#if defined(__GNUC__) && !defined(EOMC_NO_SIMD)
#define EOMC_BATCH_SIMD 1
#ifndef EOMC_NOINLINE
#define EOMC_NOINLINE
#endif
#ifndef EOMC_BATCH_LANES
#define EOMC_BATCH_LANES 4
#endif
#if EOMC_BATCH_LANES != 2 && EOMC_BATCH_LANES != 4 && EOMC_BATCH_LANES != 8
#error "EOMC_BATCH_LANES must be 2, 4 or 8"
#endif
#if (defined(__x86_64__) || defined(__i386__)) && EOMC_BATCH_LANES == 8
#define EOMC_VTARGET __attribute__((target("avx512f")))
#define EOMC_VCPU_OK() __builtin_cpu_supports("avx512f")
#elif (defined(__x86_64__) || defined(__i386__)) && EOMC_BATCH_LANES == 4
#define EOMC_VTARGET __attribute__((target("avx2")))
#define EOMC_VCPU_OK() __builtin_cpu_supports("avx2")
#else
#define EOMC_VTARGET
#define EOMC_VCPU_OK() 1
#endif
/* sin and cos of one argument, inlined side by side, share their reduction and kernels */
#define EOMC_VINLINE inline __attribute__((always_inline))
typedef double eomc_vd __attribute__((vector_size(8 * EOMC_BATCH_LANES)));
typedef unsigned long long eomc_vu __attribute__((vector_size(8 * EOMC_BATCH_LANES)));
#else
#define EOMC_BATCH_SIMD 0
#endif"""

# fdlibm (FreeBSD msun e_rem_pio2.c, k_sin.c, k_cos.c; Sun's permissive notice) in lanes:
# x = n*pi/2 + y0 + y1 by Cody-Waite: fdlibm's first round (pi/2 in 33 + 53 bits), its 2nd
# and 3rd rounds taken in the lanes that need them (fdlibm's tests on the bits cancelled; each
# lane's bits depend on its own x alone), then the degree-13/14 kernels on
# |y| <= pi/4 and the quadrant as a bit select.  |x| >= 2^19*pi/2, inf and NaN lanes take
# libm's sin/cos (fdlibm's medium-size reduction holds below that).  -DEOMC_BATCH_LIBM_TRIG
# makes every lane call libm: NAME_rhs_batch is then the scalar rhs bit for bit.
VECTOR_TRIG = r"""static EOMC_VTARGET EOMC_VINLINE void {p}_vkernel(eomc_vd x, eomc_vu *q, eomc_vd *s, eomc_vd *c)
{{
    const double toint = 6755399441055744.0;   /* 1.5 * 2^52: adding it rounds to an integer */
    eomc_vd k = x * 6.36619772367581382433e-01 + toint;
    eomc_vd fn = k - toint;
    eomc_vd r = x - fn * 1.57079632673412561417e+00;
    eomc_vd w = fn * 6.07710050650619224932e-11;
    eomc_vd y0 = r - w, y1, t, z, v, rs, rc;
    /* fdlibm's tests: more than 16 bits cancelled in a lane (x near a multiple of pi/2) needs
       the 2nd round, more than 49 after it the 3rd; each round is computed for all lanes when
       one lane needs it and taken only in the lanes that need it, as fdlibm's scalar code does,
       so a lane's bits depend on its own x alone, not on the other states of its batch (the
       lanes rollout's rows then do not depend on which rows share their rounds) */
    const eomc_vu ex = ((eomc_vu)x >> 52) & 0x7ff;
    eomc_vu far = (eomc_vu)(ex - (((eomc_vu)y0 >> 52) & 0x7ff) > 16);
    unsigned long long any = 0;
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) any |= far[l];
    *q = (eomc_vu)k;
    if (any) {{
        const eomc_vu far2 = far;
        eomc_vd r2, w2, y2;
        t = r;
        w2 = fn * 6.07710050630396597660e-11;
        r2 = t - w2;
        w2 = fn * 2.02226624879595063154e-21 - ((t - r2) - w2);
        y2 = r2 - w2;
        far = far2 & (eomc_vu)(ex - (((eomc_vu)y2 >> 52) & 0x7ff) > 49);
        any = 0;
        for (l = 0; l < EOMC_BATCH_LANES; l++) any |= far[l];
        if (any) {{
            eomc_vd r3, w3;
            t = r2;
            w3 = fn * 2.02226624871116645580e-21;
            r3 = t - w3;
            w3 = fn * 8.47842766036889956997e-32 - ((t - r3) - w3);
            r2 = (eomc_vd)(((eomc_vu)r3 & far) | ((eomc_vu)r2 & ~far));
            w2 = (eomc_vd)(((eomc_vu)w3 & far) | ((eomc_vu)w2 & ~far));
            y2 = r2 - w2;
        }}
        r = (eomc_vd)(((eomc_vu)r2 & far2) | ((eomc_vu)r & ~far2));
        w = (eomc_vd)(((eomc_vu)w2 & far2) | ((eomc_vu)w & ~far2));
        y0 = (eomc_vd)(((eomc_vu)y2 & far2) | ((eomc_vu)y0 & ~far2));
    }}
    y1 = (r - y0) - w;
    z = y0 * y0;
    w = z * z;
    v = z * y0;
    rs = 8.33333333332248946124e-03 + z * (-1.98412698298579493134e-04 + z * 2.75573137070700676789e-06)
        + z * w * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10);
    *s = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * -1.66666666666666324348e-01);
    rc = z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * 2.48015872894767294178e-05))
        + w * w * (-2.75573143513906633035e-07 + z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11));
    t = 0.5 * z;
    v = 1.0 - t;
    *c = v + (((1.0 - v) - t) + (z * rc - y0 * y1));
}}

/* sin (shift 0) or cos (shift 1) from the kernels by the quadrant: a bit select and a sign */
static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_vquadrant(eomc_vu q, eomc_vd s, eomc_vd c)
{{
    const eomc_vu odd = (eomc_vu)((q & 1) != 0);
    eomc_vu bits = ((eomc_vu)c & odd) | ((eomc_vu)s & ~odd);
    bits ^= (q & 2) << 62;
    return (eomc_vd)bits;
}}

/* the lanes libm takes: |x| >= 2^19*pi/2, inf, NaN (one vector compare; *any says if one is) */
static EOMC_VTARGET EOMC_VINLINE eomc_vu {p}_vbig(eomc_vd x, int *any)
{{
    const eomc_vu big = ~(eomc_vu)((eomc_vd)((eomc_vu)x & 0x7fffffffffffffffULL) < 823549.6656250000);
    unsigned long long a = 0;
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) a |= big[l];
    *any = a != 0;
    return big;
}}

static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_vtrig(eomc_vd x, unsigned long long shift)
{{
    eomc_vu q;
    eomc_vd s, c, y;
    int l, any;
    {p}_vkernel(x, &q, &s, &c);
    y = {p}_vquadrant(q + shift, s, c);
#ifdef EOMC_BATCH_LIBM_TRIG
    (void)any;
    for (l = 0; l < EOMC_BATCH_LANES; l++) y[l] = shift ? cos(x[l]) : sin(x[l]);   /* the scalar rhs's bits */
#else
    {{
        const eomc_vu big = {p}_vbig(x, &any);
        if (any) {{
            for (l = 0; l < EOMC_BATCH_LANES; l++) {{
                if (big[l]) y[l] = shift ? cos(x[l]) : sin(x[l]);
            }}
        }}
    }}
#endif
    return y;
}}

static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_vsin(eomc_vd x)
{{
    return {p}_vtrig(x, 0);
}}

static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_vcos(eomc_vd x)
{{
    return {p}_vtrig(x, 1);
}}

/* sin and cos of one angle from one reduction and one pair of kernels: the same bits as
   {p}_vsin and {p}_vcos (the rewrite pairs them when a function uses both of one angle) */
static EOMC_VTARGET EOMC_VINLINE void {p}_vsincos(eomc_vd x, eomc_vd *so, eomc_vd *co)
{{
    eomc_vu q;
    eomc_vd s, c;
    int l, any;
    {p}_vkernel(x, &q, &s, &c);
    *so = {p}_vquadrant(q, s, c);
    *co = {p}_vquadrant(q + 1, s, c);
#ifdef EOMC_BATCH_LIBM_TRIG
    (void)any;
    for (l = 0; l < EOMC_BATCH_LANES; l++) {{
        (*so)[l] = sin(x[l]);
        (*co)[l] = cos(x[l]);
    }}
#else
    {{
        const eomc_vu big = {p}_vbig(x, &any);
        if (any) {{
            for (l = 0; l < EOMC_BATCH_LANES; l++) {{
                if (big[l]) {{
                    (*so)[l] = sin(x[l]);
                    (*co)[l] = cos(x[l]);
                }}
            }}
        }}
    }}
#endif
}}"""

# The looped rhs's links' sin and cos in lanes (NAME_chain_sincos, compiler/tree/chain_loop.py):
# what that scalar helper runs, lane by lane -- the kernels above where it has lanes (its guard
# EOMC_CHAIN_VTRIG, defined before it: gcc with AVX2), libm's sin and cos where it has not --
# so each lane gets the scalar rhs's bits.  Not switched by EOMC_BATCH_LIBM_TRIG, as the scalar
# helper is not.  (The test is "!= 0": the f32 target cuts "#if EOMC_CHAIN_VTRIG" blocks whole.)
_CHAIN_TRIG = """static EOMC_VTARGET EOMC_VINLINE void {p}_vsincos_chain(eomc_vd x, eomc_vd *so, eomc_vd *co)
{{
    int l;
#if EOMC_CHAIN_VTRIG != 0
    eomc_vu q, big;
    eomc_vd s, c;
    int any;
    {p}_vkernel(x, &q, &s, &c);
    *so = {p}_vquadrant(q, s, c);
    *co = {p}_vquadrant(q + 1, s, c);
    big = {p}_vbig(x, &any);
    if (any) {{
        for (l = 0; l < EOMC_BATCH_LANES; l++) {{
            if (big[l]) {{
                (*so)[l] = sin(x[l]);
                (*co)[l] = cos(x[l]);
            }}
        }}
    }}
#else
    for (l = 0; l < EOMC_BATCH_LANES; l++) {{
        (*so)[l] = sin(x[l]);
        (*co)[l] = cos(x[l]);
    }}
#endif
}}"""

_VSET = """static EOMC_VTARGET eomc_vd {p}_vset(double a)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = a;
    return v;
}}"""

# fabs, fmax and fmin as vector bit operations and compares: bit for bit libm's and the scalar
# inline form's (printer.MINMAX_C; glibc 2.36 x86-64: fmax/fmin return a when a > b (a < b) or
# b is NaN, else b -- so b for a == b: fmax(-0, +0) = +0), not a call per lane -- joint limits
# put two fmax per joint in a robot's rhs (UR10: 26 of them)
_VECTOR_EXACT = {
    "fabs": """static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_v_fabs(eomc_vd a)
{{
    return (eomc_vd)((eomc_vu)a & 0x7fffffffffffffffULL);
}}""",
    "fmax": """static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_v_fmax(eomc_vd a, eomc_vd b)
{{
    const eomc_vu take_a = (eomc_vu)((a > b) | (b != b));
    return (eomc_vd)(((eomc_vu)a & take_a) | ((eomc_vu)b & ~take_a));
}}""",
    "fmin": """static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_v_fmin(eomc_vd a, eomc_vd b)
{{
    const eomc_vu take_a = (eomc_vu)((a < b) | (b != b));
    return (eomc_vd)(((eomc_vu)a & take_a) | ((eomc_vu)b & ~take_a));
}}""",
}

# sqrt is correctly rounded (IEEE 754), so the vector instruction gives libm's bits in every lane
# (a NaN's sign or payload aside); a call per lane cost Go2's implicit_batch 15 % of its time
_VECTOR_EXACT["sqrt"] = """static EOMC_VTARGET EOMC_VINLINE eomc_vd {p}_v_sqrt(eomc_vd a)
{{
#if (defined(__x86_64__) || defined(__i386__)) && EOMC_BATCH_LANES == 8
    return (eomc_vd)__builtin_ia32_sqrtpd512_mask(a, a, (unsigned char)0xff, 4);   /* _MM_FROUND_CUR_DIRECTION */
#elif (defined(__x86_64__) || defined(__i386__)) && EOMC_BATCH_LANES == 4
    return (eomc_vd)__builtin_ia32_sqrtpd256(a);
#elif defined(__x86_64__) && EOMC_BATCH_LANES == 2
    return (eomc_vd)__builtin_ia32_sqrtpd(a);
#else
    eomc_vd v = {{0}};
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = sqrt(a[l]);
    return v;
#endif
}}"""

# printer.MINMAX_C's eomc_tanh0 in lanes: libm's tanh in each lane but where the lane is ±0 (a joint
# inside its range: its limit's stretch is 0), which keeps its value, as the scalar helper does
_VECTOR_EXACT["tanh0"] = """static EOMC_VTARGET eomc_vd {p}_v_tanh0(eomc_vd a)
{{
    eomc_vd v = a;
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) if (a[l] != 0.0) v[l] = tanh(a[l]);
    return v;
}}"""

# printer.MINMAX_C's eomc_tanhc in lanes, lane by lane with the scalar helper's arithmetic (the joint
# friction's secant slope, compiler/tree/joint_laws.tanhc)
_VECTOR_EXACT["tanhc"] = """static EOMC_VTARGET eomc_vd {p}_v_tanhc(eomc_vd a)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = a[l] != 0.0 ? tanh(a[l]) / a[l] : 1.0;
    return v;
}}"""

_VECTOR_EXACT["sign"] = """static EOMC_VTARGET eomc_vd {p}_v_sign(eomc_vd a)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = (a[l] > 0) - (a[l] < 0);   /* SymPy's sign, as the scalar C */
    return v;
}}"""

_VECTOR_EXACT["step"] = """static EOMC_VTARGET eomc_vd {p}_v_step(eomc_vd a)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = a[l] > 0.0 ? 1.0 : 0.0;   /* Heaviside, as the scalar C */
    return v;
}}"""

# a branch's block runs when one lane of its mask is set (compiler/emit/batch.py _Rewriter.branch)
_VANY = """static EOMC_VTARGET EOMC_VINLINE int {p}_vany(eomc_vu m)
{{
    unsigned long long a = 0;
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) a |= m[l];
    return a != 0;
}}"""

# A lane's outputs of the pairs' loop into their vectors (pairs_call).  Why a helper: a store of
# one double into each of n vectors is a cache line each, and on the humanoid (1059 + 2725
# outputs, mostly the far pairs' zeros) those stores were half of NAME_implicit_batch's time
# (perf): the vectors are zeroed whole before the loop, and a run of four +0.0 is skipped.
_PUT_LANE = """static EOMC_VTARGET EOMC_VINLINE void {p}_put_lane(eomc_vd *dst, const double *src, int n, int l)
{{
    int k;
    for (k = 0; k + 4 <= n; k += 4) {{
        unsigned long long b[4];
        __builtin_memcpy(b, src + k, sizeof b);
        if ((b[0] | b[1] | b[2] | b[3]) == 0) continue;     /* +0.0 there already */
        dst[k][l] = src[k];
        dst[k + 1][l] = src[k + 1];
        dst[k + 2][l] = src[k + 2];
        dst[k + 3][l] = src[k + 3];
    }}
    for (; k < n; k++) dst[k][l] = src[k];
}}"""

_COMPARE = re.compile(r"[<>?]|==|!=")
# the printed forms of SymPy's sign(a) and Heaviside(a) (joint limits' jac_x): (head, tail after
# the balanced operand a, the marker _calls turns into the lanes' helper or back into C)
_PIECEWISE = (("(((", " > 0) - (({a}) < 0))", "EOMC_SIGN"), ("((", " > 0.0 ? 1.0 : 0.0)", "EOMC_STEP"))
_SCALAR_FORM = {"EOMC_SIGN": "((({a}) > 0) - (({a}) < 0))", "EOMC_STEP": "(({a}) > 0.0 ? 1.0 : 0.0)"}


def _signs(expr):
    """``expr`` with every ``(((a) > 0) - ((a) < 0))`` written ``EOMC_SIGN(a)`` and every
    ``((a) > 0.0 ? 1.0 : 0.0)`` written ``EOMC_STEP(a)``."""
    for head, tail, marker in _PIECEWISE:
        out, i = [], 0
        while True:
            j = expr.find(head, i)
            if j < 0:
                out.append(expr[i:])
                break
            k, depth = j + len(head), 1
            while k < len(expr) and depth:
                depth += {"(": 1, ")": -1}.get(expr[k], 0)
                k += 1
            a = expr[j + len(head):k - 1]
            rest = tail.format(a=a)
            if depth == 0 and expr.startswith(rest, k):
                out.append(expr[i:j] + f"{marker}({a})")
                i = k + len(rest)
            else:
                out.append(expr[i:j + 1])
                i = j + 1
        expr = "".join(out)
    return expr


_LANEWISE1 = """static EOMC_VTARGET eomc_vd {p}_v_{f}(eomc_vd a)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = {f}(a[l]);
    return v;
}}"""

_LANEWISE2 = """static EOMC_VTARGET eomc_vd {p}_v_{f}(eomc_vd a, eomc_vd b)
{{
    eomc_vd v = {{0}};   /* every lane set below; the zero keeps gcc's -Wmaybe-uninitialized quiet */
    int l;
    for (l = 0; l < EOMC_BATCH_LANES; l++) v[l] = {f}(a[l], b[l]);
    return v;
}}"""


# batch functions whose parameters are one row for all states (a double array, not lanes)
SHARED_PARAMETERS = ("implicit",)
SHARED_PARAMETERS_ARRAY = "p"


class Unsupported(ValueError):
    """A statement of the scalar rhs the lane rewrite does not know; NAME_rhs_batch then loops
    the scalar rhs (correct, not vectorized).  The message names the statement."""


class _Rewriter:
    """Types (vector or scalar) of one function's temporaries and the rewrite of its lines."""

    def __init__(self, prefix, vector_arrays, scalar_arrays, used):
        self.prefix = prefix
        self.vec_arrays = set(vector_arrays)
        self.scalar_arrays = set(scalar_arrays)
        self.vtemps = set()
        self.used = used            # helper names the rewritten code calls
        self.paired = set()         # angles (x[i] or a temporary) whose sin and cos both occur
        self.sincos = {}            # angle -> its k in sin_k, cos_k (computed by NAME_vsincos)
        self.pre = []               # declarations the current statement needs first
        self.blocks = []            # open blocks: None (a loop, a scalar branch) or a branch's masks
        self.nbranch = 0            # branches so far (their masks' names)
        self.masked = set()         # arrays stored under a mask (the other lanes' old values read)
        self.sizes = {}             # local arrays' declared sizes
        self.pairs_read = {}        # a pairs' table function -> the outputs it zeroes for full = 0 (_pairs_read)
        self.pairs_energy = {}      # ... -> where it writes its points' elastic energy (_pairs_energy)
        self.rows_ok = False        # NAME_implicit_lanes' body: the pairs' slope block may go to rows_ (pairs_call)
        self.rows_block = None      # ... and it does: (its first output, its length)

    @property
    def mask(self):
        """The lanes the current statement applies to: the innermost vector branch's mask
        (a name), None outside every vector branch (all lanes)."""
        return next((b["mask"] for b in reversed(self.blocks) if b is not None), None)

    def branch(self, indent, cond):
        """``if (cond) {`` on a state-dependent cond: the condition's lanes as a mask; the
        block runs when one of its lanes is set (a contact out of reach in every lane skips
        its law, as the scalar code does) and its stores keep the other lanes' values.
        None when cond is not state-dependent (a plain C branch)."""
        negated = cond.startswith("!(") and cond.endswith(")") and _balanced(cond[2:-1])
        inner = cond[2:-1] if negated else cond
        parts = _top_level_relation(inner)
        if parts is None:
            if self.is_vector(inner):
                raise Unsupported(f"a branch on {cond[:80]!r}")
            return None
        a, op, b = parts
        (ta, va), (tb, vb) = self.expression(a), self.expression(b)
        if not (va or vb):
            return None
        pre = self.take_pre(indent)
        k = self.nbranch
        self.nbranch += 1
        self.used.add("mask")
        parent = self.mask
        test = f"(eomc_vu)(({ta}) {op} ({tb}))"
        mask = f"~c{k}_" if negated else f"c{k}_"
        other = f"c{k}_" if negated else f"~c{k}_"
        if parent is not None:
            mask, other = f"{parent} & {mask}", f"{parent} & {other}"
        self.blocks.append({"mask": f"m{k}_", "else": (f"e{k}_", other)})
        return (f"{pre}{indent}const eomc_vu c{k}_ = {test};\n"
                f"{indent}const eomc_vu m{k}_ = {mask};\n"
                f"{indent}if ({self.prefix}_vany(m{k}_)) {{")

    def branch_else(self, indent):
        """``} else {`` of a vector branch: the other lanes of the enclosing mask."""
        block = self.blocks[-1] if self.blocks else None
        if block is None:
            return f"{indent}}} else {{"
        name, expr = block["else"]
        block["mask"] = name
        return (f"{indent}}}\n"
                f"{indent}const eomc_vu {name} = {expr};\n"
                f"{indent}if ({self.prefix}_vany({name})) {{")

    def pair_scan(self, lines):
        """Note the angles whose sin and cos this function both takes: at the first of the
        two, one NAME_vsincos computes both (one reduction and one pair of kernels; a store
        between the two calls would otherwise keep the compiler from sharing them)."""
        seen = {"sin": set(), "cos": set()}
        for line in lines:
            for fn, arg in re.findall(r"\b(sin|cos)\((xq?\d*\[\d+\]|t\d+(?:_\d+)?)\)", line):
                seen[fn].add(arg)
        self.paired = seen["sin"] & seen["cos"]
        self.sincos = {}

    def take_pre(self, indent):
        pre, self.pre = self.pre, []
        return "".join(f"{indent}{line}\n" for line in pre)

    def is_vector(self, expr):
        for name in _ARRAY_REF.findall(expr):
            if name in self.vec_arrays:
                return True
            if name not in self.scalar_arrays:
                raise Unsupported(f"reads array {name}[] (not a state, input, scratch or parameter)")
        return any(t in self.vtemps for t in _TEMP.findall(expr))

    def expression(self, expr):
        """``expr`` with calls on vectors turned into the lane helpers; (text, is_vector).

        SymPy's sign(a), printed ``(((a) > 0) - ((a) < 0))`` (jac_x of |a|), becomes a call of
        the lane-wise sign; any other comparison on a vector is refused: a vector compare
        gives -1/0 masks, not C's 1/0, so it cannot be left as written."""
        expr = _signs(expr)
        vec = self.is_vector(expr)
        if vec and _COMPARE.search(expr):
            raise Unsupported(f"compares a state-dependent value in {expr[:80]!r}")
        return self._calls(expr), vec

    def _calls(self, expr):
        out, i = [], 0
        while True:
            m = _CALL.search(expr, i)
            if m is None:
                out.append(expr[i:])
                return "".join(out)
            out.append(expr[i:m.start()])
            name, j, depth, start, args = m.group(1), m.end(), 1, m.end(), []
            while depth:
                if j >= len(expr):
                    raise Unsupported(f"unbalanced parentheses in {expr!r}")
                ch = expr[j]
                if ch == "(":
                    depth += 1
                elif ch == ")":
                    depth -= 1
                    if depth == 0:
                        args.append(expr[start:j])
                elif ch == "," and depth == 1:
                    args.append(expr[start:j])
                    start = j + 1
                j += 1
            vec = [self.is_vector(a) for a in args]
            new = [self._calls(a) for a in args]
            if name in _SCALAR_FORM:      # _signs's markers: the lanes' helper, or the C as printed
                if vec[0]:
                    self.used.add(name[5:].lower())
                    out.append(f"{self.prefix}_v_{name[5:].lower()}({new[0]})")
                else:
                    out.append(_SCALAR_FORM[name].format(a=new[0]))
            elif not any(vec):
                out.append(f"{name}({','.join(new)})")
            elif name == "eomc_limit_stored" and len(args) == 2:     # printer.CALLED_C's, in lanes: its sum
                r, e = (f"({a.strip()})" for a in args)
                out.append(self._calls(f"((1.0/2.0)*({r}*{r}) - 2.0*{e}*{r} + 3.0*({e}*{e})*log(1.0 + {r}/{e})"
                                       f" + ({e}*{e}*{e})/({e} + {r}) - {e}*{e})"))
            elif name in ("sin", "cos") and len(args) == 1 and args[0].strip() in self.paired and (
                    args[0].strip() in self.sincos or not self.blocks):   # a branch's block would hide sin_k
                self.used.add("trig")
                angle = args[0].strip()
                if angle not in self.sincos:
                    k = self.sincos[angle] = len(self.sincos)
                    self.pre += [f"eomc_vd sin_{k}, cos_{k};", f"{self.prefix}_vsincos({angle}, &sin_{k}, &cos_{k});"]
                out.append(f"{name}_{self.sincos[angle]}")
            elif name in ("sin", "cos") and len(args) == 1:
                self.used |= {"trig", f"v{name}"}
                out.append(f"{self.prefix}_v{name}({new[0]})")
            elif name in ("eomc_tanh0", "eomc_tanhc") and len(args) == 1:    # printer.MINMAX_C's, in lanes
                self.used.add(name[5:])
                out.append(f"{self.prefix}_v_{name[5:]}({new[0]})")
            elif (name in MATH1 and len(args) == 1) or (_LIBM.get(name, name) in MATH2 and len(args) == 2):
                name = _LIBM.get(name, name)
                self.used.add(name)
                wrapped = [a if v else f"{self.prefix}_vset({a.strip()})" for a, v in zip(new, vec)]
                if len(wrapped) > 1:
                    self.used.add("vset")
                out.append(f"{self.prefix}_v_{name}({','.join(wrapped)})")
            else:
                raise Unsupported(f"calls {name}() on a state-dependent value")
            i = j

    def temp(self, indent, name, expr):
        text, vec = self.expression(expr)
        pre = self.take_pre(indent)
        if vec:
            self.vtemps.add(name)
            return f"{pre}{indent}const eomc_vd {name} = {text};"
        self.vtemps.discard(name)       # the looped rhs's blocks reuse their temporaries' names
        return f"{pre}{indent}const double {name} = {text};"

    def variables(self, indent, decls):
        """The looped rhs's ``double a = v, b = w;``: vectors, every lane starting from v."""
        out = []
        for decl in decls.split(", "):
            var, value = decl.split(" = ")
            self.vtemps.add(var)
            value = value.strip()
            out.append(f"{var} = {{0}}" if re.fullmatch(r"0\.0|0", value) else f"{var} = (eomc_vd){{0}} + ({value})")
        return f"{indent}eomc_vd {', '.join(out)};"

    def assign(self, indent, var, op, expr):
        """``var = expr;`` or ``var += expr;`` on a looped rhs's variable (a vector)."""
        if var not in self.vtemps or self.mask is not None:
            raise Unsupported(f"assigns {var} (undeclared or under a branch)")
        text, vec = self.expression(expr)
        if not vec and op == "=" and re.fullmatch(r"0\.0|0", text.strip()):
            text = "(eomc_vd){0}"
        elif not vec:
            self.used.add("vset")
            text = f"{self.prefix}_vset({text})"
        return f"{self.take_pre(indent)}{indent}{var} {op} {text};"

    def running_min(self, indent, var, value):
        """``dmin = piv < dmin ? piv : dmin;`` per lane: a compare and a bit select (a NaN pivot
        keeps dmin, as the scalar ternary does)."""
        if var not in self.vtemps or self.mask is not None:
            raise Unsupported(f"assigns {var} (undeclared or under a branch)")
        text, vec = self.expression(value)
        if not vec:
            self.used.add("vset")
            text = f"{self.prefix}_vset({text})"
        return (f"{self.take_pre(indent)}{indent}{{\n"
                f"{indent}    const eomc_vd a_ = {text};\n"
                f"{indent}    const eomc_vu lt_ = (eomc_vu)(a_ < {var});\n"
                f"{indent}    {var} = (eomc_vd)(((eomc_vu)a_ & lt_) | ((eomc_vu){var} & ~lt_));\n"
                f"{indent}}}")

    def chain_sincos(self, indent, first, count, array):
        """``NAME_chain_sincos(x + first, count, SC);`` (SC[2k], SC[2k + 1]: sin and cos of
        x[first + k]) in lanes: per link NAME_vsincos_chain, what the scalar helper computes
        (four links at a time there): the same bits lane by lane."""
        if array not in self.vec_arrays or self.blocks:
            raise Unsupported(f"takes the chain's sin and cos into {array}[] inside a block")
        self.used |= {"trig", "chain_trig"}
        return (f"{indent}{{\n"
                f"{indent}    int k_;\n"
                f"{indent}    for (k_ = 0; k_ < {count}; k_++) "
                f"{self.prefix}_vsincos_chain(x[{first} + k_], &{array}[2 * k_], &{array}[2 * k_ + 1]);\n"
                f"{indent}}}")

    def store(self, indent, array, index, expr):
        if array not in self.vec_arrays:
            raise Unsupported(f"stores into {array}[]")
        text, vec = self.expression(expr)
        target, mask = f"{array}[{index}]", self.mask
        if mask is not None:
            self.masked.add(array)
        if mask is not None and not vec and re.fullmatch(r"0\.0|0", text.strip()):   # +0.0 is all zero bits
            return f"{self.take_pre(indent)}{indent}{target} = (eomc_vd)((eomc_vu){target} & ~{mask});"
        if not vec:
            self.used.add("vset")
            text = f"{self.prefix}_vset({text})"
        if mask is not None:     # the branch's lanes take the value, the others keep theirs
            text = f"(eomc_vd)(((eomc_vu)({text}) & {mask}) | ((eomc_vu){target} & ~{mask}))"
        return f"{self.take_pre(indent)}{indent}{target} = {text};"

    def pairs_call(self, indent, name, fn, nin, items, pars, offset, full, array, first,
                   slopes=None, slopes_first=None, nslopes=None):
        """The pairs' table loop (eomc_pairs: a static C function of loops over the pairs, with a
        broad phase that skips far pairs) lane by lane: each lane's inputs gathered, the scalar
        function called, its outputs put in the lane (its bits, whatever its branches do).  The
        law parameters must be shared (NAME_implicit_batch's p), the call outside every branch.
        ``slopes``: the array (out) where NAME_implicit's call writes its slope block, from
        ``slopes_first`` on, ``nslopes`` long: each lane's block written by the loop into a
        buffer of its own and put in its lane of that array the same way -- or, in
        NAME_implicit_lanes' own body (``rows_ok``), when the caller hands rows (``rows_``, one
        output buffer per lane: NAME_implicit_batch_rows), written by the loop straight into
        its lane's row at the block's place (kept, as NAME_implicit_var keeps it in the step's
        buffers: contact/table.KEPT_BLOCK), the block's columns left alone, and a lane whose
        block holds a non-finite entry marked in ``sb_`` (looked for only when the loop's sum of
        what it wrote is not finite: NAME_implicit's own verdict, compiler/tree/emit.finite_return).
        Why: on gymnasium's humanoid the block is 2725 of the 4739 outputs, nearly all zeros, and
        in the lanes rollout zeroing its columns, putting it in the lanes, checking it and copying
        it back into each row took ~28 % of the C time (session 26, report-percall2.md)."""
        if pars not in self.scalar_arrays:
            raise Unsupported(f"calls {fn}() with parameters in lanes")
        if self.mask is not None or array not in self.vec_arrays or array not in self.sizes:
            raise Unsupported(f"calls {fn}() under a branch or into {array}[]")
        if slopes is not None and slopes not in self.vec_arrays:
            raise Unsupported(f"calls {fn}() writing its slopes into {slopes}[]")
        elems, depth, start = [], 0, 0
        for j, ch in enumerate(items + ","):
            depth += {"(": 1, ")": -1}.get(ch, 0)
            if ch == "," and depth == 0:
                elems.append(items[start:j].strip())
                start = j + 1
        if len(elems) != int(nin):
            raise Unsupported(f"calls {fn}() with {len(elems)} inputs for {nin}")
        for e in elems:
            self.is_vector(e)          # refuses unknown arrays
            if _CALL.search(e):
                raise Unsupported(f"calls {fn}() on a call")
        nout = self.sizes[array] - int(first)
        # full = 0: the function's readers read only the wrenches, which it zeroes itself
        # (compiler/contact/table.py: full is 0 when no read is past them), so only those go into
        # the lanes; the rest of out_ (a near pair's point and depth) is scratch, as in the scalar
        # code.  Why: the humanoid's table has 1059 outputs and 78 wrenches: zeroing and putting the
        # rest cost 4 x 8.5 kB of memset and 1059 lane puts per call of 4 states.
        nput = self.pairs_read.get(fn) if full == "0" else None
        nput = nput if nput is not None and nput <= nout else None
        # and the points' elastic energy past them (NAME_implicit's energy slot reads it)
        energy = self.pairs_energy.get(fn) if nput is not None else None
        energy = energy if energy is not None and nput <= energy < nout else None
        inputs = ", ".join(self.lanes(e) for e in elems)
        rows = slopes is not None and self.rows_ok and self.rows_block is None
        if rows:
            self.rows_block = (int(slopes_first), int(nslopes))
        zero = (f"{indent}for (l_ = 0; l_ < {nout if nput is None else nput}; l_++) {array}[{first} + l_] = (eomc_vd){{0}};\n"
                + (f"{indent}{'if (!rows_) ' if rows else ''}for (l_ = 0; l_ < {nslopes}; l_++) "
                   f"{slopes}[{slopes_first} + l_] = (eomc_vd){{0}};\n" if slopes else ""))
        into = (f"{indent}    double slo_[{nslopes}];   /* the loop zeroes it first (kept = 0) */\n" if slopes else "",
                f", slo_, {nslopes}, 0" if slopes else "",
                f"{indent}    {self.prefix}_put_lane({slopes} + {slopes_first}, slo_, {nslopes}, l_);\n"
                if slopes else "")
        if rows:    # the block into the lane's row (rows_), else into slo_ and its lane as above
            into = (into[0] + f"{indent}    double *const dst_ = rows_ ? rows_[l_] + {slopes_first} : slo_;\n",
                    f", dst_, {nslopes}, rows_ != 0",
                    f"{indent}    if (!rows_) {self.prefix}_put_lane({slopes} + {slopes_first}, slo_, {nslopes}, l_);\n"
                    f"{indent}    else if (!({name} - {name} == 0.0)) {{   /* the sum not finite: the block entry by entry */\n"
                    f"{indent}        int e_;\n"
                    f"{indent}        for (e_ = 0; e_ < {nslopes}; e_++) if (!(dst_[e_] - dst_[e_] == 0.0)) sb_[l_] = 1;\n"
                    f"{indent}    }}\n")
        self.used.add("put_lane")
        return (f"{indent}double {name} = 0.0;\n{zero}"
                f"{indent}for (l_ = 0; l_ < EOMC_BATCH_LANES; l_++) {{   /* the pairs' loop, lane by lane */\n"
                f"{indent}    const double in_[{nin}] = {{{inputs}}};\n"
                f"{indent}    double out_[{nout}];\n"
                f"{into[0]}"
                + (f"{indent}    __builtin_memset(out_, 0, sizeof out_);   /* what a far pair leaves unwritten */\n"
                   if nput is None else "")
                + f"{indent}    {name} = {fn}(in_, &{pars}[{offset}], {full}, out_{into[1]});\n"
                f"{indent}    {self.prefix}_put_lane({array} + {first}, out_, {nout if nput is None else nput}, l_);\n"
                + (f"{indent}    {array}[{int(first) + energy}][l_] = out_[{energy}];\n" if energy is not None else "")
                + f"{into[2]}"
                f"{indent}}}")

    def lanes(self, expr):
        """``expr`` read at lane ``l_``: vector temporaries and vector arrays subscripted."""
        expr = _TEMP.sub(lambda m: f"{m.group(0)}[l_]" if m.group(0) in self.vtemps else m.group(0), expr)
        return re.sub(r"\b([A-Za-z_]\w*)\[(\d+|k)\]",
                      lambda m: f"{m.group(0)}[l_]" if m.group(1) in self.vec_arrays else m.group(0), expr)


def _statement(rw, line, parts_renamed):
    """One line of a function body, rewritten; raises Unsupported on an unknown shape."""
    if not line.strip():
        return line
    m = _PAIRS_LINE.match(line)
    if m:
        return rw.pairs_call(*m.groups())
    if _VOID_TEMP.match(line):
        return line
    m = _TEMP_LINE.match(line)
    if m:
        return rw.temp(*m.groups())
    m = _STORE_LINE.match(line)
    if m:
        return rw.store(*m.groups())
    m = _VAR_DECLS.match(line)
    if m:
        return rw.variables(*m.groups())
    m = _RUNNING_MIN.match(line)
    if m:
        return rw.running_min(m.group(1), m.group(2), m.group(3))
    m = _VAR_SET.match(line)
    if m:
        return rw.assign(*m.groups())
    m = _CHAIN_SINCOS.match(line)
    if m:
        return rw.chain_sincos(*m.groups())
    if _LOOP_DOWN.match(line):
        rw.blocks.append(None)
        return line
    if line.strip() in ("(void)t;", "(void)work;"):
        return line if line.strip() == "(void)t;" else None
    if _VOID_NAME.match(line):
        return line      # a limb routine's (void)xq0; of an argument it does not read
    m = _LIMB_DECLS.match(line)
    if m:
        names = re.findall(r"([A-Za-z_]\w*)\[\d+\]", m.group(2))
        rw.vec_arrays.update(names + ["lS"])
        rw.vtemps.add("thr")
        return f"{m.group(1)}eomc_vd {m.group(2)}lS[1] = {{{{0}}}}, thr;"
    m = _SUM_LOOP.match(line)
    if m and m.group(2) in rw.vec_arrays and m.group(3) in rw.vec_arrays and rw.mask is None:
        return line      # the limbs' pivots summed, lane by lane in the scalar order
    m = _SCRATCH_DECL.match(line)
    if m:
        rw.vec_arrays.add(m.group(2))
        rw.sizes[m.group(2)] = int(m.group(3))
        return f"{m.group(1)}eomc_vd {m.group(2)}[{m.group(3)}];"
    m = _CALL_LINE.match(line)
    if m and m.group(2) in parts_renamed:
        return f"{m.group(1)}{parts_renamed[m.group(2)]}({m.group(3)});"
    m = _POINTER_DECL.match(line)
    if m:
        rw.vec_arrays.add(m.group(2))
        return f"{m.group(1)}const eomc_vd *{m.group(2)};"
    m = _POINTER_SET.match(line)
    if m and m.group(3) in rw.vec_arrays and m.group(2) in rw.vec_arrays:
        return line
    m = _IF_LINE.match(line)
    if m:
        text = rw.branch(*m.groups())
        if text is None:       # a branch on parameters only: the same in every lane
            rw.blocks.append(None)
            return line
        return text
    m = _ELSE_LINE.match(line)
    if m:
        return rw.branch_else(m.group(1))
    if line.strip() == "}":
        if not rw.blocks:
            raise Unsupported("an unbalanced '}'")
        rw.blocks.pop()
        return line
    if _LOOP_HEAD.match(line) or line.strip() == "{":
        rw.blocks.append(None)
        return line
    if _INT_DECL.match(line):
        return line
    m = _GATHER.match(line) or _GATHER_ITEM.match(line)
    if m and m.group(2) in rw.vec_arrays and m.group(3) in rw.vec_arrays:
        return line       # u[e] = x[nq + sp[e]], ud[e] = w[sp[e]]: a whole vector per dof
    if _GATHER_HEAD.match(line):
        rw.blocks.append(None)
        return line
    m = _SCRATCH_DECLS.match(line)
    if m:
        names = re.findall(r"([A-Za-z_]\w*)\[\d+\]", m.group(2))
        rw.vec_arrays.update(names)
        return f"{m.group(1)}eomc_vd {m.group(2)};"
    m = _ZERO_RUN.match(line)
    if m:
        indent, a, b, array, value = m.groups()
        return f"{indent}for (k = {a}; k < {b}; k++) {rw.store('', array, 'k', value)}"
    m = _GUARD_LINE.match(line)
    if m:
        indent, cond, code = m.groups()
        rw.is_vector(cond)   # refuses unknown arrays
        if _CALL.search(cond):
            raise Unsupported(f"a guard with a call: {line.strip()}")
        lane = "" if rw.mask is None else f"{rw.mask}[l_] && "
        return (f"{indent}for (l_ = 0; l_ < EOMC_BATCH_LANES; l_++) {{\n"
                f"{indent}    if (st[l_] == EOMC_OK && {lane}({rw.lanes(cond)})) st[l_] = {code};\n"
                f"{indent}}}")
    if _FINITE_RETURN.match(line):
        return None      # the block checks each lane's outputs
    if "/* one state's A at a time */" in line:
        return line      # _per_lane_solve's loop
    raise Unsupported(f"statement {line.strip()[:80]!r}")


def _zero_masked(stmts, rw):
    """stmts with each local array that a masked store reads (the lanes outside the branch
    keep their old value) zeroed where it is declared: every lane then holds a defined value
    (a lane no branch wrote reads 0 where the scalar code wrote nothing), and gcc sees no
    read of an uninitialized array."""
    out = []
    for s in stmts:
        out.append(s)
        m = re.match(r"^(\s+)eomc_vd ([A-Za-z_]\w*)\[\d+\];$", s or "")
        if m and m.group(2) in rw.masked:
            out.append(f"{m.group(1)}__builtin_memset({m.group(2)}, 0, sizeof {m.group(2)});")
    return out


def _balanced(text):
    """True when text's parentheses balance and never close more than they opened."""
    depth = 0
    for ch in text:
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if depth < 0:
            return False
    return depth == 0


def _top_level_relation(cond):
    """(a, op, b) of ``a op b`` with op one of > < >= <= outside every parenthesis, or None."""
    found = [m for m in _RELATION.finditer(cond) if _balanced(cond[:m.start()])]
    if len(found) != 1:
        return None
    m = found[0]
    a, b = cond[:m.start()], cond[m.end():]
    return (a, m.group(1), b) if _balanced(a) and _balanced(b) else None


def _param_list(params, rw):
    out = []
    for param in params.split(", "):
        if param in ("void", "double t"):
            out.append(param)
            continue
        m = re.fullmatch(r"(const )?double \*(restrict )?([A-Za-z_]\w*)", param)
        if not m:
            raise Unsupported(f"parameter {param!r}")
        const, restrict, name = m.groups()
        if name in rw.scalar_arrays or re.fullmatch(r"kk\d*", name):
            # shared parameters: one double for every lane; a limb's table of numbers (tree/limbs.py)
            rw.scalar_arrays.add(name)
            out.append(param)
        elif (name in ("x", "r", "F", "w", "p", "P", "Gm", "an", "out", "G_", "PT_") or name.startswith("S")
              or re.fullmatch(_LIMB_ARGS, name)):
            rw.vec_arrays.add(name)
            out.append(f"{const or ''}eomc_vd *{restrict or ''}{name}")
        else:
            raise Unsupported(f"parameter {param!r}")
    return ", ".join(out)


# the limb routines' arguments (tree/limbs.py: a limb's slots, its parent's velocity and acceleration, its
# T, f, pivots, stored values and u'; numbered per limb in a shape's routine) and the rhs's arrays they fill
_LIMB_ARGS = r"(?:xq|xu|pp|rr|vP|T|f|D|L|aP|ud)\d*|l(?:T|f|S|D|L|vP|aP)"


def _functions(text):
    """The static functions of a C text (the dynamics helper and its parts), one string each."""
    out, cur = [], []
    for line in text.rstrip("\n").split("\n"):
        if not cur and not line.strip():
            continue
        cur.append(line)
        if line == "}":
            out.append("\n".join(cur))
            cur = []
    if any(line.strip() for line in cur):
        raise Unsupported("dynamics helper text")
    return out


_FACTOR_LINE = re.compile(r"^(\s+)status = ([A-Za-z_]\w*\(F(?:, piv)?\));$")
_SOLVE_LINE = re.compile(r"^(\s+)([A-Za-z_]\w*\(F, (?:piv, )?w\));$")


def _per_lane_solve(lines, sizes):
    """Kane's `status = factor(F); if (status != EOMC_OK) return status; solve(F, w);` as one
    loop over lanes: each state's A (its lane of F) factored and solved by the scalar solver
    (its pivoting and singularity test per state)."""
    out, i = [], 0
    while i < len(lines):
        m = _FACTOR_LINE.match(lines[i])
        if m and i + 2 < len(lines) and lines[i + 1].strip() == "if (status != EOMC_OK) return status;" \
                and _SOLVE_LINE.match(lines[i + 2]):
            ind, factor = m.groups()
            solve = _SOLVE_LINE.match(lines[i + 2]).group(2)
            nf, nw = sizes["F"], sizes["w"]
            piv = f"{ind}        int piv[{sizes['piv']}];\n" if "piv" in factor else ""
            out.append(
                f"{ind}for (l_ = 0; l_ < EOMC_BATCH_LANES; l_++) {{   /* one state's A at a time */\n"
                f"{ind}    double Fl_[{nf}], wl_[{nw}];\n"
                f"{ind}    int k_;\n"
                f"{ind}    if (st[l_] != EOMC_OK) continue;\n"
                f"{ind}    for (k_ = 0; k_ < {nf}; k_++) Fl_[k_] = F[k_][l_];\n"
                f"{ind}    for (k_ = 0; k_ < {nw}; k_++) wl_[k_] = w[k_][l_];\n"
                f"{ind}    {{\n{piv}"
                f"{ind}        const int s_ = {_lane_args(factor)};\n"
                f"{ind}        if (s_ != EOMC_OK) {{\n"
                f"{ind}            st[l_] = s_;\n"
                f"{ind}            continue;\n"
                f"{ind}        }}\n"
                f"{ind}        {_lane_args(solve)};\n"
                f"{ind}    }}\n"
                f"{ind}    for (k_ = 0; k_ < {nw}; k_++) w[k_][l_] = wl_[k_];\n"
                f"{ind}}}")
            i += 3
            continue
        out.append(lines[i])
        i += 1
    return out


def _lane_args(call):
    return re.sub(r"\bF\b", "Fl_", re.sub(r"\bw\b", "wl_", call))


_KERNEL_HEAD = re.compile(r"^static (inline )?(void|double) ([A-Za-z_]\w*)\(")
_LITERAL = r"(-?\d+\.\d*(?:e[-+]?\d+)?)"


_GROUND_SKIP = "            if (!(g[0] > 0.0) && g[0] == g[0]) continue;   /* clear of the ground: all \u00b10 */"
_GROUND_ROWS = re.compile(r"(ok\[[qu]c\[a\]\] -= )(sign \* \([^;]*\));")


def _ground_contact_lanes(name, text):
    """The kernel's ground-contact block (compiler/tree/analytic.py _contact_lines) in lanes: a
    contact is skipped when every lane is clear of the ground (depth <= 0, not NaN: the scalar
    test), and its terms are added under that mask, so a clear lane's rows get +0 subtracted
    (unchanged, bit for bit, -0 and NaN included) whatever the block computed in it.  The scalar
    skip, ``if (!(g[0] > 0.0) && ...) continue;`` on a vector, was a compile error."""
    if _GROUND_SKIP not in text:
        return text
    text, rows = _GROUND_ROWS.subn(r"\1(double)((eomc_vu)(\2) & in_);", text)
    if rows != 2:
        raise Unsupported("has a ground-contact block of an unknown shape")
    return text.replace(_GROUND_SKIP,
                        "            const eomc_vu in_ = (eomc_vu)(g[0] > 0.0) | (eomc_vu)(g[0] != g[0]);\n"
                        f"            if (!{name}_vany(in_)) continue;   /* every lane clear of the ground */")


def vector_kernels(name, helpers_text):
    """(C text, {old name: new name}): jac_x's analytic kernel (compiler/tree/analytic.py:
    ``NAME_rnea_derivs`` and its ``NAME_rd_*`` helpers, loops over the tree's int tables)
    retyped into lanes: every double a vector, the loops and int tables as they are, so each
    lane runs the scalar kernel's arithmetic in its order.  Scalar literals that stand for a
    value (an assignment, a ternary's branch) become vectors (``EOMC_VLIT``); ``sign`` stays a
    double (scalar times vector).  Refused (:class:`Unsupported`) when the kernel calls libm or
    holds double tables: the retype is exact only for + - * / on lanes."""
    funcs, cur, names = [], None, {}
    for line in helpers_text.split("\n"):
        if cur is None:
            m = _KERNEL_HEAD.match(line)
            if m and re.fullmatch(rf"{name}_(rd_\w+|rnea_derivs)", m.group(3)):
                cur = [line]
                names[m.group(3)] = m.group(3).replace(f"{name}_", f"{name}_v", 1)
            continue
        cur.append(line)
        if line == "}":
            funcs.append("\n".join(cur))
            cur = None
    if not funcs or f"{name}_rnea_derivs" not in names:
        raise Unsupported("calls NAME_rnea_derivs, whose text was not found")
    # the articulated solve's choice of AVX2 row helpers (analytic._aba_dispatch): lanes are vectors already
    text = without_cpu_dispatch("\n\n".join(funcs))
    if re.search(r"\b(sqrt|fabs|fmax|fmin|eomc_fmax|eomc_fmin|sin|cos|exp|log|pow|atan2)\(", text) or "static const double" in text:
        raise Unsupported("has an analytic kernel with libm calls or double tables")
    for old, new in names.items():
        text = re.sub(rf"\b{old}\b", new, text)
    text = _ground_contact_lanes(name, text)
    text = re.sub(r"\bdouble\b", "eomc_vd", text).replace("eomc_vd sign", "double sign")
    text = re.sub(rf"= {_LITERAL};", r"= EOMC_VLIT(\1);", text)
    text = re.sub(rf"\? {_LITERAL} :", r"? EOMC_VLIT(\1) :", text)
    text = re.sub(rf": {_LITERAL}([;)])", r": EOMC_VLIT(\1)\2", text)
    text = re.sub(r"^static (inline )?", lambda m: f"static EOMC_VTARGET {m.group(1) or ''}", text, flags=re.M)
    return "/* a vector plus a double: the double in every lane */\n" \
           "#define EOMC_VLIT(c) ((eomc_vd){0} + (c))\n\n" + text, names


_PAIRS_ZERO = re.compile(r"^static double (eomc_pairs\w*)\(const double \*in, const double \*pars, int full, "
                         r"double \*out[^)]*\)\n\{\n(?:.*\n){0,6}?\s+for \(k = 0; k < \(full \? \d+ : (\d+)\); \+\+k\) "
                         r"out\[k\] = 0\.0;$", re.M)


def _pairs_read(kernels):
    """{pairs' table function: the outputs it zeroes when called with full = 0} from the helper
    code (compiler/contact/table.py's loop: ``for (k = 0; k < (full ? noutput : nwrench); ++k)``)."""
    return {m.group(1): int(m.group(2)) for m in _PAIRS_ZERO.finditer(kernels or "")}


# a pairs' table loop writing its points' elastic energy (table.Table.energy_at) last: ``out[E] = en;``
_PAIRS_ENERGY = re.compile(r"^static double (eomc_pairs\w*)\((?:(?!\}\n).*\n)*?    out\[(\d+)\] = en;\n    return \w+;\n\}$",
                           re.M)


def _pairs_energy(kernels):
    """{pairs' table function: the output where it writes its points' elastic energy} (its "slopes"
    variant with the energy: NAME_implicit's energy slot reads it; pairs_call puts it in the lanes
    beside the wrenches)."""
    return {m.group(1): int(m.group(2)) for m in _PAIRS_ENERGY.finditer(kernels or "")}


def batch_rhs(name, lines, parts, dynamics="", fn="rhs", out="xdot", kernels="", rows=None):
    """(C code of the lane functions, helper names used) for the scalar rhs whose body is
    ``lines`` and whose sub-functions are ``parts`` (split_body's output); ``dynamics``: the
    text of Kane's NAME_dynamics helper (and its parts), which the rhs calls.

    The code defines ``static EOMC_VTARGET void NAME_rhs_lanes(double t, const eomc_vd *x,
    const eomc_vd *p, const eomc_vd *r, eomc_vd *xdot, int *st)`` (the parameters in lanes too:
    one parameter row per state, or one row broadcast); raises :class:`Unsupported`
    when a line is of a shape the rewrite does not know.  fn="jac_x", out="out": the same for
    the scalar jac_x's body and parts (``NAME_jac_x_lanes``, its tangent loop kept as a loop).

    fn="implicit": the parameters are shared (``const double *p``: NAME_implicit_batch has no
    parameter row per state), so what depends on them alone (a pair's broad-phase radius, a
    contact's law constants) is one double computed once for all lanes.  ``rows``: a dict that
    gets "block" = (first output, length) when NAME_implicit_lanes can write the pairs' slope
    block into rows of the caller's (its arguments then end in ``double *const *rows_, int
    *sb_``: :meth:`_Rewriter.pairs_call`)."""
    shared = (SHARED_PARAMETERS_ARRAY,) if fn in SHARED_PARAMETERS else ()
    used = set()
    renamed = {}
    out_parts = []
    if any(re.search(rf"\b{name}_dynamics\(", line) for line in lines):
        for text in _functions(dynamics):
            head = text.split("\n", 1)[0]
            m = re.match(r"^static void ([A-Za-z_]\w*)\((.*)\)$", head)
            if m:          # the helper itself: a part in all but its name
                parts = list(parts) + [text.replace(head, f"static EOMC_NOINLINE void {m.group(1)}({m.group(2)})", 1)]
            else:
                parts = list(parts) + [text]
        sizes = {}
        for line in lines:
            m = re.match(r"^\s+(?:double|int) (F|w|piv)\[(\d+)\];$", line)
            if m:
                sizes[m.group(1)] = int(m.group(2))
        lines = [line for line in lines if line.strip() not in ("int status;",)
                 and not re.match(r"^\s+int piv\[\d+\];$", line)]
        lines = _per_lane_solve(lines, sizes)
    if any(re.search(rf"\b{name}_rnea_derivs\(", line) for line in lines):
        text, kernel_names = vector_kernels(name, kernels)
        if f"{name}_vany(" in text:
            used.add("mask")
        out_parts.append(text)
        renamed.update(kernel_names)
    for part in parts:
        if fn == "rhs" and _LIMB_TABLE.match(part):
            continue        # a limb's numbers (tree/limbs.py), defined before the scalar rhs: read as they are
        head, *body = part.rstrip("\n").split("\n")
        m = _PART_HEAD.match(head)
        limb = _LIMB_HEAD.match(head) if fn == "rhs" and not m else None
        if not (m or limb) or body[0] != "{" or body[-1] != "}":
            raise Unsupported(f"sub-function {head[:60]!r}")
        old = (m or limb).group(1)
        new = (old.replace(f"{name}_limb", f"{name}_vlimb", 1) if f"{name}_limb" in old else
               old.replace(f"_{fn}_part", f"_{fn}_batch_part", 1) if f"_{fn}_part" in old else
               old.replace("_dynamics", "_batch_dynamics", 1))
        renamed[old] = new
        rw = _Rewriter(name, (), shared, used)
        params = _param_list((m or limb).group(2), rw)
        rw.pair_scan(body)
        stmts = _zero_masked([_statement(rw, line, renamed) for line in body[1:-1]], rw)
        if rw.blocks:
            raise Unsupported(f"a block not closed in {old}")
        # a limb shape's routine: inlined or not as the compiler sees fit, as the scalar one
        attr = "static EOMC_VTARGET void" if limb else "static EOMC_NOINLINE EOMC_VTARGET void"
        out_parts.append("\n".join([f"{attr} {new}({params})", "{"]
                                   + [s for s in stmts if s is not None] + ["}"]))
    rw = _Rewriter(name, ("x", "r", out) + (() if shared else ("p",)), shared, used)
    rw.pairs_read = _pairs_read(kernels)
    rw.pairs_energy = _pairs_energy(kernels)
    rw.rows_ok = fn == "implicit" and rows is not None
    rw.pair_scan(lines)
    stmts = [_statement(rw, line, renamed) for line in lines]
    if rw.blocks:
        raise Unsupported("a block not closed")
    stmts = _zero_masked(stmts, rw)
    guard = any("l_" in (s or "") for s in stmts)
    if any("/* one state's A at a time */" in (s or "") for s in stmts):
        rw.vec_arrays |= {"F", "w"}
    body = ["    int l_;"] if guard else []
    body += [s for s in stmts if s is not None]
    text = "\n".join(body)
    body = [f"    (void){a};" for a in ("t", "x", "p", "r", "st") if not re.search(rf"\b{a}\b", text)] + body
    if rw.rows_block is not None:
        rows["block"] = rw.rows_block
    lanes = "\n".join([f"static EOMC_VTARGET void {name}_{fn}_lanes(double t, const eomc_vd *x, "
                       f"const {'double' if shared else 'eomc_vd'} *p, "
                       f"const eomc_vd *r, eomc_vd *{out}, int *st"
                       + (", double *const *rows_, int *sb_" if rw.rows_block is not None else "") + ")", "{"]
                      + body + ["}"])
    pair = _pair_lanes(name, fn, body) if fn == "rhs" and not out_parts and not rw.nbranch else None
    if pair is not None:
        used.add("pair")
    return "\n\n".join(out_parts + [lanes] + ([pair] if pair else [])), used


# The looped rhs's names (compiler/tree/chain_loop.py) and the lanes function's arguments: the
# second group's copy of a statement reads and writes these with a suffix (_pair_lanes)
_PAIR_RENAMED = re.compile(r"\b(t\d+|o\d+|piv|c[vTfa]\d+|dsum|dmin|L\d+_\d+|SC\d+|sin_\d+|cos_\d+|x|p|r|xdot|st)\b")
_PAIR_KEPT = {"k", "l_", "k_", "a_", "lt_", "t", "const", "eomc_vd", "eomc_vu", "double", "int", "for", "if", "void",
              "DBL_MAX"}
_SCALAR_CALLS = {"sin", "cos", *MATH1, *MATH2, *_LIBM, "eomc_tanh0", "eomc_tanhc"}     # left as calls on doubles (constants) by the rewrite
_PAIR_ONCE = re.compile(r"^\s*(?:for \(k = \d+; k (?:<|>=) \d+; k(?:\+\+|--)\) \{|\{|\}|int k;|int l_;|\(void\)t;)$")


def _pair_lanes(name, fn, body):
    """``NAME_rhs_lanes2``: the lanes function on two groups of lanes at once, each statement
    of a looped rhs (compiler/tree/chain_loop.py) written for the first group and then for the
    second (its names suffixed _1), the loops and blocks shared; or None where the body is not
    a looped rhs or holds a name this copy does not know.

    Why: ABA's passes carry each link's values to the next link, a chain of dependent
    operations (pass 2's pivot division among them) whose latency, not the lanes' arithmetic,
    bounds a looped body; the two groups' chains are independent, so the core overlaps them.
    Each group's operations are its own, in its own order: its lanes' bits are those of
    NAME_rhs_lanes."""
    if not any(re.match(r"^\s*for \(k = \d+; k < \d+; k\+\+\) \{$", line) for line in body):
        return None
    for line in body:
        for ident in re.findall(r"\b[A-Za-z_]\w*\b", line):
            if not (_PAIR_RENAMED.fullmatch(ident) or ident in _PAIR_KEPT or ident.startswith(f"{name}_")
                    or re.fullmatch(r"EOMC_[A-Z_]+", ident) or ident in _SCALAR_CALLS):
                return None
    out = []
    for line in body:
        if _PAIR_ONCE.match(line):
            out.append(line)
        else:
            out += [line, _PAIR_RENAMED.sub(r"\1_1", line)]
    return "\n".join([f"static EOMC_VTARGET void {name}_{fn}_lanes2(double t, const eomc_vd *x, const eomc_vd *x_1, "
                      f"const eomc_vd *p, const eomc_vd *p_1, const eomc_vd *r, const eomc_vd *r_1, "
                      f"eomc_vd *xdot, eomc_vd *xdot_1, int *st, int *st_1)", "{"] + out + ["}"])


def _trig_blocks(name, used):
    """[(key, C text)] of VECTOR_TRIG's parts a lane code calls: the kernels and NAME_vsincos
    always, NAME_vtrig and the lone NAME_vsin / NAME_vcos only where an angle's sin or cos is
    taken alone (``"vsin"``, ``"vcos"`` in ``used``).  Why: most bodies pair every angle into
    vsincos, and an unused static function is a clang -Wunused-function warning in every
    lanes build (the guide: generated C clean under -Wall -Wextra with gcc and clang)."""
    text = VECTOR_TRIG.format(p=name)
    cut = [text.index(f"static EOMC_VTARGET EOMC_VINLINE eomc_vd {name}_v{f}(") for f in ("trig", "sin", "cos")]
    cut.append(text.index("/* sin and cos of one angle from one reduction"))
    blocks = [("trig", text[:cut[0]] + text[cut[3]:])]
    if used & {"vsin", "vcos"}:
        blocks.append(("vtrig", text[cut[0]:cut[1]].rstrip() + "\n"))
    for key, start, end in (("vsin", cut[1], cut[2]), ("vcos", cut[2], cut[3])):
        if key in used:
            blocks.append((key, text[start:end].rstrip() + "\n"))
    return blocks


def helper_blocks(name, used):
    """[(key, C text)] of the static helpers the lane code calls (vset, sin/cos, lane-wise libm):
    keyed so that a second batch function in the same file (jac_x_batch after rhs_batch)
    defines only the ones the first did not."""
    code = []
    if "vset" in used or any(f in MATH2 for f in used):
        code.append(("vset", _VSET.format(p=name)))
    if "trig" in used:
        code += _trig_blocks(name, used)
    if "chain_trig" in used:
        code.append(("chain_trig", _CHAIN_TRIG.format(p=name)))
    if "mask" in used:
        code.append(("mask", _VANY.format(p=name)))
    if "put_lane" in used:
        code.append(("put_lane", _PUT_LANE.format(p=name)))
    for f in sorted(used):
        if f in _VECTOR_EXACT:
            code.append((f, _VECTOR_EXACT[f].format(p=name)))
        elif f in MATH1:
            code.append((f, _LANEWISE1.format(p=name, f=f)))
        elif f in MATH2:
            code.append((f, _LANEWISE2.format(p=name, f=f)))
    return code


def helpers(name, used, defined=()):
    """The static helper functions the lane code calls, less the keys in ``defined``."""
    return "\n\n".join(text for key, text in helper_blocks(name, used) if key not in defined)


# bytes of a tile's copies of its states, inputs and outputs (NAME_rhs_groups): the tile is the
# largest of 32, 16 or 8 states within it (32 states of a 12-state UR10: 7.5 KB), else one group
TILE_BYTES = 32768


# bytes of the scalar loop's tile (NAME_<fn>_batch_any): up to 8 states' inputs and outputs, so
# that a row of the column-major outputs is written a whole cache line at a time (Go2's jac_x:
# 8 states of 1296 outputs, 86 KB; cart n = 40's, 6724 outputs: 2 states)
SCALAR_TILE_BYTES = 131072


def scalar_tile(nx, nr, nout):
    """(states per tile, doubles per tile row) of the scalar loop: the row (a state's outputs)
    rounded up to an odd number of 64-byte lines (rows of a tile then fall in different L1
    sets when the loop writes them out column by column), and the largest of 8, 4, 2 states
    whose tile fits :data:`SCALAR_TILE_BYTES`, else 1."""
    width = -(-nout // 8) * 8
    if width % 16 == 0:
        width += 8
    ts = next((t for t in (8, 4, 2) if t * (nx + max(nr, 1) + width) * 8 <= SCALAR_TILE_BYTES), 1)
    return ts, width


def _tile(nx, nr, nout):
    """States per tile of NAME_<fn>_groups: the largest of 32, 16 or 8 whose copies fit
    :data:`TILE_BYTES`, else None (one group of lanes)."""
    return next((t for t in (32, 16, 8) if t * (nx + nr + nout) * 8 <= TILE_BYTES), None)


def _finite_by_sum(xo, ranges):
    """The lanes' check of their outputs for inf or NaN (``bad``, a lane's mask) over ``ranges``
    ((lo, hi, C condition or None) each) as NAME_finite_wide does it: the plain sums first, in
    four chains, one add a vector; only when a lane's sum is not finite (an entry inf or NaN, or
    finite entries whose sum overflows) every entry again, subtracted from itself -- the same
    verdict as the entry by entry test alone.  Why (NAME_implicit_batch, the lanes rollout's): on
    gymnasium's humanoid the entry by entry test over 2038 outputs took 3.4 % of the lanes rollout
    (perf, session 33: a subtraction, a compare, a mask's blend and an or a vector).  The other
    batch functions (rhs, jac_x: nx or nx * nx outputs) keep the entry by entry test."""
    L = ["            {   /* inf or NaN: the sums first, entry by entry when a lane's is not finite */",
         "                eomc_vd s0_ = {0}, s1_ = {0}, s2_ = {0}, s3_ = {0};",
         "                int any_ = 0;"]
    for lo, hi, cond in ranges:
        if hi <= lo:
            continue
        pre = f"if ({cond}) " if cond else ""
        if hi - lo < 16:
            L.append(f"                {pre}for (i = {lo}; i < {hi}; i++) s0_ += {xo}[i];")
            continue
        L.append(f"                {pre}{{")
        L.append(f"                    for (i = {lo}; i + 4 <= {hi}; i += 4) {{")
        L.append(f"                        s0_ += {xo}[i];")
        for k in (1, 2, 3):
            L.append(f"                        s{k}_ += {xo}[i + {k}];")
        L.append("                    }")
        L.append(f"                    for (; i < {hi}; i++) s0_ += {xo}[i];")
        L.append("                }")
    L.append("                s0_ = (s0_ + s1_) + (s2_ + s3_);")
    L.append("                for (l = 0; l < L; l++) any_ |= !(s0_[l] - s0_[l] == 0.0);")
    L.append("                if (any_) {")
    for lo, hi, cond in ranges:
        if hi <= lo:
            continue
        pre = f"if ({cond}) " if cond else ""
        L.append(f"                    {pre}for (i = {lo}; i < {hi}; i++) bad |= (eomc_vu)({xo}[i] - {xo}[i] != 0.0);")
    L.append("                }")
    L.append("            }")
    return "\n".join(L) + "\n"


def batch_function(name, nx, nr, npar, lanes_code, helper_code, fn="rhs", nout=None, prelude=True, pair=False,
                   rows=None):
    """(code before NAME_rhs_batch, its body): the prelude and the lane code (when there is
    any), ``NAME_rhs_batch_p`` (one parameter row per state, ``P[j*n + k]``: what a rollout
    of many parameter sets needs), then the public function's body with its scalar tail and
    fallback.  Both run one static loop; shared parameters are broadcast into the lanes, so
    the two give the same bits for the same parameters.

    The lanes run in ``NAME_<fn>_groups``: tiles of 32, 16 or 8 states (the largest whose
    copies fit :data:`TILE_BYTES`; one group of lanes when none does), the shared parameters
    broadcast once per call, a parameter row (``_p``) read per group.

    fn="jac_x", nout=nx*nx: ``NAME_jac_x_batch``'s code (OUT[e*n + k] is element e of state k's
    row-major Jacobian), its scalar tail NAME_jac_x; no ``_p`` entry.  prelude=False when the
    rhs's batch code (with the prelude) comes first in the same file.

    rows=(first, length) (fn="implicit", batch_rhs's rows["block"]): also ``NAME_implicit_batch_rows``,
    whose ``rows[k]`` is state k's own output buffer: the pairs' slope block goes there (at its
    place, ``first`` on) and not into OUT, whose block rows the lanes leave as they were (the
    scalar tail writes them too); the rest as NAME_implicit_batch (the lanes' status checks the
    block in the rows; a guard's NaN fills it there).  The lanes rollout's
    (runtime/c/eomc_rollout.c)."""
    nr1, np1 = max(nr, 1), max(npar, 1)
    nout = nx if nout is None else nout
    tile = _tile(nx, nr, nout)
    groups = f"({tile} / EOMC_BATCH_LANES)" if tile else "1"
    inputs = (f"""                for (i = 0; i < {nr}; i++) __builtin_memcpy(&r[g][i], R + (size_t)i * n + k + g * L, sizeof(eomc_vd));
""" if nr else "")
    simd = ""
    shared = fn in SHARED_PARAMETERS      # the lanes read p itself (batch_rhs)
    pair = pair and tile is not None and not shared and lanes_code is not None
    if shared:
        params = "    (void)P;\n"
    else:
        params = ("" if npar else "    (void)p;\n    (void)P;\n") + (
            f"    for (i = 0; i < {np1}; i++) for (l = 0; l < L; l++) pv[i][l] = "
            f"{'P == NULL ? p[i] : 0.0' if npar else '0.0'};\n")
        if pair:
            params += (f"    for (i = 0; i < {np1}; i++) for (l = 0; l < L; l++) pv_1[i][l] = "
                       f"{'P == NULL ? p[i] : 0.0' if npar else '0.0'};\n")
    skip = (f"            if (rows != NULL && i >= {rows[0]} && i < {rows[0] + rows[1]}) continue;   /* in the rows */\n"
            if rows else "")
    copy_out = f"""        for (i = 0; i < {nout}; i++) {{
{skip}            for (g = 0; g < gs; g++) __builtin_memcpy(XDOT + (size_t)i * n + k + g * L, &xdot[g][i], sizeof(eomc_vd));
        }}
"""
    xo, direct_decl = "xdot[g]", ""
    if not tile:
        # one group and its outputs many: n == L states in an aligned OUT are the group's vectors
        # as they lie, so the lanes write there and the tile's copy is skipped.  Why: on the
        # humanoid's implicit (4738 outputs, 296 KB at 8 lanes) that copy was a sixth of
        # NAME_implicit_batch's time in the lanes rollout (perf), which calls it with n == L.
        xo = "xo"
        direct_decl = ("    const int direct = n == L && (size_t)XDOT % sizeof(eomc_vd) == 0;\n"
                       "    eomc_vd *xo = direct ? (eomc_vd *)XDOT : xdot[0];\n")
        copy_out = f"        if (!direct) {{\n{copy_out.replace(chr(10) + '        ', chr(10) + '            ').replace('        for', '            for', 1)}        }}\n"
    if pair:
        # two groups of lanes per call of NAME_rhs_lanes2 (_pair_lanes), the last one alone when
        # the tile's count of groups is odd; each group's status and outputs checked as one group's
        group_loop = f"""        for (g = 0; g < gs; g += 2) {{
            int st[2][L], h;
{f"            if (P != NULL) for (i = 0; i < {npar}; i++) {{" + chr(10) + "                __builtin_memcpy(&pv[i], P + (size_t)i * n + k + g * L, sizeof(eomc_vd));" + chr(10) + "                if (g + 1 < gs) __builtin_memcpy(&pv_1[i], P + (size_t)i * n + k + (g + 1) * L, sizeof(eomc_vd));" + chr(10) + "            }" + chr(10) if npar else ""}            for (l = 0; l < L; l++) st[0][l] = st[1][l] = EOMC_OK;
            if (g + 1 < gs) {name}_{fn}_lanes2(t, x[g], x[g + 1], pv, pv_1, r[g], r[g + 1], xdot[g], xdot[g + 1], st[0], st[1]);
            else {name}_{fn}_lanes(t, x[g], pv, r[g], xdot[g], st[0]);
            for (h = 0; h < 2 && g + h < gs; h++) {{
                eomc_vu bad = {{0}};
                for (i = 0; i < {nout}; i++) bad |= (eomc_vu)(xdot[g + h][i] - xdot[g + h][i] != 0.0);   /* inf or NaN */
                for (l = 0; l < L; l++) {{
                    if (st[h][l] == EOMC_OK && bad[l]) st[h][l] = EOMC_NONFINITE;
                    if (st[h][l] != EOMC_OK && st[h][l] != EOMC_NONFINITE) {{   /* the guard stopped it: NaN, as the scalar tail */
                        for (i = 0; i < {nout}; i++) xdot[g + h][i][l] = NAN;
                    }}
                    if (status != NULL) status[k + (g + h) * L + l] = st[h][l];
                    if (st[h][l] != EOMC_OK && *worst == EOMC_OK) *worst = st[h][l];
                }}
            }}
        }}
"""
    elif rows:
        first, nblk = rows
        group_loop = f"""        for (g = 0; g < gs; g++) {{
            int st[L], sb[L];
            eomc_vu bad = {{0}};
            double *const *rg = rows != NULL ? rows + k + g * L : NULL;   /* the group's rows: its block there */
{f"            if (P != NULL) for (i = 0; i < {npar}; i++) __builtin_memcpy(&pv[i], P + (size_t)i * n + k + g * L, sizeof(eomc_vd));" + chr(10) if npar and not shared else ""}            for (l = 0; l < L; l++) st[l] = EOMC_OK, sb[l] = 0;
            {name}_{fn}_lanes(t, x[g], {"p" if shared else "pv"}, r[g], {xo}, st, rg, sb);
{_finite_by_sum(xo, [(0, first, None), (first + nblk, nout, None), (first, first + nblk, "rg == NULL")])}            for (l = 0; l < L; l++) {{
                if (st[l] == EOMC_OK && (bad[l] || sb[l])) st[l] = EOMC_NONFINITE;
                if (st[l] != EOMC_OK && st[l] != EOMC_NONFINITE) {{   /* the guard stopped it: NaN, as the scalar tail */
                    for (i = 0; i < {nout}; i++) {xo}[i][l] = NAN;
                    if (rg != NULL) for (i = {first}; i < {first + nblk}; i++) rg[l][i] = NAN;
                }}
                if (status != NULL) status[k + g * L + l] = st[l];
                if (st[l] != EOMC_OK && *worst == EOMC_OK) *worst = st[l];
            }}
        }}
"""
    else:
        finite = (_finite_by_sum(xo, [(0, nout, None)]) if fn == "implicit" else
                  f"            for (i = 0; i < {nout}; i++) bad |= (eomc_vu)({xo}[i] - {xo}[i] != 0.0);   /* inf or NaN */\n")
        group_loop = f"""        for (g = 0; g < gs; g++) {{
            int st[L];
            eomc_vu bad = {{0}};
{f"            if (P != NULL) for (i = 0; i < {npar}; i++) __builtin_memcpy(&pv[i], P + (size_t)i * n + k + g * L, sizeof(eomc_vd));" + chr(10) if npar and not shared else ""}            for (l = 0; l < L; l++) st[l] = EOMC_OK;
            {name}_{fn}_lanes(t, x[g], {"p" if shared else "pv"}, r[g], {xo}, st);
{finite}            for (l = 0; l < L; l++) {{
                if (st[l] == EOMC_OK && bad[l]) st[l] = EOMC_NONFINITE;
                if (st[l] != EOMC_OK && st[l] != EOMC_NONFINITE) {{   /* the guard stopped it: NaN, as the scalar tail */
                    for (i = 0; i < {nout}; i++) {xo}[i][l] = NAN;
                }}
                if (status != NULL) status[k + g * L + l] = st[l];
                if (st[l] != EOMC_OK && *worst == EOMC_OK) *worst = st[l];
            }}
        }}
"""
    if lanes_code is not None:
        simd = f"""#if EOMC_BATCH_SIMD
{helper_code + chr(10) + chr(10) if helper_code else ""}{lanes_code}

/* The states k with k + EOMC_BATCH_LANES <= n in lanes, in tiles of up to NG groups of lanes
   ({f"{tile} states" if tile else "one group: a state's outputs are many"}): each row's part of a tile is copied in before the tile and out
   after it, whole cache lines at a time.  Why: rows n doubles apart share L1 sets when n is a
   power of two, and a row's line read or written one group at a time was fetched again for
   the next group (UR10, n = 1024, 4 lanes: 107 -> 77 ns a state).  Shared parameters are
   broadcast once.  Returns the first state not done. */
static EOMC_VTARGET int {name}_{fn}_groups(int n, double t, const double *X, const double *p, const double *P,
                                   const double *R, double *XDOT, {"double *const *rows, " if rows else ""}int *status, int *worst)
{{
    enum {{ L = EOMC_BATCH_LANES, NG = {groups} }};
    eomc_vd x[NG][{nx}], {"" if shared else f"pv[{np1}], "}{f"pv_1[{np1}], " if pair else ""}r[NG][{nr1}], xdot[NG][{nout}];
    int k, i, g, l, gs;
{direct_decl}{"" if nr else "    (void)R;" + chr(10)}{params}    for (g = 0; g < NG; g++) for (i = 0; i < {nr1}; i++) for (l = 0; l < L; l++) r[g][i][l] = 0.0;
    for (k = 0; k + L <= n; k += gs * L) {{
        gs = (n - k) / L < NG ? (n - k) / L : NG;
        for (i = 0; i < {nx}; i++) {{
            for (g = 0; g < gs; g++) __builtin_memcpy(&x[g][i], X + (size_t)i * n + k + g * L, sizeof(eomc_vd));
        }}
{"        if (R != NULL) {" + chr(10) + "            for (g = 0; g < gs; g++) {" + chr(10) + inputs + "            }" + chr(10) + "        }" + chr(10) if nr else ""}{group_loop}{copy_out}    }}
    return k;
}}
#endif
"""
    block_call = ""
    if lanes_code is not None:
        block_call = f"""#if EOMC_BATCH_SIMD
    if (EOMC_VCPU_OK()) k = {name}_{fn}_groups(n, t, X, p, P, R, XDOT, {"rows, " if rows else ""}status, &worst);
#endif
"""
    ts, width = scalar_tile(nx, nr, nout)
    tail_inputs = (f"""        for (i = 0; i < {nr}; i++) {{
            for (j = 0; j < m; j++) rt[j][i] = R != NULL ? R[(size_t)i * (size_t)n + (size_t)(k + j)] : 0.0;
        }}
""" if nr else "")
    tail_params = (f"""            if (P != NULL) {{
                for (i = 0; i < {npar}; i++) ps[i] = P[(size_t)i * (size_t)n + (size_t)(k + j)];
            }}
""" if npar else "")
    entry_p = "" if fn != "rhs" else f"""/* NAME_rhs_batch with one parameter row per state: P[j*n + k] is parameter j of state k. */
int {name}_rhs_batch_p(int n, double t, const double *X, const double *P, const double *R, double *XDOT,
                    int *status, double *work);
int {name}_rhs_batch_p(int n, double t, const double *X, const double *P, const double *R, double *XDOT,
                    int *status, double *work)
{{
    return {name}_rhs_batch_any(n, t, X, NULL, P, R, XDOT, status, work);
}}
"""
    loop = f"""/* The states the lanes do not take (all of them when the {fn} is not vectorized) through the
   scalar {name}_{fn}, in tiles of up to T states: a tile's inputs are gathered row by row, each
   state's outputs written one after another into its row of the tile, then the tile written
   out row by row (T doubles a row: whole cache lines).  Why: the column-major OUT puts a
   state's outputs n doubles apart, and one state at a time wrote a line per output and
   fetched it again for each of the next states (Go2's jac_x, 1296 outputs, n = 1024: 0.52x
   the scalar call).  W, a tile row's length, is an odd number of cache lines, so that the
   tile's rows do not share L1 sets. */
static int {name}_{fn}_batch_any(int n, double t, const double *X, const double *p, const double *P,
                              const double *R, double *XDOT, {"double *const *rows, " if rows else ""}int *status, double *work)
{{
    enum {{ T = {ts}, W = {width} }};
    double xt[T][{nx}], ps[{np1}], rt[T][{nr1}], ot[T][W];
    int k = 0, i, j, m, s, worst = EOMC_OK;
{"" if nr else "    (void)R;" + chr(10)}{"" if npar else "    (void)P;" + chr(10)}    if (n < 0 || X == NULL || XDOT == NULL{" || (p == NULL && P == NULL)" if npar else ""}) return EOMC_BAD_ARGUMENT;
    ps[0] = 0.0;
    for (j = 0; j < T; j++) rt[j][0] = 0.0;
{block_call}    for (; k < n; k += m) {{
        m = n - k < T ? n - k : T;
        for (i = 0; i < {nx}; i++) {{
            for (j = 0; j < m; j++) xt[j][i] = X[(size_t)i * (size_t)n + (size_t)(k + j)];
        }}
{tail_inputs}        for (j = 0; j < m; j++) {{
            const double *xs = xt[j], *rs = rt[j];
            double *xd = ot[j];
{tail_params}            s = {name}_{fn}(t, xs, P != NULL ? ps : p, rs, xd, work);
            if (s != EOMC_OK && s != EOMC_NONFINITE) {{
                for (i = 0; i < {nout}; i++) xd[i] = NAN;
            }}
{f"            if (rows != NULL) __builtin_memcpy(rows[k + j] + {rows[0]}, xd + {rows[0]}, {rows[1]} * sizeof(double));" + chr(10) if rows else ""}            if (status != NULL) status[k + j] = s;
            if (s != EOMC_OK && worst == EOMC_OK) worst = s;
        }}
        for (i = 0; i < {nout}; i++) {{
            double *o = XDOT + (size_t)i * (size_t)n + (size_t)k;
            if (m == T) {{
                for (j = 0; j < T; j++) o[j] = ot[j][i];   /* a whole tile: a fixed count the compiler unrolls */
            }} else {{
                for (j = 0; j < m; j++) o[j] = ot[j][i];
            }}
        }}
    }}
    return worst;
}}

{entry_p}"""
    if rows:
        loop += f"""/* {name}_implicit_batch with the pairs' slope block (outputs {rows[0]} .. {rows[0] + rows[1] - 1}) into each
   state's own output buffer rows[k] instead of OUT (batch_function's rows). */
int {name}_implicit_batch_rows(int n, double t, const double *X, const double *p, const double *R, double *OUT,
                          double *const *rows, int *status, double *work);
int {name}_implicit_batch_rows(int n, double t, const double *X, const double *p, const double *R, double *OUT,
                          double *const *rows, int *status, double *work)
{{
    return {name}_implicit_batch_any(n, t, X, p, NULL, R, OUT, rows, status, work);
}}
"""
    body = (f"    return {name}_{fn}_batch_any(n, t, X, p, NULL, R, {'XDOT' if fn == 'rhs' else 'OUT'}, "
            f"{'NULL, ' if rows else ''}status, work);")
    head = SIMD_PRELUDE if prelude else ""
    return head + ("\n" + simd.rstrip("\n") if simd else "") + "\n\n" + loop.rstrip("\n"), body


def batch_code(name, nx, nr, printed, dynamics="", npar=0, fn="rhs", defined=None, prelude=True, kernels="",
               nout=None):
    """(code before NAME_rhs_batch, its body, metadata) from the scalar rhs's (lines, parts).

    The metadata says whether the lanes are vectorized and, when they are not, why (the
    statement the rewrite does not know): the function then loops the scalar rhs.

    fn="jac_x": the same for ``NAME_jac_x_batch`` from the scalar jac_x's (lines, parts) (its
    tangent loop in lanes; nx*nx outputs per state); fn="outputs", nout=noutput: for
    ``NAME_outputs_batch`` from the scalar outputs'.  ``defined``: a set of the helper keys an
    earlier batch function of the same file defined (not repeated; this call's keys are added
    to it); prelude=False when that earlier function's code holds the prelude."""
    lines, parts = printed
    nout = nout if nout is not None else nx if fn == "rhs" else nx * nx
    out = "xdot" if fn == "rhs" else "out"
    layout = {"rhs": "nx x n", "jac_x": "nx*nx x n", "outputs": "noutput x n", "implicit": "size x n"}[fn]
    # implicit: does NAME_implicit read t?  The lanes rollout batches rows an ulp apart in time
    # only when it does not (runtime/c/eomc_rollout.c, same_call: the batch takes one t).
    extra = {"reads_t": reads_t(lines)} if fn == "implicit" else {}
    rows = {}
    try:
        lanes, used = batch_rhs(name, lines, parts, dynamics, fn=fn, out=out, kernels=kernels, rows=rows)
    except Unsupported as exc:
        before, body = batch_function(name, nx, nr, npar, None, "", fn=fn, nout=nout, prelude=prelude)
        return before, body, {"vectorized": False, "why": f"the scalar {fn} {exc}", "layout": layout, **extra}
    pair = "pair" in used and _tile(nx, nr, nout) is not None and npar is not None
    if "pair" in used and not pair:     # one group of lanes a tile: NAME_rhs_lanes2 would not be called
        lanes = lanes[:lanes.index(f"static EOMC_VTARGET void {name}_{fn}_lanes2(")].rstrip("\n")
    used.discard("pair")
    before, body = batch_function(name, nx, nr, npar, lanes, helpers(name, used, defined or ()), fn=fn,
                                  nout=nout, prelude=prelude, pair=pair, rows=rows.get("block"))
    if "block" in rows:     # NAME_implicit_batch_rows: the pairs' slope block into the states' own rows
        extra["rows_block"] = list(rows["block"])
    if defined is not None:
        defined.update(key for key, _ in helper_blocks(name, used))
    return before, body, {"vectorized": True, "layout": layout,
                          "sin_cos": "vectorized fdlibm kernels, within 1 ulp of libm" if "trig" in used else None,
                          **extra}


def reads_t(lines):
    """Whether a scalar function's printed body reads its argument t.  Why the C text and not
    the expressions' free symbols: it is what the function reads, its calls included (a split
    part or helper gets t only as an argument, so the call names it; bodies.void_unused's test,
    which writes ``(void)t;`` otherwise).  A false True (t in a comment) only keeps the exact
    test."""
    return any(re.search(r"\bt\b", line) for line in lines)
