"""Body–body pairs as one table-driven C loop (``pairs.PAIR_TABLE``): code O(kinds), not O(pairs).

One job: every :class:`.pairs.PairLoad` of a tree lowered into *one* call,
:class:`PairTableCall`, of a generated static C function that loops over a static table of the
pairs, the way MuJoCo does it.  The inlined pairs (and the law routines, ``pairs.LAW_ROUTINES``)
are generated code per pair: gymnasium's humanoid with its 109 self-pairs built its rhs in
28.7 s CPU inlined, 15.2 s with law routines (no self-pairs 7.6 s; benchmarks/results/
mjcf_contact.md, session 10), and jac_x's tangent differentiated every pair.  In one loop: 10.4 s
against 32.5 s inlined and 8.6 s without the self-pairs, rhs 1.98x the no-contact rhs against 2.00x
inlined (mjcf_contact.md, 2026-11-29 22:11, one run).  jac_x and jac_id keep the analytic
kernel (compiler/tree/analytic.py, block W): the table's wrenches are constant loads there, and
their tangents along each state column come from the forward-mode twin below; the tangent path
made the humanoid's default function set 44 s CPU against 23 s without self-pairs.

The call's inputs (one array) are what varies per call: per moving body that holds a pair's shape
its origin, world -> body rotation (rows), ω and origin velocity (body components: the law
routine's body layout, .narrow.BODY_INPUTS), per shape its offset from its body's origin (body
frame; a world shape's centre), per pair the law's k, c, μ, v_s, then per pair with torsional or
rolling friction (MJCF condim 4, 6: :attr:`Table.spins`) its μ_t, μ_r, ρ.  In a table with such a
pair every pair's law is the spinning law routine (.narrow.LAW_SPIN_RID), with 0, 0, 1 for a pair
without them (a moment of ±0).  Why in the table: such pairs were inlined one by one, and dm_control's
dog (condim-6 teeth against ~120 shapes) did not get past generate in ten minutes.  What is fixed at build is in
static tables: per shape its body, rotation and size, per pair its two shapes, margin and the
square of its broad-phase reach.  The function

1. places every shape's centre (its axes only when one of its pairs needs them);
2. per kind of pair, loops over that kind's pairs: a pair whose centres are further apart than
   the reach is skipped (the inlined path's bounding-ball guard, :func:`.pairs.pair_clearance`,
   with balls about the shapes' own centres); else its kinds' narrow routine (.narrow) gives
   p, n, δ per contact point, and a point in contact (not -δ > 0) calls the law routine, whose
   wrenches are added to the two bodies' accumulated wrenches;
3. writes per body its wrench (moment about the origin, force; body components), then per
   contact point F_n, friction (3, world), δ, the clip's function and p (3): a pair's
   :class:`.pairs.PairValue` kinds, in order.

The skips are exact (the force is ±0 where they apply), so the rhs equals the inlined path to
rounding.  Events read every point's δ and clip, also far ones: the events function calls the loop
with ``full`` = 2 (:meth:`PairTableCall.for_program`), where a
skipped pair costs its bounding-ball test too and its points get the balls' bounds instead of the
narrow phase: F_n and friction 0 (exact: the law has no force apart), δ = -gap and clip = gap with
gap = max(|c_A - c_B| - ρ, BROAD_PAD) (ρ = the pair's reach less the pad: its bounding radii and
margin; every δ the narrow phase computes is at most ρ - |c_A - c_B|, .pairs.pair_clearance), and p
midway between the centres; a point of a pair that is not skipped but apart by more than
BROAD_PAD (δ < -BROAD_PAD) skips the law: its F_n and friction are 0 (exact) and its clip -δ.  So
a skipped pair's contact event is below -BROAD_PAD and every bounded clip event above it (clip =
max(1 + 3/2 c δ̇, -δ) ≥ -δ): each on the side its exact value is on and outside the runtime's
noise band, so every sign change the exact functions have is still seen (a crossing needs
δ ≥ 0, where nothing is bounded).  The outputs function calls it with ``full`` = 1, no skips: users
read every point's depth and position exact (tests/compiler/contact/test_solid_pairs_built.py), and
outputs are not on the integrators' path.  Why: gymnasium's humanoid (109 pairs) evaluated its events in 11.5 µs
against 1.0 µs without self-pairs, up to four times a BDF step (3.1 µs now at its rest pose;
benchmarks/results/passive.md, 2026-11-30).  ``full`` = 1 (no skips, the narrow phase
everywhere) is also the tangent and reverse loops' own variant (PairTableDot, PairTableBar).
NAME_energy, which reads a point's δ only as (δ + |δ|)/2 and nothing else of the loop, calls it
with ``full`` = DEPTHS (4): the rhs's skips (balls and segments), δ written for the pairs that pass
them and 0 for the rest (+0 in the energy either way: the narrow phase's δ there is < 0), and no
law.  Why: the rollouts' energy watch calls NAME_energy every step of every row; with ``full`` = 2
its far pairs' bounds (two sqrt each) and touching pairs' laws were 3 % of the humanoid's lanes
rollout (perf, session 28), for values the energy does not read.

Derivatives: the tangent (jvp, jac_p; jac_x and jac_id per state column, into the analytic
kernel's block W) is one call of the function's forward-mode twin per direction, ``eomc_pairs_dot``,
with the inputs' tangents.  It reads what the taped primal call, ``eomc_pairs_tape``, stored
after its outputs: its inputs, per pair a flag (0: no point in contact at this state, else where
its routine tapes are, -1: no room), and the narrow and law routines' tapes of the pairs in
contact (up to TAPE_ROOM doubles; a pair past it re-runs its routines' ``_tape`` variants).  So
the twin (full = 0) runs only the ``_dot`` routines of the pairs in contact at the state -- the
decision is the state's, the same for every direction -- and skips a pair none of whose inputs
moves along the direction (exactly zero tangents).  jac_x and jac_id run the columns only when
some pair is in contact, and only the columns that move one of its bodies: the analytic kernel
forms the inputs' tangents itself and calls the twin (:class:`PairTableKernelTape`,
compiler/tree/analytic.py ``_kernel_pair_lines``; generated tangent code per state column,
compiler/tree/analytic_emit.py, only where a shape's offset or a law's parameter reads the state).  Why: jac_x of gymnasium's humanoid ran the twin's primal and
tangent of every pair within its bounding balls per column: at rest (5 self-pair points in
contact) 178 µs, now 87, with none in contact 86 µs, now 17, against 17 and 14 without the
self-pairs (benchmarks/results/pair_jac_x.md, one run).  The reverse sweep (vjp; hvp and hess_id
differentiate it forward) is one call of its reverse twin, ``eomc_pairs_bar`` (:class:`PairTableBar`),
with the bars of the outputs the function reads; its tangent, ``eomc_pairs_bar_dot``
(:class:`PairTableBarDot`).  They run the pairs the primal runs (the same skips: exact, the force is
±0 there), the routines' ``_bar`` and ``_bar_dot`` variants (.narrow), and take the placements' bars
back to the bodies' inputs.
"""
import re

import sympy as sm

from . import narrow as nw
from eomc.runtime.errors import ModelError

__all__ = ["DEPTHS_POSITIVE", "PairTableCall", "PairTableOut", "PairTableKernelTape", "lower_table",
           "reads_depths_positive_only", "table_of"]

TAPE_ROOM = 4096         # doubles of the pairs' routine tapes a taped call keeps (pairs in contact; see _loop)
LAW_PARAMS = ("k", "c", "mu", "vs")   # per pair in the loop's inputs; then per spinning pair nw.SPIN_PARAMS
POINT_OUTPUTS = 9        # F_n, friction (3), δ, clip, p (3): PairValue kinds 0..8
# the "slopes" variant's outputs per contact point, after the others: NAME_implicit's contact entry
# (compiler/tree/lower.implicit_layout): δ (0 where the broad phase skips the pair), p (3; 0 there),
# v_B - v_A at p (3), K (9), C (9) (.pairs.law_slopes; 0 out of contact)
SLOPE_OUTPUTS = 25
SLOPES = 3               # ``full`` of a call in its "slopes" variant (its C passes 0: the rhs's skips)
# ``full`` of a call in its "slopes" variant that also sums its points' elastic energy (Table.energy_at)
SLOPES_ENERGY = 5
DEPTH_OUTPUT = 4         # a contact point's δ among its POINT_OUTPUTS (PairValue kind "depth")
DEPTHS_POSITIVE = "depths"   # for_program's ``exact`` for a function reading δ only as (δ + |δ|)/2
# ``full`` of such a function's call when δ is all it reads of the loop (NAME_energy): the rhs's skips
# (the balls, SEGMENT_BOUND), every point's δ (0 where its pair is skipped), no law (module docstring)
DEPTHS = 4
_TABLES = {}             # table id -> Table (this process's lowering; the C is what the caches keep)


class Table:
    """What the C function is generated from: the shapes, the pairs, the gathered bodies."""

    def __init__(self, bodies, shapes, pairs, spins=()):
        self.bodies = bodies     # tree body indices, in input order
        self.shapes = shapes     # [(gathered body index or -1, kind, rot 9, size 3)]
        self.pairs = pairs       # [(rid, shape a, shape b, margin, reach², first point)]
        # the pairs with torsional or rolling friction (indices into pairs): where there are any, every
        # pair's law is the spinning law routine, theirs with their 3 more parameters (nw.SPIN_PARAMS,
        # after every pair's 4 in the inputs: the 4-blocks stay the parameters' own consecutive slots
        # where they were), the others with 0, 0, 1 (a moment of ±0)
        self.spins = tuple(spins)
        self.spin = bool(self.spins)
        self.law = nw.LAW_SPIN_RID if self.spin else nw.LAW_RID
        self.npoints = sum(len(_parts(rid)) for rid, *_ in pairs)
        self.nstate = 18 * len(bodies) + 3 * len(shapes)
        self.spin_at = self.nstate + len(LAW_PARAMS) * len(pairs)     # the spinning pairs' parameters
        self.ninput = self.spin_at + len(nw.SPIN_PARAMS) * len(self.spins)
        self.nwrench = 6 * len(bodies)
        self.noutput = self.nwrench + POINT_OUTPUTS * self.npoints
        law = nw.routine_outputs(self.law) + len(nw.tape_of(self.law))
        need = sum(nw.routine_outputs(rid) + len(nw.tape_of(rid)) + len(_parts(rid)) * law for rid, *_ in pairs)
        self.room = min(need, TAPE_ROOM)     # the taped call's room for them
        # the "slopes" variant's output after its slope block: its points' elastic energy, per point
        # in touch (the law runs, δ >= 0) k δ^(5/2) / (5/2), compiler/tree/contacts._pair_energy's
        # term (δ₊ = δ there; 0 elsewhere), summed in the loop's order.  NAME_implicit's energy slot
        # reads it (contacts.ENERGY_IMPLICIT): the slopes variant does not write the points' δ
        # outputs the other functions' terms read.  (Its "into" variant writes it at noutput.)
        self.energy_at = self.noutput + SLOPE_OUTPUTS * self.npoints

    def key(self):
        return (tuple(self.bodies), tuple(self.shapes), tuple(self.pairs), self.room, self.spins)


