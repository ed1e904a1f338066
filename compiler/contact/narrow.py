"""Body–body pairs' narrow phase as C routines: one static function per pair of kinds, called.

One job: the pair schemes of :mod:`.pairs` (closest points, a solid's signed distance, box–box's
corners; per contact point p, n, δ) written once per pair of kinds as a static C function of
the two shapes' placements and sizes, and its forward-mode derivative; the IR nodes that call
them (:class:`NarrowCall`, :class:`NarrowOut`, :class:`NarrowDot`).

Why: the schemes were inlined per pair as straight-line SymPy, so every pair was generated,
differentiated (jac_x's tangent) and compiled on its own, in rhs, events and outputs.  gymnasium's
humanoid with its self-collisions (109 pairs) took 28.9 s CPU to build its rhs alone (17 s gcc on
1.5 MB of C), dm_control's stacker ~103 s (jac_x's tangent of 96 box–box parts: 2.27 M ops).  Now
a pair is a call: ``NarrowCall(routine, uid, *inputs)`` writes the pair's outputs into a local
array ``NP<uid>_`` (7 per contact point: p, n, δ) and each output is ``NarrowOut(call, uid, k)``.
The routines are generated from the same scheme functions, with the sizes and margin as inputs
(not literals), so one routine serves every pair of its kinds; agreement with the inlined schemes
is to rounding (tests/compiler/contact/test_narrow.py).

With ``pairs.LAW_ROUTINES`` the contact law goes out of line too: after the pair's narrow
routine, each contact point calls the *law routine* (one for every kind: the law and the
wrenches on both bodies, from the point's p, n, δ, the two bodies' origins, rotations and
velocities and the law's parameters, LAW_NPOSE), inside the point's depth guard, so that the
generated function only adds the wrenches it returns to the bodies' loads: SymPy lowers the law
once, not per pair, and a point out of contact skips it.  gymnasium's humanoid with its 109
self-pairs, rhs only (benchmarks/results/mjcf_contact.md, 2026-11-29 20:39, one run): 28.7 s CPU
inlined, 15.2 s with law routines (no self-pairs 7.6 s); rhs 2.00x vs 2.13x the no-contact rhs.
(The first law routine, narrow phase and law in one call per pair, built in 21.3 s but its rhs
ran 2.83x: it ran the law for every pair inside its bounding balls.)

Derivatives: the tangent of an output along a direction is ``NarrowDot``'s: the routine's
forward-mode derivative (the scheme's program differentiated once per pair of kinds by
:func:`eomc.compiler.passes.diff.tangent`, not per pair) called with the placements' tangents,
writing the outputs' tangents into ``ND<k>_``.  Placement inputs are the shapes' centres and axes
(24); sizes and margin are numbers (their tangents are 0).  The ``_dot`` routine reads the primal
values its tangent needs from a *tape* (:func:`tape_of`): in a function that differentiates a
pair (jac_x, jvp) its call is the ``_tape`` variant (:class:`NarrowTapeCall`, chosen by
:meth:`NarrowCall.taped` when the function is generated), which also stores those values after its
outputs in ``NP<uid>_``; jac_x's columns then run only the tangent, not the narrow phase again
(it recomputed the primal per column: stacker's jac_x 0.57x the inlined schemes').

Reverse sweeps (vjp, and through them hvp and hess_id): a call's ``reverse`` (the adjoint pass,
compiler/passes/adjoint.py, gathers the bars of its outputs) is a :class:`NarrowBar`, a call of the
routine's ``_bar`` variant -- the adjoint of the routine's program, generated once per routine --
whose outputs' (:class:`BarOut`) tangent is the ``_bar_dot`` variant's call (:class:`NarrowBarDot`:
forward over reverse, what hvp and hess_id differentiate).  A tangent of a tangent (forward over
forward) and third derivatives are refused with a message.
"""
import functools

import sympy as sm

