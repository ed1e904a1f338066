"""A robot's ground contact points as data: one C loop per model, the law written once (issue 29).

One job: the ground contacts (:class:`.tree.ContactLoad`) of a tree lowered, for the functions that
read their forces and outputs (NAME_rhs, NAME_outputs, NAME_events, and what reads the bodies' loads:
the analytic jac_x's block F, NAME_implicit's forcing, RNEA's inverse dynamics), as *one* call,
:class:`GroundCall`, of a static C function that loops over a static table of the points.

Why: ``eomc simulate ROBOT.urdf --floating-base --ground`` places each link's collision hull
thinned to 32 points (Solo12 544, Go2 608, G1 840), and each point's law was straight-line code of
its own in every function that reads it: NAME_rhs 1.4 MB of C on Solo12, NAME_outputs 1.0 MB,
NAME_events 0.4 MB -- gcc's time grew with the points (benchmarks/results/ground_run.md, sessions
25-26).  Here the code is O(1) in the points: per body its points' offsets (numbers, a static
table; the shift the body's mass centre parameters make is an input per body), per point the index
of its law's parameter set k, c, μ, v_s, r among the distinct sets (one per link under --ground:
its points share its parameters), the sets an input array (p[] itself where they are consecutive
slots).

A body with points on several planes (an MJCF file's floor and tilted walls: dm_control's
quadruped and dog have four walls) is one entry per plane, each in its plane's frame
(:func:`plane_frame`: the entry's origin and world -> body rows are given rotated and shifted so its
plane is z = 0); the loop below is written for z = 0 and its wrench comes out in body components
either way; a point's friction output is turned back into world components outside it.  The slopes
variant's records are world quantities, so it runs only where every plane is z = 0.

The function, per entry (a body, or a body's points on one plane):

1. its broad phase (as the straight-line rhs's guard, :func:`eomc.compiler.tree.contacts.body_guards`,
   with the box its offsets span): the lowest corner of its points' box in the world less its
   largest radius; above the ground (n = z,
   height 0) every point's depth is negative, so its force is ±0 and the body is skipped;
2. per point: the centre d = R off (world, from the body's origin), its depth δ = r - (o_z + d_z);
   a point out of contact (not δ > 0) is skipped (its force is ±0 exactly: δ₊ = 0); else the law of
   :func:`eomc.compiler.contact.law.ground_forces` inline (Hunt-Crossley with δ₊^{3/2} as
   δ₊ sqrt(δ₊), regularised Coulomb friction at the contact point c - r n), its force and moment
   about the body's origin added to the body's (world) sums;
3. the body's sums turned into body components: the wrench the recursion adds to the body's load.

``full`` = 1 (NAME_outputs: users read every point's F_n, friction, depth and the clip's switching
function) skips nothing and writes per point F_n, F_t (3), δ and the clip function after the
wrenches, in :data:`.tree.OUTPUT_KINDS` order then the clip; ``full`` = 2 (NAME_events, which reads
the depths and clips alone) writes only those, with no law (its wrenches are not read).  The
skips are exact (the force is ±0 where they apply), so the loop equals the straight-line law to
rounding (the sums run in another order: tests/compiler/contact/test_ground_table.py states the
bound).

Derivatives: the call has none of its own.  Each output node keeps the straight-line twin it
stands for (its temporary, :data:`_TWINS`): a forward-mode derivative differentiates that twin.
The slopes the analytic jac_x (its block G: per point δ, p, c, the world force, K, C) and
NAME_implicit (per point δ, p, the slip velocity, K, C) read come from the loop too, where every
ground contact of the model is the loop's: ``full`` JAC or IMP, the slopes variant
``eomc_ground_slopes`` -- the same wrenches as ``full`` 0, and per point its record, the law's
K = -∂F/∂p and C = -∂F/∂v (:func:`.law.ground_jacobians` on the plane z = 0) only in touch --
written in place into jac_x's an[] and NAME_implicit's out[] (:func:`ground_into`), and SymPy
forms no point's K and C (compiler/tree/contacts.py).  Why: jac_x's straight-line block G was 2.4
of Solo12's 3.4 MB of C, 28 temporaries and a guard per point (session 28).  A build asking for a
reverse-mode function (vjp, hvp, hess_id), jac_p, jvp, jac_id, a regressor or a lanes
(``_batch``) twin keeps the straight-line law (:func:`wanted`).
"""

import sympy as sm

from . import narrow as nw
from .table import _array, _fmt
from eomc.runtime.errors import ModelError

