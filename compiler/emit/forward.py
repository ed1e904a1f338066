"""An output stored where its value is made, not copied later from a scratch slot.

One job: in NAME_implicit's split C (its body lines and its sub-functions), a statement
``out[k] = S_[j];`` -- an output that the split computed in one sub-function and stored in a later
one, through the scratch array (compiler/emit/split.py) -- is dropped, and the statement that put
that value in slot j, ``S_[j] = tN;``, becomes ``out[k] = tN;``; every read of slot j while it
holds that value reads ``out[k]`` instead.

Why: gymnasium's humanoid's NAME_implicit_var copied 579 outputs so (a load and a store each, in
the sub-functions that write out[]), its ant's 342.  Forwarded (humanoid 379 stores, the rest
then copies of an output already stored; ant all), with the pairs' literal read in place
(:mod:`.packed`), NAME_implicit_var on the states of the qpos0 run took 1.5-3.5 % less time on
the humanoid and 2 % less on the ant (session 32: four builds a side with their code placed
apart, one process per library, alternating; benchmarks/results/fixedstep.md's notes).

Same bits: no expression and no order of evaluation changes, only where a value is kept.  Taken
only where that is plainly so:

- the copy is a statement of its own at the top level (of the body or of a sub-function), and
  every store into slot j in the function is one too, so program order is the order they run in;
- the store it forwards is the last into slot j before the copy, of a temporary, and no store
  into slot j lies between them; the slot's reads from that store to its next one are rewritten
  (whichever block they sit in: they run after the store and before the next);
- out[k] is stored nowhere else and read nowhere, and lies below every ``&out[a]`` the body
  passes on (the pairs' slope block the loop writes);
- slot j lies below every ``&S_[a]`` the body passes on (the pairs' packed inputs, which the
  loop reads);
- the body returns only at its end (an early return would now leave out[k] written), calls its
  sub-functions only as statements of their own, each once, and passes the scratch array and
  out[] to nothing else.

A sub-function that now stores or reads out[] and did not take it gets ``double *out`` as its
first parameter.  Any other shape leaves the C as it is.
"""
import re
from collections import Counter, defaultdict

__all__ = ["forwarded_outputs"]

_WRITE = re.compile(r"^(\s+)S_\[(\d+)\] = (.*);$")
_SLOT = re.compile(r"\bS_\[(\d+)\]")
_COPY = re.compile(r"^    out\[(\d+)\] = S_\[(\d+)\];$")
_OUT_STORE = re.compile(r"\bout\[(\d+)\] = ")
_OUT_INDEX = re.compile(r"\bout\[(\d+)\]")
_OUT_ANY = re.compile(r"\bout\b")
_TEMP = re.compile(r"t\d+")


def _part(text, base):
    """(name, head before the parameters, parameters, body lines) of a sub-function's text, or None."""
    m = re.fullmatch(r"(static [^\n(]*\b(" + re.escape(base) + r"\d+_\d+))\(([^)\n]*)\)\n\{\n(.*)\n\}\n?", text, re.S)
    return (m.group(2), m.group(1), m.group(3), m.group(4).split("\n")) if m else None