from ..emit.bodies import IND, store, temps
from ..emit.printer import CPrinter
from ..emit.split import split_body
from ..ir import Program, c_names
from ..passes.adjoint import adjoint
from ..passes.dce import dce
from ..passes.diff import tangent
from ..passes.powers import expand_powers
from eomc.runtime.errors import ModelError

__all__ = ["NarrowCall", "NarrowTapeCall", "NarrowOut", "NarrowDot", "ROUTINE_KINDS", "routine_index", "narrow_inputs",
           "routine_outputs", "routine_code", "use_schemes", "NPOSE", "NINPUT", "PER_PART"]

NPOSE = 24         # inputs with tangents: A's centre and 3 axes, B's centre and 3 axes (world)
NINPUT = 31        # then A's 3 sizes, B's 3 sizes, the margin
PER_PART = 7       # outputs per contact point: p (3), n (3, A to B), δ
# statements: a routine up to this long is one function compiled at the file's level; longer
# (the cylinder pairs') cut into sub-functions (compiler/emit/split.py).  Why: a box pair's routine
# (~400 statements) cut into -O1 parts with a scratch array ran the table-box-ball scene's rhs
# 686 ns vs 607 ns whole (inlined schemes 483 ns; tests/compiler/contact/test_narrow.py's scene),
# and gcc took 2.12 vs 2.24 s on that file.
ROUTINE_SPLIT = 1200
# the ordered pairs of kinds a PairLoad may hold (a, b as with_pairs orders them): each its routine
ROUTINE_KINDS = tuple((a, b) for a in ("sphere", "capsule", "box", "cylinder", "ellipsoid")
                      for b in ("sphere", "capsule", "box", "cylinder", "ellipsoid"))
# The *law routine* (routine index LAW_RID, ``pairs.LAW_ROUTINES``): the contact law at one contact
# point and the wrenches on both bodies, one routine for every pair of kinds (the law does not depend
# on the shapes).  A pair's narrow phase is its kinds' narrow routine; each of its points then calls
# the law routine inside the point's depth guard (compiler/emit/guards.py), so a point out of contact
# skips its law as the inlined law does.  Inputs, all with tangents (LAW_NPOSE): the point's p (3,
# world), n (3, A to B) and δ, per body (A, B) its origin (3), world -> body rotation (9, rows),
# angular and origin velocity (6, body components), then the law's k, c, mu, vs.  Outputs
# (LAW_OUTPUTS): B's wrench (moment about its origin, force; body components), A's, then F_n,
# friction (3, world) and the clip's switching function.
BODY_INPUTS = 18
LAW_NPOSE = PER_PART + 2 * BODY_INPUTS + 4
LAW_OUTPUTS = 17
LAW_RID = len(ROUTINE_KINDS)
# The *slopes routine* (SLOPES_RID, the pairs' table loop in NAME_implicit: compiler/contact/table.py's
# "slopes" loop): the law's inputs, and as outputs the relative velocity v_B(p) - v_A(p) (3, world) and
# the law's K = -dF/dp, C = -dF/dv on that relative motion (9 + 9, rows; .law.ground_jacobians)
SLOPES_RID = LAW_RID + 1
# The *spinning law routine* (LAW_SPIN_RID): the law routine with torsional and rolling friction
# (.law.spin_moment), for a table that holds a pair with them (MJCF condim 4, 6): its inputs are the
# law routine's and then the pair's μ_t, μ_r and ρ (0, 0 and 1 for a pair without them: its moment is
# then ±0), its outputs the law routine's, the moment added to both wrenches.  Why a routine of its
# own: such pairs were inlined one by one (the table's law had no moment), and dm_control's dog, whose
# teeth are condim 6 against ~120 shapes, did not get past generate in ten minutes.
LAW_SPIN_RID = SLOPES_RID + 1
SPIN_PARAMS = ("mut", "mur", "rho")
LAW_SPIN_NPOSE = LAW_NPOSE + len(SPIN_PARAMS)
# a law call's output array is NP<LAW_UID + the point's index>_ (a narrow call's: NP<the pair's first point>_)
LAW_UID = 1000000


