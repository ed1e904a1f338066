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

The function, per body:

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
stands for (its temporary, :data:`_TWINS`): a forward-mode derivative differentiates that twin,
and the analytic jac_x and NAME_implicit read the straight-line slopes (K, C) under their own broad
phase as before, so only the points in touch evaluate them.  A build asking for a reverse-mode
function (vjp, hvp, hess_id), jac_p, jvp, jac_id, a regressor or a lanes (``_batch``) twin keeps the
straight-line law (:func:`wanted`).
"""

import sympy as sm

from . import narrow as nw
from .table import _array, _fmt

__all__ = ["GROUND_TABLE", "TABLE_FROM", "wanted", "eligible", "lower_ground_table", "GroundCall", "GroundOut"]

GROUND_TABLE = True      # False: every point's law straight-line, as before session 27 (for A/B)
TABLE_FROM = 64          # ground points from which the loop is used (fewer: straight-line, as before)
PER_BODY = 21            # a body's inputs: origin (3), world -> body rows (9), ω (3), v (3), offset shift (3)
PER_POINT = 6            # full outputs per point: F_n, F_t (3), δ, clip
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


def eligible(load):
    """A point the loop computes: a sphere (no ellipsoid), no torsional or rolling friction, on the
    plane z = 0 (the default ground's and --contact's)."""
    return (load.shape is None and not any(k in load.params for k in ("mut", "mur"))
            and tuple(float(x) for x in load.normal) == (0.0, 0.0, 1.0) and sm.sympify(load.height) == 0)


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


def lower_ground_table(loads, bodies, rec, v, rename, poses, twins):
    """Lower the ContactLoads ``loads`` [(contact index, load)] as one :class:`GroundCall`: add the
    wrenches to the bodies' fext; return {(contact index, kind): output node} for the kinds
    F_n, F_t (3), δ (0..4) and the clip (5).  ``twins``: {(contact index, kind): the straight-line
    temporary} (kinds as above) and {("wrench", body, k): its straight-line sum} for the forward
    mode.  None when the offsets do not split into numbers and one shift per body (then the caller
    keeps the straight-line law)."""
    by_body = {}
    for index, load in loads:
        by_body.setdefault(load.body, []).append((index, load))
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
    inputs = []
    for i, shift in zip(gathered, shifts):
        R = poses.world_to_body(i)
        o = poses.origin(i)
        inputs += list(o) + [x for row in R for x in row] + list(v[i][:3]) + list(v[i][3:]) + list(shift)
    table = Table(tuple(gathered), tuple(points))
    tid = next((k for k, t in _TABLES.items() if t.key() == table.key()), len(_TABLES))
    _TABLES.setdefault(tid, table)
    call = rec.let(GroundCall(sm.Integer(tid), sm.S.Zero, sm.Integer(len(params)),
                              *[rec.let(x) for x in inputs], *params))
    for j, i in enumerate(gathered):
        w = []
        for k in range(6):
            _TWINS[(tid, 6 * j + k)] = twins.get(("wrench", i, k), sm.S.Zero)
            w.append(rec.let(GroundOut(call, sm.Integer(tid), sm.Integer(6 * j + k))))
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [old[k] + x for k, x in enumerate(w)]
    values, place = {}, table.place()
    for index, _ in loads:
        at = table.nwrench + PER_POINT * place[index]
        for kind in range(PER_POINT):
            _TWINS[(tid, at + kind)] = twins.get((index, kind), sm.S.Zero)
            values[(index, kind)] = GroundOut(call, sm.Integer(tid), sm.Integer(at + kind))
    return values


class GroundCall(nw.Token):
    """GroundCall(table id, full, nparams, *inputs, *params): the ground points' loop, run once
    (params: the points' distinct law parameter sets k, c, μ, v_s, r);
    its outputs are read by :class:`GroundOut`.  Its own value is a token (the C function's
    return, 0.0)."""
    c_token = True

    @property
    def table(self):
        return table_of(self.args[0])

    def c_declaration(self):
        t = self.table
        return f"double GT_[{t.noutput if int(self.args[1]) else t.nwrench}];"

    def c_routines(self):
        return [((_KEY, 0), _tables(self.table), False), ((_KEY, 1), _loop(self.table), False)]

    def for_program(self, reads, exact=False):
        """``full`` 1 when the program reads a point's F_n or friction, 2 when it reads only points'
        depths and clips (NAME_events: no law, no wrench), else 0 (GroundOut reads are negative:
        -1 - index)."""
        t = self.table
        mine = [-1 - k for k in reads if k < 0]
        points = [(k - t.nwrench) % PER_POINT for k in mine if k >= t.nwrench]
        if not points:
            full = 0
        elif all(kind >= 4 for kind in points) and not any(k < t.nwrench for k in mine):
            full = 2
        else:
            full = 1
        return self.func(self.args[0], sm.Integer(full), *self.args[2:])

    def _ccode(self, printer):
        t = self.table
        ins = self.args[3:3 + t.ninput]
        pars = self.args[3 + t.ninput:]
        state = ", ".join(printer._print(a) for a in ins)
        return f"eomc_ground((const double[{t.ninput}]){{{state}}}, {_array(pars, printer)}, {int(self.args[1])}, &GT_[0])"


class GroundOut(sm.Function):
    """GroundOut(call, table id, k): output k of the ground points' call."""
    nargs = 3
    is_real = True

    def _eval_derivative(self, s):
        return sm.diff(_TWINS[(int(self.args[1]), int(self.args[2]))], s)

    def forward(self, dd, k):
        """The straight-line twin's tangent (the loop has no derivative of its own)."""
        return dd.d(_TWINS[(int(self.args[1]), int(self.args[2]))], k)

    def read_index(self):
        """-1 - k: below the pairs' table's indices (compiler/emit/generate._variants passes every
        call the same set; GroundCall.for_program reads the negative ones)."""
        return -1 - int(self.args[2])

    def _ccode(self, printer):
        return f"GT_[{int(self.args[2])}]"


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


def _loop(t):
    nb = len(t.points)
    return f"""/* the ground points' loop (compiler/contact/ground_table.py): per body in[21] = origin, world -> body
   rows, omega, v (body), offset shift; per parameter set par[5] = k, c, mu, vs, r (eomc_ground_set: a point's).  out: per body its wrench
   (moment about the origin, force; body components), then with full per point F_n, F_t (3), depth, clip
   (full 2: depth and clip alone; the wrenches are then not read) */
static double eomc_ground(const double *in, const double *par, int full, double *out)
{{
    for (int b = 0; b < {nb}; ++b) {{
        const double *o = &in[{PER_BODY} * b], *R = o + 3, *w = o + 12, *v = o + 15, *sh = o + 18;
        const int p0 = eomc_ground_first[b], p1 = eomc_ground_first[b + 1];
        double m0 = 0.0, m1 = 0.0, m2 = 0.0, f0 = 0.0, f1 = 0.0, f2 = 0.0;
        if (!full) {{
            /* the body's broad phase: its points' lowest box corner above its largest radius */
            const double *bx = eomc_ground_box[b];
            double rmax = par[5 * eomc_ground_set[p0] + 4];
            for (int j = p0 + 1; j < p1; ++j)
                rmax = fmax(rmax, par[5 * eomc_ground_set[j] + 4]);
            const double clear = o[2] + R[2] * (bx[0] + sh[0]) + R[5] * (bx[1] + sh[1]) + R[8] * (bx[2] + sh[2])
                - (fabs(R[2]) * bx[3] + fabs(R[5]) * bx[4] + fabs(R[8]) * bx[5]) - rmax;
            if (clear > 0.0) {{
                for (int k = 0; k < 6; ++k)
                    out[6 * b + k] = 0.0;
                continue;
            }}
        }}
        /* omega and the origin's velocity in the world */
        const double W0 = R[0] * w[0] + R[3] * w[1] + R[6] * w[2];
        const double W1 = R[1] * w[0] + R[4] * w[1] + R[7] * w[2];
        const double W2 = R[2] * w[0] + R[5] * w[1] + R[8] * w[2];
        const double V0 = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
        const double V1 = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
        const double V2 = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
        for (int j = p0; j < p1; ++j) {{
            const double *q = &par[5 * eomc_ground_set[j]];
            const double a0 = eomc_ground_off[j][0] + sh[0], a1 = eomc_ground_off[j][1] + sh[1],
                a2 = eomc_ground_off[j][2] + sh[2];
            const double d2 = R[2] * a0 + R[5] * a1 + R[8] * a2;
            const double r = q[4];
            const double depth = r - (o[2] + d2);
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
            m0 += d1 * fn - e2 * F1;
            m1 += e2 * F0 - d0 * fn;
            m2 += d0 * F1 - d1 * F0;
            f0 += F0;
            f1 += F1;
            f2 += fn;
            if (full) {{
                po[0] = fn;
                po[1] = F0;
                po[2] = F1;
                po[3] = 0.0;
            }}
        }}
        out[6 * b + 0] = R[0] * m0 + R[1] * m1 + R[2] * m2;
        out[6 * b + 1] = R[3] * m0 + R[4] * m1 + R[5] * m2;
        out[6 * b + 2] = R[6] * m0 + R[7] * m1 + R[8] * m2;
        out[6 * b + 3] = R[0] * f0 + R[1] * f1 + R[2] * f2;
        out[6 * b + 4] = R[3] * f0 + R[4] * f1 + R[5] * f2;
        out[6 * b + 5] = R[6] * f0 + R[7] * f1 + R[8] * f2;
    }}
    return 0.0;
}}
"""
