"""Bounded-size C: long straight-line runs of temporaries become static sub-functions.

Why: gcc's register allocation (IRA, then LRA's hard-register assignment) grows much
faster than linearly with the number of values live in one function.  On the Whipple
bicycle's 2,200-line jac_x it was two thirds of gcc's 6 s; on large chains gcc took
minutes and gigabytes.  A function made of pieces of at most :data:`CHUNK` statements
costs gcc about the same per statement whatever the model's size.  The thresholds come
from benchmarks/bench_build_scaling.py (results/build_scaling.md): chunks of 100 compiled
fastest of 100/250/500, and the split code ran no slower than the unsplit (up to 30%
faster: gcc spills less badly in small functions).

How: a *run* is a maximal block of consecutive statements of two shapes, at one
indentation: ``const double tN = ...;`` (what :func:`eomc.compiler.emit.bodies.temps`
prints) and stores to a constant index, ``F[12] = ...;`` (the results).  A run longer
than :data:`SPLIT_MIN` statements is cut into consecutive chunks of at most
:data:`CHUNK` statements and :data:`CHUNK_BYTES` characters of C (Kane's mass matrix
in relative coordinates has sums of hundreds of terms: counting statements alone left
580 kB in one function at n = 40).  Each chunk becomes
``static EOMC_NOINLINE void NAME_partK(...)``, which takes the caller's arrays it uses
(``x``, ``p``, ``w``, ``F``, ...; ``const double *`` unless it stores into them) and
keeps its own temporaries as locals.  A temporary read by a later chunk, or by the rest of
the caller, is also stored in a scratch array on the caller's stack
(``double SK[n]``, so the code stays reentrant); later chunks and the caller read it
from there.  Slots whose last reader has run are reused, so the scratch array holds
only what is live across a chunk boundary.  The values, and the order in which every
expression is evaluated, are those of the unsplit function.

The rewrite works on the printed lines: C names of temporaries are ``t<digits>``
(:func:`eomc.compiler.ir.c_names`), arrays are ``name[...]``, calls are ``name(...)``,
and the time is ``t``.  A run that reads any other identifier (a loop counter, say) is
left as it is.  Output depends only on the input lines: byte-identical C.
"""
import functools
import re

__all__ = ["split_body", "NOINLINE_MACRO", "FOLD_MIN", "SPLIT_MIN",
           "CHUNK", "CHUNK_BYTES", "LEAN_MACRO", "LEAN_FUNCTIONS",
           "LEAN_MIN", "lean_attribute", "PART_LEAN_FUNCTIONS", "PART_LEAN_MACRO", "NEAR_MACRO"]

SPLIT_MIN = 300      # statements: shorter runs stay as they are
FOLD_BLOCKS = True   # split_body's ``blocks`` honoured (False: the C before session 17, for A/B)
FOLD_MIN = 1200      # lines the plain split leaves in a body before generate.py folds its guard blocks
CHUNK = 100          # statements per sub-function, at most
CHUNK_BYTES = 8000   # characters of C per sub-function, about (a chunk ends past this)
# Near pointers (split_body's ``windows``): in a run of at least WINDOW_MIN statements, each
# sub-function takes its scratch slots through up to WINDOWS pointers &S_[b], each within
# reach of an 8-bit displacement of the slots it serves (WINDOW_MIN_REFS references or more),
# and x and p shifted likewise.  Why: a floating-base humanoid's rhs is 50-180 kB of straight-line
# code that streams from L2 through the L1i every call, and its time follows its bytes on this
# host (AMD Zen 5); S_[k] with k >= 16 takes a 4-byte displacement.  G1's rhs 7 % fewer bytes,
# 3-5 % faster (G1, Talos, Go2: 124, 168, 47 kB of code); code that fits the 32 kB L1i lost:
# UR10's 12 kB rhs 2 %, Panda's 29 kB (862 statements) 10 %, Allegro's 26 kB (1,098) 1-6 %,
# hence the run length (Solo12 1,494, Go2 1,632; benchmarks/results/free_joint.md, session 18).
WINDOW_MIN = 1300    # statements of a run
WINDOWS = 8          # pointers into the scratch array per sub-function, at most
WINDOW_MIN_REFS = 6  # references a window must serve
WINDOW_SPAN = 32     # doubles an 8-bit displacement reaches: base - 16 .. base + 15