def _parts(rid):
    from .pairs import pair_parts
    return pair_parts(*nw.kinds_of(rid))


def table_of(tid):
    return _TABLES[int(tid)]


def lower_table(loads, bodies, rec, v, rename, poses, wrenches=None, slopes=None, call_info=None, energy=None):
    """Lower the PairLoads ``loads`` (one per contact point, as :func:`.pairs.with_pairs` makes
    them) as one :class:`PairTableCall`: add the wrenches to the bodies' fext; return
    {PairValue placeholder: temporary}.  ``wrenches``: a list to fill with (tree body, its six
    wrench temporaries), per gathered body in input order (the analytic jac_x reads their
    tangents, compiler/tree/analytic.py).  ``slopes``: a list to fill, per load in order, with
    NAME_implicit's entries of its point (depth, point, v_rel, K, C: :data:`SLOPE_OUTPUTS` outputs
    of the loop's "slopes" variant, which a function reading them calls: :meth:`PairTableCall.for_program`).
    ``call_info``: a dict to fill with the call's temporary ("call"), its table id ("table") and
    the shapes' offsets and the laws' parameters as expressions ("fixed": where none reads the
    state, the analytic kernel forms the tangents of the call's inputs itself,
    :class:`PairTableKernelTape`).  ``energy``: a dict to fill with "energy", the points' elastic
    energy as the "slopes" variant sums it (:attr:`Table.energy_at`; NAME_implicit's)."""
    from .pairs import BROAD_PAD, PairValue, bounding_radius, _num
    first = {}
    for ld in loads:                        # a pair's points share its index base and shapes
        first.setdefault(ld.index - max(ld.part, 0), ld)
    gathered, shape_ids, shapes, offsets, pairs, params = [], {}, [], [], [], []

    def shape_index(s, what):
        key = (s.body, s.kind, tuple(float(x) for x in s.size), tuple(sm.sympify(x) for x in s.offset),
               tuple(float(x) for row in s.rot for x in row))
        if key not in shape_ids:
            if s.body >= 0 and s.body not in gathered:
                gathered.append(s.body)
            shape_ids[key] = len(shapes)
            shapes.append((gathered.index(s.body) if s.body >= 0 else -1, s.kind,
                           tuple(float(x) for row in s.rot for x in row),
                           tuple(float(x) for x in s.size) + (0.0,) * (3 - len(s.size))))
            offsets.append([rename(x, what) if isinstance(x, sm.Basic) else _num(x) for x in s.offset])
        return shape_ids[key]
    point = 0
    bases, spins, extra = {}, [], []
    for base, ld in sorted(first.items()):
        what = f"the contact {ld.name}"
        ia, ib = shape_index(ld.a, what), shape_index(ld.b, what)
        rid = nw.routine_index(ld.a.kind, ld.b.kind)
        reach = (max(float(ld.margin), 0.0) + BROAD_PAD + bounding_radius(ld.a.kind, ld.a.size)
                 + bounding_radius(ld.b.kind, ld.b.size))
        pairs.append((rid, ia, ib, float(ld.margin), reach * reach, point))
        bases[base] = point
        point += len(_parts(rid))
        params += [rename(ld.params[k], what) for k in LAW_PARAMS]
        if ld.spins:                        # condim 4 has no rolling: μ_r 0 (no such part, .law.spin_moment)
            spins.append(len(pairs) - 1)
            extra += [rename(ld.params[k], what) if k in ld.params or k == "rho" else sm.S.Zero
                      for k in nw.SPIN_PARAMS]
    params += extra
    inputs = []
    for i in gathered:
        R = poses.world_to_body(i)
        o = poses.origin(i)
        inputs += list(o) + [x for row in R for x in row] + list(v[i][:3]) + list(v[i][3:])
    for off in offsets:
        inputs += off
    inputs += params
    table = Table(tuple(gathered), tuple(shapes), tuple(pairs), spins)
    tid = next((k for k, t in _TABLES.items() if t.key() == table.key()), len(_TABLES))
    _TABLES.setdefault(tid, table)
    call = rec.let(PairTableCall(sm.Integer(tid), sm.S.Zero, *[rec.let(x) for x in inputs]))
    if call_info is not None:
        call_info.update(call=call, table=tid, fixed=[x for off in offsets for x in off] + params)
    for j, i in enumerate(gathered):
        w = [rec.let(PairTableOut(call, sm.Integer(0), sm.Integer(6 * j + k))) for k in range(6)]
        if wrenches is not None:
            wrenches.append((i, w))
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [old[k] + x for k, x in enumerate(w)]
    values = {}
    if energy is not None:
        energy["energy"] = PairTableOut(call, sm.Integer(0), sm.Integer(table.energy_at))
    for ld in loads:
        point = bases[ld.index - max(ld.part, 0)] + max(ld.part, 0)
        at = table.nwrench + POINT_OUTPUTS * point
        for kind in range(POINT_OUTPUTS):
            values[PairValue(ld.index, kind)] = PairTableOut(call, sm.Integer(0), sm.Integer(at + kind))
        if slopes is not None:
            e = [PairTableOut(call, sm.Integer(0), sm.Integer(table.noutput + SLOPE_OUTPUTS * point + k))
                 for k in range(SLOPE_OUTPUTS)]
            slopes.append({"depth": e[0], "point": e[1:4], "velocity": e[4:7],
                           "K": [e[7 + 3 * r:10 + 3 * r] for r in range(3)],
                           "C": [e[16 + 3 * r:19 + 3 * r] for r in range(3)]})
    return values


class PairTableCall(nw.Token):
    """PairTableCall(table id, full, *inputs): the pairs' loop, run once; its outputs are read by
    :class:`PairTableOut`.  Its own value is a token (the C function's return, 0.0)."""
    c_token = True

    @property
    def table(self):
        return table_of(self.args[0])

    def _tape(self):
        return False

    def _slopes(self):
        return int(self.args[1]) in (SLOPES, SLOPES_ENERGY)

    def _energy(self):
        return int(self.args[1]) == SLOPES_ENERGY

    DEPTHS_POSITIVE = DEPTHS_POSITIVE

    def reads_depths_positive_only(self, prog):
        """:func:`reads_depths_positive_only` (compiler/emit/generate.py asks the node)."""
        return reads_depths_positive_only(prog)

    def c_declaration(self):
        t = self.table
        n = t.noutput + (t.ninput + len(t.pairs) + t.room if self._tape() else 0)
        n += SLOPE_OUTPUTS * t.npoints if self._slopes() else 0
        return f"double PT_[{n + self._energy()}];"

    def c_routines(self):
        return _routines(self.table, self._tape(), False, self._slopes(), self._energy())

    def _ccode(self, printer):
        t = self.table
        state = ", ".join(printer._print(a) for a in self.args[2:2 + t.nstate])
        tape = "_tape" if self._tape() else "_slopes" if self._slopes() else ""
        full = 0 if self._slopes() else int(self.args[1])
        return (f"eomc_pairs{tape}((const double[{t.nstate}]){{{state}}}, {_array(self.args[2 + t.nstate:], printer)}, "
                f"{full}, &PT_[0])")

    def taped(self):
        return PairTableTapeCall(*self.args)

    def reverse(self, fresh, bars):
        """The reverse sweep through the loop (compiler/passes/adjoint.py): ([(temporary,
        PairTableBar)], [(input, its bar)]) from ``bars``, {output index: its bar}.  It evaluates
        every pair (``full``) only when a contact point's output has a bar."""
        t = self.table
        ins = self.args[2:]
        g = [bars.get(k, sm.S.Zero) for k in range(t.noutput)]
        full = any(k >= t.nwrench for k in bars)
        sym = fresh()
        uid = sm.Integer(int(sym.name[2:]))
        node = PairTableBar(self.args[0], uid, sm.Integer(int(full)), *ins, *g)
        return [(sym, node)], nw.reverse_pairs(ins, sym, 2, uid)

    def for_program(self, reads, exact=False):
        """The call with ``full`` = 2 (far pairs' bounds, see the module docstring) when the program
        reads a contact point's quantities (``reads``: the output indices its PairTableOut read), else 0;
        ``exact`` (the outputs function: users read every point's depth and position) 1, no skips;
        ``exact`` = DEPTHS_POSITIVE (NAME_energy: it reads a point's δ only through its positive part
        (δ + |δ|)/2): 2 when the program reads no other point quantity, else 1.

        Why DEPTHS_POSITIVE may skip: a pair the bounding balls skip has δ = -gap < 0 where the narrow
        phase's δ is < 0 too (module docstring), so (δ + |δ|)/2 is +0 with either (0.5|δ| and 0.5δ
        round to opposite numbers), and a point that is not skipped keeps the narrow phase's δ
        itself; the law (F_n, friction) is not read -- so where the program reads nothing but δ
        (no wrench either) the call is ``full`` = DEPTHS, which skips the law and the bounds too.
        The energy's value is the outputs' bit for
        bit (tests/compiler/emit/test_energy_fn.py); G1's NAME_energy ran every pair's narrow phase
        and law (41 % of its time)."""
        t = self.table
        if any(k >= t.noutput for k in reads):      # NAME_implicit: the pairs' slopes
            if any(t.nwrench <= k < t.noutput for k in reads):
                raise ModelError("a function reads both the body-body pairs' slopes and their outputs")
            full = SLOPES_ENERGY if t.energy_at in reads else SLOPES
        else:
            depths = exact == DEPTHS_POSITIVE
            if depths:
                exact = any(k >= t.nwrench and (k - t.nwrench) % POINT_OUTPUTS != DEPTH_OUTPUT for k in reads)
                depths = not exact and not any(k < t.nwrench for k in reads)
            full = (1 if exact else DEPTHS if depths else 2) if any(k >= t.nwrench for k in reads) else 0
        return self.func(self.args[0], sm.Integer(full), *self.args[2:])


