"""A contact loop's input array read in place from the scratch array, not copied into a literal.

One job: in NAME_implicit's split C (its body lines and its sub-functions), each call of a static
contact loop whose first argument is a compound literal -- the pairs' loop,
``eomc_pairs_slopes((const double[285]){S_[39], S_[40], ..., x[27], -p[22], 0.0, ...}, ...)``
(compiler/contact/table.py), a ground table's ``eomc_ground_slopes((const double[n]){...}, ...)``
(compiler/contact/ground_table.py) -- becomes a call on ``&S_[N]``, a run of the scratch array
that holds those values where the loop reads them.

Why: the literal is built at every call, one load and one store per entry from slots spread over
the scratch array (the humanoid's 285 doubles for its 17 shapes' bodies: origin, rotation, ω, v
per body, then each shape's offset).  In a harness of the humanoid's NAME_implicit_var on the
states of its qpos0 run, building it twice instead of once cost 70-280 ns of the ~3.8 us call;
read in place, the call is within the noise of a build's code placement alone (about -1 %), and
with :mod:`.forward` 1.5-3.5 % faster (benchmarks/results/fixedstep.md's notes, session 32).

How (a renaming of slots, so the same bits): the scratch array grows by the literal's length L
at its end, slots N .. N+L.  Entry j that is a scratch slot ``S_[k]`` (its first time in a
literal) renames slot k to N+j in the whole function -- every write and read of slot k, in the
body and in every sub-function, whatever temporary it holds at that time -- so at the call slot
N+j holds what slot k held.  Every other entry (a slot already placed, a state, a parameter,
a number, an expression) is stored into its slot N+j right before the call, by a statement of
its own that reads what the literal read there.  Slot k is then unused, and no statement's
expression or order changes: the loop reads the same values, the function computes the same
bits.  Left as it is: a function with no scratch array (nothing split: the literal's entries
are the body's temporaries, in registers), one whose sub-functions take their scratch slots
through near pointers (split.WINDOWS: ``S_w0[..]``, never NAME_implicit's), and a literal in a
sub-function (none so far).
"""
import re

__all__ = ["packed_inputs"]

_DECL = re.compile(r"^    double S_\[(\d+)\];$")
_LITERAL = re.compile(r"\(const double\[(\d+)\]\)\{([^{}]*)\}")
_CALL = re.compile(r"\beomc_(?:pairs_slopes|ground_slopes)\(\(const double\[\d+\]\)\{")
_SLOT = re.compile(r"\bS_\[(\d+)\]")
_WHOLE_SLOT = re.compile(r"S_\[(\d+)\]")
_PASSED = re.compile(r"\b([A-Za-z_]\w*)\([^;]*\bS_\b(?!\[)")     # a call taking the scratch array
_LOCAL = re.compile(r"\bdouble S_\[")


def _entries(text):
    """The literal's entries (a flat list: its entries hold no braces, and no commas but the
    separators outside parentheses)."""
    out, depth, cur = [], 0, []
    for ch in text:
        if ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
            continue
        depth += (ch in "([") - (ch in ")]")
        cur.append(ch)
    out.append("".join(cur).strip())
    return out


def packed_inputs(lines, parts, base):
    """(body lines, sub-function texts) of one function with its contact loops' literal inputs
    read from the scratch array (module doc), or the two unchanged.  ``base``: its
    sub-functions' name prefix (split_body's, ``NAME_fn_part``); the other texts in ``parts``
    (helpers the body calls, with scratch arrays of their own) are left as they are."""
    decl = next((i for i, line in enumerate(lines) if _DECL.match(line)), None)
    calls = [i for i, line in enumerate(lines) if _CALL.search(line)]
    if decl is None or not calls or any("S_w" in text for text in (*lines, *parts)):
        return lines, parts
    mine = re.compile(r"^static [^\n(]*\b(" + re.escape(base) + r"\d+_\d+)\(")
    own = {m.group(1): i for i, text in enumerate(parts) for m in [mine.match(text)] if m}
    passed = {m.group(1) for line in lines for m in _PASSED.finditer(line)}
    if not passed <= set(own) or any(_LOCAL.search(parts[i]) for i in own.values()):
        return lines, parts     # the scratch array passed to a function that is not one of its parts
    size = int(_DECL.match(lines[decl]).group(1))
    rename, stores, literal_at = {}, {}, {}
    for i in calls:
        m = _LITERAL.search(lines[i])
        n, entries = int(m.group(1)), _entries(m.group(2))
        if len(entries) != n:
            return lines, parts
        start = size
        size += n
        literal_at[i] = (m.start(), m.end(), start)
        stores[i] = []
        for j, e in enumerate(entries):
            s = _WHOLE_SLOT.fullmatch(e)
            if s and int(s.group(1)) not in rename:
                rename[int(s.group(1))] = start + j
            else:
                stores[i].append((start + j, e))

    def ren(text):
        return _SLOT.sub(lambda q: f"S_[{rename.get(int(q.group(1)), int(q.group(1)))}]", text)
    out = []
    for i, line in enumerate(lines):
        if i == decl:
            out.append(f"    double S_[{size}];")
            continue
        if i in literal_at:
            a, b, start = literal_at[i]
            indent = line[:len(line) - len(line.lstrip())]
            out += [f"{indent}S_[{k}] = {ren(e)};" for k, e in stores[i]]
            out.append(ren(line[:a]) + f"&S_[{start}]" + ren(line[b:]))
            continue
        out.append(ren(line))
    return out, [ren(text) if i in own.values() else text for i, text in enumerate(parts)]