def forwarded_outputs(lines, parts, base):
    """(body lines, sub-function texts) with outputs stored where they are made (module doc), or
    the two unchanged.  ``base``: the sub-functions' name prefix (``NAME_fn_part``)."""
    own = {}
    for i, text in enumerate(parts):
        got = _part(text, base)
        if got is not None:
            own[got[0]] = (i, *got[1:])
    call = re.compile(r"^    (" + re.escape(base) + r"\d+_\d+)\(([^()]*)\);$")
    last = _last_statement(lines)
    order, called = [], Counter()
    for i, line in enumerate(lines):
        m = call.match(line)
        if m and m.group(1) in own:
            called[m.group(1)] += 1
            names = [_param_name(q) for q in own[m.group(1)][2].split(",") if q.strip()]
            if [a.strip() for a in m.group(2).split(",") if a.strip()] != names:
                return lines, parts     # a call passing other names than its parameters'
            order += [(m.group(1), j) for j in range(len(own[m.group(1)][3]))]
            continue
        if base in line or (re.search(r"\breturn\b", line) and i != last):
            return lines, parts     # a sub-function called in another shape, or an early return
        order.append((None, i))
    if not own or any(called[n] != 1 for n in own):
        return lines, parts

    def text(where):
        name, j = where
        return lines[j] if name is None else own[name][3][j]
    body_text = "\n".join(line for i, line in enumerate(lines) if not call.match(line) and i != last)
    if re.search(r"\bout\[(?!\d+\])", body_text.replace("&out[", "")) or re.search(r"\bout\b(?!\[)", body_text):
        return lines, parts     # out[] indexed by a variable, or passed on whole
    rest = "\n".join(line for line in lines if not call.match(line) and "double S_[" not in line)
    if re.search(r"\bS_\b(?!\[)", rest):
        return lines, parts     # the scratch array passed on whole
    out_floor = min((int(a) for a in re.findall(r"&out\[(\d+)\]", body_text)), default=None)
    slot_floor = min((int(a) for a in re.findall(r"&S_\[(\d+)\]", body_text)), default=None)
    for name, (_, _, _, plines) in own.items():
        ptext = "\n".join(plines)
        if re.search(r"\bout\[(?!\d+\])", ptext) or re.search(r"\bout\b(?![\[])", ptext) \
                or re.search(r"\bS_\b(?!\[)", ptext) or "&" in ptext.replace("&&", ""):
            return lines, parts     # a sub-function using out[] or the scratch array otherwise

    writes, reads, stored, read_out, copies = defaultdict(list), defaultdict(list), Counter(), Counter(), []
    for pos, where in enumerate(order):
        t = text(where)
        m = _WRITE.match(t)
        rhs = m.group(3) if m else t
        if m:
            writes[int(m.group(2))].append((pos, len(m.group(1)) == 4, m.group(3)))
        for r in _SLOT.finditer(rhs):
            reads[int(r.group(1))].append(pos)
        for o in _OUT_STORE.finditer(t):
            stored[int(o.group(1))] += 1
        for o in _OUT_INDEX.finditer(t.split(" = ", 1)[1] if _OUT_STORE.match(t.strip()) else t):
            read_out[int(o.group(1))] += 1
        c = _COPY.match(t)
        if c:
            copies.append((pos, int(c.group(1)), int(c.group(2))))

    edits, renamed, needs_out = {}, defaultdict(dict), set()
    for pos, k, j in copies:
        if stored[k] != 1 or read_out[k] or (out_floor is not None and k >= out_floor) \
                or (slot_floor is not None and j >= slot_floor):
            continue
        ws = writes[j]
        if not all(top for _, top, _ in ws):
            continue
        before = [w for w in ws if w[0] < pos]
        if not before or not _TEMP.fullmatch(before[-1][2]):
            continue
        at = before[-1][0]
        nxt = min((w[0] for w in ws if w[0] > at), default=len(order))
        if nxt < pos:
            continue
        rs = [r for r in reads[j] if at < r < nxt and r != pos]
        if at in edits or any(r in edits for r in rs):
            continue
        edits[at] = f"    out[{k}] = {before[-1][2]};"
        edits[pos] = None
        for r in rs:
            renamed[r][j] = f"out[{k}]"
        needs_out |= {order[q][0] for q in (at, *rs) if order[q][0] is not None}
    if not edits:
        return lines, parts

    new_lines, new_parts = list(lines), {name: list(v[3]) for name, v in own.items()}
    for pos, where in enumerate(order):
        if pos in edits:
            new = edits[pos]
        elif pos in renamed:
            t, mp = text(where), renamed[pos]
            m = _WRITE.match(t)
            sub = lambda s: _SLOT.sub(lambda q: mp.get(int(q.group(1)), q.group(0)), s)   # noqa: E731
            new = f"{m.group(1)}S_[{m.group(2)}] = {sub(m.group(3))};" if m else sub(t)
        else:
            continue
        name, j = where
        if name is None:
            new_lines[j] = new
        else:
            new_parts[name][j] = new
    # each sub-function's parameters: the arrays its statements now use (out[] added where it
    # now stores or reads an output; one whose copies all went takes no scratch array, and one
    # left with no statement is dropped with its call)
    texts, params_of = list(parts), {}
    for name, (i, head, params, _) in own.items():
        body = [x for x in new_parts[name] if x is not None]
        used = "\n".join(body)
        plist = [q.strip() for q in params.split(",")] if params.strip() else []
        if name in needs_out and not any(_param_name(q) == "out" for q in plist):
            plist.insert(0, "double *out")
        plist = [q for q in plist if re.search(r"\b" + re.escape(_param_name(q)) + r"\b", used)]
        params_of[name] = [_param_name(q) for q in plist] if any(x.strip() for x in body) else None
        texts[i] = (f"{head}({', '.join(plist) or 'void'})\n{{\n" + "\n".join(body) + "\n}\n"
                    if params_of[name] is not None else None)
    out_lines = []
    for line in new_lines:
        if line is None:
            continue
        m = call.match(line)
        if m and m.group(1) in own:
            if params_of[m.group(1)] is None:
                continue
            line = f"    {m.group(1)}({', '.join(params_of[m.group(1)])});"
        out_lines.append(line)
    return out_lines, [t for t in texts if t is not None]


def _param_name(param):
    """The name a C parameter declares (``const double *restrict S_`` -> ``S_``)."""
    return re.search(r"(\w+)$", param).group(1)


def _last_statement(lines):
    """Index of the body's last non-empty line (its return)."""
    return max(i for i, line in enumerate(lines) if line.strip())