def reads_depths_positive_only(prog):
    """Whether ``prog`` reads the pairs' loops' contact point outputs only as their δ's positive
    part, (δ + |δ|)/2 (the energy's elastic terms, compiler/tree/contacts._pair_energy): every
    PairTableOut of a point's δ, or a temporary holding one, occurs only inside such a sum, and no
    other point output is read.  Then the loop may skip far pairs (PairTableCall.for_program's
    DEPTHS_POSITIVE); a program that reads anything else of a point keeps every pair exact."""
    tables = {t: e.table for t, e in prog.assignments if isinstance(e, PairTableCall)}
    if not tables:
        return False
    outs = set()
    for _, e in (*prog.assignments, *prog.results):
        if isinstance(e, sm.Basic):
            outs.update(e.atoms(PairTableOut))
    depth = set()
    for n in outs:
        t = tables.get(n.args[0])
        k = int(n.args[2])
        if t is None or int(n.args[1]) != 0:
            return False
        if k >= t.nwrench:
            if (k - t.nwrench) % POINT_OUTPUTS != DEPTH_OUTPUT:
                return False
            depth.add(n)
    alias = {t for t, e in prog.assignments if e in depth}
    held = depth | alias
    half = sm.Rational(1, 2)
    parts = {frozenset((half * d, half * sm.Abs(d))) for d in held}    # (built once: per node they were 3 % of the humanoid's generate)

    def positive_part(e):
        return isinstance(e, sm.Add) and len(e.args) == 2 and frozenset(e.args) in parts
    mark = sm.Dummy()
    for t, e in (*prog.assignments, *prog.results):
        if t in alias or not isinstance(e, sm.Basic) or not e.has(*held):
            continue
        rest = e.replace(positive_part, lambda _: mark)
        if rest.has(*held):
            return False
    return True


class PairTableTapeCall(PairTableCall):
    """PairTableCall that also stores its inputs after its outputs (its tangent call reads them)."""

    def _tape(self):
        return True

    def taped(self):
        return self


class PairTableSlopesInto(PairTableCall):
    """PairTableSlopesInto(table id, offset, *inputs): the "slopes" variant writing its slope
    block into NAME_implicit's ``out`` from ``offset`` on (:func:`slopes_into` makes it when
    out[offset ...] are exactly the block).  Why: the "slopes" variant's block lived in PT_, which
    the loop zeroed and NAME_implicit then copied into out[] entry by entry (2725 doubles each on
    gymnasium's humanoid); written in place, NAME_implicit at qpos0 took 6.16 instead of 7.59 us
    together with NAME_finite_wide's 16 sums (session 14, fsmodel: this cut alone 1.00-1.12x in
    two runs, the 16 sums alone 1.08x)."""

    def _slopes(self):
        return True

    def _energy(self):
        return False

    def c_declaration(self):
        return f"double PT_[{self.table.noutput + self._energy()}];"

    def c_routines(self):
        return _routines(self.table, False, False, "into", self._energy())

    def for_program(self, reads, exact=False):
        return self

    def _ccode(self, printer):
        t = self.table
        state = ", ".join(printer._print(a) for a in self.args[2:2 + t.nstate])
        # the block's length too: NAME_implicit_batch's lanes (compiler/emit/batch.py) gather it
        return (f"eomc_pairs_slopes((const double[{t.nstate}]){{{state}}}, {_array(self.args[2 + t.nstate:], printer)}, "
                f"0, &PT_[0], &out[{int(self.args[1])}], {SLOPE_OUTPUTS * t.npoints}, {int(KEPT_BLOCK)})")


class PairTableSlopesEnergyInto(PairTableSlopesInto):
    """:class:`PairTableSlopesInto` of a call in the SLOPES_ENERGY variant: its points' elastic energy
    (:attr:`Table.energy_at`) in ``PT_[noutput]`` (slopes_into reads it there)."""

    def _energy(self):
        return True


def slopes_into(program, group):
    """``program`` with its pairs' slopes call made :class:`PairTableSlopesInto` when the results
    (group, i) for i from some offset on are exactly the call's slope block, and the set of those
    result keys (the caller stores no value for them), else (program, empty set): the "slopes"
    variant into PT_, copied, as before (several tables, or a block read by another result)."""
    into = [(s, e) for s, e in program.assignments if isinstance(e, PairTableSlopesInto)]
    if into:        # (made already: the keys it writes)
        call = into[0][1]
        return program, {(group, int(call.args[1]) + j) for j in range(SLOPE_OUTPUTS * call.table.npoints)}
    calls = [(s, e) for s, e in program.assignments if type(e) is PairTableCall and e._slopes()]
    if len(calls) != 1:
        return program, set()
    sym, call = calls[0]
    t = call.table
    n = SLOPE_OUTPUTS * t.npoints
    res = dict(program.results)
    first = [k for k, e in res.items() if k[0] == group and isinstance(e, PairTableOut)
             and e.args[0] == sym and int(e.args[1]) == 0 and int(e.args[2]) == t.noutput]
    if len(first) != 1:
        return program, set()
    off = first[0][1]
    keys = {(group, off + j) for j in range(n)}
    for j in range(n):
        e = res.get((group, off + j))
        if not (isinstance(e, PairTableOut) and e.args[0] == sym and int(e.args[1]) == 0
                and int(e.args[2]) == t.noutput + j):
            return program, set()
    others = [e for k, e in res.items() if k not in keys] + [e for _, e in program.assignments]
    if any(isinstance(x, PairTableOut) and x.args[0] == sym and t.noutput <= int(x.args[2]) < t.energy_at
           for e in others if isinstance(e, sm.Basic) for x in sm.preorder_traversal(e)):
        return program, set()
    kind = PairTableSlopesEnergyInto if call._energy() else PairTableSlopesInto
    into = kind(call.args[0], sm.Integer(off), *call.args[2:])
    # the energy (energy_at after the block in PT_) is PT_[noutput] of the "into" variant
    moved = {PairTableOut(sym, sm.Integer(0), sm.Integer(t.energy_at)): PairTableOut(sym, sm.Integer(0),
                                                                                    sm.Integer(t.noutput))}
    assignments = tuple((s, into if s == sym else e.xreplace(moved) if isinstance(e, sm.Basic) else e)
                        for s, e in program.assignments)
    results = tuple((k, e.xreplace(moved) if isinstance(e, sm.Basic) else e) for k, e in program.results)
    return program.with_(assignments=assignments, results=results), keys


class PairTableDot(nw.Token):
    """PairTableDot(table id, uid, call, full, *input tangents): the outputs' tangents, into
    ``PD<uid>_``, from the primal inputs the call stored after its outputs."""
    c_token = True

    def tape_of(self):
        return (self.args[2],)

    @property
    def table(self):
        return table_of(self.args[0])

    def c_declaration(self):
        return f"double PD{int(self.args[1])}_[{self.table.noutput}];"

    def c_routines(self):
        return _routines(self.table, True, True)

    def for_program(self, reads, exact=False):
        full = any(k >= self.table.nwrench for k in reads)
        return self.func(self.args[0], self.args[1], self.args[2], sm.Integer(int(full)), *self.args[4:])

    def _ccode(self, printer):
        t = self.table
        dins = self.args[4:]
        state = ", ".join(printer._print(a) for a in dins[:t.nstate])
        par = dins[t.nstate:]
        if all(x.is_Number and x == 0 for x in par):
            ptext = "0"
        else:
            ptext = f"(const double[{len(par)}]){{{', '.join(printer._print(a) for a in par)}}}"
        return (f"eomc_pairs_dot(&PT_[{t.noutput}], (const double[{t.nstate}]){{{state}}}, {ptext}, "
                f"{int(self.args[3])}, &PD{int(self.args[1])}_[0])")


class PairTableKernelTape(nw.Token):
    """PairTableKernelTape(table id, call): a result of jac_x and jac_id (group ``tpw``) where the
    analytic kernel forms the table inputs' tangents itself (compiler/tree/analytic.py,
    :func:`~eomc.compiler.tree.analytic.kernel_c`) and calls ``eomc_pairs_dot`` per column: it
    makes the function's ``call`` the taped variant (``tape_of``) and brings the twin's routines
    (``c_routines``).  It is not printed (the kernel reads ``PT_`` through its ``pt`` argument)."""
    c_token = True

    def tape_of(self):
        return (self.args[1],)

    @property
    def table(self):
        return table_of(self.args[0])

    def c_routines(self):
        return _routines(self.table, True, True)

    def _ccode(self, printer):
        return "0.0"


class PairTableOut(sm.Function):
    """PairTableOut(call, tag, k): output k of the pairs' call (tag 0: ``PT_``; tag > 0: a
    PairTableDot's ``PD<tag - 1>_``)."""
    nargs = 3
    is_real = True

    def _eval_derivative(self, s):
        raise ModelError(nw._REFUSAL)

    def reverse_read(self):
        """(the call it reads, which output): the reverse sweep gathers each output's bar."""
        return self.args[0], int(self.args[2])

    def forward(self, dd, k):
        call, tag, index = self.args
        if int(tag) != 0:
            raise ModelError(nw._REFUSAL)
        key = ("pairtable", call, k)
        hit = dd.extra.get(key)
        if hit is None:
            expr = dd.definition(call)
            dins = [dd.d(x, k) for x in expr.args[2:]]
            if all(x.is_Number and x == 0 for x in dins):
                hit = sm.S.Zero
            else:
                sym = dd.names.fresh()
                uid = int(sym.name[2:])
                dd.out.append((sym, PairTableDot(expr.args[0], sm.Integer(uid), call, expr.args[1], *dins)))
                hit = (sym, uid)
            dd.extra[key] = hit
        if hit is sm.S.Zero:
            return sm.S.Zero
        return PairTableOut(hit[0], sm.Integer(hit[1] + 1), index)

    def read_index(self):
        """The output it reads (compiler/emit/generate.py picks the loop's variant from these)."""
        return int(self.args[2])

    def _ccode(self, printer):
        tag, index = int(self.args[1]), int(self.args[2])
        return f"PT_[{index}]" if tag == 0 else f"PD{tag - 1}_[{index}]"