def routine_index(kind_a, kind_b):
    return ROUTINE_KINDS.index((kind_a, kind_b))


def is_law(rid):
    """A routine of the law's inputs (the law routine, the slopes routine, the spinning law routine),
    not a narrow phase."""
    return rid in (LAW_RID, SLOPES_RID, LAW_SPIN_RID)


def kinds_of(rid):
    return ROUTINE_KINDS[rid]


def npose(rid):
    """How many of routine ``rid``'s inputs have tangents (the rest: sizes and margin, numbers)."""
    return LAW_SPIN_NPOSE if rid == LAW_SPIN_RID else LAW_NPOSE if is_law(rid) else NPOSE


def ninput(rid):
    return npose(rid) if is_law(rid) else NINPUT


def _cname(rid, variant=None):
    base = ("eomc_pair_slopes" if rid == SLOPES_RID else "eomc_pair_law_spin" if rid == LAW_SPIN_RID else
            "eomc_pair_law" if is_law(rid) else "eomc_narrow_%s_%s" % kinds_of(rid))
    return base + ("_" + variant if variant else "")


def narrow_inputs(a, b, size_a, size_b, margin):
    """The routine's inputs: placed shapes' centres and axes ({centre, axes}, world), sizes, margin."""
    out = list(a["centre"]) + [x for axis in a["axes"] for x in axis]
    out += list(b["centre"]) + [x for axis in b["axes"] for x in axis]
    for size in (size_a, size_b):
        s = [float(x) for x in size] + [0.0] * (3 - len(size))
        out += [_number(x) for x in s[:3]]
    return out + [_number(float(margin))]


def _number(x):
    return sm.S.Zero if x == 0 else sm.Float(x, 17)


class Token(sm.Function):
    """A routine's call in the expression graph: its own value is a token (0.0, the C function's
    return), its outputs are read by other nodes (NarrowOut, table.PairTableOut), so it has no
    derivative of its own (the outputs' tangents come from their ``forward``)."""
    is_real = True

    def _eval_derivative(self, s):
        return sm.S.Zero

    def forward(self, dd, k):
        return sm.S.Zero


class NarrowCall(Token):
    """NarrowCall(routine, uid, *inputs): the pair's narrow phase, run once; its outputs are
    read by :class:`NarrowOut`."""

    def c_declaration(self):
        return f"double NP{int(self.args[1])}_[{routine_outputs(int(self.args[0]))}];"

    def c_routines(self):
        """[(key, C text, split)] of the routines this node calls (generate_c prints each once)."""
        rid = int(self.args[0])
        return [((rid, 0), *routine_code(rid))]

    def _ccode(self, printer):
        args = ", ".join(printer._print(a) for a in self.args[2:])
        return f"{_cname(int(self.args[0]))}({args}, &NP{int(self.args[1])}_[0])"

    def taped(self):
        """The same call writing the tape its ``_dot`` reads (a function that differentiates it)."""
        return NarrowTapeCall(*self.args)

    def reverse(self, fresh, bars):
        """The reverse sweep through the call (compiler/passes/adjoint.py): ([(temporary, NarrowBar)],
        [(input, its bar)]) from ``bars``, {output index: its bar}."""
        rid = int(self.args[0])
        ins = self.args[2:]
        sym = fresh()
        uid = sm.Integer(int(sym.name[2:]))
        node = NarrowBar(self.args[0], uid, *ins, *[bars.get(i, sm.S.Zero) for i in range(routine_outputs(rid))])
        return [(sym, node)], reverse_pairs(ins[:npose(rid)], sym, 0, uid)