# gcc (not clang, which also defines __GNUC__) compiles the sub-functions at -O1 when the
# library is built optimized (-O2/-O3; not -O0, -Og or -Os, which keep their own choice):
# -O2's extra passes on long straight-line code (SLP vectorization, the second scheduling,
# PRE) took a third of gcc's time on a 200-link chain's rhs and a 40-link cart's jac_x,
# and the code ran no faster for them (benchmarks/results/urdf_build.md, default_build.md).
# -DEOMC_PARTS_FULL_OPT in CFLAGS keeps the command line's level for them too.
NOINLINE_MACRO = """#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) \\
    && !defined(__OPTIMIZE_SIZE__) && !defined(__NO_INLINE__) && !defined(EOMC_PARTS_FULL_OPT)
#define EOMC_NOINLINE __attribute__((noinline, optimize("O1")))
#elif defined(__GNUC__)
#define EOMC_NOINLINE __attribute__((noinline))
#else
#define EOMC_NOINLINE
#endif"""

# What the split leaves in a function is not always small: a contact model's guard blocks cut
# its straight-line code into runs shorter than SPLIT_MIN, so the bodies of gymnasium ant's rhs,
# jac_x and NAME_implicit stay 1,800, 2,700 and 1,500 lines with branches, compiled at the
# command line's level.  They were most of ant's gcc time (jac_x 2.7 of 6.7 s, 1.5 s of it its
# own body).  A body of more than LEAN_MIN lines of one of LEAN_FUNCTIONS is compiled at -O1
# plus the -O2 passes that paid for themselves there (SLP vectorization, peephole2, the
# expensive optimizations, caller-saves, rematerialization, store merging; for rhs also PRE
# and GCSE, without which its call was 2 % slower).  What that leaves out (the second
# scheduling, code hoisting, VRP, the regional allocator; PRE and GCSE for jac_x and
# NAME_implicit) is what gcc spent most on in them: gcc 5.8 -> 4.6 s on ant, 11.0 -> 8.7 s on
# the humanoid, and the calls ran as fast (within 1 % both ways, bit-identical results;
# benchmarks/results/mjcf_build.md).  -O1 alone made them 1-2 % slower.  Same guard and
# -DEOMC_PARTS_FULL_OPT opt-out as the sub-functions.  The bits are the same: no option here
# reassociates or contracts.
LEAN_FUNCTIONS = {"rhs": "EOMC_LEAN_PRE", "jac_x": "EOMC_LEAN", "implicit": "EOMC_LEAN"}
LEAN_MIN = 600       # lines of the body the split left
LEAN_MACRO = """#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) \\
    && !defined(__OPTIMIZE_SIZE__) && !defined(__NO_INLINE__) && !defined(EOMC_PARTS_FULL_OPT)
#define EOMC_LEAN __attribute__((optimize("O1", "tree-slp-vectorize", "peephole2", \\
    "expensive-optimizations", "caller-saves", "lra-remat", "store-merging")))
#define EOMC_LEAN_PRE __attribute__((optimize("O1", "tree-slp-vectorize", "peephole2", \\
    "expensive-optimizations", "caller-saves", "lra-remat", "store-merging", "tree-pre", "gcse")))
#else
#define EOMC_LEAN
#define EOMC_LEAN_PRE
#endif"""


# A chunk holding a folded branch block (split_body's ``blocks``) is code that stood in the
# function's own body before: in NAME_implicit those chunks, at the sub-functions' plain -O1,
# made the humanoid's call 5-6 % slower; with EOMC_LEAN's passes (and noinline) it is as fast
# as before (0.99x) for ~0.05 s more gcc than plain -O1.  rhs and jac_x ran as fast or faster
# with their chunks at -O1 (rhs 0.93x, jac_x 0.98-0.99x; their lean passes gave them nothing
# and cost 0.25 s of gcc).  benchmarks/results/mjcf_build.md, session 17.
PART_LEAN_FUNCTIONS = {"implicit": "EOMC_PART_LEAN"}
PART_LEAN_MACRO = """#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) \\
    && !defined(__OPTIMIZE_SIZE__) && !defined(__NO_INLINE__) && !defined(EOMC_PARTS_FULL_OPT)
#define EOMC_PART_LEAN __attribute__((noinline, optimize("O1", "tree-slp-vectorize", "peephole2", \\
    "expensive-optimizations", "caller-saves", "lra-remat", "store-merging")))
#else
#define EOMC_PART_LEAN EOMC_NOINLINE
#endif"""