def _array(values, printer):
    """C of a read-only array of ``values``: ``&p[i]`` when they are the consecutive slots p[i], p[i+1], ...
    of the parameters (the law's k, c, μ, v_s of each pair are), else a compound literal.
    It reads the printed names: the printer is told (emit/printer.CPrinter.reads_names)."""
    printer.reads_names()
    text = [printer._print(a) for a in values]
    m = re.fullmatch(r"p\[(\d+)\]", text[0]) if text else None
    if m and text == [f"p[{int(m.group(1)) + k}]" for k in range(len(text))]:
        return f"&p[{m.group(1)}]"
    return f"(const double[{len(text)}]){{{', '.join(text)}}}" if text else "0"


# --- the C text --------------------------------------------------------------------------------

def _fmt(x):
    return repr(float(x))


def _routines(table, tape, dot, slopes=False, energy=False):
    """[(key, C text, split)]: the narrow and law routines the loop calls, then the loop
    (``slopes``: its "slopes" variant and the slopes routine instead of the primal; ``energy``:
    that variant summing its points' elastic energy, Table.energy_at)."""
    rids = sorted({p[0] for p in table.pairs})
    out = []
    for rid in rids + [table.law] + ([nw.SLOPES_RID] if slopes else []):
        for var in ([None, "tape", "dot"] if dot else [None, "tape"] if tape else [None]):
            text, split = nw.routine_code(rid, var)
            out.append(((rid, {None: 0, "dot": 1, "tape": 2}[var]), text, split))
    out.append(((1000, 0), _tables(table), False))
    if slopes:
        out.append(((1000, 7 if energy else 6), _loop(table, "into" if slopes == "into" else "slopes", energy),
                    False))
    else:
        out.append(((1000, 1), _loop(table, "primal"), False))
    if tape:
        out.append(((1000, 2), _loop(table, "tape"), False))
    if dot:
        out.append(((1000, 3), _loop(table, "dot"), False))
    return out


def _tables(t):
    rows = []
    rows.append("/* body-body pairs' tables (compiler/contact/table.py): per shape its body (-1: the world), "
                "rotation rows (shape -> body), size; per kind its pairs */")
    rows.append(f"static const int eomc_pairs_sbody[{len(t.shapes)}] = {{{', '.join(str(s[0]) for s in t.shapes)}}};")
    rows.append(f"static const double eomc_pairs_srot[{len(t.shapes)}][9] = {{"
                + ", ".join("{" + ", ".join(_fmt(x) for x in s[2]) + "}" for s in t.shapes) + "};")
    rows.append(f"static const double eomc_pairs_ssize[{len(t.shapes)}][3] = {{"
                + ", ".join("{" + ", ".join(_fmt(x) for x in s[3]) + "}" for s in t.shapes) + "};")
    if t.spin:      # per pair its place among the spinning pairs (-1: none), and a non-spinning pair's 3
        index = {q: j for j, q in enumerate(t.spins)}
        rows.append(f"static const int eomc_pairs_spin[{len(t.pairs)}] = {{"
                    + ", ".join(str(index.get(q, -1)) for q in range(len(t.pairs))) + "};")
        rows.append("static const double eomc_pairs_nospin[3] = {0.0, 0.0, 1.0};   /* mu_t, mu_r, rho */")
    for rid in sorted({p[0] for p in t.pairs}):
        mine = [(q, p) for q, p in enumerate(t.pairs) if p[0] == rid]
        name = "%s_%s" % nw.kinds_of(rid)
        rows.append(f"static const int eomc_pairs_{name}_i[{len(mine)}][4] = {{"
                    + ", ".join(f"{{{p[1]}, {p[2]}, {q}, {p[5]}}}" for q, p in mine) + "};")
        if nw.kinds_of(rid) in _SEGMENT_BOUND:   # and the segment bound's reach (_segment_bound_lines)
            rows.append(f"static const double eomc_pairs_{name}_d[{len(mine)}][3] = {{"
                        + ", ".join(f"{{{_fmt(p[3])}, {_fmt(p[4])}, {_fmt(_segment_reach(t, p))}}}" for q, p in mine)
                        + "};")
            continue
        rows.append(f"static const double eomc_pairs_{name}_d[{len(mine)}][2] = {{"
                    + ", ".join(f"{{{_fmt(p[3])}, {_fmt(p[4])}}}" for q, p in mine) + "};")
    return "\n".join(rows) + "\n"