__all__ = ["GROUND_TABLE", "SLOPES_TABLE", "TABLE_FROM", "wanted", "eligible", "lower_ground_table", "GroundCall",
           "GroundOut", "GroundInto", "ground_into"]

GROUND_TABLE = True      # False: every point's law straight-line, as before session 27 (for A/B)
SLOPES_TABLE = True      # False: the slopes jac_x and NAME_implicit read straight-line, as in session 27 (for A/B)
TABLE_FROM_DEFAULT = 64  # ground points from which the loop is used (fewer: straight-line, as before)
TABLE_FROM = TABLE_FROM_DEFAULT  # the three switches: in the caches' keys when not default (build/reuse.generator_switches)
PER_BODY = 21            # a body's inputs: origin (3), world -> body rows (9), ω (3), v (3), offset shift (3)
PER_POINT = 6            # full outputs per point: F_n, F_t (3), δ, clip
# the slopes variants' records per point (after the outputs, in this order): the analytic jac_x's
# block G (compiler/tree/analytic.GSIZE: δ, p (3), centre (3), world force (3), K (9), C (9)) and
# NAME_implicit's contact entry (compiler/tree/lower.implicit_layout: δ, p (3), slip velocity (3), K, C)
JAC_RECORD, IMP_RECORD = 28, 25
JAC, IMP = 3, 4          # ``full`` of the slopes variants
_KEY = 2000              # the routines' keys (compiler/emit/generate._called_routines sorts them)
_TABLES = {}             # table id -> Table
_TWINS = {}              # (table id, output index) -> the straight-line temporary it stands for

# functions whose build keeps the straight-line law: they differentiate in reverse or by the tangent
# path through the contact forces, or rewrite the code into lanes (compiler/emit/batch.py)
_KEEPS = {"jac_p", "jvp", "jvp_more", "vjp", "hvp", "hess_id", "jac_id", "regressor",
          "rhs_batch", "jac_x_batch", "outputs_batch", "implicit_batch"}


def wanted(functions):
    """Whether a build of ``functions`` may lower its ground points as the loop."""
    return GROUND_TABLE and not (set(functions or ()) & _KEEPS)


FLAT = ((0.0, 0.0, 1.0), 0.0)   # the plane z = 0: the default ground's and --contact's


def plane_of(load):
    """(normal, height) of a point's plane as floats, or None when they are not numbers (or the
    normal is not a unit vector to rounding: the loop's frame needs one)."""
    try:
        n, h = tuple(float(x) for x in load.normal), float(sm.sympify(load.height))
    except (TypeError, ValueError):
        return None
    return (n, h) if abs(sum(x * x for x in n) - 1.0) <= 1e-12 else None


def eligible(load):
    """A point the loop computes: a sphere (no ellipsoid), no torsional or rolling friction, on a
    plane of numbers: z = 0 (the default ground's and --contact's) or any other (an MJCF file's
    tilted walls: dm_control's quadruped and dog have four).  The loop runs in the plane's own
    frame (:func:`plane_frame`)."""
    return (load.shape is None and not any(k in load.params for k in ("mut", "mur"))
            and plane_of(load) is not None)


def plane_frame(plane):
    """The rows (e1, e2, n) of the world -> plane rotation Q of a plane (normal n, height h): a body
    entry of the loop on that plane takes its origin as Q o - h e_z and its world -> body rows as
    B Q^T, so the loop, written for z = 0, computes the plane's depths, forces and wrench (which it
    turns into body components with those rows: the same as in the world).  e1: the world axis
    least along n made orthogonal to it, e2 = n x e1 (as the fixed step's secant friction picks
    them, runtime/c/eomc_fixedstep.c)."""
    n = [float(x) for x in plane[0]]
    m = min(range(3), key=lambda k: (abs(n[k]), k))
    e1 = [(1.0 if k == m else 0.0) - n[m] * n[k] for k in range(3)]
    size = sum(x * x for x in e1) ** 0.5
    e1 = [x / size for x in e1]
    e2 = [n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2], n[0] * e1[1] - n[1] * e1[0]]
    return e1, e2, n