# The sub-functions of a run that takes near pointers also skip gcc's temporary expression
# replacement (TER: single-use values expanded at their use), which lengthens live ranges in
# these 100-statement bodies: G1's rhs 4 % fewer bytes and 3.5 % faster again (4 file copies
# each), the same bits (TER moves no operation across another: same expressions, same order).
NEAR_MACRO = """#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) \\
    && !defined(__OPTIMIZE_SIZE__) && !defined(__NO_INLINE__) && !defined(EOMC_PARTS_FULL_OPT)
#define EOMC_NEAR __attribute__((noinline, optimize("O1", "no-tree-ter")))
#else
#define EOMC_NEAR EOMC_NOINLINE
#endif"""


def lean_attribute(fn, lines):
    """The macro (``EOMC_LEAN`` or ``EOMC_LEAN_PRE``) to put before function ``fn``'s
    definition, whose body is ``lines`` (what split_body left), or "" for none."""
    return LEAN_FUNCTIONS.get(fn, "") if len(lines) > LEAN_MIN else ""


_TEMP_LINE = re.compile(r"^(\s+)const double (t\d+) = (.*);$")
_STORE_LINE = re.compile(r"^(\s+)([A-Za-z_]\w*)\[(\d+)\] = (.*);$")
_TEMP = re.compile(r"\bt\d+\b")
_OUT_ARG = re.compile(r"&([A-Za-z_]\w*)\[")
_IDENT = re.compile(r"\b([A-Za-z_]\w*)\s*([\[(]?)")
_IND = "    "


_IF_LINE = re.compile(r"^(\s+)if \((.*)\) \{$")
_ELSE_LINE = re.compile(r"^\s+\} else (?:if \((.*)\) )?\{$")
_CLOSE_LINE = re.compile(r"^\s+\}$")
BLOCK = "{block}"    # the lvalue of a folded block's statement (_fold_blocks)


@functools.lru_cache(maxsize=1 << 16)
def _statement(line):
    """(indent, temp or None, lvalue or None, expression) of a run's line, or None.  A folded
    block (several lines in one string, :func:`_fold_blocks`) is (indent, None, BLOCK, its
    text).  Remembered: split_body looks at every line again after each run it splits."""
    if "\n" in line:
        m = _IF_LINE.match(line.split("\n", 1)[0])
        return (m.group(1), None, BLOCK, line) if m else None
    m = _TEMP_LINE.match(line)
    if m:
        return m.group(1), m.group(2), None, m.group(3)
    m = _STORE_LINE.match(line)
    if m:
        return m.group(1), None, f"{m.group(2)}[{m.group(3)}]", m.group(4)
    return None


def _block_parts(text):
    """(the texts a folded block reads: its conditions and right sides, with the arrays it
    stores into; {array names it stores into}; {temporaries it defines})."""
    reads, stored, own = [], set(), set()
    for line in text.split("\n"):
        m = _IF_LINE.match(line) or _ELSE_LINE.match(line)
        if m:
            reads.append(m.groups()[-1] or "")
            continue
        st = _statement(line)
        if st is None:
            continue                 # a closing brace
        _, name, lvalue, expr = st
        reads.append(expr)
        if name:
            own.add(name)
        else:
            stored.add(lvalue.split("[", 1)[0])
    return reads, stored, own


def _read_names(st):
    """The temporaries statement ``st`` reads (a folded block: not its own)."""
    if st[2] != BLOCK:
        return _TEMP.findall(st[3])
    reads, _, own = _block_parts(st[3])
    return [n for text in reads for n in _TEMP.findall(text) if n not in own]