class NarrowTapeCall(NarrowCall):
    """NarrowCall that also stores the tape (:func:`tape_of`) after its outputs in ``NP<uid>_``."""

    def c_declaration(self):
        rid = int(self.args[0])
        return f"double NP{int(self.args[1])}_[{routine_outputs(rid) + len(tape_of(rid))}];"

    def c_routines(self):
        rid = int(self.args[0])
        return [((rid, 2), *routine_code(rid, "tape"))]

    def _ccode(self, printer):
        args = ", ".join(printer._print(a) for a in self.args[2:])
        return f"{_cname(int(self.args[0]), 'tape')}({args}, &NP{int(self.args[1])}_[0])"

    def taped(self):
        return self


class NarrowDot(Token):
    """NarrowDot(routine, uid, call, call uid, *input tangents): the outputs' tangents, into
    ``ND<uid>_``, from the tape the call (a temporary: it keeps the call before this one in every
    pass) wrote after its outputs in ``NP<call uid>_``."""

    def tape_of(self):
        """The temporaries whose call must write a tape (compiler/emit/generate.py: ``taped()``)."""
        return (self.args[2],)

    def c_declaration(self):
        return f"double ND{int(self.args[1])}_[{routine_outputs(int(self.args[0]))}];"

    def c_routines(self):
        rid = int(self.args[0])
        return [((rid, 1), *routine_code(rid, "dot"))]

    def _ccode(self, printer):
        rid = int(self.args[0])
        args = ", ".join(printer._print(a) for a in self.args[4:])
        return (f"{_cname(rid, 'dot')}(&NP{int(self.args[3])}_[{routine_outputs(rid)}], {args}, "
                f"&ND{int(self.args[1])}_[0])")


class NarrowOut(sm.Function):
    """NarrowOut(call, tag, k): output k of a pair's call (tag ≥ 0: a NarrowCall's uid, its array
    ``NP<tag>_``; tag < 0: a NarrowDot's, ``ND<-tag-1>_``).  Reads the call's temporary, so every
    pass keeps it after the call."""
    nargs = 3
    is_real = True

    def _eval_derivative(self, s):
        raise ModelError(_REFUSAL)

    def reverse_read(self):
        """(the call it reads, which output): the reverse sweep gathers each output's bar."""
        return self.args[0], int(self.args[2])

    def forward(self, dd, k):
        """Its tangent along direction k of the diff pass ``dd`` (:class:`eomc.compiler.passes.diff._Diff`)."""
        call, tag, index = self.args
        if int(tag) < 0:
            raise ModelError(_REFUSAL)
        key = ("narrow", call, k)
        hit = dd.extra.get(key)
        if hit is None:
            expr = dd.definition(call)
            inputs = expr.args[2:]
            dins = [dd.d(x, k) for x in inputs[:npose(int(expr.args[0]))]]
            if all(x.is_Number and x == 0 for x in dins):
                hit = sm.S.Zero
            else:
                sym = dd.names.fresh()
                uid = int(sym.name[2:])
                dd.out.append((sym, NarrowDot(expr.args[0], sm.Integer(uid), call, tag, *dins)))
                hit = (sym, uid)
            dd.extra[key] = hit
        if hit is sm.S.Zero:
            return sm.S.Zero
        return NarrowOut(hit[0], sm.Integer(-hit[1] - 1), index)

    def _ccode(self, printer):
        tag, index = int(self.args[1]), int(self.args[2])
        return f"NP{tag}_[{index}]" if tag >= 0 else f"ND{-tag - 1}_[{index}]"


_REFUSAL = ("a second forward derivative (a tangent of a tangent) of a body–body contact pair's narrow phase is "
            "not generated (vjp, hvp and hess_id go through its reverse sweep): build without it, or without "
            "the pairs (the self-collisions: pairs=\"trees\" / --pairs trees; every body–body pair: pairs=False / "
            "--pairs none)")


def routine_outputs(rid):
    return len(_program(rid)[0].results)


_SCHEMES = []   # the pair schemes: .pairs sets them when imported (it imports this module)