class Table:
    """Per body (tree index, in input order) its points [(contact index, offset numbers (3), its law's
    parameter set)]."""

    def __init__(self, bodies, points):
        self.bodies = bodies            # tree body indices
        self.points = points            # per body: tuple of (contact index, (ox, oy, oz))
        self.npoints = sum(len(p) for p in points)
        self.nwrench = 6 * len(bodies)
        self.noutput = self.nwrench + PER_POINT * self.npoints
        self.ninput = PER_BODY * len(bodies)
        self.jac_base = self.noutput                                   # GroundOut indices of the records
        self.imp_base = self.jac_base + JAC_RECORD * self.npoints
        self.nindex = self.imp_base + IMP_RECORD * self.npoints

    def record(self, k):
        """(the slopes variant, the record size, the index in its records) of GroundOut index k,
        or None for a wrench or an output."""
        if k >= self.imp_base:
            return IMP, IMP_RECORD, k - self.imp_base
        if k >= self.jac_base:
            return JAC, JAC_RECORD, k - self.jac_base
        return None

    def key(self):
        return (tuple(self.bodies), tuple(self.points))

    def place(self):
        """{contact index: its point's place in the table (0 ..)}."""
        out, j = {}, 0
        for pts in self.points:
            for index, *_ in pts:
                out[index] = j
                j += 1
        return out


def table_of(tid):
    return _TABLES[int(tid)]


def _split(e):
    """(number, rest) of an offset component: number + rest, rest free of numbers (a mass centre
    parameter's -cx_<body>, or 0)."""
    e = sm.sympify(e)
    if e.is_Number:
        return float(e), sm.S.Zero
    if isinstance(e, sm.Add):
        nums = [a for a in e.args if a.is_Number]
        if len(nums) <= 1:
            rest = sm.Add(*[a for a in e.args if not a.is_Number])
            return (float(nums[0]) if nums else 0.0), rest
    return 0.0, e


def _dot(coeffs, xs):
    """sum(c x) over the numbers ``coeffs`` (a plane frame's) with its zero terms left out."""
    return sm.Add(*[x if c == 1.0 else c * x for c, x in zip(coeffs, xs) if c != 0.0])


def gather(loads, rename):
    """(entries, points, shifts, params) of the table of ``loads`` [(contact index, load)]: its
    entries (tree body, plane) in order of their first point (a body's points on one plane: the
    plane z = 0's alone on a robot on the ground, one entry per body as before), per entry its
    points (contact index, offset numbers, its law's parameter set), per entry the shift of its
    offsets, the distinct parameter sets flat (k, c, μ, v_s, r each); None when a body's offsets do
    not split into numbers plus one shift."""
    by_body = {}
    for index, load in loads:
        by_body.setdefault((load.body, plane_of(load)), []).append((index, load))
    gathered, points, shifts, params, sets = [], [], [], [], {}
    for i, group in by_body.items():
        shift, pts = None, []
        for index, load in group:
            what = f"contact {load.name}"
            parts = [_split(rename(x, what)) for x in load.offset]
            rest = tuple(r for _, r in parts)
            if shift is None:
                shift = rest
            elif rest != shift:
                return None
            law = tuple(rename(load.params[k], what) for k in ("k", "c", "mu", "vs", "r"))
            if law not in sets:         # a link's points share its k, c, mu, vs (one set per link)
                sets[law] = len(sets)
                params += law
            pts.append((index, tuple(n for n, _ in parts), sets[law]))
        gathered.append(i)
        points.append(tuple(pts))
        shifts.append(shift)
    return gathered, points, shifts, params