def _fold_blocks(lines):
    """``lines`` with each branch block whose lines are all run statements (``if (c) {``,
    ``} else {``, ``}`` around them, nested too) joined into one string: a statement of a run,
    so the straight-line code on both sides of it and the block itself go into sub-functions
    together.  A contact model's guard blocks (compiler/emit/guards.py) cut the code of rhs,
    jac_x and NAME_implicit into runs shorter than SPLIT_MIN, which stayed in the function's
    own body: gcc's register allocation of those 2,000-3,000-line bodies was most of the
    humanoid's compile (compiler/emit/generate.py asks for it where the split leaves a body of
    more than FOLD_MIN lines: ant's and the humanoid's 1,500-2,900; not hopper's and walker2d's
    rhs of 650-800 lines, which ran 3-8 % slower folded).  Only blocks whose temporaries are defined nowhere else in the
    function (so no name is shadowed) and that read no identifier a sub-function would not
    see; the lines are kept as they are (split_body joins them back)."""
    defined = {}
    for line in lines:
        m = _TEMP_LINE.match(line)
        if m:
            defined[m.group(2)] = defined.get(m.group(2), 0) + 1
    out, i = [], 0
    while i < len(lines):
        m = _IF_LINE.match(lines[i])
        end = None
        if m:
            depth, j = 1, i + 1
            while j < len(lines) and depth:
                line = lines[j]
                if _IF_LINE.match(line):
                    depth += 1
                elif _CLOSE_LINE.match(line):
                    depth -= 1
                elif not (_ELSE_LINE.match(line) or _statement(line)):
                    break
                j += 1
            if not depth and lines[j - 1] == f"{m.group(1)}}}":
                end = j
        if end is not None:
            text = "\n".join(lines[i:end])
            reads, _, own = _block_parts(text)
            if all(defined[n] == 1 for n in own) and not any(_reads(r)[2] for r in reads):
                out.append(text)
                i = end
                continue
        out.append(lines[i])
        i += 1
    return out


def _runs(lines):
    """(start, end) of every maximal block of run statements with one indentation."""
    runs, start, indent = [], None, None
    for i, line in enumerate(lines + [""]):
        st = _statement(line)
        if st and start is not None and st[0] == indent:
            continue
        if start is not None:
            runs.append((start, i))
        start, indent = (i, st[0]) if st else (None, None)
    return runs


def _chunks(stmts):
    """Consecutive pieces of at most CHUNK statements and about CHUNK_BYTES characters."""
    chunks, current, count, size = [], [], 0, 0
    for st in stmts:
        if current and (count >= CHUNK or size >= CHUNK_BYTES):
            chunks.append(current)
            current, count, size = [], 0, 0
        current.append(st)
        count += st[3].count("\n") + 1 if st[2] == BLOCK else 1
        size += len(st[3]) + 24
    return chunks + ([current] if current else [])


@functools.lru_cache(maxsize=1 << 16)
def _temps(line):
    """The temporaries' names in ``line``, in order (remembered, as :func:`_statement`)."""
    return tuple(_TEMP.findall(line))


@functools.lru_cache(maxsize=1 << 16)
def _reads(text):
    """(arrays, reads the time ``t``, other identifiers) of one expression's text (frozensets;
    remembered: _split_run asks it twice of each statement)."""
    arrays, scalars = set(), set()
    for name, follow in _IDENT.findall(text):
        if follow == "[":
            arrays.add(name)
        elif follow != "(" and not _TEMP.fullmatch(name):
            scalars.add(name)
    return frozenset(arrays), "t" in scalars, frozenset(scalars - {"t"})


class _Slots:
    """Lowest-free-first slot allocation (deterministic)."""

    def __init__(self):
        self.free, self.size = [], 0

    def take(self):
        if self.free:
            self.free.sort()
            return self.free.pop(0)
        self.size += 1
        return self.size - 1

    def fresh(self):
        """A slot no earlier run has used: for a value stored where it is defined, which
        can be before an earlier run's chunks, while that run still uses its freed slots."""
        self.size += 1
        return self.size - 1

    def give(self, slot):
        self.free.append(slot)


