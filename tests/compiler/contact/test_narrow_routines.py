"""The narrow phase's routines (compiler/contact/narrow.py) against the pair schemes inlined as the
generated code had them (pairs.scheme with sizes and margin as literals): p, n and δ of every
contact point, and their forward-mode tangents (the routine's ``_dot`` from the tape its ``_tape``
variant writes, what jac_x calls), to
1e-12 at random poses where the shapes are near, touching or pressed -- for every ordered pair of
kinds a model may hold.  Both programs are evaluated in Python from their straight-line IR (no C
compiler: the compiled routines are test_narrow.py's)."""
import math
import zlib

import numpy as np
import pytest
import sympy as sm
from sympy.printing.pycode import PythonCodePrinter

from eomc.compiler.contact import narrow
from eomc.compiler.contact.pairs import PAIR_KINDS, bounding_radius, pair_parts, scheme
from eomc.compiler.ir import Program
from eomc.compiler.passes.diff import tangent
from eomc.compiler.tree.recorder import Recorder
from helpers.rotations import random_rotation

SIZES = {"sphere": (0.05, 0, 0), "capsule": (0.03, 0.08, 0), "box": (0.06, 0.04, 0.03),
         "cylinder": (0.05, 0.04, 0), "ellipsoid": (0.03, 0.05, 0.04)}
# one order of each kind the routines serve (a model holds either: both run the same scheme code,
# swapped), but the cylinder's with a capsule, box or cylinder: their 25-65 points take 20-70 s to
# generate twice here; tests/compiler/contact/test_narrow.py compiles box–cylinder and compares
ORDERED = [("sphere", "sphere"), ("capsule", "sphere"), ("capsule", "capsule"), ("box", "sphere"), ("capsule", "box"),
           ("box", "box"), ("sphere", "cylinder"), ("ellipsoid", "sphere"), ("capsule", "ellipsoid"),
           ("ellipsoid", "ellipsoid"), ("box", "ellipsoid")]


class _Py(PythonCodePrinter):
    def _print_step(self, e):
        return f"(1.0 if ({self._print(e.args[0])}) > 0 else 0.0)"


def _function(prog, inputs, group):
    """A Python function of ``inputs`` returning the results of ``group`` (the program's straight line)."""
    pr = _Py({"fully_qualified_modules": False})
    lines = [f"    {t.name} = {pr.doprint(e)}" for t, e in prog.assignments]
    values = prog.result_exprs(group)
    keys = sorted(values, key=lambda k: k[1])
    lines.append("    return [" + ", ".join(pr.doprint(values[k]) for k in keys) + "]")
    text = f"def f({', '.join(s.name for s in inputs)}):\n" + "\n".join(lines)
    space = {"math": math, "sqrt": math.sqrt, "Abs": abs, "copysign": math.copysign, "cos": math.cos, "sin": math.sin}
    exec(compile(text, "<narrow>", "exec"), space)
    return space["f"]


def _inline(ka, kb, margin):
    """(Python function of the 24 pose inputs and their 24 tangents -> outputs, tangents) of the
    scheme inlined with this test's sizes as literals."""
    pose = sm.symbols("x0:24", real=True)
    seeds = sm.symbols("d0:24", real=True)
    a = {"kind": ka, "centre": list(pose[0:3]), "axes": [list(pose[3:6]), list(pose[6:9]), list(pose[9:12])],
         "size": [float(x) for x in SIZES[ka]]}
    b = {"kind": kb, "centre": list(pose[12:15]), "axes": [list(pose[15:18]), list(pose[18:21]), list(pose[21:24])],
         "size": [float(x) for x in SIZES[kb]]}
    rec, out = Recorder(), []
    for part in pair_parts(ka, kb):
        p, n, depth = scheme(a, b, part, margin, rec.let)
        out += list(p) + list(n) + [depth]
    prog = Program(inputs=pose, assignments=tuple(rec.assignments),
                   results=tuple((("o", i), sm.sympify(e)) for i, e in enumerate(out)), ntemp=rec.count)
    prog = tangent(prog.with_(inputs=pose + seeds), "o", dict(zip(pose, seeds)), "do")
    return _function(prog, pose + seeds, "o"), _function(prog, pose + seeds, "do")


def _routine(ka, kb):
    """(outputs then the tape, tangents from the tape, number of outputs): the routine as jac_x
    calls it -- its ``_tape`` variant, then ``_dot`` reading only the tape and the seeds."""
    rid = narrow.routine_index(ka, kb)
    prog, ins = narrow._program(rid)
    tape, seeds, dot = narrow._dot_program(rid)
    nout = narrow.routine_outputs(rid)
    taped = prog.with_(results=prog.results + tuple((("o", nout + j), s) for j, s in enumerate(tape)))
    assert set(dot.inputs) == set(tape) | set(seeds)
    return _function(taped, tuple(ins), "o"), _function(dot, tape + tuple(seeds), "do"), nout


@pytest.mark.parametrize("ka,kb", ORDERED)
def test_routine_is_the_inlined_scheme_with_its_tangent(ka, kb):
    margin = 0.004
    inline, inline_dot = _inline(ka, kb, margin)
    routine, routine_dot, nout = _routine(ka, kb)
    rng = np.random.default_rng(zlib.crc32(f"{ka} {kb}".encode()))
    reach = bounding_radius(ka, SIZES[ka]) + bounding_radius(kb, SIZES[kb])
    # where a scheme is well posed: no point deeper than a third of the thinner shape (deeper, a
    # sphere's centre inside a box has no direction and the two roundings pick different ones)
    thin = min(x for x in SIZES[ka] + SIZES[kb] if x > 0) / 3
    compared, pressed = 0, 0
    sizes = [float(x) for x in SIZES[ka] + SIZES[kb]] + [margin]
    for _ in range(800):
        Ra, Rb = random_rotation(rng), random_rotation(rng)
        u = rng.normal(size=3)
        cb = u / np.linalg.norm(u) * reach * rng.uniform(0.3, 1.05)
        pose = [0.0, 0.0, 0.0] + list(Ra.T.ravel()) + list(cb) + list(Rb.T.ravel())   # axes: the columns
        pose, dpose = [float(x) for x in pose], [float(x) for x in rng.normal(size=24)]
        want, taped = inline(*pose, *dpose), routine(*pose, *sizes)
        got, tape = taped[:nout], taped[nout:]
        depths = want[6::7]
        if max(depths) > thin:
            continue
        compared += 1
        pressed += max(depths) > 0
        assert np.abs(np.subtract(got, want)).max() <= 1e-12 * (1 + np.abs(want).max())
        dwant, dgot = inline_dot(*pose, *dpose), routine_dot(*tape, *dpose)
        assert np.abs(np.subtract(dgot, dwant)).max() <= 1e-12 * (1 + np.abs(dwant).max())
    assert compared >= 100 and pressed >= 10, (compared, pressed)