def lower_ground_table(loads, bodies, rec, v, rename, poses, twins, gathered=None):
    """Lower the ContactLoads ``loads`` [(contact index, load)] as one :class:`GroundCall`: add the
    wrenches to the bodies' fext; return {(contact index, kind): output node} for the kinds
    F_n, F_t (3), δ (0..4) and the clip (5), and {(contact index, "jac"): its JAC_RECORD record
    nodes, (contact index, "imp"): its IMP_RECORD} (the slopes variants'; read only where a
    function reads the slopes).  ``twins``: {(contact index, kind): the straight-line
    temporary} (kinds 0..5) and {("wrench", body, k): its straight-line sum} for the forward
    mode.  ``gathered``: :func:`gather`'s (made here when None).  None when the offsets do not
    split into numbers and one shift per body (then the caller keeps the straight-line law)."""
    gathered = gather(loads, rename) if gathered is None else gathered
    if gathered is None:
        return None
    gathered, points, shifts, params = gathered
    inputs, frames = [], {}
    for (i, plane), shift in zip(gathered, shifts):
        R = poses.world_to_body(i)
        o = list(poses.origin(i))
        if plane != FLAT:       # the loop in the plane's frame (plane_frame): o' = Q o - h e_z, B Q^T
            Q = frames[plane] = plane_frame(plane)
            o = [_dot(row, o) for row in Q]
            o[2] = o[2] - plane[1]
            R = [[_dot(axis, row) for axis in Q] for row in R]
        inputs += o + [x for row in R for x in row] + list(v[i][:3]) + list(v[i][3:]) + list(shift)
    table = Table(tuple(i for i, _ in gathered), tuple(points))
    tid = next((k for k, t in _TABLES.items() if t.key() == table.key()), len(_TABLES))
    _TABLES.setdefault(tid, table)
    call = rec.let(GroundCall(sm.Integer(tid), sm.S.Zero, sm.Integer(len(params)),
                              *[rec.let(x) for x in inputs], *params))
    for j, (i, plane) in enumerate(gathered):
        w = []
        for k in range(6):
            _TWINS[(tid, 6 * j + k)] = twins.get(("wrench", (i, plane), k), sm.S.Zero)
            w.append(rec.let(GroundOut(call, sm.Integer(tid), sm.Integer(6 * j + k))))
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [old[k] + x for k, x in enumerate(w)]
    values, place = {}, table.place()
    rank = {index: k for k, index in enumerate(sorted(index for index, _ in loads))}
    for index, load in loads:
        at = table.nwrench + PER_POINT * place[index]
        Q = frames.get(plane_of(load))
        for kind in range(PER_POINT):
            twin = twins.get((index, kind), sm.S.Zero)
            if Q is not None and kind in (1, 2, 3):     # the loop's friction: plane components
                twin = _dot(Q[kind - 1], [twins.get((index, 1 + k), sm.S.Zero) for k in range(3)])
            _TWINS[(tid, at + kind)] = twin
            values[(index, kind)] = GroundOut(call, sm.Integer(tid), sm.Integer(at + kind))
        if Q is not None:       # the world's friction components: Q^T (the plane's)
            plane_ft = [values[(index, 1 + r)] for r in range(3)]
            for k in range(3):
                values[(index, 1 + k)] = _dot([Q[r][k] for r in range(3)], plane_ft)
        for kind, base, size in (("jac", table.jac_base, JAC_RECORD), ("imp", table.imp_base, IMP_RECORD)):
            at = base + size * rank[index]      # the records in the contacts' order
            values[(index, kind)] = [GroundOut(call, sm.Integer(tid), sm.Integer(at + k)) for k in range(size)]
    return values


class GroundCall(nw.Token):
    """GroundCall(table id, full, nparams, *inputs, *params): the ground points' loop, run once
    (params: the points' distinct law parameter sets k, c, μ, v_s, r);
    its outputs are read by :class:`GroundOut`.  Its own value is a token (the C function's
    return, 0.0).  ``full`` JAC or IMP: the slopes variant (``eomc_ground_slopes``), the wrenches
    as with 0 and per point its record of jac_x's block G or of NAME_implicit's contact entry, into
    ``GS_`` (or in place: :class:`GroundInto`)."""
    c_token = True

    @property
    def table(self):
        return table_of(self.args[0])

    def _full(self):
        return int(self.args[1])

    def c_declaration(self):
        t, full = self.table, self._full()
        if full in (JAC, IMP):
            size = JAC_RECORD if full == JAC else IMP_RECORD
            return f"double GT_[{t.nwrench}], GS_[{size * t.npoints}];"
        return f"double GT_[{t.noutput if full else t.nwrench}];"

    def c_routines(self):
        out = [((_KEY, 0), _tables(self.table), False)]
        if self._full() in (JAC, IMP):
            return out + [((_KEY, 2), _slopes_loop(self.table), False)]
        return out + [((_KEY, 1), _loop(self.table), False)]

    def for_program(self, reads, exact=False):
        """``full`` 1 when the program reads a point's F_n or friction, 2 when it reads only points'
        depths and clips (NAME_events: no law, no wrench), JAC or IMP when it reads the points'
        records of jac_x's block G or NAME_implicit's entries (the slopes variant), else 0
        (GroundOut reads are negative: -1 - index)."""
        t = self.table
        mine = [-1 - k for k in reads if k < 0]
        records = {t.record(k)[0] for k in mine if t.record(k) is not None}
        points = [(k - t.nwrench) % PER_POINT for k in mine if t.nwrench <= k < t.noutput]
        if records:
            if len(records) > 1 or points:
                raise ModelError("a function reads the ground points' slopes for both jac_x and NAME_implicit, "
                                 "or with their outputs")
            full = records.pop()
        elif not points:
            full = 0
        elif all(kind >= 4 for kind in points) and not any(k < t.nwrench for k in mine):
            full = 2
        else:
            full = 1
        return self.func(self.args[0], sm.Integer(full), *self.args[2:])

    def _parts(self, at=3):
        t = self.table
        return self.args[at:at + t.ninput], self.args[at + t.ninput:]

    def _ccode(self, printer):
        ins, pars = self._parts()
        state = ", ".join(printer._print(a) for a in ins)
        t, full = self.table, self._full()
        if full in (JAC, IMP):
            return (f"eomc_ground_slopes((const double[{t.ninput}]){{{state}}}, {_array(pars, printer)}, "
                    f"{int(full == IMP)}, &GT_[0], &GS_[0])")
        return f"eomc_ground((const double[{t.ninput}]){{{state}}}, {_array(pars, printer)}, {full}, &GT_[0])"