def use_schemes(outputs, law, slopes, law_spin):
    """``outputs(a, b, margin, let)``: the list p, n, δ of every contact point of two placed
    shapes ({kind, centre, axes, size}) -- :mod:`.pairs`' schemes, the routines' bodies;
    ``law(p, n, depth, body_a, body_b, params, let)``: the law routine's outputs (LAW_OUTPUTS;
    body_*: (origin, rotation rows, ω, v), params {k, c, mu, vs}); ``slopes``, with the same
    arguments: the slopes routine's (SLOPES_RID); ``law_spin``, with params also holding "mut",
    "mur", "rho": the spinning law routine's (LAW_SPIN_RID)."""
    _SCHEMES[:] = [outputs, law, slopes, law_spin]


class _Straight:
    """A straight-line program's temporaries, value-numbered, named ``_t<k>`` (the recursions'
    Recorder, eomc.compiler.tree.recorder, sits above this package)."""

    def __init__(self):
        self.count, self.assignments, self._seen = 0, [], {}

    def let(self, expr):
        expr = sm.sympify(expr)
        if expr.is_Atom or (expr.is_Mul and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Atom):
            return expr
        hit = self._seen.get(expr)
        if hit is None:
            hit = self._seen[expr] = sm.Symbol(f"_t{self.count}", real=True)
            self.count += 1
            self.assignments.append((hit, expr))
        return hit


@functools.lru_cache(maxsize=None)
def _program(rid):
    """(Program with results ("o", i): the outputs of routine ``rid``, input symbols)."""
    rec = _Straight()
    if is_law(rid):
        ins = sm.symbols(f"in0:{npose(rid)}", real=True)
        bodies = []
        for j in (PER_PART, PER_PART + BODY_INPUTS):
            R = [list(ins[j + 3 + 3 * r:j + 6 + 3 * r]) for r in range(3)]
            bodies.append((list(ins[j:j + 3]), R, list(ins[j + 12:j + 15]), list(ins[j + 15:j + 18])))
        params = dict(zip(("k", "c", "mu", "vs"), ins[LAW_NPOSE - 4:LAW_NPOSE]))
        if rid == LAW_SPIN_RID:
            params.update(zip(SPIN_PARAMS, ins[LAW_NPOSE:]))
        scheme = _SCHEMES[{LAW_RID: 1, SLOPES_RID: 2, LAW_SPIN_RID: 3}[rid]]
        results = scheme(list(ins[0:3]), list(ins[3:6]), ins[6], bodies[0], bodies[1], params, rec.let)
    else:
        ka, kb = kinds_of(rid)
        ins = sm.symbols(f"in0:{NINPUT}", real=True)
        a = {"kind": ka, "centre": list(ins[0:3]), "axes": [list(ins[3:6]), list(ins[6:9]), list(ins[9:12])],
             "size": list(ins[NPOSE:NPOSE + 3])}
        b = {"kind": kb, "centre": list(ins[12:15]), "axes": [list(ins[15:18]), list(ins[18:21]), list(ins[21:24])],
             "size": list(ins[NPOSE + 3:NPOSE + 6])}
        results = _SCHEMES[0](a, b, ins[NPOSE + 6], rec.let)
    prog = Program(inputs=tuple(ins), assignments=tuple(rec.assignments),
                   results=tuple((("o", i), sm.sympify(e)) for i, e in enumerate(results)), ntemp=rec.count)
    return prog, ins


@functools.lru_cache(maxsize=None)
def _dot_program(rid):
    """(tape, seed symbols, tangent program): the routine's forward-mode derivative reading the
    primal values it needs -- the tape: inputs and temporaries of :func:`_program` that its own
    assignments or results read, in the primal's order -- as inputs, so it computes no primal."""
    prog, ins = _program(rid)
    seeds = sm.symbols(f"din0:{npose(rid)}", real=True)
    full = dce(tangent(prog.with_(inputs=tuple(ins) + tuple(seeds)), "o", dict(zip(ins[:npose(rid)], seeds)), "do"),
               ("do",))
    primal = set(ins) | {t for t, _ in prog.assignments}
    own = tuple((t, e) for t, e in full.assignments if t not in primal)
    read = set()
    for _, e in own + full.results:
        read |= e.free_symbols
    tape = tuple(s for s in list(ins) + [t for t, _ in prog.assignments] if s in read)
    return tape, seeds, full.with_(inputs=tape + tuple(seeds), assignments=own)