def _split_run(lines, start, end, base, scratch, slots, restrict=False, block_attribute=None, windows=False):
    """Split ``lines[start:end]``: (sub-function texts, caller lines, {temp: slot} of the
    run's temporaries the rest reads, {earlier temp: slot} to store), or None."""
    stmts = [_statement(line) for line in lines[start:end]]
    if any(_reads(expr)[2] for _, _, lvalue, expr in stmts if lvalue != BLOCK):
        return None                  # reads a name a sub-function would not see
    indent = stmts[0][0]
    windows = windows and len(stmts) >= (WINDOW_MIN if windows is True else windows)   # an int: its own threshold
    chunks = _chunks(stmts)
    where = {name: c for c, chunk in enumerate(chunks) for _, name, _, _ in chunk if name}
    last, outside = {}, {}           # temp -> last chunk reading it; earlier temps read
    for c, chunk in enumerate(chunks):
        for st in chunk:
            for name in _read_names(st):
                if name not in where:
                    outside.setdefault(name, None)
                elif where[name] != c:
                    last[name] = c
    after = {n for line in lines[end:] for n in _temps(line) if n in where}
    slot_of = {name: slots.fresh() for name in outside}  # held until the function ends

    def scratch_ref(m):
        name = m.group(0)
        return f"{scratch}[{slot_of[name]}]" if name in slot_of and name not in local else name

    released = {}                    # chunk -> the temps whose last reader was the chunk before
    for name, c_last in last.items():
        released.setdefault(c_last + 1, []).append(name)
    parts = []
    for c, chunk in enumerate(chunks):
        for name in released.get(c, ()):
            if name not in after:
                slots.give(slot_of[name])
        body, local, written, reads = [], set(), set(), []
        attribute = "EOMC_NEAR" if windows else "EOMC_NOINLINE"
        for _, name, lvalue, expr in chunk:
            if lvalue == BLOCK:      # a folded block: its lines one level in, its own temps local
                block_reads, stored, own = _block_parts(expr)
                local |= own
                text = _TEMP.sub(scratch_ref, expr)
                body.append("\n".join(_IND + line[len(indent):] for line in text.split("\n")))
                written |= stored
                written.update(_OUT_ARG.findall(text))
                reads += [_TEMP.sub(scratch_ref, r) for r in block_reads]
                attribute = block_attribute or attribute
                continue
            expr = _TEMP.sub(scratch_ref, expr)
            reads.append(expr)
            if name is None:
                body.append(f"{_IND}{lvalue} = {expr};")
                written.add(lvalue.split("[", 1)[0])
                written.update(_OUT_ARG.findall(expr))
                continue
            body.append(f"{_IND}const double {name} = {expr};")
            written.update(_OUT_ARG.findall(expr))   # a call's output array: &A[0]
            local.add(name)
            if name in last or name in after:
                slot_of[name] = slots.take()
                body.append(f"{_IND}{scratch}[{slot_of[name]}] = {name};")
        _pair_sincos(body, scratch)
        arrays, uses_t = set(written), False
        for line in body:
            if " = " in line and "\n" not in line:
                reads.append(line.split(" = ", 1)[1])   # the scratch stores
        for text in reads:
            a, ut, _ = _reads(text)
            arrays |= a
            uses_t |= ut
        uses_scratch = any(f"{scratch}[" in line for line in body)
        arrays = sorted(arrays - {scratch})
        params = (["double t"] if uses_t else []) + [
            f"{'double' if a in written else 'const double'} *{a}" for a in arrays]
        params += [f"double *{'restrict ' if restrict else ''}{scratch}"] if uses_scratch else []
        args = (["t"] if uses_t else []) + arrays + ([scratch] if uses_scratch else [])
        if windows:
            body, params, args = _near_pointers(body, params, args, scratch, restrict, written)
        fname = f"{base}{c}"
        parts.append(f"static {attribute} void {fname}({', '.join(params) or 'void'})\n"
                     f"{{\n" + "\n".join(body) + "\n}\n")
        parts.append(f"{indent}{fname}({', '.join(args)});")
    helpers, calls = parts[0::2], parts[1::2]
    return (helpers, calls, {n: slot_of[n] for n in after},
            {n: slot_of[n] for n in outside})


def _window(counts):
    """(references served, lowest, highest index) of the WINDOW_SPAN-wide index range that
    serves the most of ``counts`` ({index: references}); the lowest such range on a tie."""
    keys = sorted(counts)
    best = (0, 0, 0)
    for lo in keys:
        inside = [k for k in keys if lo <= k < lo + WINDOW_SPAN]
        served = sum(counts[k] for k in inside)
        if served > best[0]:
            best = (served, lo, inside[-1])
    return best