class GroundInto(GroundCall):
    """GroundInto(table id, full, nparams, offset, *inputs, *params): the slopes variant writing
    its records in place, into NAME_implicit's ``out`` (IMP) or jac_x's kernel inputs ``an``
    (JAC) from ``offset`` on (:func:`ground_into` makes it where those entries are exactly the
    records, in order).  Why: copied from GS_ entry by entry, the records were 13,600 stores of
    NAME_implicit's C on Solo12 (544 points) and 15,232 of jac_x's."""

    def c_declaration(self):
        return f"double GT_[{self.table.nwrench}];"

    def for_program(self, reads, exact=False):
        return self

    def _parts(self, at=4):
        return super()._parts(at)

    def _ccode(self, printer):
        ins, pars = self._parts()
        t, full = self.table, self._full()
        state = ", ".join(printer._print(a) for a in ins)
        dst = "out" if full == IMP else "an"
        return (f"eomc_ground_slopes((const double[{t.ninput}]){{{state}}}, {_array(pars, printer)}, "
                f"{int(full == IMP)}, &GT_[0], &{dst}[{int(self.args[3])}])")


def ground_into(program, group):
    """(``program`` with its ground slopes call made :class:`GroundInto` when the results (group,
    i) for i from some offset on are exactly the call's records in order, the set of those result
    keys: the caller stores no value for them), else (program, empty set): the records copied from
    GS_, as any other temporaries.  Idempotent (made already: its keys)."""
    done = [e for _, e in program.assignments if isinstance(e, GroundInto)]
    if done:
        e = done[0]
        n = (JAC_RECORD if e._full() == JAC else IMP_RECORD) * e.table.npoints
        return program, {(group, int(e.args[3]) + j) for j in range(n)}
    calls = [(s, e) for s, e in program.assignments if type(e) is GroundCall and e._full() in (JAC, IMP)]
    if len(calls) != 1:
        return program, set()
    sym, call = calls[0]
    t, full = call.table, call._full()
    base, size = (t.jac_base, JAC_RECORD) if full == JAC else (t.imp_base, IMP_RECORD)
    n = size * t.npoints
    res = dict(program.results)

    def at(e):      # the record index of a node of this call, else None
        if isinstance(e, GroundOut) and e.args[0] == sym and base <= int(e.args[2]) < base + n:
            return int(e.args[2]) - base
        return None
    first = [k for k, e in res.items() if k[0] == group and at(e) == 0]
    if len(first) != 1:
        return program, set()
    off = first[0][1]
    keys = {(group, off + j) for j in range(n)}
    if any(at(res.get((group, off + j))) != j for j in range(n)):
        return program, set()
    others = [e for k, e in res.items() if k not in keys] + [e for _, e in program.assignments]
    if any(at(x) is not None for e in others if isinstance(e, sm.Basic) for x in sm.preorder_traversal(e)):
        return program, set()
    into = GroundInto(call.args[0], call.args[1], call.args[2], sm.Integer(off), *call.args[3:])
    return program.with_(assignments=tuple((s, into if s == sym else e) for s, e in program.assignments)), keys