def tape_of(rid):
    """The primal values routine ``rid``'s ``_dot`` reads (its ``_tape`` variant stores them)."""
    return _dot_program(rid)[0]


@functools.lru_cache(maxsize=None)
def routine_code(rid, variant=None):
    """(C text of routine ``rid`` -- ``variant`` "tape": also storing the tape after the outputs;
    "dot": its forward-mode derivative from the tape; "bar", "bar_dot": its reverse sweep and that
    sweep's tangent, :func:`_reverse_code` --, whether it was split into sub-functions
    (then the file needs EOMC_NOINLINE))."""
    if variant in ("bar", "bar_dot"):
        return _reverse_code(rid, variant)
    prog, ins = _program(rid)
    name = _cname(rid, variant)
    nout = routine_outputs(rid)
    names = {s: f"in[{k}]" for k, s in enumerate(ins)}
    n0 = npose(rid)
    if variant == "dot":
        tape, seeds, prog = _dot_program(rid)
        params = ["const double *tape"] + [f"double b{k}" for k in range(n0)]
        head = [f"{IND}const double din[{n0}] = {{{', '.join(f'b{k}' for k in range(n0))}}};"]
        names = {s: f"tape[{k}]" for k, s in enumerate(tape)}
        names.update({s: f"din[{k}]" for k, s in enumerate(seeds)})
        group, stored = "do", nout
    else:
        m = ninput(rid)
        params = [f"double a{k}" for k in range(m)]
        head = [f"{IND}const double in[{m}] = {{{', '.join(f'a{k}' for k in range(m))}}};"]
        group, stored = "o", nout
        if variant == "tape":
            tape = tape_of(rid)
            prog = prog.with_(results=prog.results + tuple((("o", nout + j), s) for j, s in enumerate(tape)))
            stored += len(tape)
    prog = expand_powers(dce(prog, (group,)))
    names.update(c_names(prog))
    pr = CPrinter(names)
    values = prog.result_exprs(group)
    body = temps(prog, pr) + [store(f"out[{i}]", values.get((group, i), sm.S.Zero), pr) for i in range(stored)]
    what = {None: "", "tape": "", "dot": "the tangents of "}[variant]
    after = (f", then the {stored - nout} values its _dot reads (the tape)" if variant == "tape" else
             ", from the tape its _tape variant wrote" if variant == "dot" else "")
    if rid == SLOPES_RID:
        head_text = ("/* body-body pair contact law's slopes at one contact point: v_B - v_A, K = -dF/dp, "
                     "C = -dF/dv (compiler/contact/narrow.py) */\n")
    elif is_law(rid):
        spin = " with torsional and rolling friction" if rid == LAW_SPIN_RID else ""
        head_text = (f"/* body-body pair contact law{spin} at one contact point: {what}the wrenches on B and A, F_n, "
                     f"friction, clip{after} (compiler/contact/narrow.py) */\n")
    else:
        ka, kb = kinds_of(rid)
        head_text = (f"/* body-body pair narrow phase: {what}p, n, depth of each contact point of a {ka} (A) against a "
                     f"{kb} (B), {nout // PER_PART} point(s){after} (compiler/contact/narrow.py) */\n")
    return _function_text(head_text, name, params, head, body)


def _function_text(head_text, name, params, head, body):
    """(C text of a routine from its statements, cut into sub-functions when long; whether cut)."""
    lines, parts = split_body(body, f"{name}_part") if len(body) > ROUTINE_SPLIT else (body, [])
    text = (head_text +
            f"static double {name}({', '.join(params)}, double *out)\n{{\n" + "\n".join(head + lines)
            + f"\n{IND}return 0.0;\n}}\n")
    return "\n".join(list(parts) + [text]), bool(parts)