def _near_pointers(body, params, args, scratch, restrict, written):
    """A sub-function's (body, params, args) with its references to ``scratch`` served by
    pointers ``&S_[b]`` (``S_w0``, ``S_w1``, ...: slot ``k`` becomes ``S_wj[k - b]``, within
    an 8-bit displacement) and its reads of ``x`` and ``p`` through one shifted pointer each.
    Each slot is reached through one pointer only, so ``restrict`` stays true of every one; a
    base is an index the function reads (the pointer stays inside the array).  The values and
    the order of evaluation are unchanged: only the addressing."""
    text = "\n".join(body)
    ref = re.compile(rf"(?<![\w&]){re.escape(scratch)}\[(\d+)\]")
    new_params, new_args = list(params), list(args)
    for name in ("p", "x"):                     # read-only inputs: one shifted pointer
        if name not in args or name in written or re.search(rf"&{name}\[", text):
            continue
        pat = re.compile(rf"(?<![\w&]){name}\[(\d+)\]")
        counts = {}
        for k in pat.findall(text):
            counts[int(k)] = counts.get(int(k), 0) + 1
        served, lo, hi = _window(counts)
        near = sum(c for k, c in counts.items() if k < WINDOW_SPAN // 2)
        if served <= near:
            continue
        b = min(lo + WINDOW_SPAN // 2, hi)
        text = pat.sub(lambda m, b=b, name=name: f"{name}[{int(m.group(1)) - b}]", text)
        new_args[new_args.index(name)] = f"&{name}[{b}]"
    if scratch in args and not re.search(rf"&{re.escape(scratch)}\[", text):
        counts = {}
        for k in ref.findall(text):
            counts[int(k)] = counts.get(int(k), 0) + 1
        serve, bases = {}, []
        while len(bases) < WINDOWS and counts:
            served, lo, hi = _window(counts)
            if served < WINDOW_MIN_REFS:
                break
            b = min(lo + WINDOW_SPAN // 2, hi)
            for k in [k for k in counts if lo <= k <= hi]:
                serve[k] = (len(bases), k - b)
                del counts[k]
            bases.append(b)
        if bases:
            def near(m):
                k = int(m.group(1))
                return f"{scratch}w{serve[k][0]}[{serve[k][1]}]" if k in serve else m.group(0)
            text = ref.sub(near, text)
            i = new_args.index(scratch)
            if not counts:                       # every slot through a window
                del new_params[i], new_args[i]
            kind = f"double *{'restrict ' if restrict else ''}"
            new_params += [f"{kind}{scratch}w{j}" for j in range(len(bases))]
            new_args += [f"&{scratch}[{b}]" for b in bases]
    return text.split("\n"), new_params, new_args


_TRIG_LINE = re.compile(r"^\s+const double (t\d+) = (sin|cos)\((.*)\);$")


def _pair_sincos(body, scratch):
    """Move a sin (cos) temporary's scratch store below the cos (sin) of the same argument
    that follows it, in place, so the two calls are adjacent and gcc makes them one
    ``sincos`` call.  With the store between them, gcc (12, at -O1 and -O2, with or without
    ``restrict`` on the scratch) reloads the argument and keeps two libm calls: on
    gymnasium's ant 7 of the 11 angles' pairs in NAME_implicit's kinematics were such, and
    pairing them made NAME_implicit 2.7 % faster.  Only a store moves, past a statement
    that does not read it: the values are the same, and glibc's sincos returns sin's and
    cos's bits (checked on 2e7 arguments, 1e-300 to 1e300)."""
    for i in range(len(body) - 2):
        first = _TRIG_LINE.match(body[i])
        second = _TRIG_LINE.match(body[i + 2])
        if (first and second and first.group(2) != second.group(2) and first.group(3) == second.group(3)
                and re.fullmatch(rf"\s+{re.escape(scratch)}\[\d+\] = {first.group(1)};", body[i + 1])):
            body[i + 1], body[i + 2] = body[i + 2], body[i + 1]


def split_body(lines, base, scratch="S_", restrict=False, blocks=False, block_attribute=None, windows=False):
    """(new body lines, sub-function texts) for one function body; ``base``: the C name
    prefix of its sub-functions (``NAME_fn_part``).  Unchanged when no run is long.

    One scratch array serves the whole function, declared first in its body.

    ``restrict``: the sub-functions take it as ``double *restrict S_``.  Always true of it
    (the caller's own stack array, which no other argument points into), and it tells the
    compiler that a store to a scratch slot leaves ``x``, ``p``, ``r`` unchanged.  Without
    it gcc reloads every input read after such a store and cannot pair ``sin(x[k])`` with
    ``cos(x[k])`` into one ``sincos`` (a store sits between them): G1's rhs ran 10 % faster
    with it, same bits (benchmarks/results/free_joint.md).  The formulation asks for it per
    function (:meth:`eomc.compiler.emit.formulation.Formulation.restrict_scratch`), so the C
    of the functions that do not stays as it was.

    ``blocks``: branch blocks of run statements (a contact's guard) are statements of a run
    too (:func:`_fold_blocks`); ``block_attribute``: the macro a sub-function holding one is
    declared with (default EOMC_NOINLINE, as the others; PART_LEAN_FUNCTIONS)."""
    lines, helpers, slots, pos, nrun = list(lines), [], _Slots(), 0, 0
    blocks = blocks and FOLD_BLOCKS
    if blocks:
        lines = _fold_blocks(lines)

    def weight(s, e):                # the lines of the run, a folded block's counted
        return sum(line.count("\n") + 1 for line in lines[s:e])
    while True:
        run = next(((s, e) for s, e in _runs(lines) if s >= pos and weight(s, e) > SPLIT_MIN), None)
        if run is None:
            break
        start, end = run
        done = _split_run(lines, start, end, f"{base}{nrun}_", scratch, slots, restrict, block_attribute,
                          windows)
        if done is None:
            pos = end
            continue
        nrun += 1
        new_helpers, calls, renamed, stored = done
        tail = _rename_tail(lines[end:], renamed, scratch)
        head = []
        visible = _visible_definitions(lines[:start], stored)
        for i, line in enumerate(lines[:start]):   # earlier temporaries the chunks read: stored
            head.append(line)                       # right after the definition the run sees
            if i in visible:
                m = _TEMP_LINE.match(line)
                head.append(f"{m.group(1)}{scratch}[{stored[m.group(2)]}] = {m.group(2)};")
        lines = head + calls + tail
        pos = len(head) + len(calls)
        helpers += new_helpers
    if blocks:
        lines = [line for text in lines for line in text.split("\n")]
    if slots.size:
        lines.insert(0, f"{_IND}double {scratch}[{slots.size}];")
    return lines, helpers


# Temporaries' names are unique within a scope, not within a function: the columns' loop of
# a Jacobian (a block of its own) defines t28 again though t28 exists outside it.  So what
# the split renames or stores must follow C's scopes: a definition in a block shadows the
# outer name until the block closes.

def _depth_change(line):
    return line.count("{") - line.count("}")


def _rename_tail(tail, renamed, scratch):
    """``tail`` with reads of the run's temporaries (``renamed``: name -> slot) replaced by
    their scratch slots, except where a definition in an inner block shadows the name."""
    shadow = [set()]                 # names redefined in each open block
    out = []
    for line in tail:
        m = _TEMP_LINE.match(line)
        if m and m.group(2) in renamed:
            shadow[-1].add(m.group(2))
        if renamed.keys().isdisjoint(_temps(line)):
            out.append(line)         # (most lines: nothing to rename)
        else:
            hidden = set().union(*shadow)
            out.append(_TEMP.sub(lambda t: f"{scratch}[{renamed[t.group(0)]}]"
                                 if t.group(0) in renamed and t.group(0) not in hidden
                                 else t.group(0), line))
        for _ in range(max(_depth_change(line), 0)):
            shadow.append(set())
        for _ in range(max(-_depth_change(line), 0)):
            if len(shadow) > 1:
                shadow.pop()
            else:                    # the run's own block closes: its names are gone
                return out + tail[len(out):]
    return out


def _visible_definitions(head, names):
    """Indices of the lines in ``head`` defining one of ``names`` that are still in scope
    at its end (a definition inside a block that has closed is not the one a later run
    reads)."""
    open_defs = [{}]                 # per open block: name -> line index
    for i, line in enumerate(head):
        m = _TEMP_LINE.match(line)
        if m and m.group(2) in names:
            open_defs[-1][m.group(2)] = i
        change = _depth_change(line)
        for _ in range(max(change, 0)):
            open_defs.append({})
        for _ in range(max(-change, 0)):
            if len(open_defs) > 1:
                open_defs.pop()
    seen = {}
    for level in open_defs:          # inner blocks shadow outer ones
        seen.update(level)
    return set(seen.values())

