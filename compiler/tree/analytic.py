"""Analytic first-order derivatives of RNEA (Carpentier & Mansard, RSS 2018), as C loops.

Why: differentiating RNEA's straight-line trace along every state column (the tangent
path of :mod:`.inverse_derivatives` and :mod:`.derivatives`) costs O(n) work per column,
O(n²) in all, and its unrolled variants O(n²) code.  Carpentier and Mansard's algorithm
works in the world frame, where a joint's motion axis S_j, once placed, is the same for
every body it moves; the derivatives of the joint forces then are short dot products of
per-body 6-vectors over the pairs (joint, joint in its support): O(n·depth) work with
small constants, and -- written as C loops over tree arrays -- O(n) code whatever n is.

What is generated (:func:`kernel_c`): one static function per model, ``NAME_rnea_derivs``,
fed by straight-line code that computes per body its parent-to-body rotation E and
position r, its joints' body-frame axes S, mass and inertia about its mass centre, its
body-frame load, and gravity (the ``anx`` result group, in the program's own slot
symbols, so the usual optimizer shares their sines and cosines); the function places
the bodies in the world, runs the forward pass (velocities v, accelerations a with
gravity as the root's acceleration, ∂v/∂q, ∂a/∂q, ∂a/∂v per joint axis; world inertias
Y and their variation Ẏ + (h ×*)) and the backward pass (composite Y, Ẏ and forces; for
every pair of a joint and one of its support the four entries ∂τ/∂q, ∂τ/∂v both ways).

Coordinates: a one-speed joint's coordinate is its speed's integral (q' = u, checked).
A joint of k speeds (the Euler-angle free joint, a ball, planar, cylindrical joint) has
k coordinates with q' = K(q) u; the algorithm differentiates along the body-frame
perturbation ξ of the joint's placement, the direction its speeds move it, and
δξ = K⁻¹ δq, so ∂τ/∂q = ∂τ/∂ξ · K⁻¹ (K inverted numerically, k ≤ 6, once a call).
A quaternion free or ball joint has one coordinate more than it has speeds: its quaternion's
block of K (4×3, q' = ½ q ⊗ (0, ω)) has no inverse, but the dynamics does not see the
quaternion's length (joint_kinds.quaternion_rotation: R(c q) = R(q)), so ∂τ/∂q · q = 0, and
the block's columns are orthogonal to q: δξ = K⁺ δq with K⁺ = (KᵀK)⁻¹Kᵀ, whose null space is
q's direction, gives ∂τ/∂q = ∂τ/∂ξ · K⁺ (why: every quaternion model's jac_x took the tangent
path, ~2x the Euler build's time in the W-method, benchmarks/results/quaternion_fixedstep.md).

Where it applies (:func:`analytic_plan`): an open tree whose loads are body-frame loads
that do not depend on the state (inputs, parameters, time: motor torques, forces on a
body), or depend on it only through the laws of 1-dof joints (``Tree.joint_torques``: soft
limits, damping, friction of URDF and MJCF joints, a function of the joint's own q and u,
applied on the child about the axis with its reaction on the parent).  Such a pair is the
generalized force e_k·τ_k on the joint's own speed and nothing else, so the kernel takes
the law's value as a constant load (in F) and adds its own derivative, ∂τ_k/∂q_k and
∂τ_k/∂u_k (block L of ``an[]``), to row k (why: without it every URDF robot built with its
limits on -- the default -- differentiated the whole recursion per column, unrolled:
G1's jac_x was 809 kB of C, 2.6x its rhs).  Ground contacts likewise: each contact's
force enters F as a body-fixed load (as the rhs computes it), and the kernel adds what
that misses, per touching contact and pairs of dofs in its body's support, from the law's
slopes K = -∂f/∂p, C = -∂f/∂v_p (block G, :func:`_contact_lines`; why: every model with
ground contacts differentiated the whole recursion per column -- the gymnasium ant's jac_x
33 µs, 20 rhs calls, Solo12's 106 µs; benchmarks/results/contact_jac.md).  A contact clear
of the ground costs a compare there, and jac_x's straight-line part skips its law with the
rhs's broad phase (compiler/emit/guards.py).  Body-body pairs lowered as one table call
(``pairs.PAIR_TABLE``, compiler/contact/table.py): each table body's wrench enters F the same
way, and the kernel adds its components' change along each column: it forms the tangents of the
table's inputs itself and calls the table's forward-mode twin per column of a dof that moves a
body of a pair in contact (:func:`_kernel_pair_lines`), or -- where a shape's offset or a law's
parameter reads the state -- the caller computes them per state column into block W
(:func:`_pair_lines`; why:
the tangent path differentiated the whole recursion per column, and the gymnasium humanoid's
default function set with its self-pairs built in 44 s CPU against 23 s without them, its jac_x
723 kB of C against 265 kB).  An ellipsoid's contact point, its support point, moves on its
body as the body turns: block GM holds that motion per such contact (δc = M ω along a turn ω,
:func:`.contacts.support_motion`) and :func:`_moving_lines` adds what it changes (why: dm_control's
humanoid_CMU, whose hands are ellipsoids, kept the tangent path, a 732 kB jac_x and a ~400 s CPU
default build).  Other state-dependent loads (world-frame forces, a ball joint's damping, inlined
body-body pairs) and trees closed by constraints keep the tangent path.

Checked against central differences and Pinocchio's ``computeRNEADerivatives`` /
``computeABADerivatives`` (tests/compiler/tree/test_analytic_derivatives.py).
"""
import itertools
from dataclasses import dataclass, field

import sympy as sm

__all__ = ["AnalyticPlan", "analytic_plan", "kernel_c", "ANX", "analytic_ops", "finite_lines", "c_table", "world_axis_lines",
           "WORLD_INERTIA_LINES", "world_load_lines", "rd_helpers", "VARIATION_LINES", "tree_tables", "PLACE_FROM_PARENT_LINES", "ARTICULATED_START_LINES", "body_head_lines", "YMUL_LINES", "DOT6_LINE",
           "place_c", "place_call", "IO_FROM_Y_LINES", "SCALAR_MACRO"]

ANX = "anx"      # the result group of the kernel's inputs


@dataclass(frozen=True)
class AnalyticPlan:
    nb: int                 # bodies (fixed-joint bodies included)
    nd: int                 # speeds (dofs), numbered body by body
    par: tuple              # parent body, -1 at the ground
    first: tuple            # first dof of each body
    count: tuple            # dofs of each body
    row: tuple              # speed index of each dof
    qcol: tuple             # the dof's coordinate column (for a k-speed joint: its tangent's, see module doc)
    multi: tuple            # (first dof, k, offset of K in anx) of each k-speed joint
    loads: bool             # some body has a load (the anx block F exists)
    offsets: dict           # anx block -> first index: E, r, S, I, F, g, K, arm
    size: int               # len(anx)
    lam: tuple = ()         # the dof before each dof on its path to the root (-1: none)
    dep: tuple = ()         # the number of dofs before it on that path
    off: tuple = ()         # where its row of M (itself, then its support, nearest first) starts
    solver: str = "ltdl"    # jac_x's M⁻¹: "ltdl" (rows of M over the support) or "aba" (articulated, see solve_tables)
    kblocks: tuple = ()     # per k-speed joint: its K's diagonal blocks ((coordinates), (speeds)), see _blocks
    laws: tuple = ()        # dofs with a joint law, in dof order (their ∂τ/∂q, ∂τ/∂u: anx block L)
    contacts: tuple = ()    # per ground contact (its body, the last dof on the body's path to the root): anx block G
    k2nz: tuple = ()        # per k-speed joint: its coordinates b with a dK/dq_b not identically 0 (hess_id's block K2)
    spat: tuple = ()        # per k-speed joint: its axes' entries (block S), 0 / 1 where identically so, else 2 (hess_id's root dots)
    pairs: tuple = ()       # per body of the pairs' table with a dof on its path: (its index in the table, body, that last dof)
    npair: int = 0          # bodies of the pairs' table (anx block W: their wrench tangents, 6 each, per state column)
    moving: tuple = ()      # per ground contact: where in anx its support point's motion M is (block GM), -1 for none; () when no contact's point moves
    table: int = -1         # the pairs' table id when the kernel forms its inputs' tangents itself (no block W; _kernel_pair_lines)
    # per k-speed joint: all its coordinate columns when they outnumber its speeds (a quaternion's
    # joint: qcol holds only the first k, the kernel's ξ columns), else (): see _quaternion_rows
    kcols: tuple = ()
    # per law of block L named by shape (_NamedSlopes): (its ∂τ/∂q's index in anx, the shape's
    # common subexpressions and slopes in canonical symbols, (canonical symbol, the joint's) pairs):
    # NAME_dyn_inputs prints the laws that print alike as one loop (.law_loop; it reads the joint's symbols)
    law_code: tuple = field(default=(), compare=False, repr=False)

    def dofs(self, b):
        return range(self.first[b], self.first[b] + self.count[b])

    def coordinate_columns(self, e):
        """The state columns of dof ``e``'s coordinates: its qcol, or all of its joint's when
        a quaternion makes them more than its speeds."""
        for (e0, k, _), cols in zip(self.multi, self.kcols):
            if cols and e0 <= e < e0 + k:
                return cols
        return (self.qcol[e],)

    @property
    def nq(self):
        """The coordinates (state columns before the speeds)."""
        return len(self.qcol) + sum(len(cols) - k for (_, k, _), cols in zip(self.multi, self.kcols) if cols)