def _loop(t, mode, energy=False):
    """The loop: ``mode`` "primal" (eomc_pairs), "tape" (eomc_pairs_tape: also stores its inputs,
    per pair a flag, and the narrow and law routines' tapes of the pairs in contact), "dot"
    (eomc_pairs_dot, its forward-mode twin, reading what the tape stored) or "slopes"
    (eomc_pairs_slopes, NAME_implicit's: the primal with full = 0, also writing per contact point
    its :data:`SLOPE_OUTPUTS` after the other outputs); ``energy`` (slopes): also the points'
    elastic energy, summed where their law runs (:attr:`Table.energy_at`; "into": at noutput)."""
    from .pairs import BROAD_PAD
    dot, tape, slopes, into = mode == "dot", mode == "tape", mode in ("slopes", "into"), mode == "into"
    ns, nb = len(t.shapes), len(t.bodies)
    off = 18 * nb
    nlaw, nlt = nw.routine_outputs(t.law), len(nw.tape_of(t.law))
    law = nw._cname(t.law)
    L = []
    if dot:
        L.append("/* tangents of the body-body pairs' loop (compiler/contact/table.py): in the tape (eomc_pairs_tape's), "
                 "din the bodies' and offsets' tangents, dpar the law parameters' (0: none) */")
        L.append("static double eomc_pairs_dot(const double *in, const double *din, const double *dpar, int full, "
                 "double *out)\n{")
    elif tape:
        L.append("/* the body-body pairs' loop storing after its outputs its inputs, per pair its tape's place "
                 "(0: no point in contact, -1: in contact, no room), then the pairs' routine tapes (the twin's) */")
        L.append("static double eomc_pairs_tape(const double *in, const double *pars, int full, double *out)\n{")
    elif into:
        L.append("/* body-body pairs' loop for NAME_implicit (compiler/contact/table.py): eomc_pairs' outputs with "
                 "full = 0, and per contact point depth, p, v_B - v_A, K, C into slo[0 .. nslo) (0 where a pair is "
                 "skipped); returns the sum of what it wrote there (finite: the whole block is, FINITE_BY_SUM).  "
                 "kept = 0: the block is zeroed first; 1: it holds what this loop wrote there at its last call (or "
                 "zeros, or NaNs), and only the records written then are zeroed again (KEPT_BLOCK) */")
        L.append("static double eomc_pairs_slopes(const double *in, const double *pars, int full, double *out, "
                 "double *slo, int nslo, int kept)\n{")
    elif slopes:
        L.append("/* body-body pairs' loop for NAME_implicit (compiler/contact/table.py): eomc_pairs' outputs with "
                 "full = 0, then per contact point depth, p, v_B - v_A, K, C (0 where a pair is skipped) */")
        L.append("static double eomc_pairs_slopes(const double *in, const double *pars, int full, double *out)\n{")
    else:
        L.append("/* body-body pairs' loop (compiler/contact/table.py): wrenches per body, then per contact point "
                 "F_n, friction, depth, clip, p; full = 0 skips what the rhs does not read */")
        L.append("/* full = 2: a skipped pair's points get its bounding balls' bounds (outputs, events); 1: no skips */")
        L.append("static double eomc_pairs(const double *in, const double *pars, int full, double *out)\n{")
    L.append(f"    static const double zero[18] = {{0}};")
    L.append(f"    double cen[{3 * ns}], ax[{9 * ns}];")
    if dot:
        L.append(f"    double dcen[{3 * ns}], dax[{9 * ns}];")
    L.append(f"    int have[{ns}] = {{0}};")
    L.append("    int q, m, k, w, j;" if dot else "    int s, q, m, k, w, j;")
    L.append(f"    for (k = 0; k < (full ? {t.noutput} : {t.nwrench}); ++k) out[k] = 0.0;")
    if energy:
        L.append("    double en = 0.0;   /* the points' elastic energy (Table.energy_at) */")
    if into:
        L.append("    double chk = 0.0;")
        L.append(f"    int qs[{max(sum(1 for p in t.pairs if p[0] == rid) for rid in {p[0] for p in t.pairs})}], nb, i;")
        L.append("    if (!kept) for (k = 0; k < nslo; ++k) slo[k] = 0.0;")
    elif slopes:
        L.append(f"    for (k = {t.noutput}; k < {t.noutput + SLOPE_OUTPUTS * t.npoints}; ++k) out[k] = 0.0;")
    if dot:
        L.append(f"    const double *pars = in + {t.nstate}, *act = in + {t.ninput}, *area = act + {len(t.pairs)};")
    if tape:
        L.append(f"    double *act = out + {t.noutput + t.ninput}, *area = act + {len(t.pairs)};")
        L.append("    int used = 0;")
        L.append(f"    for (k = 0; k < {t.nstate}; ++k) out[{t.noutput} + k] = in[k];")
        L.append(f"    for (k = 0; k < {t.ninput - t.nstate}; ++k) out[{t.noutput + t.nstate} + k] = pars[k];")
        L.append(f"    for (k = 0; k < {len(t.pairs)}; ++k) act[k] = 0.0;")
    if not dot:     # (the twin places a shape when a pair in contact first reads it)
        L += _centres(ns, off, False)
    for rid in sorted({p[0] for p in t.pairs}):
        name = "%s_%s" % nw.kinds_of(rid)
        count = sum(1 for p in t.pairs if p[0] == rid)
        npts = len(_parts(rid))
        nout = nw.routine_outputs(rid)
        ntape = len(nw.tape_of(rid)) if dot or tape else 0
        need = nout + ntape + npts * (nlaw + nlt)      # a pair's routine tapes
        if into:    # the ball test first, over every pair without a branch (_balls_first)
            L += _balls_first(name, count, npts)
            L.append(f"    for (i = 0; i < nb; ++i) {{  /* {name} pairs past the ball test */")
            L.append("        q = qs[i];")
        else:
            L.append(f"    for (q = 0; q < {count}; ++q) {{  /* {name} pairs */")
        L.append(f"        const int *P = eomc_pairs_{name}_i[q];")
        L.append(f"        const double *D = eomc_pairs_{name}_d[q];")
        if dot:
            L.append(f"        double nl[{nout + ntape}], nd[{nout}];")
            L.append("        const double *np = nl;")
            L.append("        if (!full && act[P[2]] == 0.0) continue;   /* exact at the state: no point in contact */")
        elif tape:
            L.append(f"        double *np = used + {need} <= {t.room} ? area + used : 0, nl[{nout + ntape}];")
            L.append("        int on = 0;")
            L.append("        if (!np) np = nl;")
            L += _ball_lines()
        elif into:
            L.append(f"        double np[{nout}];")
            L += _ball_lines()[:1]                  # (the ball test ran: e and |e|² for the bound alone)
            if SEGMENT_BOUND and nw.kinds_of(rid) in _SEGMENT_BOUND:
                L += _ball_lines()[1:2]
            if SEGMENT_BOUND and nw.kinds_of(rid) == ("capsule", "capsule"):
                L.append("        const double dd = e0 * e0 + e1 * e1 + e2 * e2;")
        else:
            L.append(f"        double np[{nout}];")
            L += _ball_lines()[:2] + _far_bounds(t, npts)
        bound = not dot and not tape and SEGMENT_BOUND and nw.kinds_of(rid) in _SEGMENT_BOUND
        if bound:   # the segment bound reads the capsules' axes alone: the rest of a frame after it
            L += _axes(dot, part=_bound_axes(nw.kinds_of(rid)))
            L += _segment_bound_lines(nw.kinds_of(rid), depths=not slopes)
            L += _axes(dot, part="rest")
        elif not dot and not tape:
            L += _axes(dot, part="rest")
        else:
            L += _axes(dot, ["    " + x for x in _centre_lines("sh", off, True)] if dot else ())
        if dot:
            L += _ball_lines()
            L += _still_lines(off)
        args = ", ".join(_narrow_args())
        if dot:     # the tape's routine tapes when it had room for them, else the primal again
            L.append(f"        if (!full && act[P[2]] > 0.0) np = area + (int)act[P[2]] - 1;")
            L.append(f"        else eomc_narrow_{name}_tape({args}, nl);")
            dargs = ", ".join(_narrow_dargs())
            L.append(f"        eomc_narrow_{name}_dot(&np[{nout}], {dargs}, nd);")
        else:
            L.append(f"        eomc_narrow_{name}{'_tape' if tape else ''}({args}, np);")
        L.append(f"        for (m = 0; m < {npts}; ++m) {{")
        L.append("            const double *pp = np + 7 * m;")
        L.append("            const int ba = eomc_pairs_sbody[P[0]], bb = eomc_pairs_sbody[P[1]];")
        L.append(f"            const double *A = ba < 0 ? zero : in + 18 * ba, *B = bb < 0 ? zero : in + 18 * bb;")
        L.append("            const double *par = pars + 4 * P[2];")
        L += _spin_lines(t, "sp", "pars")
        L.append(f"            double *po = out + {t.nwrench} + {POINT_OUTPUTS} * (P[3] + m);")
        if dot:
            L.append("            const double *pd = nd + 7 * m;")
            L.append(f"            const double *dA = ba < 0 ? zero : din + 18 * ba, *dB = bb < 0 ? zero : din + 18 * bb;")
            L.append("            const double *dp = dpar ? dpar + 4 * P[2] : zero;")
            L += _spin_lines(t, "dsp", "dpar", tangent=True)
            L.append(f"            double ll[{nlaw + nlt}], lo[{nlaw}];")
            L.append(f"            const double *lt = np != nl ? np + {nout + ntape} + {nlaw + nlt} * m : ll;")
            src, tgt = "pd", "lo"
        elif tape:
            L.append(f"            double ll[{nlaw + nlt}], *lo = np != nl ? np + {nout + ntape} + {nlaw + nlt} * m : ll;")
            src, tgt = "pp", "lo"
        else:
            L.append(f"            double lo[{nlaw}];")
            src, tgt = "pp", "lo"
        L.append(f"            po[4] = {src}[6];")
        L.append(f"            for (k = 0; k < 3; ++k) po[6 + k] = {src}[k];")
        if slopes:
            L.append(f"            double *sl = {'slo' if into else 'out + ' + str(t.noutput)} + {SLOPE_OUTPUTS} * (P[3] + m);")
            L.append("            sl[0] = pp[6];")
            L.append("            for (k = 0; k < 3; ++k) sl[1 + k] = pp[k];")
            if into:
                L.append("            chk += (sl[0] + sl[1]) + (sl[2] + sl[3]);")
        if into:    # (kept: its slopes from the last call, when it touched then)
            L.append(f"            if (!full && -pp[6] > 0) {{ if (kept) for (k = 4; k < {SLOPE_OUTPUTS}; ++k) sl[k] = 0.0; continue; }}")
        else:
            L.append("            if (!full && -pp[6] > 0) continue;")
        if not dot and not tape:   # full = 2, a point apart by more than the pad: F_n, friction 0; clip >= -δ
            L.append(f"            if (full == 2 && -pp[6] > {_fmt(BROAD_PAD)}) {{ po[5] = -pp[6]; continue; }}")
        if not dot and not tape and not slopes:
            L.append(f"            if (full == {DEPTHS}) continue;   /* NAME_energy: the point's δ alone */")
        largs = ", ".join(_law_args("pp", "A", "B", "par", t.spin and "sp"))
        if dot:
            L.append(f"            if (lt == ll) {law}_tape({largs}, ll);")
            dl = ", ".join(_law_args("pd", "dA", "dB", "dp", t.spin and "dsp"))
            L.append(f"            {law}_dot(&lt[{nlaw}], {dl}, lo);")
        elif tape:
            L.append("            on = 1;")
            L.append(f"            {law}_tape({largs}, lo);")
        else:
            L.append(f"            {law}({largs}, lo);")
            if slopes:      # (the slopes have no moment: the law's first parameters alone)
                L.append(f"            eomc_pair_slopes({', '.join(_law_args('pp', 'A', 'B', 'par'))}, &sl[4]);")
            if into:
                L.append(f"            for (k = 4; k < {SLOPE_OUTPUTS}; ++k) chk += sl[k];")
            if energy:  # k δ^(5/2) / (5/2), as NAME_energy prints _pair_energy's term (δ₊ = δ here)
                L.append("            en += (2.0/5.0)*par[0]*(pp[6]*pp[6]*sqrt(pp[6]));")
        L.append(f"            if (bb >= 0) for (k = 0; k < 6; ++k) out[6 * bb + k] += {tgt}[k];")
        L.append(f"            if (ba >= 0) for (k = 0; k < 6; ++k) out[6 * ba + k] += {tgt}[6 + k];")
        L.append(f"            for (k = 0; k < 4; ++k) po[k] = {tgt}[12 + k];")
        L.append(f"            po[5] = {tgt}[16];")
        L.append("        }")
        if tape:    # a pair in contact keeps its tapes (its place + 1; -1: no room, the twin re-runs it)
            L.append("        if (on && np != nl) {")
            L.append("            act[P[2]] = 1.0 + used;")
            L.append(f"            used += {need};")
            L.append("        } else if (on) act[P[2]] = -1.0;")
        L.append("    }")
    if energy:
        L.append(f"    out[{t.noutput if into else t.energy_at}] = en;")
    L.append("    return chk;\n}\n" if into else "    return 0.0;\n}\n")
    return "\n".join(L)


# eomc_pairs_slopes into out[] ("into") returns chk, the sum of every value it writes into the slope
# block (each record's depth and p when its pair passes the broad phase, its 21 slopes when its law
# runs; the rest of the block is its zeros): NAME_implicit checks out[] before the block and reads
# the block itself only when chk is not finite (compiler/tree/emit.finite_return), the same verdict.
# Partial sums per record, so the running sum's chain is one add a record, not one an entry.

# The primal loops (eomc_pairs with full = 0: the rhs; eomc_pairs_slopes: NAME_implicit) skip a
# pair of a capsule and a sphere or capsule whose balls overlap but whose segments (a sphere's:
# its centre) are further apart than the two radii and the margin, from a lower bound on the
# segments' distance computed before the narrow phase (_segment_bound_lines).  Why: on gymnasium's
# humanoid 16 pairs a call pass the ball test and 0.64 touch (session 18, report-humcall2.md):
# the narrow phase ran for pairs that were apart.  Exact as the ball test is: a skipped pair is
# apart by more than BROAD_PAD, where the narrow phase's δ < 0 and the loop skips its law anyway;
# only its δ and p slots (not read by the rhs; NAME_implicit's readers read δ > 0 only) stay 0.
# The tape and tangent loops (jac_x) and full = 1, 2 (outputs, events) keep the ball test alone;
# full = DEPTHS (NAME_energy, reading δ only as (δ + |δ|)/2: +0 for a skipped pair's 0 as for its
# narrow phase's δ < 0) takes the primal's skips too.
SEGMENT_BOUND = True
_SEGMENT_BOUND = (("capsule", "capsule"), ("sphere", "capsule"), ("capsule", "sphere"))