# --- reverse sweeps and their tangents (vjp, hvp, hess_id) ---------------------------------------
# A routine's reverse variant ``_bar`` takes its inputs and the weights (bars) of its outputs and
# returns the bars of its first npose inputs: the adjoint of its program (compiler/passes/adjoint.py),
# generated once per routine as its tangent is, recomputing the primal (no tape: a reverse call runs
# once per vjp, not per column).  ``_bar_dot`` is that program's tangent along the inputs' and the
# bars' tangents (forward over reverse: hvp's and hess_id's second derivatives), returning the bars
# then their tangents.  Both read arrays: ``in`` (ninput), ``g`` (the output bars), ``din`` (npose),
# ``dg``.

@functools.lru_cache(maxsize=None)
def _bar_program(rid):
    """(program with results ("ib", j): the bars of the pose inputs, inputs, bars g, din, dg)."""
    prog, ins = _program(rid)
    nout, n0 = routine_outputs(rid), npose(rid)
    g = sm.symbols(f"g0:{nout}", real=True)
    prog = prog.with_(inputs=tuple(ins) + g)
    bar = dce(adjoint(prog, {("o", i): g[i] for i in range(nout)}, ins[:n0], "ib"), ("ib",))
    din = sm.symbols(f"din0:{n0}", real=True)
    dg = sm.symbols(f"dg0:{nout}", real=True)
    return bar, ins, g, din, dg


@functools.lru_cache(maxsize=None)
def _bar_dot_program(rid):
    """The reverse program's tangent: results ("ib", j) and ("dib", j)."""
    bar, ins, g, din, dg = _bar_program(rid)
    seeds = {**dict(zip(ins[:npose(rid)], din)), **dict(zip(g, dg))}
    return dce(tangent(bar.with_(inputs=bar.inputs + din + dg), "ib", seeds, "dib"), ("ib", "dib"))


def _reverse_code(rid, variant):
    bar, ins, g, din, dg = _bar_program(rid)
    n0 = npose(rid)
    params = ["const double *in", "const double *g"]
    names = {s: f"in[{k}]" for k, s in enumerate(ins)}
    names.update({s: f"g[{k}]" for k, s in enumerate(g)})
    groups = [("ib", 0)]
    if variant == "bar_dot":
        bar = _bar_dot_program(rid)
        params += ["const double *din", "const double *dg"]
        names.update({s: f"din[{k}]" for k, s in enumerate(din)})
        names.update({s: f"dg[{k}]" for k, s in enumerate(dg)})
        groups.append(("dib", n0))
    prog = expand_powers(bar)
    names.update(c_names(prog))
    pr = CPrinter(names)
    body = temps(prog, pr)
    for group, at in groups:
        values = prog.result_exprs(group)
        body += [store(f"out[{at + j}]", values.get((group, j), sm.S.Zero), pr) for j in range(n0)]
    what = "bars" if variant == "bar" else "bars and their tangents"
    of = "the contact law's inputs" if is_law(rid) else "the narrow phase's placements (%s, %s)" % kinds_of(rid)
    head = f"/* reverse sweep of a body-body pair routine: the {what} of {of} (compiler/contact/narrow.py) */\n"
    return _function_text(head, _cname(rid, variant), params, [], body)


def _literal(values, printer):
    """C of a read-only array of ``values`` (a compound literal)."""
    return f"(const double[{len(values)}]){{{', '.join(printer._print(a) for a in values)}}}"