def analytic_plan(tree, bodies, gravity, layout, rename, contacts=None, let=None, pairs=None, table=None,
                  law_memo=None):
    """(plan, [(("anx", i), expr)]) when the tree qualifies (see the module doc), else (None, []).

    ``contacts``: the ground contacts as lowered (:func:`.contacts.lower_contacts`' "analytic"
    list: body, depth, point, centre, world force, K, C per contact, and an ellipsoid's support
    point's motion M or None: block GM), or None when the tree's
    contacts cannot be planned (then a tree with contacts keeps the tangent path).
    ``let``: a recorder's ``let`` (:class:`.recorder.Recorder`): the joint laws' slopes (block L)
    then come as small expressions of named temporaries, common subexpressions taken once per
    shape of law (:func:`_law_slopes`); without it, as whole expressions (what the law
    Hessians of :mod:`.second_order` differentiate).
    ``pairs``: the body-body pairs' table bodies [(body, wrench)] when the pairs are one table
    call (compiler/contact/table.py; their wrenches in F, their tangents block W, filled per
    column by the caller), else None (then a tree with pairs keeps the tangent path).
    ``table``: that call's table id when the kernel forms the tangents of its inputs itself and
    calls the table's tangent loop per column (:func:`_kernel_pair_lines`; no block W).
    ``law_memo``: :func:`_law_slopes`' memo, shared with the build's other differentiations
    of the same laws (NAME_implicit's, lower._implicit_results)."""
    from ..contact.pairs import PairLoad
    from ..contact.tree import ContactLoad
    if tree.loops is not None:
        return None, []
    nq, nu = len(tree.coordinates), len(tree.speeds)
    xs = set(layout.x)
    speeds = layout.x[nq:nq + nu]
    laws = _joint_laws(tree, layout, rename, xs, speeds, let, law_memo)
    if laws is None:
        return None, []
    lawful = {x for qs, _, _ in laws.values() for x in (qs,)} | {speeds[s] for s in laws}
    for load in tree.loads:
        if isinstance(load, ContactLoad) and contacts is not None:
            continue        # its force is in the body's fext; its slopes are block G
        if isinstance(load, PairLoad) and pairs is not None:
            continue        # in the table's wrenches (fext); their tangents: block W
        if load.frame != "body":
            return None, []
        for e in list(load.moment) + list(load.force) + list(load.offset):
            if rename(e, "a load").free_symbols & xs - lawful:
                return None, []
    kin = [rename(k, "the kinematics") for k in tree.kinematics]
    if len(kin) != nq:
        return None, []
    nb = len(bodies)
    par, first, count, row, qcol, multi, kblocks, kcols = [], [], [], [], [], [], [], []
    E, r, S, I, F, K, arm = [], [], [], [], [], [], []
    lam, dep, last = [], [], {}     # last: body -> its last dof, or its nearest ancestor's
    used = set()
    for b in bodies:
        par.append(b.parent)
        first.append(len(row))
        if b.S is not None:
            dofs = [(b.speed, b.S)]
        elif b.multi:
            dofs = list(b.multi)
        else:
            dofs = []
        count.append(len(dofs))
        if len(dofs) == 1:
            s = dofs[0][0]
            hit = [i for i, k in enumerate(kin) if k == speeds[s]]
            if len(hit) != 1 or hit[0] in used:
                return None, []
            used.add(hit[0])
            qcol.append(hit[0])
        elif dofs:
            mine = {speeds[s] for s, _ in dofs}
            rows = [i for i, k in enumerate(kin) if k.free_symbols & mine]
            quats = _quaternion_rows(tree, rows)
            if len(rows) != len(dofs) + len(quats) or used & set(rows):
                return None, []
            others = set(speeds) - mine
            if any(kin[i].free_symbols & others for i in rows):
                return None, []
            kj = [[sm.diff(kin[i], speeds[s]) for s, _ in dofs] for i in rows]
            blocks = _blocks(kj, quats)
            if any(len(r) != len(c) and r not in quats for r, c in blocks):
                return None, []
            used.update(rows)
            multi.append((len(row), len(dofs), len(K)))
            kblocks.append(blocks)
            for line in kj:
                K += line
            qcol += rows[:len(dofs)]
            kcols.append(tuple(rows) if quats else ())
        before = last.get(b.parent, -1)
        for (s, axis), a in zip(dofs, b.armature):
            lam.append(before)
            dep.append(dep[before] + 1 if before >= 0 else 0)
            before = len(row)
            row.append(s)
            S += list(axis)
            arm.append(a)
        last[len(par) - 1] = before
        E += [b.E[i][j] for i in range(3) for j in range(3)]
        r += list(b.r)
        m = b.I[3][3]
        I += [m] + [b.I[i][j] for i in range(3) for j in range(3)]
        F += list(b.fext) if b.fext is not None else [0] * 6
    if len(used) != nq or len(row) != nu or (pairs and len(layout.x) != nq + nu):
        return None, []     # (block W's columns are the state's: no extra first-order states)
    loads = any(b.fext is not None for b in bodies)
    lawdofs, L = [e for e, s in enumerate(row) if s in laws], []
    if any(layout.x[qcol[e]] != laws[row[e]][0] for e in lawdofs):
        return None, []     # a law's coordinate is not its dof's column
    law_code = []
    for e in lawdofs:       # the plan is sure from here: named slopes are named now
        _, dq, du = laws[row[e]]
        if du is None:
            law_code.append((len(L), dq.named, tuple(dq.back.items())))
        L += list(dq()) if du is None else [dq, du]
    G, ends, GM, moving = [], [], [], []
    from ..contact.ground_table import GroundOut
    for body, depth, point, centre, force, Kc, Cc, *shape in contacts or ():
        if last.get(body, -1) < 0 and not isinstance(depth, GroundOut):
            continue        # on a body no joint moves: no generalized force (the ground loop's records
        ends.append((body, last.get(body, -1)))     # stay, in place: their rows loop over no dof)
        G += [depth, *point, *centre, *force] + [x for M in (Kc, Cc) for row in M for x in row]
        moving.append(-1 if not shape or shape[0] is None else len(GM))
        GM += [x for row in shape[0] for x in row] if shape and shape[0] is not None else []
    blocks = [("E", E), ("r", r), ("S", S), ("I", I)] + ([("F", F)] if loads else []) + [
        ("g", list(gravity)), ("K", K), ("arm", arm)] + ([("L", L)] if L else []) + ([("G", G)] if G else []) + (
        [("GM", GM)] if GM else [])
    offsets, values = {}, []
    for name, vals in blocks:
        offsets[name] = len(values)
        values += vals
    moving = tuple(offsets["GM"] + m if m >= 0 else -1 for m in moving) if GM else ()
    off = [0]
    for d in dep:
        off.append(off[-1] + d + 1)
    pair_ends = tuple((j, b, last[b]) for j, (b, _) in enumerate(pairs or ()) if last.get(b, -1) >= 0)
    size = len(values)
    if pairs and table is None:
        offsets["W"] = size
        size += 6 * len(pairs) * len(layout.x)
    plan = AnalyticPlan(nb, len(row), tuple(par), tuple(first), tuple(count), tuple(row),
                        tuple(qcol), tuple(multi), loads, offsets, size, tuple(lam), tuple(dep),
                        tuple(off), choose_solver(dep), tuple(kblocks), tuple(lawdofs), tuple(ends),
                        pairs=pair_ends, npair=len(pairs or ()), moving=moving,
                        table=-1 if table is None or not pairs else int(table),
                        law_code=tuple((offsets["L"] + i, named, back) for i, named, back in law_code),
                        kcols=tuple(kcols) if any(kcols) else ())
    return plan, [((ANX, i), sm.sympify(v)) for i, v in enumerate(values)]


def _quaternion_rows(tree, rows):
    """The quaternions among a k-speed joint's coordinate ``rows`` (the tree's ``quaternions``:
    each one's w coordinate, x, y, z following), as tuples of their positions in ``rows``."""
    out = []
    for w in getattr(tree, "quaternions", ()):
        if w in rows:
            if not all(w + t in rows for t in range(4)):
                return [()]         # (cannot happen: refused by the caller's count)
            out.append(tuple(rows.index(w + t) for t in range(4)))
    return out


def _blocks(kj, quats=()):
    """The diagonal blocks of a k-speed joint's K (q' = K u; rows coordinates, columns speeds)
    up to a permutation: the connected parts of its structural non-zeros, as ((coordinates),
    (speeds)) pairs, or one block of all when a part is not square -- but for a quaternion's
    4 rows on 3 speeds (``quats``: its rows, :func:`_quaternion_rows`).  Why: a free joint's K is
    a translation block and an angle block, and inverting two 3×3 blocks and applying them
    costs a quarter and a half of the 6×6 (measured: K⁻¹ was 7 % of Go2's jac_x)."""
    nr, k = len(kj), len(kj[0])
    parent = list(range(nr + k))    # union-find over coordinates 0..nr-1 and speeds nr..nr+k-1

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for i in range(nr):
        for j in range(k):
            if kj[i][j] != 0:
                parent[find(i)] = find(nr + j)
    parts = {}
    for n in range(nr + k):
        parts.setdefault(find(n), []).append(n)
    blocks = sorted((tuple(n for n in ns if n < nr), tuple(n - nr for n in ns if n >= nr)) for ns in parts.values())
    if any(len(r) != len(c) and not (r in quats and len(c) == 3) for r, c in blocks):
        return ((tuple(range(nr)), tuple(range(k))),)
    return tuple(blocks)


def _joint_laws(tree, layout, rename, xs, speeds, let=None, memo=None):
    """{speed index: (its coordinate's slot, ∂τ/∂q, ∂τ/∂u)} of the 1-dof joints' laws that
    depend on the state (``Tree.joint_torques``), or None when a law reads another joint's
    state (then its pair of loads is not e_k·τ_k alone in the kernel's terms).  ``let``: see
    :func:`analytic_plan`; ``memo``: :func:`_law_slopes`' (a fresh one when None)."""
    from .joint_laws import ramp
    out, memo = {}, {} if memo is None else memo
    for q, u, tau in getattr(tree, "joint_torques", ()):
        what = f"the law of the joint of speed {u}"
        qs, us = rename(q, what), rename(u, what)
        if qs not in xs or us not in speeds:
            return None
        # |a| as 2 ramp(a) - a before differentiating (SymPy's d|a| divides by |a|; see lower._implicit_results)
        t = sm.sympify(rename(tau, what)).replace(sm.Abs, lambda a: 2 * ramp(a) - a)
        if t.free_symbols & xs - {qs, us}:
            return None
        slopes = _law_slopes(t, qs, us, memo, let)
        if isinstance(slopes, _NamedSlopes):     # (its names are recorded only if the plan is made)
            if not slopes.zero:
                out[speeds.index(us)] = (qs, slopes, None)
            continue
        dq, du = slopes
        if dq != 0 or du != 0:
            out[speeds.index(us)] = (qs, dq, du)
    return out


def _law_slopes(t, qs, us, memo, let=None):
    """(∂t/∂qs, ∂t/∂us), differentiated once per shape of law: the laws of a robot's joints
    differ only in their symbols (each joint's own limits, gains, coordinate and speed), so
    the derivative of the first law of a shape, its symbols renamed back, serves the others.
    Why: SymPy's diff of a limit law (ramps, powers, ~60 operations) costs ~14 ms, and G1's
    29 laws were 0.8 s of its 6-7 s default build.  The renamed-back derivative is the one
    diff returns (the same SymPy expression, checked in tests/compiler/tree/test_analytic_derivatives.py).

    With ``let`` (a recorder's: expr -> its temporary), the pair's common subexpressions are
    found once per shape too (``sympy.cse`` of the shape's pair), and a :class:`_NamedSlopes`
    is returned: called, it names the law's through ``let`` and returns the slopes' names.  Why: the program's CSE over G1's
    58 slopes of ~170 operations each was 0.2 s of its default build, the same search 29 times."""
    syms = sorted(t.free_symbols, key=lambda x: (x != qs, x != us, sm.default_sort_key(x)))
    canon = {x: sm.Symbol(f"_law{k}", **x.assumptions0) for k, x in enumerate(syms)}
    floats = _law_floats(t)
    fcanon = {f: sm.Symbol(f"_lawf{k}", real=True) for k, f in enumerate(floats)}
    shape = t.xreplace({**canon, **fcanon})     # its symbols and coefficients renamed: a law of the same shape gives an equal one
    key = (shape, qs in canon, us in canon)
    hit = memo.get(key)
    if hit is None:
        cq, cu = canon[qs] if qs in canon else sm.Dummy(), canon[us] if us in canon else sm.Dummy()
        hit = memo[key] = (tuple(canon.values()) + tuple(fcanon.values()), sm.diff(shape, cq), sm.diff(shape, cu))
    names, dq, du = hit
    back = dict(zip(names, syms + floats))
    if let is None:
        return dq.xreplace(back), du.xreplace(back)
    named = memo.get((key, "cse"))
    if named is None:
        temps = (sm.Symbol(f"_lawt{k}", real=True) for k in itertools.count())
        named = memo[(key, "cse")] = sm.cse([dq, du], symbols=temps, order="none", list=True)
    return _NamedSlopes(named, back, let, dq == 0 and du == 0)


def _law_floats(t):
    """The law's Float coefficients (a product's numeric factor), in the order a walk of it
    meets them: each joint's own (MJCF's hold term ``(G - 1)·w`` differs per joint), so that
    laws differing only in them have one shape (:func:`_law_slopes`).  Floats elsewhere (a
    Clamp's bounds, exponents) stay numbers; so do ±1 (SymPy treats them specially)."""
    seen = {}
    for node in sm.preorder_traversal(t):
        if isinstance(node, sm.Mul) and isinstance(node.args[0], sm.Float) and abs(node.args[0]) != 1:
            seen.setdefault(node.args[0], None)
    return list(seen)


class _NamedSlopes:
    """One law's slopes, named through ``let`` when called (:func:`_law_slopes`): only once
    its analytic plan is sure, since a name recorded and then not used would still shift the
    numbers of the recorder's later temporaries, and with them SymPy's order of operands."""

    def __init__(self, named, back, let, zero):
        self.named, self.back, self.let, self.zero = named, back, let, zero

    def __call__(self):
        lets, (dq, du) = self.named
        back = dict(self.back)
        for s, e in lets:       # in sympy.cse's order: each reads only the ones before it
            back[s] = self.let(e.xreplace(back))
        return self.let(dq.xreplace(back)), self.let(du.xreplace(back))


ABA_DEPTH = 5     # mean support depth above which jac_x's M⁻¹ runs articulated (measured, see choose_solver)


def choose_solver(dep):
    """jac_x's M⁻¹ product on the 2n state columns: LᵀDL row updates cost 2·Σdepth row
    operations (two sweeps over each dof's support), the articulated solve about ten per dof
    whatever the depth (6-vector messages instead of whole support rows).  Measured jac_x,
    articulated vs LᵀDL (2026-11-28, benchmarks/bench_derivatives.py): cart n = 40 31.8 vs
    63.2 µs, G1 (mean depth 8.7) 22.7 vs 25.5, Go2 (5.5) 7.9 vs 8.0; LᵀDL ahead on Panda
    (3.4 vs 3.6) and the 8-link cart (3.0 vs 3.2), mean depth about 4.  Re-measured with the
    faster pair loop and K's blocks (2026-11-29): Go2 articulated 6.6 vs LᵀDL 7.0 µs.
    Deep trees (mean depth above ABA_DEPTH) go articulated."""
    return "aba" if len(dep) and sum(dep) > ABA_DEPTH * len(dep) else "ltdl"