# NAME_implicit_var's loop (PairTableSlopesInto) is called with kept = KEPT_BLOCK: it does not zero
# its slope block first but zeroes the records the last call wrote (their depth or p not 0; a
# NaN-filled buffer's too: _balls_first), and of a pair whose narrow phase finds it apart the
# slopes.  Why: the fixed step calls NAME_implicit_var again and again into the same two buffers,
# and on gymnasium's humanoid the zeroing wrote the block's 2725 doubles at every call (~105 ns of
# its ~3.9 us; 0.58 of 109 pairs touch: report-humcall.md, session 30).  The outputs are the
# zeroing loop's, to the bit, given a buffer NAME_implicit_const and the step's NaN fill or this
# loop wrote before: a record whose depth and p were all exactly 0 at the last call keeps its other
# 21 entries then (its depth is 0: no reader reads them; the header says so).  NAME_implicit (its
# const, the block zeroed, then var: any buffer) and NAME_implicit_batch's lanes (kept = 0) zero it;
# NAME_implicit_batch_rows (the lanes rollout's: each lane's block straight into its row's own
# buffer, the step's T or T1) keeps it as NAME_implicit_var does (session 46: the zeroing was the
# memset of 2725 doubles per lane and call, ~5 % of the humanoid's lanes rollout; +3.4 % steps per
# CPU second measured, same bits).  The fixed step zeroes its two buffers once per run
# (runtime/c/eomc_fixedstep.c), the rollout its padding lanes' row.
KEPT_BLOCK = True


def _segment_reach(t, p):
    """A pair's radii (its shapes' size[0]) plus its margin and BROAD_PAD: the distance of the
    segments past which its narrow phase's δ is below -BROAD_PAD."""
    from .pairs import BROAD_PAD
    return t.shapes[p[1]][3][0] + t.shapes[p[2]][3][0] + p[3] + BROAD_PAD


def _balls_first(name, count, npts):
    """C of eomc_pairs_slopes (into): per pair of a kind, its records zeroed when the last call wrote
    them (kept = 1, KEPT_BLOCK: their depth or p not 0, a NaN-filled buffer's too; else they are
    zeros), and its ball test, the pairs that pass listed in qs[0 .. nb) without a branch; the kind's
    loop then runs over those.  Why: on gymnasium's humanoid 16 of the 109 pairs pass the test a call,
    the test's branch taken or not pair by pair; and a skipped pair's records are checked here, once."""
    return [
        "    nb = 0;",
        f"    for (q = 0; q < {count}; ++q) {{  /* {name} pairs: the ball test */",
        f"        const int *P = eomc_pairs_{name}_i[q];",
        "        const double *ca = cen + 3 * P[0], *cb = cen + 3 * P[1];",
        "        const double e0 = cb[0] - ca[0], e1 = cb[1] - ca[1], e2 = cb[2] - ca[2];",
        f"        if (kept) for (m = 0; m < {npts}; ++m) {{",
        f"            double *sl = slo + {SLOPE_OUTPUTS} * (P[3] + m);",
        "            if (sl[0] != 0.0 || sl[1] != 0.0 || sl[2] != 0.0 || sl[3] != 0.0)",
        f"                for (k = 0; k < {SLOPE_OUTPUTS}; ++k) sl[k] = 0.0;",
        "        }",
        "        qs[nb] = q;",
        f"        nb += !(e0 * e0 + e1 * e1 + e2 * e2 > eomc_pairs_{name}_d[q][1]);",
        "    }"]


def _segment_bound_lines(kinds, depths=False):
    """C, in the primal loop after a pair's axes are placed (e = c_B - c_A, dd = |e|², from the
    ball test): skip the pair when a lower bound on its segments' distance exceeds D[2]
    (_segment_reach).  A capsule's segment is c ± s x, |s| <= l (x its axis, ax's third row, l
    its half-length, size[1]).  Sphere against capsule: the centre's distance to the segment
    (exact).  Two capsules: a point of B's segment is at least |e⊥a| - l_b |x_b⊥a| from A's
    axis line (⊥a: the part normal to x_a), and the same with A and B swapped; the larger.
    ``depths``: with full = DEPTHS too (eomc_pairs; eomc_pairs_slopes is called with 0 only).
    Its max and min are the printer's inline eomc_fmax / eomc_fmin (printer.MINMAX_C: libm's bits),
    not libm's calls.  Why (session 51): on gymnasium's humanoid these were 7 calls through the PLT
    in eomc_pairs_slopes, each spilling the loop's registers around it, for the ~16 of its 109
    pairs that pass the ball test a call; inline, its fixed step's 1-s qpos0 run took 1.5 % less
    CPU (2.633 -> 2.592 ms: the two builds loaded in one process, interleaved, 30 rounds, core 0),
    the same 440 calls and the same end state (the bounds only decide a skip); its lanes rollout
    0.6 % less, the same bits."""
    if kinds not in _SEGMENT_BOUND:
        return []
    if kinds == ("capsule", "capsule"):
        body = [
            "            const double *xa = ax + 9 * P[0] + 6, *xb = ax + 9 * P[1] + 6;",
            "            const double ea = e0 * xa[0] + e1 * xa[1] + e2 * xa[2], eb = e0 * xb[0] + e1 * xb[1] + e2 * xb[2];",
            "            const double c = xa[0] * xb[0] + xa[1] * xb[1] + xa[2] * xb[2], sn = sqrt(eomc_fmax(1.0 - c * c, 0.0));",
            "            const double ga = sqrt(eomc_fmax(dd - ea * ea, 0.0)) - eomc_pairs_ssize[P[1]][1] * sn;",
            "            const double gb = sqrt(eomc_fmax(dd - eb * eb, 0.0)) - eomc_pairs_ssize[P[0]][1] * sn;",
            "            if (ga > D[2] || gb > D[2]) continue;"]
    else:
        cap, sign = ("1", "-") if kinds[1] == "capsule" else ("0", "")
        body = [
            f"            const double *xc = ax + 9 * P[{cap}] + 6, l = eomc_pairs_ssize[P[{cap}]][1];",
            f"            const double f0 = {sign}e0, f1 = {sign}e1, f2 = {sign}e2;   /* the sphere's centre from the capsule's */",
            "            const double s = eomc_fmin(eomc_fmax(f0 * xc[0] + f1 * xc[1] + f2 * xc[2], -l), l);",
            "            const double u0 = f0 - s * xc[0], u1 = f1 - s * xc[1], u2 = f2 - s * xc[2];",
            "            if (u0 * u0 + u1 * u1 + u2 * u2 > D[2] * D[2]) continue;"]
    test = f"!full || full == {DEPTHS}" if depths else "!full"
    return [f"        if ({test}) {{   /* the segments apart past the radii and margin (SEGMENT_BOUND): skip */",
            *body, "        }"]


def _ball_lines():
    """C: the pair's bounding-ball test (its shapes' centres placed)."""
    return ["        const double *ca = cen + 3 * P[0], *cb = cen + 3 * P[1];",
            "        const double e0 = cb[0] - ca[0], e1 = cb[1] - ca[1], e2 = cb[2] - ca[2];",
            "        if (!full && e0 * e0 + e1 * e1 + e2 * e2 > D[1]) continue;"]


def _far_bounds(t, npts):
    """The primal loop's broad phase (after :func:`_ball_lines`' first two): a pair whose centres
    are further apart than its reach is skipped; with full = 2 its points get the bounds of the
    module docstring."""
    from .pairs import BROAD_PAD
    pad = _fmt(BROAD_PAD)
    return ["        const double dd = e0 * e0 + e1 * e1 + e2 * e2;",
            "        if (full != 1 && dd > D[1]) {",
            "            if (full == 2) {",
            f"                const double gap = eomc_fmax(sqrt(dd) - sqrt(D[1]) + {pad}, {pad});",
            f"                for (m = 0; m < {npts}; ++m) {{",
            f"                    double *po = out + {t.nwrench} + {POINT_OUTPUTS} * (P[3] + m);",
            "                    po[4] = -gap;",
            "                    po[5] = gap;",
            "                    for (k = 0; k < 3; ++k) po[6 + k] = 0.5 * (ca[k] + cb[k]);",
            "                }",
            "            }",
            "            continue;",
            "        }"]


def _centre_lines(s, off, dot):
    """C: shape ``s``'s centre (of body b; ``dot``: and its tangent) in the world."""
    L = [f"        const double *o = in + {off} + 3 * {s};",
         f"        if (b < 0) {{ for (k = 0; k < 3; ++k) cen[3 * {s} + k] = o[k]; }}",
         "        else for (k = 0; k < 3; ++k)",
         f"            cen[3 * {s} + k] = in[18 * b + k] + in[18 * b + 3 + k] * o[0] + in[18 * b + 6 + k] * o[1]"
         " + in[18 * b + 9 + k] * o[2];"]
    if dot:
        L += [f"        const double *d = din + {off} + 3 * {s};",
              f"        if (b < 0) {{ for (k = 0; k < 3; ++k) dcen[3 * {s} + k] = d[k]; }}",
              "        else for (k = 0; k < 3; ++k)",
              f"            dcen[3 * {s} + k] = din[18 * b + k] + din[18 * b + 3 + k] * o[0] + din[18 * b + 6 + k] * o[1]"
              " + din[18 * b + 9 + k] * o[2] + in[18 * b + 3 + k] * d[0] + in[18 * b + 6 + k] * d[1]"
              " + in[18 * b + 9 + k] * d[2];"]
    return L


def _still_lines(off):
    """C, in the tangent loop over a kind's pairs: skip the pair when nothing it reads moves along
    this direction (its bodies' inputs, its shapes' offsets and its law's parameters have zero
    tangents, exactly: a body away from the column's joint); its outputs' tangents are then zero
    (the twin is linear in the tangents).  Why: jac_x's columns of a joint move only the bodies
    it carries (gymnasium's humanoid: a pressed pair reads about half of the 46 columns)."""
    return [
        "        if (!full) {   /* nothing of the pair moves along this direction: zero tangents */",
        "            const int ba = eomc_pairs_sbody[P[0]], bb = eomc_pairs_sbody[P[1]];",
        "            int moves = dpar != 0;",
        f"            for (k = 0; k < 3 && !moves; ++k) moves = din[{off} + 3 * P[0] + k] != 0.0 || din[{off} + 3 * P[1] + k] != 0.0;",
        "            for (k = 0; k < 18 && !moves; ++k)",
        "                moves = (ba >= 0 && din[18 * ba + k] != 0.0) || (bb >= 0 && din[18 * bb + k] != 0.0);",
        "            if (!moves) continue;",
        "        }",
    ]