class GroundOut(sm.Function):
    """GroundOut(call, table id, k): output k of the ground points' call (k from the table's
    jac_base on: a slopes variant's record entry, read from GS_)."""
    nargs = 3
    is_real = True

    def _twin(self):
        key = (int(self.args[1]), int(self.args[2]))
        if key not in _TWINS:       # a slopes record: nothing differentiates jac_x's or NAME_implicit's inputs
            raise NotImplementedError("the ground points' slopes records have no derivative")
        return _TWINS[key]

    def _eval_derivative(self, s):
        return sm.diff(self._twin(), s)

    def forward(self, dd, k):
        """The straight-line twin's tangent (the loop has no derivative of its own)."""
        return dd.d(self._twin(), k)

    def tangent_reads(self):
        """The temporaries :meth:`forward` reads (compiler/passes/diff._needed_by): the twin's."""
        key = (int(self.args[1]), int(self.args[2]))
        return set(_TWINS[key].free_symbols) if key in _TWINS else set()

    def read_index(self):
        """-1 - k: below the pairs' table's indices (compiler/emit/generate._variants passes every
        call the same set; GroundCall.for_program reads the negative ones)."""
        return -1 - int(self.args[2])

    def _ccode(self, printer):
        k = int(self.args[2])
        rec = table_of(self.args[1]).record(k)
        if rec is not None:
            return f"GS_[{k - (table_of(self.args[1]).jac_base if rec[0] == JAC else table_of(self.args[1]).imp_base)}]"
        return f"GT_[{k}]"


def _tables(t):
    """The static tables: per body its first point and its box (centre, half sizes) in the body
    frame; per point its offset."""
    first, box, offs = [0], [], []
    for pts in t.points:
        first.append(first[-1] + len(pts))
        o = [p for _, p, _ in pts]
        lo = [min(p[k] for p in o) for k in range(3)]
        hi = [max(p[k] for p in o) for k in range(3)]
        box.append([(lo[k] + hi[k]) / 2 for k in range(3)] + [(hi[k] - lo[k]) / 2 for k in range(3)])
        offs += o
    nb = len(t.points)
    sets = [k for pts in t.points for _, _, k in pts]
    rows = ["/* ground points' tables (compiler/contact/ground_table.py): per body its first point and its "
            "points' box (centre, half sizes; body frame, before the body's shift); per point its offset */",
            f"static const int eomc_ground_first[{nb + 1}] = {{{', '.join(map(str, first))}}};",
            f"static const double eomc_ground_box[{nb}][6] = {{"
            + ", ".join("{" + ", ".join(_fmt(x) for x in b) + "}" for b in box) + "};",
            f"static const double eomc_ground_off[{t.npoints}][3] = {{"
            + ", ".join("{" + ", ".join(_fmt(x) for x in p) + "}" for p in offs) + "};",
            f"static const int eomc_ground_set[{t.npoints}] = {{{', '.join(map(str, sets))}}};"]
    return "\n".join(rows) + "\n"


# C lines both loops write (eomc_ground and eomc_ground_slopes: the same wrenches, skips and sums in the same
# order, so the slopes' loop gives the rhs's bits); inserted into their f-strings as they are.
_BODY = f"""        const double *o = &in[{PER_BODY} * b], *R = o + 3, *w = o + 12, *v = o + 15, *sh = o + 18;
        const int p0 = eomc_ground_first[b], p1 = eomc_ground_first[b + 1];
        double m0 = 0.0, m1 = 0.0, m2 = 0.0, f0 = 0.0, f1 = 0.0, f2 = 0.0;"""
_CLEAR = """        const double *bx = eomc_ground_box[b];
        double rmax = par[5 * eomc_ground_set[p0] + 4];
        for (int j = p0 + 1; j < p1; ++j)
            rmax = fmax(rmax, par[5 * eomc_ground_set[j] + 4]);
        const double clear = o[2] + R[2] * (bx[0] + sh[0]) + R[5] * (bx[1] + sh[1]) + R[8] * (bx[2] + sh[2])
            - (fabs(R[2]) * bx[3] + fabs(R[5]) * bx[4] + fabs(R[8]) * bx[5]) - rmax;"""     # the body's broad phase


def _indent(text, n):
    """``text`` with every line moved right by n spaces (a snippet inside one more C block)."""
    return "\n".join(" " * n + line for line in text.split("\n"))
_RATES = """        const double W0 = R[0] * w[0] + R[3] * w[1] + R[6] * w[2];
        const double W1 = R[1] * w[0] + R[4] * w[1] + R[7] * w[2];
        const double W2 = R[2] * w[0] + R[5] * w[1] + R[8] * w[2];
        const double V0 = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
        const double V1 = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
        const double V2 = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];"""
_POINT = """        for (int j = p0; j < p1; ++j) {
            const double *q = &par[5 * eomc_ground_set[j]];
            const double a0 = eomc_ground_off[j][0] + sh[0], a1 = eomc_ground_off[j][1] + sh[1],
                a2 = eomc_ground_off[j][2] + sh[2];
            const double d2 = R[2] * a0 + R[5] * a1 + R[8] * a2;
            const double r = q[4];
            const double depth = r - (o[2] + d2);"""