def solve_tables(lam):
    """Tables of the articulated solve (see :func:`kernel_c`): per dof its backward mode, the
    slot of its 6-row bias message p and of its parent's, its forward mode, the slot of its
    parent's acceleration rows and of its own; and the numbers of slots.  Slots are reused as
    soon as a message has been consumed (a chain needs one of each).

    Backward modes: 0 root without children (u = y), 1 root (u = y - S.p), 2 p handed to the
    parent in place, 3 added to the parent's, 4 a leaf's U u/D starts the parent's, 5 is added
    to it.  Forward modes: 0 root leaf, 1 root with children, 2 leaf, 3 children and the
    parent's rows in place (last child), 4 children, new rows."""
    nd = len(lam)
    kids = [[] for _ in range(nd)]
    for e in range(nd):
        if lam[e] >= 0:
            kids[lam[e]].append(e)

    def taker():
        free, count = [], [0]

        def new():
            if free:
                return free.pop()
            count[0] += 1
            return count[0] - 1
        return free, count, new

    free, pcount, new = taker()
    slot, bm, bi, bo = {}, [0] * nd, [0] * nd, [0] * nd
    for e in reversed(range(nd)):
        fresh = e not in slot
        pin = slot.pop(e, 0)
        lo = lam[e]
        if lo < 0:
            mode, pout = (0 if fresh else 1), 0
        elif lo in slot:
            mode, pout = (5 if fresh else 3), slot[lo]
        elif fresh:
            mode, pout = 4, new()
            slot[lo] = pout
        else:
            mode, pout = 2, pin
            slot[lo] = pin
        if not fresh and mode in (1, 3):
            free.append(pin)
        bm[e], bi[e], bo[e] = mode, pin, pout
    free, acount, new = taker()
    aslot, fm, fi, fo = {}, [0] * nd, [0] * nd, [0] * nd
    for e in range(nd):
        lo, has = lam[e], bool(kids[e])
        last = lo >= 0 and kids[lo][-1] == e
        if lo < 0:
            fin, mode = 0, (1 if has else 0)
            fout = new() if has else 0
        else:
            fin = aslot[lo]
            if not has:
                mode, fout = 2, 0
            elif last:
                mode, fout = 3, fin
            else:
                mode, fout = 4, new()
            if last and not has:
                free.append(fin)
        if has:
            aslot[e] = fout
        fm[e], fi[e], fo[e] = mode, fin, fout
    return bm, bi, bo, fm, fi, fo, max(pcount[0], 1), max(acount[0], 1)


# C shared by the derivative kernel and NAME_dyn (:mod:`.dynamics_kernel`), written once:
# inside a loop over bodies b with parent l >= 0, the body's world rotation Rb and origin pb
# from its parent's and its placement E, r in the parent
PLACE_FROM_PARENT_LINES = [
    "            const double *Rl = R + 9 * l, *pl = P + 3 * l;",
    "            for (i = 0; i < 3; i++) {",
    "                for (j = 0; j < 3; j++)",
    "                    Rb[3 * i + j] = Rl[3 * i] * E[3 * j] + Rl[3 * i + 1] * E[3 * j + 1] + Rl[3 * i + 2] * E[3 * j + 2];",
    "                pb[i] = pl[i] + Rl[3 * i] * r[0] + Rl[3 * i + 1] * r[1] + Rl[3 * i + 2] * r[2];",
    "            }",
]

# the body of out = Y x for a world inertia Y = {m, c = m p, I_O (xx yy zz xy xz yz)}
YMUL_LINES = [
    "    out[0] = y[4] * x[0] + y[7] * x[1] + y[8] * x[2] + y[2] * x[5] - y[3] * x[4];",
    "    out[1] = y[7] * x[0] + y[5] * x[1] + y[9] * x[2] + y[3] * x[3] - y[1] * x[5];",
    "    out[2] = y[8] * x[0] + y[9] * x[1] + y[6] * x[2] + y[1] * x[4] - y[2] * x[3];",
    "    out[3] = y[0] * x[3] - y[2] * x[2] + y[3] * x[1];",
    "    out[4] = y[0] * x[4] - y[3] * x[0] + y[1] * x[2];",
    "    out[5] = y[0] * x[5] - y[1] * x[1] + y[2] * x[0];",
]

# the body of a 6-vector dot product a . b
DOT6_LINE = "    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5];"


def c_table(name, vals):
    """C: a static table of ints (the kernels' tree arrays)."""
    return f"    static const int {name}[{len(vals)}] = {{{', '.join(str(v) for v in vals)}}};"


def tree_tables(plan):
    """C: the tree arrays both kernels walk: parent body, first dof and dof count of each body,
    speed index of each dof."""
    return [c_table("par", plan.par), c_table("d0", plan.first), c_table("nd", plan.count),
            c_table("row", plan.row)]


def world_axis_lines(o):
    """C, inside a loop over bodies b: each dof's motion axis placed in the world, s = (R S_ang,
    R S_lin + p x R S_ang), from the body's world rotation Rb and origin pb (shared by the
    derivative kernel and NAME_dyn, :mod:`.dynamics_kernel`)."""
    return [
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* the axes in the world, v */",
        f"            const double *S = an + {o['S']} + 6 * e;",
        "            double *s = Sw + 6 * e;",
        "            for (i = 0; i < 3; i++) {",
        "                s[i] = Rb[3 * i] * S[0] + Rb[3 * i + 1] * S[1] + Rb[3 * i + 2] * S[2];",
        "                s[i + 3] = Rb[3 * i] * S[3] + Rb[3 * i + 1] * S[4] + Rb[3 * i + 2] * S[5];",
        "            }",
        "            s[3] += pb[1] * s[2] - pb[2] * s[1];",
        "            s[4] += pb[2] * s[0] - pb[0] * s[2];",
        "            s[5] += pb[0] * s[1] - pb[1] * s[0];",
    ]


def body_head_lines(o, a_first):
    """C, opening a loop over bodies b (the derivative kernel and the second-order kernel,
    :mod:`.second_order`): the body's pointers and locals, its world placement from its
    parent's (or the world's), v and a from the parent's (``ab[i] = a_first``), its dofs' axes
    in the world and v += S u."""
    return [
        f"        const double *E = an + 9 * b, *r = an + {o['r']} + 3 * b, *In = an + {o['I']} + 10 * b;",
        "        double *Rb = R + 9 * b, *pb = P + 3 * b, *vb = V + 6 * b, *ab = A + 6 * b;",
        "        double *Yb = Y + 10 * b, *dYb = dY + 12 * b, *fb = F + 6 * b;",
        "        double vl[6], al[6], IR[9], IO[9], C[9], t[6], hm[6], m, pp, vc;",
        "        l = par[b];",
        "        if (l >= 0) {",
        *PLACE_FROM_PARENT_LINES,
        "            for (i = 0; i < 6; i++) {",
        "                vl[i] = V[6 * l + i];",
        "                al[i] = A[6 * l + i];",
        "            }",
        "        } else {",
        "            for (i = 0; i < 3; i++) {",
        "                for (j = 0; j < 3; j++) Rb[3 * i + j] = E[3 * j + i];",
        "                pb[i] = r[i];",
        "                vl[i] = vl[i + 3] = al[i] = 0.0;",
        f"                al[i + 3] = -an[{o['g']} + i];",
        "            }",
        "        }",
        "        for (i = 0; i < 6; i++) {",
        "            vb[i] = vl[i];",
        "            ab[i] = " + a_first,
        "        }",
        *world_axis_lines(o),
        "            for (i = 0; i < 6; i++) vb[i] += s[i] * u[e];",
        "        }",
    ]


# C, inside a loop over bodies b: the body's world inertia Yb = {m, m p, I_O} (shared as above)
WORLD_INERTIA_LINES = [
    "        /* the world inertia about the world origin: {m, c = m p, I_O = R I_c R^T + m (p.p 1 - p p^T)} */",
    "        m = In[0];",
    "        for (i = 0; i < 3; i++)",
    "            for (j = 0; j < 3; j++)",
    "                IR[3 * i + j] = Rb[3 * i] * In[1 + j] + Rb[3 * i + 1] * In[4 + j] + Rb[3 * i + 2] * In[7 + j];",
    "        pp = pb[0] * pb[0] + pb[1] * pb[1] + pb[2] * pb[2];",
    "        for (i = 0; i < 3; i++)",
    "            for (j = 0; j < 3; j++)",
    "                IO[3 * i + j] = IR[3 * i] * Rb[3 * j] + IR[3 * i + 1] * Rb[3 * j + 1] + IR[3 * i + 2] * Rb[3 * j + 2]",
    "                    + m * ((i == j ? pp : 0.0) - pb[i] * pb[j]);",
    "        Yb[0] = m;",
    "        Yb[1] = m * pb[0]; Yb[2] = m * pb[1]; Yb[3] = m * pb[2];",
    "        Yb[4] = IO[0]; Yb[5] = IO[4]; Yb[6] = IO[8];",
    "        Yb[7] = 0.5 * (IO[1] + IO[3]); Yb[8] = 0.5 * (IO[2] + IO[6]); Yb[9] = 0.5 * (IO[5] + IO[7]);",
]


# C, inside a loop over bodies b (one block deeper): the body's own 6x6 inertia IA_b =
# [[I_O, [c]x], [[c]x^T, m 1]] from its world inertia Yb (m = Yb[0]) and I_O (IO, both triangles), where the
# articulated-body factorization starts (the derivative kernel's, and NAME_msolve's,
# :mod:`.input_jacobian`)
ARTICULATED_START_LINES = [
    "            double *Ib = IA + 36 * b;",
    "            for (i = 0; i < 3; i++)",
    "                for (j = 0; j < 3; j++) {",
    "                    Ib[6 * i + j] = IO[3 * i + j];",
    "                    Ib[6 * (i + 3) + j + 3] = i == j ? Yb[0] : 0.0;",
    "                }",
    "            Ib[3] = Ib[18] = 0.0; Ib[4] = Ib[24] = -Yb[3]; Ib[5] = Ib[30] = Yb[2];",
    "            Ib[9] = Ib[19] = Yb[3]; Ib[10] = Ib[25] = 0.0; Ib[11] = Ib[31] = -Yb[1];",
    "            Ib[15] = Ib[20] = -Yb[2]; Ib[16] = Ib[26] = Yb[1]; Ib[17] = Ib[32] = 0.0;",
]


# C, inside a loop over bodies b, after NAME_rd_place: the body's I_O (both triangles) from its
# world inertia Yb, as the placement left it (its diagonal, and the symmetrized off-diagonal pairs)
IO_FROM_Y_LINES = [
    "        IO[0] = Yb[4]; IO[4] = Yb[5]; IO[8] = Yb[6];   /* I_O from Yb (NAME_rd_place), both triangles */",
    "        IO[1] = IO[3] = Yb[7]; IO[2] = IO[6] = Yb[8]; IO[5] = IO[7] = Yb[9];",
]


# gcc's vectorizer on the placement's 3x3 and 6-long loops (SLP and loop vectorization) made it
# slower, and NAME_dyn's passes once the placement left their loop: on G1 NAME_dyn 1.92 -> 2.0-2.2
# us (tau) and 1.63 -> 1.75 (M) with it, 1.77 and 1.55 without (a C harness, core 1).  Without it,
# mass_matrix and forcing run 4 % faster than before the shared placement (benchmarks/results/
# derivative_build.md, session 25).  Not on NAME_rnea_derivs or NAME_msolve: their column loops
# need it (jac_x 1.3x, jac_r 1.3x slower without).  The same bits: vectorizing reassociates nothing.
SCALAR_MACRO = """#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__)
#define EOMC_RD_SCALAR __attribute__((optimize("no-tree-vectorize")))
#else
#define EOMC_RD_SCALAR
#endif"""


def place_c(name, plan):
    """C: ``NAME_rd_place(an, R, P, Sw, Y)``, every body's world rotation R (9 each, world <-
    body rows), origin P (3), its dofs' motion axes in the world Sw (6 each, :func:`world_axis_lines`)
    and its world inertia Y (10, :data:`WORLD_INERTIA_LINES`) from the kernels' inputs ``an[]``:
    one static function that NAME_rnea_derivs, NAME_dyn (:mod:`.dynamics_kernel`) and NAME_msolve
    (:mod:`.input_jacobian`) each call once, first thing.  Why: each of them placed the bodies
    in its own loop, the same C three times over (G1: gcc compiled ~0.1 s of it per copy, on
    the default build's <= 1.5x bar, issue 30).  Its name takes the rd_ prefix so that jac_x_batch's
    lanes retype it with the kernel (compiler/emit/batch.vector_kernels).  The same operations in
    the same order as the copies it replaces: the same bits."""
    nb, o = plan.nb, plan.offsets
    head = (f"static void {name}_rd_place(const double *restrict an, double *restrict R, double *restrict P, "
            "double *restrict Sw, double *restrict Y)")
    return "\n".join([
        *SCALAR_MACRO.split("\n"),
        "",
        f"/* each body's world rotation R, origin P, its dofs' axes in the world Sw and its world inertia Y",
        "   {m, m p, I_O}, from the kernels' inputs an[] (compiler/tree/analytic.py: NAME_rnea_derivs,",
        "   NAME_dyn and NAME_msolve call it) */",
        head + " EOMC_RD_SCALAR;",
        head,
        "{",
        c_table("par", plan.par),
        c_table("d0", plan.first),
        c_table("nd", plan.count),
        "    int b, i, j, e, l;",
        f"    for (b = 0; b < {nb}; b++) {{",
        f"        const double *E = an + 9 * b, *r = an + {o['r']} + 3 * b, *In = an + {o['I']} + 10 * b;",
        "        double *Rb = R + 9 * b, *pb = P + 3 * b, *Yb = Y + 10 * b;",
        "        double IR[9], IO[9], m, pp;",
        "        l = par[b];",
        "        if (l >= 0) {",
        *PLACE_FROM_PARENT_LINES,
        "        } else {",
        "            for (i = 0; i < 3; i++) {",
        "                for (j = 0; j < 3; j++) Rb[3 * i + j] = E[3 * j + i];",
        "                pb[i] = r[i];",
        "            }",
        "        }",
        *world_axis_lines(o),
        "        }",
        *WORLD_INERTIA_LINES,
        "    }",
        "}",
    ])