def _centres(ns, off, dot):
    """C lines placing every shape's centre (``dot``: and its tangent)."""
    return ([f"    for (s = 0; s < {ns}; ++s) {{", "        const int b = eomc_pairs_sbody[s];"]
            + _centre_lines("s", off, dot) + ["    }"])


def _bound_axes(kinds):
    """:func:`_axes`' ``part`` before a kind's segment bound: the capsules' (P[j]'s) axes."""
    return tuple(j for j, k in enumerate(kinds) if k == "capsule")


def _axes(dot, centres=(), part=None):
    """C lines placing a pair's two shapes' axes once (``dot``: and their tangents), after the
    lines ``centres`` (the twin places their centres there too).  ``part`` (the primal loops, a
    kind with a segment bound): a tuple of P's indices, the third row alone (a capsule's axis:
    what the bound reads) of those shapes, have[] 1; "rest": the first two rows too, have[] 2.
    Each entry the same expression either way (the same bits).  Why: of the humanoid's 16 pairs
    a call that pass the ball test 1.5 reach the narrow phase (report-humcall.md: the frames
    ~115 ns of its ~3.9 us NAME_implicit_var)."""
    if part is not None:
        expr = ("ax[9 * sh + 3 * k + w] = b < 0 ? r[3 * w + k] : in[18 * b + 3 + w] * r[k]"
                " + in[18 * b + 6 + w] * r[3 + k] + in[18 * b + 9 + w] * r[6 + k];")
        head = ["            const int sh = P[j], b = eomc_pairs_sbody[sh];",
                "            const double *r = eomc_pairs_srot[sh];"]
        if part == "rest":
            return ["        for (j = 0; j < 2; ++j) {", *head,
                    "            if (have[sh] == 2) continue;",
                    "            for (k = 0; k < (have[sh] ? 2 : 3); ++k) for (w = 0; w < 3; ++w)",
                    f"                {expr}",
                    "            have[sh] = 2;",
                    "        }"]
        if not part:
            return []
        js = f"j = {part[0]}; j < {part[-1] + 1}; ++j"
        return [f"        for ({js}) {{", *head,
                "            if (have[sh]) continue;",
                "            have[sh] = 1;",
                "            k = 2;",
                "            for (w = 0; w < 3; ++w)",
                f"                {expr}",
                "        }"]
    L = ["        for (j = 0; j < 2; ++j) {",
         "            const int sh = P[j], b = eomc_pairs_sbody[sh];",
         "            const double *r = eomc_pairs_srot[sh];",
         "            if (have[sh]) continue;",
         "            have[sh] = 1;",
         *centres,
         "            for (k = 0; k < 3; ++k) for (w = 0; w < 3; ++w)",
         "                ax[9 * sh + 3 * k + w] = b < 0 ? r[3 * w + k] : in[18 * b + 3 + w] * r[k]"
         " + in[18 * b + 6 + w] * r[3 + k] + in[18 * b + 9 + w] * r[6 + k];"]
    if dot:
        L += ["            for (k = 0; k < 3; ++k) for (w = 0; w < 3; ++w)",
              "                dax[9 * sh + 3 * k + w] = b < 0 ? 0.0 : din[18 * b + 3 + w] * r[k]"
              " + din[18 * b + 6 + w] * r[3 + k] + din[18 * b + 9 + w] * r[6 + k];"]
    return L + ["        }"]


def _narrow_args():
    """The C arguments of a pair's narrow routine in the loop: placements, sizes, margin."""
    return ([f"ca[{k}]" for k in range(3)] + [f"ax[9 * P[0] + {k}]" for k in range(9)]
            + [f"cb[{k}]" for k in range(3)] + [f"ax[9 * P[1] + {k}]" for k in range(9)]
            + [f"eomc_pairs_ssize[P[0]][{k}]" for k in range(3)]
            + [f"eomc_pairs_ssize[P[1]][{k}]" for k in range(3)] + ["D[0]"])


def _narrow_dargs():
    return ([f"dcen[3 * P[0] + {k}]" for k in range(3)] + [f"dax[9 * P[0] + {k}]" for k in range(9)]
            + [f"dcen[3 * P[1] + {k}]" for k in range(3)] + [f"dax[9 * P[1] + {k}]" for k in range(9)])


def _law_args(p, a, b, par, spin=None):
    """The law routine's C arguments: the point's p, n, δ, the bodies' inputs, the law's parameters
    (``spin``: then the spinning law routine's 3 more, from that pointer)."""
    return ([f"{p}[{k}]" for k in range(7)] + [f"{a}[{k}]" for k in range(18)]
            + [f"{b}[{k}]" for k in range(18)] + [f"{par}[{k}]" for k in range(4)]
            + ([f"{spin}[{k}]" for k in range(len(nw.SPIN_PARAMS))] if spin else []))


def _spin_lines(t, name, pars, tangent=False):
    """In a spinning table's loops (t.spin), the pair's torsion and rolling parameters: pointer ``name``
    into ``pars`` (the inputs' parameters; its spinning pairs' block) or, for a pair without them, to
    eomc_pairs_nospin (0, 0, 1: no moment).  ``tangent``: ``pars`` is the parameters' tangents (may be
    0), and a pair without them reads zeros (constants)."""
    if not t.spin:
        return []
    at = t.spin_at - t.nstate
    none = "zero" if tangent else "eomc_pairs_nospin"
    guard = "eomc_pairs_spin[P[2]] < 0" + (f" || !{pars}" if tangent else "")
    return [f"            const double *{name} = {guard} ? {none} : {pars} + {at} + 3 * eomc_pairs_spin[P[2]];"]


# --- the reverse sweep (vjp, hvp, hess_id) -------------------------------------------------------

class PairTableBar(nw.Token):
    """PairTableBar(table id, uid, full, *inputs, *output bars): the bars of the loop's inputs (the
    bodies' and offsets', then the law parameters'), into ``PB<uid>_``, by the loop's reverse twin
    ``eomc_pairs_bar``: per pair it skips, it re-runs the pair's narrow and law routines, then their
    ``_bar`` variants (.narrow), and takes the placements' bars back to the bodies."""
    c_token = True
    ARRAY, ROUTINE = "PB", "bar"

    @property
    def table(self):
        return table_of(self.args[0])

    @property
    def nbar(self):
        return self.table.ninput

    def _parts(self):
        t = self.table
        a = self.args[3:]
        n = t.ninput + t.noutput
        return [a[:t.nstate], a[t.nstate:t.ninput], a[t.ninput:t.ninput + t.nwrench], a[t.ninput + t.nwrench:n]], a[n:]

    def c_declaration(self):
        return f"double {self.ARRAY}{int(self.args[1])}_[{self.nbar * (2 if self.ROUTINE == 'bar_dot' else 1)}];"

    def c_routines(self):
        return _bar_routines(self.table, self.ROUTINE == "bar_dot")

    def _ccode(self, printer):
        (state, par, gw, gp), rest = self._parts()
        args = [nw._literal(state, printer), _array(par, printer), str(int(self.args[2])), _optional(gw, printer),
                _optional(gp, printer)]
        if rest:
            t = self.table
            dstate, dpar, dgw, dgp = (rest[:t.nstate], rest[t.nstate:t.ninput], rest[t.ninput:t.ninput + t.nwrench],
                                      rest[t.ninput + t.nwrench:])
            args += [nw._literal(dstate, printer)] + [_optional(x, printer) for x in (dpar, dgw, dgp)]
        return f"eomc_pairs_{self.ROUTINE}({', '.join(args)}, &{self.ARRAY}{int(self.args[1])}_[0])"

    def tangent_call(self, dd, k, uid):
        """The reverse twin's tangent along direction k of ``dd`` (None: zero), its node."""
        primal = self.args[3:]
        d = [dd.d(x, k) for x in primal]
        if all(x.is_Number and x == 0 for x in d):
            return None
        return PairTableBarDot(self.args[0], uid, self.args[2], *primal, *d)


class PairTableBarDot(PairTableBar):
    """PairTableBarDot(table id, uid, full, *inputs, *output bars, *their tangents): the bars and
    their tangents (from index :attr:`nbar`), into ``PE<uid>_``: ``eomc_pairs_bar_dot``."""
    ARRAY, ROUTINE = "PE", "bar_dot"


def _optional(values, printer):
    """C of a read-only array, or 0 when every value is 0 (the loop reads none)."""
    if all(x.is_Number and x == 0 for x in values):
        return "0"
    return nw._literal(values, printer)


def _bar_routines(table, dot):
    """[(key, C text, split)]: the routines the reverse loop (``dot``: its tangent) calls, then it."""
    out = []
    for rid in sorted({p[0] for p in table.pairs}) + [table.law]:
        variants = (["tape", "dot", "bar_dot"] if rid != table.law else [None, "bar_dot"]) if dot else [None, "bar"]
        for var in variants:
            text, split = nw.routine_code(rid, var)
            out.append(((rid, {None: 0, "dot": 1, "tape": 2, "bar": 3, "bar_dot": 4}[var]), text, split))
    out.append(((1000, 0), _tables(table), False))
    out.append(((1000, 5 if dot else 4), _bar_loop(table, dot), False))
    return out


