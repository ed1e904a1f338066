"""Bounded-size C: long straight-line runs of temporaries become static sub-functions.

Why: gcc's register allocation (IRA, then LRA's hard-register assignment) grows much
faster than linearly with the number of values live in one function.  On the Whipple
bicycle's 2,200-line jac_x it was two thirds of gcc's 6 s; on large chains gcc took
minutes and gigabytes.  A function made of pieces of at most :data:`CHUNK` statements
costs gcc about the same per statement whatever the model's size.  The thresholds come
from benchmarks/bench_build_scaling.py (results/build_scaling.md): chunks of 100 compiled
fastest of 100/250/500, and the split code ran no slower than the unsplit (up to 30%
faster: gcc spills less badly in small functions).

How: a *run* is a maximal block of consecutive ``const double tN = ...;`` lines (the
shape every body printer emits, :func:`eomc.compiler.emit.bodies._temps`).  A run
longer than :data:`SPLIT_MIN` is cut into consecutive chunks of :data:`CHUNK` lines.
Each chunk becomes ``static EOMC_NOINLINE void NAME_partK(...)``, which reads the
caller's arrays it needs (``x``, ``p``, ``w``, ...) as ``const double *`` and keeps
its own temporaries as locals.  A temporary read by a later chunk, or by the rest of
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
import re

__all__ = ["split_body", "NOINLINE_MACRO", "SPLIT_MIN", "CHUNK"]

SPLIT_MIN = 300      # statements: shorter runs stay as they are
CHUNK = 100          # statements per sub-function

NOINLINE_MACRO = """#if defined(__GNUC__)
#define EOMC_NOINLINE __attribute__((noinline))
#else
#define EOMC_NOINLINE
#endif"""

_TEMP_LINE = re.compile(r"^(\s+)const double (t\d+) = (.*);$")
_TEMP = re.compile(r"\bt\d+\b")
_IDENT = re.compile(r"\b([A-Za-z_]\w*)\s*([\[(]?)")
_IND = "    "


def _runs(lines):
    """(start, end) of every maximal block of temporary lines with one indentation."""
    runs, start, indent = [], None, None
    for i, line in enumerate(lines + [""]):
        m = _TEMP_LINE.match(line)
        if m and start is not None and m.group(1) == indent:
            continue
        if start is not None:
            runs.append((start, i))
        start, indent = (i, m.group(1)) if m else (None, None)
    return runs


def _reads(text):
    """(arrays, reads the time ``t``, other identifiers) of one expression's text."""
    arrays, scalars = set(), set()
    for name, follow in _IDENT.findall(text):
        if follow == "[":
            arrays.add(name)
        elif follow != "(" and not _TEMP.fullmatch(name):
            scalars.add(name)
    return arrays, "t" in scalars, scalars - {"t"}


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


def _split_run(lines, start, end, base, scratch, slots):
    """Split ``lines[start:end]``: (sub-function texts, caller lines, {temp: slot} of the
    run's temporaries the rest reads, {earlier temp: slot} to store), or None."""
    defs = [_TEMP_LINE.match(line).group(2, 3) for line in lines[start:end]]
    indent = _TEMP_LINE.match(lines[start]).group(1)
    chunks = [defs[i:i + CHUNK] for i in range(0, len(defs), CHUNK)]
    where = {name: c for c, chunk in enumerate(chunks) for name, _ in chunk}
    last, outside = {}, {}           # temp -> last chunk reading it; earlier temps read
    for c, chunk in enumerate(chunks):
        for _, expr in chunk:
            for name in _TEMP.findall(expr):
                if name not in where:
                    outside.setdefault(name, None)
                elif where[name] != c:
                    last[name] = c
    after = {n for line in lines[end:] for n in _TEMP.findall(line) if n in where}
    slot_of = {name: slots.fresh() for name in outside}  # held until the function ends

    def scratch_ref(m):
        name = m.group(0)
        return f"{scratch}[{slot_of[name]}]" if name in slot_of and name not in local else name

    parts = []
    for c, chunk in enumerate(chunks):
        for name, c_last in last.items():
            if c_last == c - 1 and name not in after:
                slots.give(slot_of[name])
        body, local = [], set()
        for name, expr in chunk:
            body.append(f"{_IND}const double {name} = {_TEMP.sub(scratch_ref, expr)};")
            local.add(name)
            if name in last or name in after:
                slot_of[name] = slots.take()
                body.append(f"{_IND}{scratch}[{slot_of[name]}] = {name};")
        arrays, uses_t = set(), False
        for line in body:
            a, ut, others = _reads(line.split(" = ", 1)[1])
            if others:
                return None
            arrays |= a
            uses_t |= ut
        arrays = sorted(arrays - {scratch})
        params = (["double t"] if uses_t else []) + [f"const double *{a}" for a in arrays]
        args = (["t"] if uses_t else []) + arrays + [scratch]
        fname = f"{base}{c}"
        parts.append(f"static EOMC_NOINLINE void {fname}({', '.join(params + [f'double *{scratch}'])})\n"
                     f"{{\n" + "\n".join(body) + "\n}\n")
        parts.append(f"{indent}{fname}({', '.join(args)});")
    helpers, calls = parts[0::2], parts[1::2]
    return (helpers, calls, {n: slot_of[n] for n in after},
            {n: slot_of[n] for n in outside})


def split_body(lines, base, scratch="S_"):
    """(new body lines, sub-function texts) for one function body; ``base``: the C name
    prefix of its sub-functions (``NAME_fn_part``).  Unchanged when no run is long.

    One scratch array serves the whole function, declared first in its body."""
    lines, helpers, slots, pos, nrun = list(lines), [], _Slots(), 0, 0
    while True:
        run = next(((s, e) for s, e in _runs(lines) if s >= pos and e - s > SPLIT_MIN), None)
        if run is None:
            break
        start, end = run
        done = _split_run(lines, start, end, f"{base}{nrun}_", scratch, slots)
        if done is None:
            pos = end
            continue
        nrun += 1
        new_helpers, calls, renamed, stored = done
        tail = [_TEMP.sub(lambda m: f"{scratch}[{renamed[m.group(0)]}]"
                          if m.group(0) in renamed else m.group(0), line) for line in lines[end:]]
        head = []
        for line in lines[:start]:      # earlier temporaries the chunks read: stored once defined
            head.append(line)
            m = _TEMP_LINE.match(line)
            if m and m.group(2) in stored:
                head.append(f"{m.group(1)}{scratch}[{stored[m.group(2)]}] = {m.group(2)};")
        lines = head + calls + tail
        pos = len(head) + len(calls)
        helpers += new_helpers
    if nrun:
        lines.insert(0, f"{_IND}double {scratch}[{max(slots.size, 1)}];")
    return lines, helpers