def place_call(name, ind="    "):
    """C: the call of :func:`place_c` into the caller's arrays R, P, Sw, Y."""
    return f"{ind}{name}_rd_place(an, R, P, Sw, Y);"


def placed_head_lines(o, a_first, place=False):
    """C, opening a loop over bodies b placed by NAME_rd_place (:func:`place_c`): the body's
    pointers and locals, v and a from the parent's (the root's: 0 and gravity as its
    acceleration, ``ab[i] = a_first``), v += S u; ``place``: Rb and pb too (the loads read them)."""
    return [
        "        double *vb = V + 6 * b, *ab = A + 6 * b" + (", *Rb = R + 9 * b, *pb = P + 3 * b;" if place else ";"),
        "        double *Yb = Y + 10 * b, *dYb = dY + 12 * b, *fb = F + 6 * b;",
        "        double vl[6], al[6], IO[9], C[9], t[6], hm[6], vc;",
        "        l = par[b];",
        "        if (l >= 0) {",
        "            for (i = 0; i < 6; i++) {",
        "                vl[i] = V[6 * l + i];",
        "                al[i] = A[6 * l + i];",
        "            }",
        "        } else {",
        "            for (i = 0; i < 3; i++) {",
        "                vl[i] = vl[i + 3] = al[i] = 0.0;",
        f"                al[i + 3] = -an[{o['g']} + i];",
        "            }",
        "        }",
        "        for (i = 0; i < 6; i++) {",
        "            vb[i] = vl[i];",
        "            ab[i] = " + a_first,
        "        }",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* v += S u */",
        "            const double *s = Sw + 6 * e;",
        "            for (i = 0; i < 6; i++) vb[i] += s[i] * u[e];",
        "        }",
    ]


# C, inside a loop over bodies b: the body's inertia variation dY (12 numbers, see
# :func:`kernel_c`) from its world inertia Yb, I_O (IO), velocity vb and momentum hm
# (shared by the first- and second-order kernels, :mod:`.second_order`)
VARIATION_LINES = [
    "        /* dY = v x* Y - Y (v x) + (. x* h) = [[T, 0], [-2 [h_f]x, 0]] (compiler/tree/analytic.py):",
    "           T = C + C^T - c v_l^T - v_l c^T + 2 (v_l . c) 1 - [h_n]x, C's columns w x I_O's */",
    "        for (j = 0; j < 3; j++) {",
    "            const double *aj = IO + 3 * j;   /* I_O symmetric: column j = row j */",
    "            C[j] = vb[1] * aj[2] - vb[2] * aj[1];",
    "            C[3 + j] = vb[2] * aj[0] - vb[0] * aj[2];",
    "            C[6 + j] = vb[0] * aj[1] - vb[1] * aj[0];",
    "        }",
    "        vc = 2.0 * (vb[3] * Yb[1] + vb[4] * Yb[2] + vb[5] * Yb[3]);",
    "        for (i = 0; i < 3; i++)",
    "            for (j = 0; j < 3; j++)",
    "                dYb[3 * i + j] = C[3 * i + j] + C[3 * j + i] - Yb[1 + i] * vb[3 + j] - vb[3 + i] * Yb[1 + j]"
    " + (i == j ? vc : 0.0);",
    "        dYb[1] += hm[2]; dYb[2] -= hm[1]; dYb[3] -= hm[2]; dYb[5] += hm[0]; dYb[6] += hm[1]; dYb[7] -= hm[0];",
    "        dYb[9] = hm[3]; dYb[10] = hm[4]; dYb[11] = hm[5];",
]


def world_load_lines(o, pad=""):
    """C, inside a loop over bodies b: subtract the body's body-frame load (an[] block F, about
    the body origin) from its world force fb, placed by Rb and pb (shared as above; ``pad``
    indents it one block deeper where the caller nests it)."""
    return [pad + x for x in (
        "        {   /* the body-frame load about the body origin, into the world */",
        f"            const double *fe = an + {o['F']} + 6 * b;",
        "            double n[3], f[3];",
        "            for (i = 0; i < 3; i++) {",
        "                n[i] = Rb[3 * i] * fe[0] + Rb[3 * i + 1] * fe[1] + Rb[3 * i + 2] * fe[2];",
        "                f[i] = Rb[3 * i] * fe[3] + Rb[3 * i + 1] * fe[4] + Rb[3 * i + 2] * fe[5];",
        "            }",
        "            fb[0] -= n[0] + pb[1] * f[2] - pb[2] * f[1];",
        "            fb[1] -= n[1] + pb[2] * f[0] - pb[0] * f[2];",
        "            fb[2] -= n[2] + pb[0] * f[1] - pb[1] * f[0];",
        "            fb[3] -= f[0];",
        "            fb[4] -= f[1];",
        "            fb[5] -= f[2];",
        "        }",
    )]


def rd_helpers(name):
    """C: the small spatial-algebra helpers of the derivative kernels (motion and force cross
    products, 6-dot, Y x, dY x, dY^T x), ``NAME_rd_*``; written once per model by whichever
    kernel comes first (:func:`kernel_c`, :mod:`.second_order`)."""
    return [
        f"static inline void {name}_rd_cross(const double *v, const double *m, double *out)",
        "{   /* out = v x m (motion cross product) */",
        "    out[0] = v[1] * m[2] - v[2] * m[1];",
        "    out[1] = v[2] * m[0] - v[0] * m[2];",
        "    out[2] = v[0] * m[1] - v[1] * m[0];",
        "    out[3] = v[1] * m[5] - v[2] * m[4] + v[4] * m[2] - v[5] * m[1];",
        "    out[4] = v[2] * m[3] - v[0] * m[5] + v[5] * m[0] - v[3] * m[2];",
        "    out[5] = v[0] * m[4] - v[1] * m[3] + v[3] * m[1] - v[4] * m[0];",
        "}",
        "",
        f"static inline void {name}_rd_crossf(const double *v, const double *f, double *out)",
        "{   /* out = v x* f (force cross product) */",
        "    out[0] = v[1] * f[2] - v[2] * f[1] + v[4] * f[5] - v[5] * f[4];",
        "    out[1] = v[2] * f[0] - v[0] * f[2] + v[5] * f[3] - v[3] * f[5];",
        "    out[2] = v[0] * f[1] - v[1] * f[0] + v[3] * f[4] - v[4] * f[3];",
        "    out[3] = v[1] * f[5] - v[2] * f[4];",
        "    out[4] = v[2] * f[3] - v[0] * f[5];",
        "    out[5] = v[0] * f[4] - v[1] * f[3];",
        "}",
        "",
        f"static inline double {name}_rd_dot(const double *a, const double *b)",
        "{",
        DOT6_LINE,
        "}",
        "",
        f"static inline double {name}_rd_dot3(const double *a, const double *b)",
        "{   /* the angular halves only: a = dY^T x, whose linear half is zero */",
        "    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];",
        "}",
        "",
        f"static inline void {name}_rd_ymul(const double *y, const double *x, double *out)",
        "{   /* out = Y x, Y = {m, c (= m p), I_O (xx yy zz xy xz yz)}: [I_O x_w + c x x_l; m x_l - c x x_w] */",
        *YMUL_LINES,
        "}",
        "",
        f"static inline void {name}_rd_dmul(const double *d, const double *x, double *out)",
        "{   /* out = dY x, dY = [[T, 0], [-2 [h]x, 0]], d = {T row-major, h} */",
        "    out[0] = d[0] * x[0] + d[1] * x[1] + d[2] * x[2];",
        "    out[1] = d[3] * x[0] + d[4] * x[1] + d[5] * x[2];",
        "    out[2] = d[6] * x[0] + d[7] * x[1] + d[8] * x[2];",
        "    out[3] = 2.0 * (d[11] * x[1] - d[10] * x[2]);",
        "    out[4] = 2.0 * (d[9] * x[2] - d[11] * x[0]);",
        "    out[5] = 2.0 * (d[10] * x[0] - d[9] * x[1]);",
        "}",
        "",
        f"static inline void {name}_rd_dmult(const double *d, const double *x, double *out)",
        "{   /* out = dY^T x = [T^T x_w + 2 h x x_l; 0] */",
        "    out[0] = d[0] * x[0] + d[3] * x[1] + d[6] * x[2] + 2.0 * (d[10] * x[5] - d[11] * x[4]);",
        "    out[1] = d[1] * x[0] + d[4] * x[1] + d[7] * x[2] + 2.0 * (d[11] * x[3] - d[9] * x[5]);",
        "    out[2] = d[2] * x[0] + d[5] * x[1] + d[8] * x[2] + 2.0 * (d[9] * x[4] - d[10] * x[3]);",
        "    out[3] = out[4] = out[5] = 0.0;",
        "}",
        "",
    ]


def finite_lines(name):
    """C: ``NAME_rd_finite(v, n)``, the analytic bodies' finiteness check of their output.
    v * 0 is 0 for a finite v and NaN otherwise; eight sums side by side (gcc -O2 pairs them
    into vectors), where the plain isfinite loop with its early exit ran one compare and
    branch per number: 5 % of Go2's jac_x, 7 % of G1's (perf, 2026-11-29).  On G1's 4900
    numbers 1.65 -> 0.60 us with -O2, 1.70 -> 0.50 with -mavx2 (an array of eight sums: 2.0
    and 0.50; four sums: 1.0 and 1.0).  Same answer: EOMC_NONFINITE exactly when some v[i]
    is not finite."""
    acc = [f"a{k}" for k in range(8)]
    return [
        f"static inline int {name}_rd_finite(const double *v, int n)",
        "{   /* v * 0 is 0 for a finite v, NaN otherwise (compiler/tree/analytic.py) */",
        "    double " + ", ".join(f"{a} = 0.0" for a in acc) + ";",
        "    int i;",
        "    for (i = 0; i + 8 <= n; i += 8) {",
        *[f"        {a} += v[i + {k}] * 0.0;".replace("i + 0", "i") for k, a in enumerate(acc)],
        "    }",
        "    for (; i < n; i++) a0 += v[i] * 0.0;",
        "    return " + " + ".join(acc) + " == 0.0 ? EOMC_OK : EOMC_NONFINITE;",
        "}",
        "",
    ]