def _bar_loop(t, dot):
    """The loop's reverse twin (``dot``: its tangent, forward over reverse)."""
    ns, nb = len(t.shapes), len(t.bodies)
    off = 18 * nb
    nlaw, nlo = nw.npose(t.law), nw.routine_outputs(t.law)
    law = nw._cname(t.law)
    L = []
    if dot:
        L.append("/* tangent of the body-body pairs' reverse sweep (compiler/contact/table.py): out = the bars of in "
                 "and pars, then their tangents along din, dpar and the bars' tangents dgw, dgp (0: none) */")
        L.append("static double eomc_pairs_bar_dot(const double *in, const double *pars, int full, const double *gw, "
                 "const double *gp, const double *din, const double *dpar, const double *dgw, const double *dgp, "
                 "double *out)\n{")
    else:
        L.append("/* reverse sweep of the body-body pairs' loop (compiler/contact/table.py): out = the bars of in and "
                 "pars from the bars gw of the wrenches and gp of the contact points' outputs (0: none) */")
        L.append("static double eomc_pairs_bar(const double *in, const double *pars, int full, const double *gw, "
                 "const double *gp, double *out)\n{")
    L.append("    static const double zero[18] = {0};")
    L.append(f"    double cen[{3 * ns}], ax[{9 * ns}], gcen[{3 * ns}], gax[{9 * ns}];")
    if dot:
        L.append(f"    double dcen[{3 * ns}], dax[{9 * ns}], dgcen[{3 * ns}], dgax[{9 * ns}];")
        L.append(f"    double *dout = out + {t.ninput};")
    L.append(f"    int have[{ns}] = {{0}};")
    L.append("    int s, q, m, k, w, j;")
    L.append(f"    for (k = 0; k < {t.ninput * (2 if dot else 1)}; ++k) out[k] = 0.0;")
    for g in (["gcen", "gax", "dgcen", "dgax"] if dot else ["gcen", "gax"]):
        L.append(f"    for (k = 0; k < {(3 if 'cen' in g else 9) * ns}; ++k) {g}[k] = 0.0;")
    L += _centres(ns, off, dot)
    for rid in sorted({p[0] for p in t.pairs}):
        name = "%s_%s" % nw.kinds_of(rid)
        count = sum(1 for p in t.pairs if p[0] == rid)
        npts = len(_parts(rid))
        nout = nw.routine_outputs(rid)
        ntape = len(nw.tape_of(rid)) if dot else 0
        L.append(f"    for (q = 0; q < {count}; ++q) {{  /* {name} pairs */")
        L.append(f"        const int *P = eomc_pairs_{name}_i[q];")
        L.append(f"        const double *D = eomc_pairs_{name}_d[q];")
        L.append(f"        double np[{nout + ntape}], gn[{nout}], nb[{nw.NPOSE * (2 if dot else 1)}];")
        if dot:
            L.append(f"        double nd[{nout}], dgn[{nout}];")
        L.append("        const double *ca = cen + 3 * P[0], *cb = cen + 3 * P[1];")
        L.append("        const double e0 = cb[0] - ca[0], e1 = cb[1] - ca[1], e2 = cb[2] - ca[2];")
        L.append("        if (!full && e0 * e0 + e1 * e1 + e2 * e2 > D[1]) continue;")
        L += _axes(dot)
        args = _narrow_args()
        L.append(f"        const double ni[{nw.NINPUT}] = {{{', '.join(args)}}};")
        if dot:
            dargs = _narrow_dargs()
            L.append(f"        const double dni[{nw.NPOSE}] = {{{', '.join(dargs)}}};")
            L.append(f"        eomc_narrow_{name}_tape({', '.join(args)}, np);")
            L.append(f"        eomc_narrow_{name}_dot(&np[{nout}], {', '.join(dargs)}, nd);")
        else:
            L.append(f"        eomc_narrow_{name}({', '.join(args)}, np);")
        L.append(f"        for (k = 0; k < {nout}; ++k) gn[k] = 0.0;")
        if dot:
            L.append(f"        for (k = 0; k < {nout}; ++k) dgn[k] = 0.0;")
        L.append(f"        for (m = 0; m < {npts}; ++m) {{")
        L.append("            const double *pp = np + 7 * m;")
        L.append("            const int ba = eomc_pairs_sbody[P[0]], bb = eomc_pairs_sbody[P[1]];")
        L.append("            const double *A = ba < 0 ? zero : in + 18 * ba, *B = bb < 0 ? zero : in + 18 * bb;")
        L.append("            const double *par = pars + 4 * P[2];")
        L += _spin_lines(t, "sp", "pars")
        L.append(f"            double lg[{nlo}], lb[{nlaw * (2 if dot else 1)}];")
        seeds = [("", "gn", "gw", "gp", "out", 0)] + ([("d", "dgn", "dgw", "dgp", "dout", nlaw)] if dot else [])
        for d, gn, gw, gp, o, at in seeds:     # the bars, then (dot) their tangents
            L.append(f"            const double *{d}go = {gp} ? {gp} + {POINT_OUTPUTS} * (P[3] + m) : zero;")
            L.append(f"            {gn}[7 * m + 6] += {d}go[4];")
            L.append(f"            for (k = 0; k < 3; ++k) {gn}[7 * m + k] += {d}go[6 + k];")
        L.append("            if (!full && -pp[6] > 0) continue;")
        L.append(f"            const double li[{nlaw}] = {{{', '.join(_law_args('pp', 'A', 'B', 'par', t.spin and 'sp'))}}};")
        if dot:
            L.append("            const double *pd = nd + 7 * m;")
            L.append("            const double *dA = ba < 0 ? zero : din + 18 * ba, *dB = bb < 0 ? zero : din + 18 * bb;")
            L.append("            const double *dp = dpar ? dpar + 4 * P[2] : zero;")
            L += _spin_lines(t, "dsp", "dpar", tangent=True)
            L.append(f"            const double dli[{nlaw}] = {{{', '.join(_law_args('pd', 'dA', 'dB', 'dp', t.spin and 'dsp'))}}};")
            L.append(f"            double dlg[{nlo}];")
        for d, gn, gw, gp, o, at in seeds:
            L.append("            for (k = 0; k < 6; ++k) {")
            L.append(f"                {d}lg[k] = {gw} && bb >= 0 ? {gw}[6 * bb + k] : 0.0;")
            L.append(f"                {d}lg[6 + k] = {gw} && ba >= 0 ? {gw}[6 * ba + k] : 0.0;")
            L.append("            }")
            L.append(f"            for (k = 0; k < 4; ++k) {d}lg[12 + k] = {d}go[k];")
            L.append(f"            {d}lg[16] = {d}go[5];")
        if dot:
            L.append(f"            {law}_bar_dot(li, lg, dli, dlg, lb);")
        else:
            L.append(f"            {law}_bar(li, lg, lb);")
        for d, gn, gw, gp, o, at in seeds:
            L.append(f"            for (k = 0; k < 7; ++k) {gn}[7 * m + k] += lb[{at} + k];")
            L.append(f"            if (ba >= 0) for (k = 0; k < 18; ++k) {o}[18 * ba + k] += lb[{at + 7} + k];")
            L.append(f"            if (bb >= 0) for (k = 0; k < 18; ++k) {o}[18 * bb + k] += lb[{at + 25} + k];")
            L.append(f"            for (k = 0; k < 4; ++k) {o}[{t.nstate} + 4 * P[2] + k] += lb[{at + 43} + k];")
            if t.spin:
                L.append(f"            if (eomc_pairs_spin[P[2]] >= 0) for (k = 0; k < 3; ++k) "
                         f"{o}[{t.spin_at} + 3 * eomc_pairs_spin[P[2]] + k] += lb[{at + 47} + k];")
        L.append("        }")
        if dot:
            L.append(f"        eomc_narrow_{name}_bar_dot(ni, gn, dni, dgn, nb);")
        else:
            L.append(f"        eomc_narrow_{name}_bar(ni, gn, nb);")
        for d, at in [("", 0)] + ([("d", nw.NPOSE)] if dot else []):
            L.append("        for (k = 0; k < 3; ++k) {")
            L.append(f"            {d}gcen[3 * P[0] + k] += nb[{at} + k];")
            L.append(f"            {d}gcen[3 * P[1] + k] += nb[{at + 12} + k];")
            L.append("        }")
            L.append("        for (k = 0; k < 9; ++k) {")
            L.append(f"            {d}gax[9 * P[0] + k] += nb[{at + 3} + k];")
            L.append(f"            {d}gax[9 * P[1] + k] += nb[{at + 15} + k];")
            L.append("        }")
        L.append("    }")
    # the placements' bars back to the bodies (cen = o + Rᵀ offset, ax = Rᵀ r, R's rows in in[18 b + 3..11])
    L.append(f"    for (s = 0; s < {ns}; ++s) {{")
    L.append("        const int b = eomc_pairs_sbody[s];")
    L.append(f"        const double *o = in + {off} + 3 * s, *r = eomc_pairs_srot[s];")
    L.append("        const double *gc = gcen + 3 * s, *ga = gax + 9 * s;")
    if dot:
        L.append(f"        const double *d = din + {off} + 3 * s, *dgc = dgcen + 3 * s, *dga = dgax + 9 * s;")
    L.append("        if (b < 0) {")
    L.append(f"            for (k = 0; k < 3; ++k) out[{off} + 3 * s + k] += gc[k];")
    if dot:
        L.append(f"            for (k = 0; k < 3; ++k) dout[{off} + 3 * s + k] += dgc[k];")
    L.append("            continue;")
    L.append("        }")
    L.append("        for (k = 0; k < 3; ++k) {")
    L.append("            out[18 * b + k] += gc[k];")
    if dot:
        L.append("            dout[18 * b + k] += dgc[k];")
    L.append("            for (j = 0; j < 3; ++j) {")
    L.append("                out[18 * b + 3 + 3 * j + k] += gc[k] * o[j];")
    L.append(f"                out[{off} + 3 * s + j] += in[18 * b + 3 + 3 * j + k] * gc[k];")
    if dot:
        L.append("                dout[18 * b + 3 + 3 * j + k] += dgc[k] * o[j] + gc[k] * d[j];")
        L.append(f"                dout[{off} + 3 * s + j] += din[18 * b + 3 + 3 * j + k] * gc[k]"
                 " + in[18 * b + 3 + 3 * j + k] * dgc[k];")
    L.append("                for (w = 0; w < 3; ++w) {")
    L.append("                    out[18 * b + 3 + 3 * j + w] += ga[3 * k + w] * r[3 * j + k];")
    if dot:
        L.append("                    dout[18 * b + 3 + 3 * j + w] += dga[3 * k + w] * r[3 * j + k];")
    L.append("                }")
    L.append("            }")
    L.append("        }")
    L.append("    }")
    L.append("    return 0.0;\n}\n")
    return "\n".join(L)
