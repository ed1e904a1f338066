"""Worst-case stack of each generated function, from the compiler's own call-graph dump.

Firmware sizes its task stacks from a number, not a guess.  gcc's ``-fcallgraph-info=su``
(gcc 10+) writes, per translation unit, every function's frame size (what ``-fstack-usage``
reports) and its call edges; the generated C has no recursion and no function pointers, so
the worst case of a function is its frame plus the deepest chain of the calls it makes
inside NAME.c.  Calls that leave the file (libm's sinf, sqrtf) are listed by name: their
frames belong to the C library the firmware links, not to eomc.  A frame gcc marks
dynamic (alloca, VLAs: the generator writes none) makes the bound unknown, and says so.

Every target is measured (the compile that builds the library adds the flag; it changes no
generated code); clang has no call-graph dump, so a clang build records why there is no
figure instead of a wrong one.
"""
import re
from pathlib import Path

__all__ = ["CALLGRAPH_FLAG", "measure_stack", "stack_header_block", "supports_callgraph"]

CALLGRAPH_FLAG = "-fcallgraph-info=su"

_NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"\\]+)\\n[^"]*?(?:\\n(\d+) bytes \(([^)]*)\))?"')
_EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')


def supports_callgraph(toolchain):
    """gcc 10 or later (clang and older gcc have no -fcallgraph-info)."""
    if toolchain.is_clang:
        return False
    m = re.search(r"\b(\d+)\.\d+(\.\d+)?\b", toolchain.version)
    return bool(m) and "gcc" in toolchain.version.lower() + toolchain.path.lower() and int(m.group(1)) >= 10


def _parse(text):
    nodes, edges = {}, {}
    for title, label, size, kind in _NODE.findall(text):
        nodes[title] = (label, int(size) if size else None, kind or "")
    for src, dst in _EDGE.findall(text):
        edges.setdefault(src, set()).add(dst)
    return nodes, edges


def measure_stack(directory, name, functions):
    """{function: {"bytes": worst case, "frame": own frame, "external": [calls leaving NAME.c]}}
    for NAME_<function> of each name in ``functions`` (those gcc kept as functions), read from
    the ``*.ci`` files in ``directory``; None when no dump is there."""
    dumps = sorted(Path(directory).glob("*.ci"))
    if not dumps:
        return None
    nodes, edges = {}, {}
    for path in dumps:
        n, e = _parse(path.read_text(errors="replace"))
        nodes.update(n)
        for k, v in e.items():
            edges.setdefault(k, set()).update(v)
    memo = {}

    def worst(title, seen=()):
        if title in memo:
            return memo[title]
        label, size, kind = nodes.get(title, (title, None, ""))
        if size is None:   # outside the file: libm or a builtin
            result = (0, {label.replace("__builtin_", "")}, False)
        elif title in seen:   # recursion: the generator writes none, never loop on it
            result = (size, set(), True)
        else:
            deepest, external, unknown = 0, set(), "dynamic" in kind and "bounded" not in kind
            for callee in sorted(edges.get(title, ())):
                b, ext, unk = worst(callee, seen + (title,))
                deepest, external, unknown = max(deepest, b), external | ext, unknown or unk
            result = (size + deepest, external, unknown)
        memo[title] = result
        return result

    by_label = {label: title for title, (label, _, _) in nodes.items()}
    out = {}
    for fn in functions:
        title = by_label.get(f"{name}_{fn}")
        if title is None:
            continue
        total, external, unknown = worst(title)
        out[fn] = {"bytes": None if unknown else total, "frame": nodes[title][1],
                   "external": sorted(external)}
    return out


def stack_header_block(name, stack, compiler):
    """#defines NAME_STACK_<FUNCTION> for NAME.h (measured at build time by ``compiler``)."""
    upper = name.upper()
    lines = [f"/* Worst-case stack in bytes per function, measured at build time ({compiler}, "
             f"{CALLGRAPH_FLAG}):", " * the function's frame plus its deepest chain of calls inside "
             f"{name}.c; calls into libm", f" * (listed in {name}.json under stack.external) come on "
             f"top.  Other compilers and flags differ: re-measure for yours. */"]
    for fn, info in stack.items():
        if info["bytes"] is not None:
            lines.append(f"#define {upper}_STACK_{fn.upper()} {info['bytes']}")
    return "\n".join(lines) + "\n"