def kernel_c(name, plan, nq, solve=False):
    """The C text of ``NAME_rnea_derivs`` (see the module doc) and its small helpers.

    ``NAME_rnea_derivs(an, u, ud, out, stride, row0, sign)`` writes, for every speed i
    and state column k of the coordinates and speeds, ``out[(row0 + i) * stride + k] =
    sign * ∂τ_i/∂x_k`` at the velocities ``u`` and accelerations ``ud`` (per dof, in the
    plan's dof order), zeroing the rest of those rows.

    ``solve`` (jac_x): with ``msolve`` set, those rows are then multiplied by M⁻¹: M from
    the same composite inertias (M_ac = S_aᵀ Yᶜ S_c, the armature on its diagonal), stored
    by rows of a dof and its support (nearest first), factored M = Lᵀ D L in place
    (Featherstone's LTDL, O(n·d²)) and applied to the rows as whole-row updates (O(n·d) row
    operations of nq + nu entries each)."""
    ncol = nq + plan.nd
    msize = plan.off[-1]
    aba = solve and plan.solver == "aba"
    ltdl = solve and not aba
    axpy = _aba_lines(ncol) + _aba_avx2_lines(ncol) if aba else _axpy_lines(ncol)
    nb, nd, o = plan.nb, plan.nd, plan.offsets
    fn = f"{name}_rnea_derivs"
    lines = rd_helpers(name) + finite_lines(name) + ([x.replace("{name}", name) for x in axpy] if solve else []) + [
        f"/* d tau / d(q, u) of RNEA by Carpentier and Mansard's algorithm (compiler/tree/analytic.py):",
        f"   out[(row0 + i) * stride + k] = sign * d tau_i / d x_k for the {nd} speeds i and the",
        "   coordinate and speed columns k, at velocities u and accelerations ud (per dof). */",
        f"static void {fn}(const double *an, const double *u, const double *ud, double *out, "
        "int stride, int row0, double sign, int msolve" + (", const double *pt)" if plan.table >= 0 else ")"),
        "{",
        *tree_tables(plan),
        c_table("qc", plan.qcol),
        c_table("uc", [nq + s for s in plan.row]),
        f"    double R[{9 * nb}], P[{3 * nb}], V[{6 * nb}], A[{6 * nb}], Y[{10 * nb}], dY[{12 * nb}], F[{6 * nb}];",
        f"    double Sw[{6 * nd}], dV[{6 * nd}], dA[{6 * nd}], dAv[{6 * nd}];",
        "    double fa[36], ft[36], fq[36], fv[36];",
        "    int b, i, j, k, e, c, l, a;",
        c_table("lam", plan.lam or (-1,)),
    ] + ([
        c_table("dep", plan.dep),
        c_table("off", plan.off[:-1]),
        f"    double Mc[{msize}];",
    ] if ltdl else []) + (_aba_decls(plan, ncol) if aba else []) + ([] if solve else ["    (void)msolve;"]) + [
        # the rows row0 + row[e] are row0 .. row0 + nd - 1 (row: a permutation of the speeds), one
        # block: one flat loop (was a loop per row through row[]: 3 % of Go2's jac_x, perf)
        f"    for (k = 0; k < {nd} * stride; k++) out[row0 * stride + k] = 0.0;",
        place_call(name),
        f"    for (b = 0; b < {nb}; b++) {{",
        *placed_head_lines(o, "0.0;   /* the bias acceleration c_b first (see below) */" if aba else "al[i];",
                           plan.loads),
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* a, and the axes' derivative terms */",
        "            const double *s = Sw + 6 * e;",
        f"            {name}_rd_cross(vb, s, t);",
        "            for (i = 0; i < 6; i++) {",
        "                ab[i] += " + ("t[i] * u[e];" if aba else "s[i] * ud[e] + t[i] * u[e];"),
        "                dAv[6 * e + i] = t[i];",
        "            }",
        f"            {name}_rd_cross(vl, s, dV + 6 * e);",
    ] + ([
        f"            {name}_rd_cross(vl, dV + 6 * e, dA + 6 * e);",
        "            for (i = 0; i < 6; i++) dAv[6 * e + i] += dV[6 * e + i];",
    ] if aba else [
        f"            {name}_rd_cross(al, s, dA + 6 * e);",
        f"            {name}_rd_cross(vl, dV + 6 * e, t);",
        "            for (i = 0; i < 6; i++) {",
        "                dA[6 * e + i] += t[i];",
        "                dAv[6 * e + i] += dV[6 * e + i];",
        "            }",
    ]) + [
        "        }",
        *IO_FROM_Y_LINES,
    ] + ([
        "        if (msolve) {   /* the body's own 6x6 inertia [[I_O, [c]x], [[c]x^T, m 1]], the articulated start */",
        *ARTICULATED_START_LINES,
        "        }",
    ] if aba else []) + [
        "        /* momentum h, force f = Y a + v x* h - load */",
        f"        {name}_rd_ymul(Yb, vb, hm);",
        f"        {name}_rd_ymul(Yb, ab, fb);" if not aba else "        /* (Y a: added once a is known, below) */",
        f"        {name}_rd_crossf(vb, hm, t);",
        "        for (i = 0; i < 6; i++) fb[i] " + ("= t[i];" if aba else "+= t[i];"),
    ]
    if plan.loads:
        lines += world_load_lines(o)
    lines += [
    ] + (["        if (msolve)",
          "            for (i = 0; i < 6; i++) PA[6 * b + i] = fb[i];   /* the bias force, ABA's start */"] if aba else []) + [
        *VARIATION_LINES,
        "    }",
    ] + (_aba_accelerations(name, plan) if aba else []) + [
        f"    for (b = {nb - 1}; b >= 0; b--) {{",
        "        const double *Yb = Y + 10 * b, *dYb = dY + 12 * b, *fb = F + 6 * b;",
        "        double t[6];",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {",
        "            const int m = 6 * (e - d0[b]);",
        "            const double *s = Sw + 6 * e;",
        f"            {name}_rd_ymul(Yb, s, fa + m);",
        f"            {name}_rd_dmult(dYb, s, ft + m);",
        f"            {name}_rd_dmul(dYb, dV + 6 * e, fq + m);",
        f"            {name}_rd_ymul(Yb, dA + 6 * e, t);",
        "            for (i = 0; i < 6; i++) fq[m + i] += t[i];",
        f"            {name}_rd_dmul(dYb, s, fv + m);",
        f"            {name}_rd_ymul(Yb, dAv + 6 * e, t);",
        "            for (i = 0; i < 6; i++) fv[m + i] += t[i];",
        "        }",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* the joint's own block */",
        "            double *o = out + (row0 + row[e]) * stride;",
        "            for (c = d0[b]; c < d0[b] + nd[b]; c++) {",
        "                const int m = 6 * (c - d0[b]);",
        f"                o[qc[c]] = sign * {name}_rd_dot(Sw + 6 * e, fq + m);",
        f"                o[uc[c]] = sign * {name}_rd_dot(Sw + 6 * e, fv + m);",
    ] + ([
        "                if (msolve && e <= c)",
        f"                    Mc[off[c] + dep[c] - dep[e]] = {name}_rd_dot(Sw + 6 * e, fa + m)"
        f" + (e == c ? an[{o['arm']} + c] : 0.0);",
    ] if ltdl else []) + [
        "            }",
        "        }",
        "        for (c = d0[b]; c < d0[b] + nd[b]; c++) {",
        "            const int m = 6 * (c - d0[b]);",
        f"            {name}_rd_crossf(Sw + 6 * c, fb, t);",
        "            for (i = 0; i < 6; i++) fq[m + i] += t[i];",
        "        }",
        "        for (c = d0[b]; c < d0[b] + nd[b]; c++) {   /* pairs with the joints a of the support */",
        "            const int m = 6 * (c - d0[b]), qcc = qc[c], ucc = uc[c];",
        "            const double *fqc = fq + m, *fvc = fv + m, *fac = fa + m, *ftc = ft + m;",
        "            double *oc = out + (row0 + row[c]) * stride;",
        "            for (a = lam[d0[b]]; a >= 0; a = lam[a]) {",
        "                const double *sa = Sw + 6 * a;",
        "                double *oa = out + (row0 + row[a]) * stride;",
        f"                oa[qcc] = sign * {name}_rd_dot(sa, fqc);",
        f"                oa[ucc] = sign * {name}_rd_dot(sa, fvc);",
        f"                oc[qc[a]] = sign * ({name}_rd_dot(fac, dA + 6 * a) + {name}_rd_dot3(ftc, dV + 6 * a));",
        f"                oc[uc[a]] = sign * ({name}_rd_dot(fac, dAv + 6 * a) + {name}_rd_dot3(ftc, sa));",
    ] + ([
        f"                if (msolve) Mc[off[c] + dep[c] - dep[a]] = {name}_rd_dot(sa, fac);",
    ] if ltdl else []) + [
        "            }",
        "        }",
        "        l = par[b];",
        "        if (l >= 0) {   /* composite inertia, its variation and force */",
        "            for (i = 0; i < 10; i++) Y[10 * l + i] += Yb[i];",
        "            for (i = 0; i < 12; i++) dY[12 * l + i] += dYb[i];",
        "            for (i = 0; i < 6; i++) F[6 * l + i] += fb[i];",
        "        }",
        "    }",
    ]
    if plan.contacts:
        lines += _contact_lines(name, plan)
    if plan.table >= 0:     # along ξ: before a k-speed joint's K⁻¹ below
        lines += _kernel_pair_lines(name, plan)
    for (e0, k, koff), blocks, cols in zip(plan.multi, plan.kblocks, plan.kcols or [()] * len(plan.multi)):
        kb = [len(r) for r, _ in blocks]
        rect = [n for n, (r, c) in enumerate(blocks) if len(r) != len(c)]     # a quaternion's (4 x 3)
        lines += [
            f"    {{   /* a {k}-speed joint: d tau/dq = d tau/d xi K^-1, q' = K u, K in {len(blocks)} diagonal block(s) */"
            if not rect else
            f"    {{   /* a {k}-speed joint with a quaternion: d tau/dq = d tau/d xi K^-1, its quaternion's 4 x 3 block"
            " by K^+ = (K^T K)^-1 K^T (analytic.py) */",
            f"        double Km[{max(kb) ** 2}], x[{k}], " + ("piv, tmp;" if max(kb) > 3 and not rect else "tmp;"),
        ] + (["        int p;"] if max(kb) > 3 and not rect else []) + [f"        double Ki{n}[{kb[n] ** 2}];" for n in range(len(blocks))] + [
            f"        double Kq{n}[{4 * 3}], Gi{n}[9];" for n in rect] + ([
            c_table("kq", cols).replace("    ", "        ", 1)] if cols else []) + [
            c_table(f"kr{n}", r).replace("    ", "        ", 1) for n, (r, _) in enumerate(blocks)] + [
            c_table(f"kc{n}", c).replace("    ", "        ", 1) for n, (_, c) in enumerate(blocks)]
        for n, b in enumerate(kb):
            if n in rect:
                lines += _pseudo_inverse_lines(f"an[{o['K'] + koff} + {k} * kr{n}[i] + kc{n}[j]]", f"Kq{n}", f"Gi{n}", f"Ki{n}")
                continue
            lines += [
                f"        for (i = 0; i < {b}; i++)",
                f"            for (j = 0; j < {b}; j++) Km[{b} * i + j] = an[{o['K'] + koff} + {k} * kr{n}[i] + kc{n}[j]];",
            ] + (_small_inverse_lines(b, f"Ki{n}") if b <= 3 else _ginv_lines(b, f"Ki{n}"))
        lines += [
            f"        for (e = 0; e < {nd}; e++) {{",
            "            double *o = out + (row0 + row[e]) * stride;",
            f"            for (c = 0; c < {k}; c++) x[c] = o[qc[{e0} + c]];",
        ]
        for n, b in enumerate(kb):
            nc = len(blocks[n][1])
            lines += [
                f"            for (c = 0; c < {b}; c++) {{",
                "                tmp = 0.0;",
                f"                for (i = 0; i < {nc}; i++) tmp += x[kc{n}[i]] * Ki{n}[{b} * i + c];",
                f"                o[kq[kr{n}[c]]] = tmp;" if cols else f"                o[qc[{e0} + kr{n}[c]]] = tmp;",
                "            }",
            ]
        lines += ["        }", "    }"]
    if plan.pairs and plan.table < 0:
        lines += _pair_lines(plan, ncol)
    if plan.laws:
        lines += [
            "    {   /* the joint laws: their value is in F (a constant load above), their own derivative here */",
            "    " + c_table("jd", plan.laws),
            f"        for (j = 0; j < {len(plan.laws)}; j++) {{",
            "            double *o = out + (row0 + row[jd[j]]) * stride;",
            f"            o[qc[jd[j]]] -= sign * an[{o['L']} + 2 * j];",
            f"            o[uc[jd[j]]] -= sign * an[{o['L']} + 2 * j + 1];",
            "        }",
            "    }",
        ]
    if aba:
        lines += ["    if (!msolve) return;"] + _aba_dispatch(name, plan.nd, ncol)
    if ltdl:
        lines += [
            "    if (!msolve) return;",
            f"    for (k = {plan.nd - 1}; k >= 0; k--) {{   /* M = L^T D L */",
            "        const double dk = Mc[off[k]];",
            "        for (i = lam[k]; i >= 0; i = lam[i]) {",
            "            const double f = Mc[off[k] + dep[k] - dep[i]] / dk;",
            "            for (j = i; j >= 0; j = lam[j]) Mc[off[i] + dep[i] - dep[j]] -= f * Mc[off[k] + dep[k] - dep[j]];",
            "            Mc[off[k] + dep[k] - dep[i]] = f;",
            "        }",
            "    }",
            f"    for (k = {plan.nd - 1}; k >= 0; k--) {{   /* rows <- L^-T rows */",
            "        for (i = lam[k]; i >= 0; i = lam[i])",
            f"            {name}_rd_axpy(out + (row0 + row[i]) * stride, out + (row0 + row[k]) * stride, "
            "Mc[off[k] + dep[k] - dep[i]]);",
            "    }",
            f"    for (k = 0; k < {plan.nd}; k++) {{   /* D^-1, then L^-1 */",
            "        double *yk = out + (row0 + row[k]) * stride;",
            "        const double f = 1.0 / Mc[off[k]];",
            f"        for (c = 0; c < {ncol}; c++) yk[c] *= f;",
            "    }",
            f"    for (k = 0; k < {plan.nd}; k++) {{",
            "        for (i = lam[k]; i >= 0; i = lam[i])",
            f"            {name}_rd_axpy(out + (row0 + row[k]) * stride, out + (row0 + row[i]) * stride, "
            "Mc[off[k] + dep[k] - dep[i]]);",
            "    }",
        ]
    lines.append("}")
    return "\n".join(lines)


GSIZE = 28     # anx block G per contact: depth, point p (3), centre c (3), world force f (3), K (9), C (9)


def _contact_lines(name, plan):
    """C: the ground contacts' terms the kernel's constant load misses (see the module doc).

    The kernel holds each contact's force as a body-fixed load: a fixed force in the body frame
    at a fixed point of the body.  The law's force f(p, v_p) (world) reads the depth along the
    plane's normal of the sphere's centre c (a point of the body) and the velocity v_p of the
    body's material point at the contact point p = c - r n; K = -∂f/∂p, C = -∂f/∂v_p
    (:func:`~eomc.compiler.contact.law.ground_jacobians`, exact).  Along a joint's perturbation
    ξ_j (world axis s_j = (ω_j, v0_j)) the true change of f is -K δc - C δv_p, with δc = ω_j × c
    + v0_j, δV_b = s_j × V_b + ∂V_b/∂ξ_j's kernel part (dV), δv_p = δω_b × p + δv0_b + ω_b × δc;
    the kernel's body-fixed load turned with the body instead (ω_j × f) and its point moved as a
    point of the body (ω_j × p + v0_j, not δc).  Along a speed u_j: δv_p = J_p,j = ω_j × p + v0_j.
    The generalized force is Q_k = J_p,k · f, τ = ID - Q, so each row k of the body's support
    gets -sign (J_p,k · Δf_j + ω_k · (Δp_j × f)), Δ the true change less the kernel's.
    Out of contact (depth ≤ 0) f, K and C are ±0: the contact costs one compare."""
    o = plan.offsets
    return [
        "    {   /* ground contacts: the law's slopes and the point's motion on its body (analytic.py) */",
        "    " + c_table("cb", [b for b, _ in plan.contacts]),
        "    " + c_table("ce", [e for _, e in plan.contacts]),
    ] + (["    " + c_table("cm", plan.moving)] if plan.moving else []) + [
        f"        double cj[{12 * plan.nd}], fw[{3 * plan.nd}];",
        f"        for (j = 0; j < {len(plan.contacts)}; j++) {{",
        f"            const double *g = an + {o['G']} + {GSIZE} * j;",
        "            const double *p = g + 1, *cc = g + 4, *f = g + 7, *Kc = g + 10, *Cc = g + 19;",
        "            const double *Vb;",
        "            if (!(g[0] > 0.0) && g[0] == g[0]) continue;   /* clear of the ground: all ±0 */",
        "            Vb = V + 6 * cb[j];",
        "            for (a = ce[j]; a >= 0; a = lam[a]) {   /* per dof of the support: dq and du of f, dp */",
        "                const double *s = Sw + 6 * a;",
        "                double *w = cj + 12 * a, jc[3], jp[3], dv[6], dvp[3];",
        "                for (i = 0; i < 3; i++) {",
        "                    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;",
        "                    jc[i] = s[i1] * cc[i2] - s[i2] * cc[i1] + s[3 + i];",
        "                    jp[i] = s[i1] * p[i2] - s[i2] * p[i1] + s[3 + i];",
        "                    w[9 + i] = s[i1] * (cc[i2] - p[i2]) - s[i2] * (cc[i1] - p[i1]);",
        "                    fw[3 * a + i] = f[i1] * s[i2] - f[i2] * s[i1];   /* f x w_a */",
        "                }",
        f"                {name}_rd_cross(s, Vb, dv);",
        "                for (i = 0; i < 6; i++) dv[i] += dV[6 * a + i];",
        "                for (i = 0; i < 3; i++) {",
        "                    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;",
        "                    dvp[i] = dv[i1] * p[i2] - dv[i2] * p[i1] + dv[3 + i] + Vb[i1] * jc[i2] - Vb[i2] * jc[i1];",
        "                }",
        "                for (i = 0; i < 3; i++) {",
        "                    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;",
        "                    w[i] = -(Kc[3 * i] * jc[0] + Kc[3 * i + 1] * jc[1] + Kc[3 * i + 2] * jc[2])",
        "                        - (Cc[3 * i] * dvp[0] + Cc[3 * i + 1] * dvp[1] + Cc[3 * i + 2] * dvp[2])",
        "                        - (s[i1] * f[i2] - s[i2] * f[i1]);",
        "                    w[3 + i] = -(Cc[3 * i] * jp[0] + Cc[3 * i + 1] * jp[1] + Cc[3 * i + 2] * jp[2]);",
        "                    w[6 + i] = jp[i];",
        "                }",
    ] + _moving_lines(plan) + [
        "            }",
        "            for (k = ce[j]; k >= 0; k = lam[k]) {   /* rows: -sign (J_p,k . df_a + w_k . (dp_a x f)) */",
        "                double *ok = out + (row0 + row[k]) * stride;",
        "                const double *jk = cj + 12 * k + 6, *fk = fw + 3 * k;",
        "                for (a = ce[j]; a >= 0; a = lam[a]) {",
        "                    const double *w = cj + 12 * a;",
        "                    ok[qc[a]] -= sign * (jk[0] * w[0] + jk[1] * w[1] + jk[2] * w[2]",
        "                                         + fk[0] * w[9] + fk[1] * w[10] + fk[2] * w[11]);",
        "                    ok[uc[a]] -= sign * (jk[0] * w[3] + jk[1] * w[4] + jk[2] * w[5]);",
        "                }",
        "            }",
        "        }",
        "    }",
    ]


def _moving_lines(plan):
    """C: an ellipsoid's support point's own motion on its body (contacts.support_motion),
    δc = M ω_a, added after w (the change along ξ_a) was formed for a material point: w's law
    part gets -K δc - C (ω_b × δc) (the law's slopes at the point's new place and its slip
    velocity) and the arm w[9..11] gets δc.  Only ξ's columns: the point does not move with u.
    A separate term, emitted only where some contact's point moves, so that every other model's
    C stays as it was."""
    if not plan.moving:
        return []
    return [
        "                if (cm[j] >= 0) {   /* an ellipsoid's support point moves on its body: dc += M w_a */",
        "                    const double *m = an + cm[j];",
        "                    double dc[3];",
        "                    for (i = 0; i < 3; i++) dc[i] = m[3 * i] * s[0] + m[3 * i + 1] * s[1] + m[3 * i + 2] * s[2];",
        "                    for (i = 0; i < 3; i++) {",
        "                        w[i] -= Kc[3 * i] * dc[0] + Kc[3 * i + 1] * dc[1] + Kc[3 * i + 2] * dc[2]",
        "                            + Cc[3 * i] * (Vb[1] * dc[2] - Vb[2] * dc[1]) + Cc[3 * i + 1] * (Vb[2] * dc[0] - Vb[0] * dc[2])",
        "                            + Cc[3 * i + 2] * (Vb[0] * dc[1] - Vb[1] * dc[0]);",
        "                        w[9 + i] += dc[i];",
        "                    }",
        "                }",
    ]


def _pair_lines(plan, ncol):
    """C: the body-body pairs' terms the kernel's constant load misses.

    The kernel holds each table body's pair wrench w (moment about its origin, force; body
    components) as a body-fixed load, so along a state column k it has the change of the
    wrench's placement but not that of its components: Δw_k = ∂w/∂x_k, which the caller
    stores per column in an[] block W (the table's forward-mode twin, compiler/contact/table.py).
    Placed in the world (moment about the world origin), the generalized force of dof a in the
    body's support is Q_a = S_a · Δw, τ = ID - Q: row a, column k gets -sign S_a · Δw_k.  The
    columns are the state's (after a k-speed joint's K⁻¹ above: the tangent is along q)."""
    o, n = plan.offsets, plan.npair
    return [
        "    {   /* body-body pairs: their wrench's change along each column (an[] block W, analytic.py) */",
        *_pair_end_tables(plan),
        f"        for (j = 0; j < {len(plan.pairs)}; j++) {{",
        "            const double *Rb = R + 9 * pbd[j], *ob = P + 3 * pbd[j];",
        f"            for (k = 0; k < {ncol}; k++) {{",
        f"                const double *wb = an + {o['W']} + {6 * n} * k + 6 * pj[j];",
        *_wrench_rows("                ", "k"),
        "            }",
        "        }",
        "    }",
    ]


def _pair_end_tables(plan):
    """C: per table body with a dof on its path, its index in the table, its body, its last dof."""
    return ["    " + c_table("pj", [j for j, _, _ in plan.pairs]),
            "    " + c_table("pbd", [b for _, b, _ in plan.pairs]),
            "    " + c_table("pe", [e for _, _, e in plan.pairs])]


def _wrench_rows(pad, col):
    """C (indented by ``pad``, inside a loop over the table bodies j with Rb, ob their rotation and
    origin): the body's wrench change ``wb`` (body components) placed in the world and taken by
    every dof a of its support into row a, column ``col``: -sign S_a · Δw."""
    return [pad + x for x in (
        "double n[3], f[3], m;",
        "if (wb[0] == 0.0 && wb[1] == 0.0 && wb[2] == 0.0 && wb[3] == 0.0 && wb[4] == 0.0 && wb[5] == 0.0)",
        "    continue;   /* no pair of the body pressed, or none moved along this column */",
        "for (i = 0; i < 3; i++) {",
        "    n[i] = Rb[3 * i] * wb[0] + Rb[3 * i + 1] * wb[1] + Rb[3 * i + 2] * wb[2];",
        "    f[i] = Rb[3 * i] * wb[3] + Rb[3 * i + 1] * wb[4] + Rb[3 * i + 2] * wb[5];",
        "}",
        "n[0] += ob[1] * f[2] - ob[2] * f[1];",
        "n[1] += ob[2] * f[0] - ob[0] * f[2];",
        "n[2] += ob[0] * f[1] - ob[1] * f[0];",
        "for (a = pe[j]; a >= 0; a = lam[a]) {",
        "    const double *s = Sw + 6 * a;",
        "    m = s[0] * n[0] + s[1] * n[1] + s[2] * n[2] + s[3] * f[0] + s[4] * f[1] + s[5] * f[2];",
        f"    out[(row0 + row[a]) * stride + {col}] -= sign * m;",
        "}",
    )]


def _kernel_pair_lines(name, plan):
    """C: the body-body pairs' terms the kernel's constant load misses, their tangents formed here.

    As :func:`_pair_lines`, but the kernel forms the tangents of the table's inputs itself from
    its own placements, velocities and ∂V/∂ξ and calls the table's tangent loop,
    ``eomc_pairs_dot`` (compiler/contact/table.py), with them -- once per column of a dof a on
    the path of a body of a pair in contact at this state (the taped call's flags, read through
    ``pt``; the other columns' tangents are exactly zero, as are the shapes' offsets' and the
    laws' parameters', lower._kernel_table).  Along ξ_a (the world twist s_a = (w, v0)) a body
    below a moves rigidly: its origin o by w × o + v0, each of its axes (a row of the world ->
    body rotation) by w × it, and its world velocity V (at the world origin) by s_a × V + dV_a
    (:func:`kernel_c`'s forward pass), so its body-frame velocity (ω, origin velocity) by R^T
    (t_ω, t_v + t_ω × o) with t = dV_a; along u_a by the same with t = s_a, o and R fixed.
    The columns are the kernel's (ξ), before a k-speed joint's K⁻¹.  Why: block W's per-column
    tangent code was SymPy's per state column, generated for each table body -- most of the
    C and gcc's time of jac_x on dm_control's humanoid_CMU (1002 self-pairs), a quarter of
    jac_x's time on gymnasium's humanoid at rest (session 12, pairjx)."""
    from ..contact.table import table_of
    t = table_of(plan.table)
    nt, nd = len(t.bodies), plan.nd
    last = {j: e for j, _, e in plan.pairs}
    pb = [[t.shapes[sa][0], t.shapes[sb][0]] for _, sa, sb, *_ in t.pairs]
    return [
        "    {   /* body-body pairs: their wrench's change along each column, from the table's tangent loop */",
        *_pair_end_tables(plan),
        "    " + c_table("tbb", t.bodies),
        "    " + c_table("tbe", [last.get(j, -1) for j in range(nt)]),
        f"        static const int pb[{len(pb)}][2] = {{" + ", ".join(f"{{{x}, {y}}}" for x, y in pb) + "};",
        f"        const double *act = pt + {t.ninput};   /* per pair: 0 no point in contact */",
        f"        double din[{t.nstate}], dw[{t.noutput}];",
        f"        unsigned char on[{nd}];",
        "        int kind, g;   /* g: the dof along whose column (a: the support's dofs, _wrench_rows) */",
        f"        for (g = 0; g < {nd}; g++) on[g] = 0;",
        f"        for (j = 0; j < {len(pb)}; j++)   /* the dofs on the paths of the pressed pairs' bodies */",
        "            if (act[j] != 0.0)",
        "                for (k = 0; k < 2; k++)",
        "                    for (g = pb[j][k] < 0 ? -1 : tbe[pb[j][k]]; g >= 0 && !on[g]; g = lam[g]) on[g] = 1;",
        f"        for (k = 0; k < {t.nstate}; k++) din[k] = 0.0;",
        f"        for (g = 0; g < {nd}; g++) {{",
        "            if (!on[g]) continue;",
        "            for (kind = 0; kind < 2; kind++) {   /* along xi_g, then u_g */",
        "                const double *s = Sw + 6 * g, *tv = kind ? s : dV + 6 * g;",
        "                const int col = kind ? uc[g] : qc[g];",
        f"                for (j = 0; j < {nt}; j++) {{   /* the table bodies' inputs' tangents */",
        "                    const double *Rb = R + 9 * tbb[j], *ob = P + 3 * tbb[j];",
        "                    double *d = din + 18 * j, tl[3];",
        "                    for (e = tbe[j]; e >= 0 && e != g; e = lam[e]) {}",
        "                    if (e < 0) {   /* g does not move it */",
        "                        for (i = 0; i < 18; i++) d[i] = 0.0;",
        "                        continue;",
        "                    }",
        "                    for (i = 0; i < 3; i++) {",
        "                        const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;",
        "                        d[i] = kind ? 0.0 : s[i1] * ob[i2] - s[i2] * ob[i1] + s[3 + i];",
        "                        tl[i] = tv[3 + i] + tv[i1] * ob[i2] - tv[i2] * ob[i1];",
        "                        for (c = 0; c < 3; c++)   /* row i of world -> body: the body's axis i, Rb's column i */",
        "                            d[3 + 3 * i + c] = kind ? 0.0"
        " : s[(c + 1) % 3] * Rb[3 * ((c + 2) % 3) + i] - s[(c + 2) % 3] * Rb[3 * ((c + 1) % 3) + i];",
        "                    }",
        "                    for (i = 0; i < 3; i++) {",
        "                        d[12 + i] = Rb[i] * tv[0] + Rb[3 + i] * tv[1] + Rb[6 + i] * tv[2];",
        "                        d[15 + i] = Rb[i] * tl[0] + Rb[3 + i] * tl[1] + Rb[6 + i] * tl[2];",
        "                    }",
        "                }",
        "                eomc_pairs_dot(pt, din, 0, 0, dw);",
        f"                for (j = 0; j < {len(plan.pairs)}; j++) {{",
        "                    const double *Rb = R + 9 * pbd[j], *ob = P + 3 * pbd[j], *wb = dw + 6 * pj[j];",
        *_wrench_rows("                    ", "col"),
        "                }",
        "            }",
        "        }",
        "    }",
    ]


def _ginv_lines(k, ki):
    """``ki`` = Km⁻¹ (k × k, Km overwritten) by Gauss-Jordan with partial pivoting, k a
    constant (gcc unrolls it): the inverse of one diagonal block of a k-speed joint's K."""
    return [
        f"        for (i = 0; i < {k * k}; i++) {ki}[i] = i % {k + 1} == 0 ? 1.0 : 0.0;",
        f"        for (j = 0; j < {k}; j++) {{",
        "            p = j;",
        f"            for (i = j + 1; i < {k}; i++)",
        f"                if (fabs(Km[{k} * i + j]) > fabs(Km[{k} * p + j])) p = i;",
        f"            for (c = 0; c < {k}; c++) {{",
        f"                tmp = Km[{k} * j + c]; Km[{k} * j + c] = Km[{k} * p + c]; Km[{k} * p + c] = tmp;",
        f"                tmp = {ki}[{k} * j + c]; {ki}[{k} * j + c] = {ki}[{k} * p + c]; {ki}[{k} * p + c] = tmp;",
        "            }",
        f"            piv = 1.0 / Km[{k} * j + j];",
        f"            for (c = 0; c < {k}; c++) {{",
        f"                Km[{k} * j + c] *= piv;",
        f"                {ki}[{k} * j + c] *= piv;",
        "            }",
        f"            for (i = 0; i < {k}; i++) {{",
        "                if (i == j) continue;",
        f"                tmp = Km[{k} * i + j];",
        f"                for (c = 0; c < {k}; c++) {{",
        f"                    Km[{k} * i + c] -= tmp * Km[{k} * j + c];",
        f"                    {ki}[{k} * i + c] -= tmp * {ki}[{k} * j + c];",
        "                }",
        "            }",
        "        }",
    ]


def _pseudo_inverse_lines(entry, kq, gi, ki):
    """``ki`` (3 x 4: speeds by coordinates) = K⁺ = (KᵀK)⁻¹Kᵀ of a quaternion's block of K
    (``entry``: its (i, j) entry, i < 4 coordinates, j < 3 speeds, read into ``kq``), through
    KᵀK in Km and its closed-form inverse ``gi`` (:func:`_small_inverse_lines`).  K⁺ K = 1 and
    K⁺ q = 0 (K's columns, ½ q ⊗ e_j, are orthogonal to q): the change of the joint's placement
    along δq, whatever part of δq only rescales the quaternion, which the dynamics does not see."""
    return [
        "        for (i = 0; i < 4; i++)",
        f"            for (j = 0; j < 3; j++) {kq}[3 * i + j] = {entry};",
        "        for (i = 0; i < 3; i++)   /* K^T K */",
        "            for (j = 0; j < 3; j++) {",
        "                tmp = 0.0;",
        f"                for (c = 0; c < 4; c++) tmp += {kq}[3 * c + i] * {kq}[3 * c + j];",
        "                Km[3 * i + j] = tmp;",
        "            }",
    ] + _small_inverse_lines(3, gi) + [
        "        for (i = 0; i < 3; i++)   /* (K^T K)^-1 K^T */",
        "            for (j = 0; j < 4; j++) {",
        "                tmp = 0.0;",
        f"                for (c = 0; c < 3; c++) tmp += {gi}[3 * i + c] * {kq}[3 * j + c];",
        f"                {ki}[4 * i + j] = tmp;",
        "            }",
    ]


def _small_inverse_lines(k, ki):
    """``ki`` = Km⁻¹ for k ≤ 3 in closed form (the adjugate over the determinant), the blocks
    of a free or ball joint's K.  Why not Gauss-Jordan (:func:`_ginv_lines`): unrolled with its
    pivot search and row swaps it was a fifth of gcc's time on the derivative kernel (G1: 0.10
    of 0.46 s), for a 3×3 whose adjugate is 30 multiplies and no branch.  A singular block
    gives an infinite determinant's reciprocal, as a zero pivot did: the output's finiteness
    check reports it."""
    if k == 1:
        return [f"        {ki}[0] = 1.0 / Km[0];"]
    if k == 2:
        return ["        tmp = 1.0 / (Km[0] * Km[3] - Km[1] * Km[2]);",
                f"        {ki}[0] = Km[3] * tmp; {ki}[1] = -Km[1] * tmp; {ki}[2] = -Km[2] * tmp; {ki}[3] = Km[0] * tmp;"]
    cof = {(i, j): f"(Km[{3 * ((j + 1) % 3) + (i + 1) % 3}] * Km[{3 * ((j + 2) % 3) + (i + 2) % 3}]"
                   f" - Km[{3 * ((j + 1) % 3) + (i + 2) % 3}] * Km[{3 * ((j + 2) % 3) + (i + 1) % 3}])"
           for i in range(3) for j in range(3)}      # (i, j) of the adjugate: the cofactor of Km[j][i]
    return ([f"        {ki}[{3 * i}] = {cof[(i, 0)]};" for i in range(3)]
            + [f"        tmp = 1.0 / (Km[0] * {ki}[0] + Km[1] * {ki}[3] + Km[2] * {ki}[6]);"]
            + [f"        {ki}[{3 * i + j}] = {cof[(i, j)]} * tmp;" for i in range(3) for j in (1, 2)]
            + [f"        {ki}[{3 * i}] *= tmp;" for i in range(3)])


def _aba_accelerations(name, plan):
    """The kernel's accelerations when jac_x runs articulated: with ``msolve`` the kernel finds
    u' itself (ABA in the world frame on the quantities it has placed: articulated inertias
    IA, bias forces v x* h - load, bias accelerations c_b; U, D kept for the solve), then, as
    for given u', each body's a = a_parent + c_b + S u', the axes' term a_parent x S, f += Y a.
    A k-speed joint is a chain of k massless stages, its body's c_b on the last."""
    o = plan.offsets
    return [
        "    if (msolve) {   /* u' = ABA: articulated inertias and bias forces to the root ... */",
        f"        for (b = {plan.nb - 1}; b >= 0; b--) {{",
        "            double *Ib = IA + 36 * b, *pA = PA + 6 * b, t[6];",
        "            for (e = d0[b] + nd[b] - 1; e >= d0[b]; e--) {",
        "                const double *s = Sw + 6 * e;",
        "                double *Ue = Ua + 6 * e;",
        "                for (i = 0; i < 6; i++)",
        "                    Ue[i] = Ib[6 * i] * s[0] + Ib[6 * i + 1] * s[1] + Ib[6 * i + 2] * s[2]"
        " + Ib[6 * i + 3] * s[3] + Ib[6 * i + 4] * s[4] + Ib[6 * i + 5] * s[5];",
        f"                Di[e] = 1.0 / ({name}_rd_dot(s, Ue) + an[{o['arm']} + e]);",
        f"                uw[e] = -{name}_rd_dot(s, pA);",
        "                if (e == d0[b] && par[b] < 0) continue;   /* a root's first dof: its IA, pA are not read again */",
        "                for (i = 0; i < 6; i++)",
        "                    for (j = 0; j < 6; j++) Ib[6 * i + j] -= Ue[i] * Ue[j] * Di[e];",
        "                if (e == d0[b] + nd[b] - 1) {   /* + IA c_b */",
        "                    const double *cb = A + 6 * b;",
        "                    for (i = 0; i < 6; i++)",
        "                        t[i] = Ib[6 * i] * cb[0] + Ib[6 * i + 1] * cb[1] + Ib[6 * i + 2] * cb[2]"
        " + Ib[6 * i + 3] * cb[3] + Ib[6 * i + 4] * cb[4] + Ib[6 * i + 5] * cb[5];",
        "                    for (i = 0; i < 6; i++) pA[i] += t[i];",
        "                }",
        "                for (i = 0; i < 6; i++) pA[i] += Ue[i] * uw[e] * Di[e];",
        "            }",
        "            if (par[b] >= 0) {",
        "                for (i = 0; i < 36; i++) IA[36 * par[b] + i] += Ib[i];",
        "                for (i = 0; i < 6; i++) PA[6 * par[b] + i] += pA[i];",
        "            }",
        "        }",
        f"        for (b = 0; b < {plan.nb}; b++) {{   /* ... and u' from the root */",
        "            double *acc = Aa + 6 * b;",
        "            l = par[b];",
        "            for (i = 0; i < 6; i++)",
        f"                acc[i] = l >= 0 ? Aa[6 * l + i] : (i < 3 ? 0.0 : -an[{o['g']} + i - 3]);",
        "            for (e = d0[b]; e < d0[b] + nd[b]; e++) {",
        "                const double *s = Sw + 6 * e;",
        "                if (e == d0[b] + nd[b] - 1)",
        "                    for (i = 0; i < 6; i++) acc[i] += A[6 * b + i];",
        f"                uw[e] = (uw[e] - {name}_rd_dot(Ua + 6 * e, acc)) * Di[e];",
        "                for (i = 0; i < 6; i++) acc[i] += s[i] * uw[e];",
        "            }",
        "        }",
        "        ud = uw;",
        "    }",
        f"    for (b = 0; b < {plan.nb}; b++) {{   /* a = a_parent + c_b + S u', the axes' a_parent x S, f += Y a */",
        "        double *ab = A + 6 * b, al[6], t[6];",
        "        l = par[b];",
        "        for (i = 0; i < 6; i++) {",
        f"            al[i] = l >= 0 ? A[6 * l + i] : (i < 3 ? 0.0 : -an[{o['g']} + i - 3]);",
        "            ab[i] += al[i];",
        "        }",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {",
        "            const double *s = Sw + 6 * e;",
        f"            {name}_rd_cross(al, s, t);",
        "            for (i = 0; i < 6; i++) {",
        "                ab[i] += s[i] * ud[e];",
        "                dA[6 * e + i] += t[i];",
        "            }",
        "        }",
        f"        {name}_rd_ymul(Y + 10 * b, ab, t);",
        "        for (i = 0; i < 6; i++) F[6 * b + i] += t[i];",
        "    }",
    ]


def _aba_decls(plan, ncol):
    bm, bi, bo, fm, fi, fo, npm, nam = solve_tables(plan.lam)
    return [c_table("bm", bm), c_table("bi", bi), c_table("bo", bo), c_table("fm", fm), c_table("fi", fi),
            c_table("fo", fo),
            f"    double IA[{36 * plan.nb}], PA[{6 * plan.nb}], Aa[{6 * plan.nb}], Ua[{6 * plan.nd}], Di[{plan.nd}], "
            f"uw[{plan.nd}];",
            f"    double Pm[{6 * ncol * npm}], Am[{6 * ncol * nam}];"]


def _loop(n, body, width=2):
    """``for c`` over n columns as loops whose trip counts are multiples of the vector width
    (gcc -O2's very cheap vectorizer takes only a loop it needs no scalar rest for): a loop
    of the first n - n % width columns, for width 4 a loop of the two after them, and the
    odd column after that."""
    main, even = n - n % width, n - n % 2
    out = [f"        for (c = 0; c < {main}; c++) {{"] + [f"            {b}" for b in body] + ["        }"]
    if main < even:
        out += [f"        for (c = {main}; c < {even}; c++) {{"] + [f"            {b}" for b in body] + ["        }"]
    if even < n:
        out += [f"        c = {even};", "        {"] + [f"            {b}" for b in body] + ["        }"]
    return out


def _aba_lines(n, variant=""):
    """NAME_rd_bw / NAME_rd_fw: one dof's step of the articulated solve over the n state
    columns (rows of n doubles; a message is 6 such rows).  restrict: the rows given differ.

    variant "avx2": the same two functions as NAME_rd_bw_avx2 / NAME_rd_fw_avx2, built for
    AVX2 (``target("avx2")``: four columns an instruction, where gcc -O2 without it runs two)
    with loops of a multiple of four columns.  The operations are element-wise per column,
    in the same order, and AVX2 without FMA neither contracts nor reassociates them, so
    both give the same bits; :func:`_aba_dispatch` chooses one per call."""
    _loop_ = (lambda k, body: _loop(k, body, 4)) if variant else _loop
    attr = '__attribute__((target("avx2"))) ' if variant else ""
    suffix = f"_{variant}" if variant else ""
    sp = "s[0] * p[c] + s[1] * p[N + c] + s[2] * p[2 * N + c] + s[3] * p[3 * N + c] + s[4] * p[4 * N + c] + s[5] * p[5 * N + c]"
    ua = "U[0] * a[c] + U[1] * a[N + c] + U[2] * a[2 * N + c] + U[3] * a[3 * N + c] + U[4] * a[4 * N + c] + U[5] * a[5 * N + c]"
    six = lambda f: [f(k) for k in range(6)]
    rk = lambda k: f"{k} * N + c" if k > 1 else ("N + c" if k else "c")
    lines = [
        attr + "static void {name}_rd_bw" + suffix + "(double *restrict y, double *restrict q, double *restrict p, const double *s,",
        "                         const double *U, double f, int mode)",
        "{   /* backward: u = y - S.p (kept in y); the parent's message q (+)= p + U u / D (f = 1/D) */",
        "    int c;",
        "    switch (mode) {",
        "    case 1:"] + _loop_(n, [f"y[c] -= {sp};"]) + ["        break;", "    case 2:"] + _loop_(
        n, [f"const double u = y[c] - ({sp}), w = u * f;", "y[c] = u;"]
        + six(lambda k: f"p[{rk(k)}] += U[{k}] * w;")) + ["        break;", "    case 3:"] + _loop_(
        n, [f"const double u = y[c] - ({sp}), w = u * f;", "y[c] = u;"]
        + six(lambda k: f"q[{rk(k)}] += p[{rk(k)}] + U[{k}] * w;")) + ["        break;", "    case 4:"] + _loop_(
        n, ["const double w = y[c] * f;"] + six(lambda k: f"q[{rk(k)}] = U[{k}] * w;")) + [
        "        break;", "    case 5:"] + _loop_(
        n, ["const double w = y[c] * f;"] + six(lambda k: f"q[{rk(k)}] += U[{k}] * w;")) + [
        "        break;", "    default:", "        break;", "    }", "}", "",
        attr + "static void {name}_rd_fw" + suffix + "(double *restrict y, double *restrict b, double *restrict a, const double *s,",
        "                         const double *U, double f, int mode)",
        "{   /* forward: y = (u - U.a) / D (the parent's rows a), the dof's rows b = a + S y */",
        "    int c;",
        "    switch (mode) {",
        "    case 0:"] + _loop_(n, ["y[c] *= f;"]) + ["        break;", "    case 1:"] + _loop_(
        n, ["const double w = y[c] * f;", "y[c] = w;"] + six(lambda k: f"b[{rk(k)}] = s[{k}] * w;")) + [
        "        break;", "    case 2:"] + _loop_(n, [f"y[c] = (y[c] - ({ua})) * f;"]) + [
        "        break;", "    case 3:"] + _loop_(
        n, [f"const double w = (y[c] - ({ua})) * f;", "y[c] = w;"] + six(lambda k: f"a[{rk(k)}] += s[{k}] * w;")) + [
        "        break;", "    default:"] + _loop_(
        n, [f"const double w = (y[c] - ({ua})) * f;", "y[c] = w;"]
        + six(lambda k: f"b[{rk(k)}] = a[{rk(k)}] + s[{k}] * w;")) + [
        "        break;", "    }", "}", ""]
    return [x.replace("N", str(n)) if "{name}" not in x else x for x in lines]


AVX2_GUARD = "EOMC_RD_AVX2"


def _aba_avx2_lines(n):
    """The AVX2 twins of NAME_rd_bw / NAME_rd_fw (:func:`_aba_lines`), compiled where
    ``EOMC_RD_AVX2`` holds: gcc (its ``target`` attribute and ``__builtin_cpu_supports``) with
    optimization on x86 when the flags do not already allow AVX (then the plain helpers are
    vector code of that width or more: nothing to choose).  ``-DEOMC_RD_AVX2=0`` leaves only
    the portable helpers.  Why: at -O2 the articulated solve's element-wise row loops run two
    doubles an instruction (SSE2, all x86-64 has); on a CPU with AVX2 they run four: Go2's
    jac_x 8.2 -> 7.3 us (sens8's A/B, session 15), the same bits."""
    return avx2_guard_lines("the solve's AVX2 row helpers, chosen per call by the CPU") + [
        f"#if {AVX2_GUARD}",
    ] + _aba_lines(n, "avx2")[:-1] + ["#endif", ""]


def avx2_guard_lines(what):
    """C: ``EOMC_RD_AVX2`` defined (once per file: ``#ifndef``) as 1 where AVX2 twins are compiled
    in and chosen per call (:func:`_aba_avx2_lines`, second_order's NAME_rnea_hess_avx2): gcc
    (its ``target`` attribute and ``__builtin_cpu_supports``), optimizing, on x86, when the
    flags do not already allow AVX; else 0.  ``what``: the comment on its first line."""
    return [
        f"#ifndef {AVX2_GUARD}   /* {what} */",
        "#if defined(__GNUC__) && !defined(__clang__) && defined(__OPTIMIZE__) && !defined(__OPTIMIZE_SIZE__) \\",
        "    && (defined(__x86_64__) || defined(__i386__)) && !defined(__AVX__)",
        f"#define {AVX2_GUARD} 1",
        "#else",
        f"#define {AVX2_GUARD} 0",
        "#endif",
        "#endif",
    ]


def _aba_dispatch(name, nd, ncol):
    """The articulated solve's two sweeps in NAME_rnea_derivs: with the AVX2 helpers where
    the CPU has AVX2, else the portable ones.  ``__builtin_cpu_supports`` reads the CPU model
    libgcc's constructor filled in at load time: a load and a test per call, no state of our
    own -- the C stays reentrant (no static set on first use, no ifunc resolver: those need
    glibc's ifunc support, which musl and macOS lack; the check is ~1 ns of a ~7 us call)."""
    def sweeps(suffix, ind):
        return [
            f"{ind}for (e = {nd - 1}; e >= 0; e--)   /* articulated solve: bias messages to the root */",
            f"{ind}    {name}_rd_bw{suffix}(out + (row0 + row[e]) * stride, Pm + {6 * ncol} * bo[e], Pm + {6 * ncol} * bi[e],"
            " Sw + 6 * e, Ua + 6 * e, Di[e], bm[e]);",
            f"{ind}for (e = 0; e < {nd}; e++)   /* accelerations to the leaves */",
            f"{ind}    {name}_rd_fw{suffix}(out + (row0 + row[e]) * stride, Am + {6 * ncol} * fo[e], Am + {6 * ncol} * fi[e],"
            " Sw + 6 * e, Ua + 6 * e, Di[e], fm[e]);",
        ]
    return ([f"#if {AVX2_GUARD}", '    if (__builtin_cpu_supports("avx2")) {   /* the same bits, four columns at once */']
            + sweeps("_avx2", "        ") + ["        return;", "    }", "#endif"] + sweeps("", "    "))


def _axpy_lines(ncol):
    """y -= f x over one row of ncol entries: restrict rows and an even trip count, so that
    gcc -O2's cheap vectorizer takes it (the LTDL solve's inner loop)."""
    even = ncol - ncol % 2
    return [
        "static void {name}_rd_axpy(double *restrict y, const double *restrict x, double f)",
        "{",
        "    int c;",
        f"    for (c = 0; c < {even}; c++) y[c] -= f * x[c];",
    ] + ([f"    y[{even}] -= f * x[{even}];"] if even < ncol else []) + ["}", ""]


def call_lines(name, plan, ind, x_name, ud_expr, row0, sign, stride, nq, msolve=0):
    """The C lines that fill u[], ud[] per dof and call NAME_rnea_derivs (inside a function
    whose ``an[]`` holds the plan's inputs)."""
    rows = ", ".join(str(s) for s in plan.row)
    if plan.table >= 0:     # the pairs' taped call's inputs and flags, after its outputs (compiler/contact/table.py)
        from ..contact.table import table_of
        msolve = f"{msolve}, &PT_[{table_of(plan.table).noutput}]"
    if ud_expr is None:     # the kernel finds u' itself (msolve, articulated): ud unread
        return [f"{ind}{{",
                f"{ind}    static const int sp[{plan.nd}] = {{{rows}}};",
                f"{ind}    double u[{plan.nd}];",
                f"{ind}    int e;",
                f"{ind}    for (e = 0; e < {plan.nd}; e++) u[e] = {x_name}[{nq} + sp[e]];",
                f"{ind}    {name}_rnea_derivs(an, u, u, out, {stride}, {row0}, {sign}, {msolve});",
                f"{ind}}}"]
    return [f"{ind}{{",
            f"{ind}    static const int sp[{plan.nd}] = {{{rows}}};",
            f"{ind}    double u[{plan.nd}], ud[{plan.nd}];",
            f"{ind}    int e;",
            f"{ind}    for (e = 0; e < {plan.nd}; e++) {{",
            f"{ind}        u[e] = {x_name}[{nq} + sp[e]];",
            f"{ind}        ud[e] = {ud_expr}[sp[e]];",
            f"{ind}    }}",
            f"{ind}    {name}_rnea_derivs(an, u, ud, out, {stride}, {row0}, {sign}, {msolve});",
            f"{ind}}}"]


def analytic_ops(plan, ncol=0):
    """Floating-point operations of one NAME_rnea_derivs call (counted from the C above,
    multiply-adds as one mul and one add): per body ~1,150 (placement, v, a, Y, Ẏ),
    per dof ~330 (axes, their terms, the backward products), per (dof, support dof) pair 48;
    with the M⁻¹ solve on ``ncol`` columns (jac_x) 2·ncol more per pair and the factorization
    (LᵀDL) or about 56·ncol more per dof (articulated); a ground contact's terms as if it
    touched (:func:`_contact_lines`); a pairs' table body's per column (:func:`_pair_lines`;
    the tangents that fill block W are the caller's, counted once there)."""
    pairs = sum(plan.dep)
    muls = 580 * plan.nb + 170 * plan.nd + 24 * pairs
    adds = 570 * plan.nb + 160 * plan.nd + 24 * pairs
    if ncol and plan.solver == "aba":
        # articulated: per dof and column the backward step (S.p, U u/D, the parent's message)
        # and the forward one (U.a, S u'), at most 26 muls and 30 adds; per dof U, D, IA's
        # reduction, ABA's u' and the accelerations (~160 / 120); per body IA's start and sum
        muls += (26 * ncol + 160) * plan.nd + 20 * plan.nb
        adds += (30 * ncol + 120) * plan.nd + 42 * plan.nb
    elif ncol:
        muls += (6 + 2 * ncol) * pairs + ncol * plan.nd
        adds += (6 + 2 * ncol) * pairs
        muls += sum(d * (d + 1) // 2 for d in plan.dep)
        adds += sum(d * (d + 1) // 2 for d in plan.dep)
    for blocks in plan.kblocks:     # per diagonal block of K: Gauss-Jordan, then every row
        for r, _ in blocks:
            muls += 2 * len(r) ** 3 + plan.nd * len(r) ** 2
            adds += 2 * len(r) ** 3 + plan.nd * len(r) ** 2
    muls += 2 * len(plan.laws)      # the sign times each law's two derivatives
    adds += 2 * len(plan.laws)
    for _, e in (c for c in plan.contacts if c[1] >= 0):      # a touching contact (one compare when clear): per support dof
        d = plan.dep[e] + 1         # its slopes' products (~70), per pair of them two dot products
        muls += 70 * d + 10 * d * d
        adds += 60 * d + 10 * d * d
    for _, _, e in plan.pairs:      # per table body and state column: its wrench placed, per support dof a dot product
        d = plan.dep[e] + 1
        muls += (_state_cols(plan, ncol)) * (24 + 7 * d)
        adds += (_state_cols(plan, ncol)) * (18 + 6 * d)
    divs = sum(k for _, k, _ in plan.multi) + (plan.nd if ncol and plan.solver == "aba" else 0)
    return {"adds": adds, "muls": muls, "divs": divs, "calls": 0}


def _state_cols(plan, ncol):
    """The state columns of block W (the kernel's own columns; ``ncol`` when given)."""
    return ncol or plan.nq + plan.nd