_SUMS = """            m0 += d1 * fn - e2 * F1;
            m1 += e2 * F0 - d0 * fn;
            m2 += d0 * F1 - d1 * F0;
            f0 += F0;
            f1 += F1;
            f2 += fn;"""
_WRENCH = """        out[6 * b + 0] = R[0] * m0 + R[1] * m1 + R[2] * m2;
        out[6 * b + 1] = R[3] * m0 + R[4] * m1 + R[5] * m2;
        out[6 * b + 2] = R[6] * m0 + R[7] * m1 + R[8] * m2;
        out[6 * b + 3] = R[0] * f0 + R[1] * f1 + R[2] * f2;
        out[6 * b + 4] = R[3] * f0 + R[4] * f1 + R[5] * f2;
        out[6 * b + 5] = R[6] * f0 + R[7] * f1 + R[8] * f2;"""


def _loop(t):
    nb = len(t.points)
    return f"""/* the ground points' loop (compiler/contact/ground_table.py): per body in[21] = origin, world -> body
   rows, omega, v (body), offset shift; per parameter set par[5] = k, c, mu, vs, r (eomc_ground_set: a point's).  out: per body its wrench
   (moment about the origin, force; body components), then with full per point F_n, F_t (3), depth, clip
   (full 2: depth and clip alone; the wrenches are then not read) */
static double eomc_ground(const double *in, const double *par, int full, double *out)
{{
    for (int b = 0; b < {nb}; ++b) {{
{_BODY}
        if (!full) {{
            /* the body's broad phase: its points' lowest box corner above its largest radius */
{_indent(_CLEAR, 4)}
            if (clear > 0.0) {{
                for (int k = 0; k < 6; ++k)
                    out[6 * b + k] = 0.0;
                continue;
            }}
        }}
        /* omega and the origin's velocity in the world */
{_RATES}
{_POINT}
            if (!(depth > 0.0) && !full)
                continue;       /* out of contact: its force is +-0 */
            double *po = full ? &out[{6 * nb} + {PER_POINT} * j] : 0;
            const double d0 = R[0] * a0 + R[3] * a1 + R[6] * a2;
            const double d1 = R[1] * a0 + R[4] * a1 + R[7] * a2;
            /* the centre's velocity, the contact point's (c - r n) slip */
            const double c0 = V0 + (W1 * d2 - W2 * d1), c1 = V1 + (W2 * d0 - W0 * d2),
                c2 = V2 + (W0 * d1 - W1 * d0);
            const double rate = -c2;
            const double lin = 1.0 + 1.5 * q[1] * rate;
            if (full) {{
                po[4] = depth;
                po[5] = 0.5 * (lin - depth + fabs(lin + depth));
                if (full == 2)
                    continue;   /* depths and clips only (NAME_events) */
            }}
            if (!(depth > 0.0)) {{
                po[0] = po[1] = po[2] = po[3] = 0.0;     /* (full) */
                continue;
            }}
            const double fe = q[0] * (depth * sqrt(depth)) * lin;
            const double fn = 0.5 * (fe + fabs(fe));
            const double t0 = c0 - W1 * r, t1 = c1 + W0 * r;     /* v + omega x (-r n), tangential */
            const double scale = -q[2] * fn / sqrt(t0 * t0 + t1 * t1 + q[3] * q[3]);
            const double F0 = scale * t0, F1 = scale * t1;
            const double e2 = d2 - r;        /* the contact point from the origin */
{_SUMS}
            if (full) {{
                po[0] = fn;
                po[1] = F0;
                po[2] = F1;
                po[3] = 0.0;
            }}
        }}
{_WRENCH}
    }}
    return 0.0;
}}
"""