class BarOut(sm.Function):
    """BarOut(call, array, uid, k): element k of a reverse call's output array ``<array><uid>_``
    (array 0: a routine's bars NB, 1: with their tangents NE, 2: the pairs' table's bars PB, 3: with
    their tangents PE).  Its tangent is the reverse call's ``_bar_dot`` (:meth:`forward`); a third
    derivative is refused."""
    nargs = 4
    is_real = True
    PREFIX = ("NB", "NE", "PB", "PE")

    def _eval_derivative(self, s):
        raise ModelError(_THIRD)

    def reverse_read(self):
        """(the reverse call, which output): a reverse sweep through it is refused (adjoint.py)."""
        return self.args[0], int(self.args[3])

    def forward(self, dd, k):
        call, array, uid, index = self.args
        if int(array) % 2:
            raise ModelError(_THIRD)
        key = ("bar", call, k)
        hit = dd.extra.get(key)
        if hit is None:
            sym = dd.names.fresh()
            node = dd.definition(call).tangent_call(dd, k, sm.Integer(int(sym.name[2:])))
            if node is None:
                hit = sm.S.Zero
            else:
                dd.out.append((sym, node))
                hit = (sym, int(sym.name[2:]), node.nbar)
            dd.extra[key] = hit
        if hit is sm.S.Zero:
            return sm.S.Zero
        return BarOut(hit[0], sm.Integer(int(array) + 1), sm.Integer(hit[1]), sm.Integer(hit[2] + int(index)))

    def _ccode(self, printer):
        return f"{self.PREFIX[int(self.args[1])]}{int(self.args[2])}_[{int(self.args[3])}]"


_THIRD = "third derivatives of a body–body contact pair's routines are not generated"


def reverse_pairs(inputs, sym, array, uid):
    """[(input, its bar)]: the bars a reverse call ``sym`` wrote, for the inputs that are not numbers."""
    return [(x, BarOut(sym, sm.Integer(array), uid, sm.Integer(j))) for j, x in enumerate(inputs)
            if not x.is_Number]


class NarrowBar(Token):
    """NarrowBar(routine, uid, *inputs, *output bars): the bars of the routine's pose inputs, into
    ``NB<uid>_``."""
    c_token = True

    def _split(self):
        rid = int(self.args[0])
        m = ninput(rid)
        return rid, self.args[2:2 + m], self.args[2 + m:]

    def c_declaration(self):
        return f"double NB{int(self.args[1])}_[{npose(int(self.args[0]))}];"

    def c_routines(self):
        rid = int(self.args[0])
        return [((rid, 3), *routine_code(rid, "bar"))]

    def _ccode(self, printer):
        rid, ins, g = self._split()
        return f"{_cname(rid, 'bar')}({_literal(ins, printer)}, {_literal(g, printer)}, &NB{int(self.args[1])}_[0])"

    def tangent_call(self, dd, k, uid):
        rid, ins, g = self._split()
        dins = [dd.d(x, k) for x in ins[:npose(rid)]]
        dg = [dd.d(x, k) for x in g]
        if all(x.is_Number and x == 0 for x in dins + dg):
            return None
        return NarrowBarDot(self.args[0], uid, *ins, *g, *dins, *dg)


class NarrowBarDot(Token):
    """NarrowBarDot(routine, uid, *inputs, *output bars, *input tangents, *bar tangents): the bars
    and their tangents, into ``NE<uid>_`` (the tangents from index :attr:`nbar`)."""
    c_token = True

    @property
    def nbar(self):
        return npose(int(self.args[0]))

    def c_declaration(self):
        return f"double NE{int(self.args[1])}_[{2 * self.nbar}];"

    def c_routines(self):
        rid = int(self.args[0])
        return [((rid, 4), *routine_code(rid, "bar_dot"))]

    def _ccode(self, printer):
        rid = int(self.args[0])
        m, n0, nout = ninput(rid), npose(rid), routine_outputs(rid)
        a = self.args[2:]
        parts = (a[:m], a[m:m + nout], a[m + nout:m + nout + n0], a[m + nout + n0:])
        return (f"{_cname(rid, 'bar_dot')}({', '.join(_literal(x, printer) for x in parts)}, "
                f"&NE{int(self.args[1])}_[0])")