def _slopes_loop(t):
    """``eomc_ground_slopes``: the loop with full = 0 (the same wrenches, the same skips, the same
    sums in the same order: bit for bit the rhs's), also writing per point its record into ``dst``
    -- ``imp`` 0: jac_x's block G (δ; p, c, the world force, K, C only where δ > 0 or is NaN: the
    kernel reads nothing else of a record out of touch, compiler/tree/analytic._contact_lines),
    ``imp`` 1: NAME_implicit's contact entry (δ, p and the slip velocity at every point: the fixed
    step reads them out of touch too, runtime/c/eomc_fixedstep.c; K and C ±0 out of touch).  K and C
    are :func:`eomc.compiler.contact.law.ground_jacobians` on the plane z = 0 (n = e_z): with
    carry = (-μ v_t/s, 1), K's third column is F_n,δ carry and C = F_n,δ̇ carry e_zᵀ + (μ F_n/s)(P -
    v_t v_tᵀ/s²), F_n,δ and F_n,δ̇ times step(F_n)."""
    nb = len(t.points)
    order = [index for pts in t.points for index, *_ in pts]
    rank = {index: k for k, index in enumerate(sorted(order))}
    return f"""/* the ground points' slopes (compiler/contact/ground_table.py): eomc_ground's wrenches (full 0) and per
   point its record into dst, at its contact's place among the records (eomc_ground_rec): imp 0 jac_x's block G
   (depth, p, centre, world force, K, C; out of touch the depth alone), imp 1 NAME_implicit's contact entry
   (depth, p, slip velocity, K, C; K and C 0 out of touch) */
static const int eomc_ground_rec[{t.npoints}] = {{{', '.join(str(rank[i]) for i in order)}}};
static double eomc_ground_slopes(const double *in, const double *par, int imp, double *out, double *dst)
{{
    for (int b = 0; b < {nb}; ++b) {{
{_BODY}
        /* the body's broad phase (eomc_ground's): clear, no point is in touch */
{_CLEAR}
        const int far = clear > 0.0;
{_RATES}
{_POINT}
            double *g = imp ? dst + {IMP_RECORD} * eomc_ground_rec[j] : dst + {JAC_RECORD} * eomc_ground_rec[j];
            g[0] = depth;
            if (!imp && (far || depth <= 0.0))
                continue;       /* out of touch: jac_x's kernel reads the depth alone */
            const double d0 = R[0] * a0 + R[3] * a1 + R[6] * a2;
            const double d1 = R[1] * a0 + R[4] * a1 + R[7] * a2;
            const double c0 = V0 + (W1 * d2 - W2 * d1), c1 = V1 + (W2 * d0 - W0 * d2),
                c2 = V2 + (W0 * d1 - W1 * d0);
            const double t0 = c0 - W1 * r, t1 = c1 + W0 * r;     /* the slip v + omega x (-r n) */
            g[1] = o[0] + d0;
            g[2] = o[1] + d1;
            g[3] = (o[2] + d2) - r;
            if (imp) {{
                g[4] = t0;
                g[5] = t1;
                g[6] = c2;
                if (far || !(depth > 0.0)) {{
                    for (int k = 7; k < {IMP_RECORD}; ++k)
                        g[k] = 0.0;
                    continue;
                }}
            }} else {{
                g[4] = o[0] + d0;
                g[5] = o[1] + d1;
                g[6] = o[2] + d2;
            }}
            const double rate = -c2;
            const double lin = 1.0 + 1.5 * q[1] * rate;
            const double sq = sqrt(depth);
            const double fe = q[0] * (depth * sq) * lin;
            const double fn = 0.5 * (fe + fabs(fe));
            const double s = sqrt(t0 * t0 + t1 * t1 + q[3] * q[3]);
            const double scale = -q[2] * fn / s;
            const double F0 = scale * t0, F1 = scale * t1;
            const double e2 = d2 - r;
{_SUMS}
            /* K = -dF/dp, C = -dF/dv (law.ground_jacobians with n = e_z) */
            const double on = fn > 0.0 ? 1.0 : 0.0;
            const double kn = 1.5 * q[0] * sq * lin * on, cn = 1.5 * q[1] * q[0] * depth * sq * on;
            const double is = 1.0 / s, gf = -scale, ms = q[2] * is, gs = gf * is * is;
            const double k0 = -ms * t0, k1 = -ms * t1;
            double *K = imp ? g + 7 : g + 10, *C = K + 9;
            if (!imp) {{
                g[7] = F0;
                g[8] = F1;
                g[9] = fn;
            }}
            K[0] = 0.0; K[1] = 0.0; K[2] = kn * k0;
            K[3] = 0.0; K[4] = 0.0; K[5] = kn * k1;
            K[6] = 0.0; K[7] = 0.0; K[8] = kn;
            C[0] = gf - gs * t0 * t0; C[1] = -(gs * t0 * t1); C[2] = cn * k0;
            C[3] = -(gs * t1 * t0); C[4] = gf - gs * t1 * t1; C[5] = cn * k1;
            C[6] = 0.0; C[7] = 0.0; C[8] = cn;
        }}
        if (far) {{      /* as eomc_ground's skip: +0 */
            for (int k = 0; k < 6; ++k)
                out[6 * b + k] = 0.0;
            continue;
        }}
{_WRENCH}
    }}
    return 0.0;
}}
"""
