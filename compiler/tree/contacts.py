"""Ground contacts (and other velocity-dependent loads) lowered into the recursion.

One job: each :class:`~eomc.compiler.contact.tree.ContactLoad` of a Tree becomes, with the
recursion's Recorder, its point's world position and velocity (the body placed along the
tree by :class:`.placement.Placement`, the point's velocity from the body's spatial
velocity), the contact law's force (:func:`eomc.compiler.contact.law.ground_forces`), and
that force and its moment added to the body's external load.  What a contact *is* (the
user's spec, its parameters, outputs and events) is :mod:`eomc.compiler.contact.tree`'s;
this module is the recursion's side of it (called by :mod:`.lower`).
"""
import sympy as sm

from ..contact.law import EXPONENT, ground_forces, ground_jacobians, spin_moment, step
from ..contact import pairs as _pairs
from ..contact.pairs import PairLoad, pair_guards
from ..contact.table import lower_table
from ..contact.tree import CLIP_KIND, ENERGY, ENERGY_IMPLICIT, ContactLoad, ContactValue, contact_outputs
from ..passes.timing import doing
from .construct import _add, _mul
from .placement import Placement
from .spatial import cross
from eomc.runtime.errors import ModelError

__all__ = ["lower_contacts", "support_motion", "BODY_ENERGY", "deferred_energy"]

# An ellipsoid's ground contact planned in the analytic kernel's block G with its support point's
# motion (support_motion).  False: such a tree keeps the tangent path (as before session 14;
# benchmarks/bench_ellipsoid_kernel.py's "tangent" contestant).
PLAN_SHAPES = True


def world_placement(bodies, rec):
    """The recursion's bodies (LoweredBody: E, r already named) placed in the world, their
    rotations named column by column (the order this lowering has always emitted)."""
    return Placement([b.parent for b in bodies], lambda i: bodies[i].E, lambda i: bodies[i].r, rec.let,
                     by_columns=True)


def lower_contacts(tree, bodies, rec, v, rename, implicit=None, energy=None, guards=None, analytic=None,
                   second=False, points_loop=False):
    """Add every ContactLoad's force to its body's ``fext`` (LoweredBody, body components
    about the origin); return {ContactValue placeholder: temporary}.

    ``v``: the bodies' spatial velocities [ω; v_origin] (body components, the recursion's);
    ``rename(expr, what)``: mechanics symbols -> slot symbols (parameters).  Other loads
    with a ``lower(bodies, rec, v, rename, placement)`` method (MJCF fluid forces:
    eomc.compiler.mjcf.fluid) are lowered here too, with the same placement.
    ``implicit``: a dict to fill for the fixed-step integrator's NAME_implicit (None: not
    built, no temporaries added), holding "step" (the C-printable unit step function); filled
    with "poses" (the placement) and "contacts", per contact (depth, contact point, its
    velocity, K, C of :func:`eomc.compiler.contact.law.ground_jacobians`), world, and "pairs", the
    same per body-body pair point on the relative motion of its second body
    (:func:`eomc.compiler.contact.pairs.law_slopes`), in the tree's loads' order.
    ``energy``: (the gravity vector (world, slot symbols), the speeds' symbols) when the
    ``energy`` output (:data:`~eomc.compiler.contact.tree.ENERGY`) is asked for, else None.
    ``guards``: a list to fill with the rhs's broad phase (:func:`body_guards`).
    ``analytic``: a dict to fill for the analytic jac_x (:mod:`.analytic`): "contacts", per
    ground contact (body, depth, contact point, sphere centre, world force, K, C, and M of
    :func:`support_motion` for an ellipsoid's moving support point, else None), or None when
    such a contact is not planned (``PLAN_SHAPES`` off); "guards", jac_x's
    broad phase (the world forces exported too: the kernel reads them); "pairs", the body-body
    pairs' table bodies and wrench temporaries when they are one table call, "pair_call" that
    call's temporary, table id and fixed inputs (table.lower_table's ``call_info``; .analytic).
    ``points_loop``: the ground points may be one loop (compiler/contact/ground_table.py, from
    its TABLE_FROM points); where every ground contact is the loop's, their "contacts" entries of
    ``implicit`` and ``analytic`` are the loop's records (its slopes variant), and no point's K
    and C is formed here.
    ``second``: a function differentiates the pairs twice (hvp, hess_id): every pair goes through the
    table whatever their number, whose loop skips the law out of contact -- inlined, the law's
    δ₊^{3/2} has the second derivative ∞·0 = NaN at every point out of contact."""
    contacts = contact_outputs(tree)
    others = [ld for ld in tree.loads if not isinstance(ld, ContactLoad) and hasattr(ld, "lower")]
    if not contacts and not others and energy is None:
        return {}
    poses = world_placement(bodies, rec)
    if implicit is not None:    # "pairs": the body-body pairs' points, after the ground's contacts
        implicit["poses"], implicit["contacts"], implicit["pairs"] = poses, [], []
    pair_slopes = implicit["pairs"] if implicit is not None else None
    values, elastic, reach, pairs = {}, [], {}, []
    # a pair with torsional/rolling friction (law.spin_moment) goes into the table as the others do (its
    # law then the spinning law routine, table.Table.spin); inlined, it has no second derivatives
    table = [ld for ld in others if isinstance(ld, PairLoad)] if _pairs.PAIR_TABLE else []
    if len(table) < _pairs.TABLE_FROM and not second:   # a few pairs stay inlined (pairs.TABLE_FROM: why)
        table = []
    in_table = set(map(id, table))
    spinning = [ld for ld in others if isinstance(ld, PairLoad) and ld.spins and id(ld) not in in_table]
    if spinning and second:
        raise ModelError(f"the contact {spinning[0].name}: torsional and rolling friction between two bodies "
                         f"have no second-order derivatives (hvp, hess_id) outside the pairs' table "
                         f"(pairs.PAIR_TABLE)")
    table_energy = {}       # the table's points' elastic energy as its slopes loop sums it (NAME_implicit's)
    if table:               # every pair in one table-driven call (compiler/contact/table.py)
        wrenches = [] if analytic is not None else None
        info = {} if analytic is not None else None
        values.update(lower_table(table, bodies, rec, v, rename, poses, wrenches, pair_slopes, info,
                                  energy=table_energy if pair_slopes is not None else None))
        if analytic is not None and not spinning:   # the analytic jac_x takes their tangents (tree/analytic.py);
            analytic["pairs"] = wrenches            # with inlined pairs beside the table: the tangent path
            analytic["pair_call"] = info
    inlined = [ld for ld in others if isinstance(ld, PairLoad) and id(ld) not in in_table]
    if implicit is not None:    # the pair points NAME_implicit holds (implicit_metadata lists them), in
        # the order their slopes are appended: the table's, then the inlined ones' (INLINE_SLOPES)
        implicit["pair_loads"] = table + (inlined if _pairs.INLINE_SLOPES else [])
    inline_slopes = pair_slopes if _pairs.INLINE_SLOPES else None
    for load in others:     # a body-body pair returns its outputs' and events' values
        if id(load) in in_table:
            continue
        if isinstance(load, PairLoad):
            # the progress log names it (dm_control's dog: its pairs with rolling friction, minutes)
            doing(f"inlining body-body contact {len(pairs) + 1} of {len(inlined)} ({load.name})")
            values.update(load.lower(bodies, rec, v, rename, poses, broad=pairs, slopes=inline_slopes))
        else:
            values.update(load.lower(bodies, rec, v, rename, poses) or {})
    loads_on = {}       # body -> its contacts' wrench terms (6 lists), added to its fext after the loop
    from ..contact import ground_table as gt
    looped = ({index for index, load in enumerate(contacts) if gt.eligible(load)}
              if points_loop and not second and gt.GROUND_TABLE else set())
    if len(looped) < gt.TABLE_FROM:
        looped = set()
    gathered = gt.gather([(index, contacts[index]) for index in sorted(looped)], rename) if looped else None
    if gathered is None:        # offsets the table cannot hold: straight-line, as before
        looped = set()
    # every contact in the loop, in their order: jac_x's block G and NAME_implicit's contact entries
    # are the slopes variant's records (ground_table.ground_into), and SymPy forms no point's K and C
    slopes_loop = (bool(looped) and gt.SLOPES_TABLE and len(looped) == len(contacts)
                   and all(gt.plane_of(load) == gt.FLAT for load in contacts)   # (records: the world's)
                   and (implicit is not None or analytic is not None))
    records = []        # (contact index, its place in implicit["contacts"], in analytic["contacts"])
    on_table, twins = {}, {}   # the loop's (body, plane)s' straight-line wrench terms; its outputs' twins
    for index, load in enumerate(contacts):
        i = load.body
        what = f"contact {load.name} on body {tree.bodies[i].name}"
        off = [rename(x, what) for x in load.offset]
        params = {k: rename(s, what) for k, s in load.params.items()}
        poses.rotation(i)
        o = poses.origin(i)
        moving = None
        if load.shape is not None:      # an ellipsoid: its support point c - A n / sqrt(n A n)
            n_b = poses.to_body(i, load.normal)
            An = [sum((a * x for a, x in zip(row, n_b)), sm.S.Zero) for row in load.shape]
            s = rec.let(sm.sqrt(sum((x * y for x, y in zip(n_b, An)), sm.S.Zero)))
            off = [rec.let(off[k] - An[k] / s) for k in range(3)]
            if analytic is not None and PLAN_SHAPES:
                moving = support_motion(poses.rotation(i), load.shape, n_b, An, s, rec.let)
        w_b, v_b = v[i][:3], v[i][3:]
        vp_b = [v_b[k] + c for k, c in enumerate(cross(w_b, off))]
        centre = [rec.let(o[k] + x) for k, x in enumerate(poses.to_world(i, off))]
        velocity = rec.vec(poses.to_world(i, vp_b))
        omega = rec.vec(poses.to_world(i, w_b))
        forces = ground_forces(centre, velocity, omega, params, load.normal, rename(load.height, what),
                               let=rec.let, twin=index in looped)
        f_b = rec.vec(poses.to_body(i, forces.force))
        arm_b = poses.to_body(i, forces.point_offset)
        lever = [off[k] + arm_b[k] for k in range(3)]
        n_b = cross(lever, f_b)
        spin = spin_moment(omega, load.normal, forces.normal, params, rec.let)
        if spin is not None:        # torsional/rolling friction (law.spin_moment): a pure moment
            m_b = rec.vec(poses.to_body(i, spin))
            n_b = [n_b[k] + m_b[k] for k in range(3)]
        pushed = (on_table.setdefault((i, gt.plane_of(load)), [[] for _ in range(6)]) if index in looped
                  else loads_on.setdefault(i, [[] for _ in range(6)]))
        for k, x in enumerate(n_b + f_b):
            pushed[k].append(x)
        slopes = ()
        if slopes_loop:     # its records: filled in from the loop's below
            records.append((index, len(implicit["contacts"]) if implicit is not None else None,
                            len(analytic.setdefault("contacts", [])) if analytic is not None else None))
            if implicit is not None:
                implicit["contacts"].append(None)
            if analytic is not None and analytic["contacts"] is not None:
                analytic["contacts"].append(None)
        elif implicit is not None or analytic is not None:
            arm_w = forces.point_offset
            point = [rec.let(centre[k] + arm_w[k]) for k in range(3)]
            K, C = ground_jacobians(forces, step, rec.let)
            # each slope named: NAME_implicit's broad phase skips them with the force (body_guards)
            K, C = ([[rec.let(x) for x in row] for row in M] for M in (K, C))
            slopes = tuple(x for M in (K, C) for row in M for x in row if isinstance(x, sm.Symbol))
        if implicit is not None and not slopes_loop:
            implicit["contacts"].append({"depth": forces.depth, "point": point,
                                         "velocity": list(forces.parts["slip"]), "K": K, "C": C})
        if analytic is not None and not slopes_loop:
            analytic.setdefault("contacts", [])
            if analytic["contacts"] is not None:
                # a moment of torsional/rolling friction is not in the kernel's block G (a force at a
                # point): such a tree's jac_x keeps the tangent path
                analytic["contacts"] = None if (load.shape is not None and moving is None) or spin is not None \
                    else analytic["contacts"] + [
                    (i, forces.depth, point, centre, list(forces.force), K, C, moving)]
        reach.setdefault(i, []).append(None if load.shape is not None else
                                       (load.normal, rename(load.height, what), params["r"], off,
                                        f_b if spin is None else list(f_b) + list(m_b),
                                        forces.depth, slopes, tuple(forces.force)))
        quantities = [forces.normal, *forces.friction, forces.depth]     # OUTPUT_KINDS' order
        for kind, value in enumerate(quantities):
            values[ContactValue(index, kind)] = value
        values[ContactValue(index, CLIP_KIND)] = forces.parts["clip"]
        if index in looped:
            for kind, value in enumerate(quantities + [forces.parts["clip"]]):
                twins[(index, kind)] = value
        if energy is not None:      # the law's elastic part k δ₊^(3/2) stores k δ₊^(5/2) / (5/2)
            elastic.append(forces.parts["elastic"] * forces.parts["dpos"] / (EXPONENT + 1))
    if looped:      # the loop's points (compiler/contact/ground_table.py)
        for entry, pushed in on_table.items():
            for k, terms in enumerate(pushed):
                twins[("wrench", entry, k)] = rec.let(sm.Add(*terms))
        got = gt.lower_ground_table([(index, contacts[index]) for index in sorted(looped)], bodies, rec, v,
                                    rename, poses, twins, gathered)
        for index, at_imp, at_jac in records if got is not None else ():
            e, g = got.pop((index, "imp")), got.pop((index, "jac"))
            if at_imp is not None:
                implicit["contacts"][at_imp] = {"depth": e[0], "point": e[1:4], "velocity": e[4:7],
                                                "K": [e[7 + 3 * r:10 + 3 * r] for r in range(3)],
                                                "C": [e[16 + 3 * r:19 + 3 * r] for r in range(3)]}
            if at_jac is not None and analytic["contacts"] is not None:
                analytic["contacts"][at_jac] = (contacts[index].body, g[0], g[1:4], g[4:7], g[7:10],
                                                [g[10 + 3 * r:13 + 3 * r] for r in range(3)],
                                                [g[19 + 3 * r:22 + 3 * r] for r in range(3)], None)
        if got is None:     # offsets the table cannot hold: straight-line, as before
            for (i, _), pushed in on_table.items():
                mine = loads_on.setdefault(i, [[] for _ in range(6)])
                for k, terms in enumerate(pushed):
                    mine[k] += terms
        else:
            values.update({ContactValue(index, kind): node for (index, kind), node in got.items()
                           if kind not in ("jac", "imp")})
    # each body's contact wrenches added to its fext in one sum: added point by point, the growing
    # sum was rebuilt at every point (Go2 --ground: 96 hull points per body)
    for i, pushed in loads_on.items():
        old = bodies[i].fext or [0] * 6
        bodies[i].fext = [sm.Add(old[k], *terms) for k, terms in enumerate(pushed)]
    clearances = {}
    if guards is not None:
        guards.extend(body_guards(reach, poses, clearances=clearances) + pair_guards(pairs))
    if implicit is not None:
        # the inlined pairs' broad phase too, as the rhs's, exporting their slopes with their forces;
        # without it every pair's narrow phase ran at every call (gymnasium hopper's 3 self-pairs:
        # +17 % per call)
        implicit["guards"] = (body_guards(reach, poses, slopes=True, clearances=clearances)
                              + pair_guards(pairs, slopes=True))
    if analytic is not None:
        analytic["guards"] = body_guards(reach, poses, slopes=True, world=True, clearances=clearances)
    if energy is not None:
        stored = getattr(tree, "joint_energy", None)       # the limits' springs (URDF)
        limits = rename(stored, "the joint limits' elastic energy") if stored else sm.S.Zero
        if limits.is_Add:   # each joint's springs one named temporary (why: _energy's per-body shares)
            limits = sm.Add(*[rec.let_apart(term) for term in limits.args])
        springs = getattr(tree, "spring_energy", None)     # MJCF's joint and fixed-tendon springs
        if springs is not None:
            limits += rename(springs, "the joint springs' energy")
        if implicit is not None and implicit.get("energy") and table:
            # NAME_implicit's energy (ENERGY_IMPLICIT): the table's pairs' elastic energy is not
            # the sum of _pair_energy's terms there (their depths are the loop's outputs, which
            # its slopes variant does not write: its slope block holds them) but the loop's own
            # sum of the same terms over its points in touch (table.Table.energy_at), equal to
            # NAME_energy's to rounding (the order of the sum).  Why: without them the fixed
            # step's energy watch called NAME_energy while a pair touched, 11-13 % of gymnasium's
            # humanoid's lanes rollout (session 32, benchmarks/results/rollout_contacts.md)
            apart = rec.let(_energy(bodies, v, poses, *energy, rec.let_apart)
                            + sm.Add(*elastic, *_pair_energy(inlined, values, rename)) + limits)
            # (not a temporary of its own: one more would renumber the later ones, and SymPy orders
            # a sum's terms by their names: the rhs's C and bits would change with it)
            values[ENERGY_IMPLICIT] = apart + table_energy["energy"]
            values[ENERGY] = rec.let(apart + sum(_pair_energy(table, values, rename), sm.S.Zero))
        elif len(energy) > 2:     # the bodies' part left to the caller (.body_loops: a loop, or deferred_energy)
            elastic += _pair_energy(others, values, rename)
            energy[2]["energy"] = _defer_energy(bodies, v, poses, *energy[:2], rec)
            values[ENERGY] = rec.let(BODY_ENERGY + sm.Add(*elastic) + limits)
        else:
            elastic += _pair_energy(others, values, rename)
            values[ENERGY] = rec.let(_energy(bodies, v, poses, *energy, rec.let_apart) + sm.Add(*elastic) + limits)
    return values


def _pair_energy(loads, values, rename):
    """[the elastic energy of each body-body pair point among ``loads``]: its law's k δ₊^(3/2)
    along the normal of its nearest points stores k δ₊^(5/2) / (5/2) (the ground contact's
    potential with the plane's height replaced by the distance of the two shapes: the depth δ
    falls along n at B's point at the rate the force's normal part does work, so the force is
    minus its gradient).  The depth is the pair's own output (PairValue kind "depth": the
    table's or the inlined law's temporary; 0 where the broad phase skips the pair)."""
    from ..contact.pairs import PairValue
    from ..contact.tree import OUTPUT_KINDS
    depth_kind = OUTPUT_KINDS.index("depth")
    out, kept = [], {}
    for ld in loads:
        if not isinstance(ld, PairLoad):
            continue
        depth = values[PairValue(ld.index, depth_kind)]
        dpos = (depth + sm.Abs(depth)) / 2
        out.append(rename(ld.params["k"], f"the contact {ld.name}") * _abs_of_part(depth, dpos, kept) ** (EXPONENT + 1)
                   / (EXPONENT + 1))
    return out


def _abs_of_part(depth, dpos, kept):
    """sm.Abs(dpos), dpos = (depth + |depth|)/2: where ``depth`` is a symbol or the pairs' table's
    output (contact/table.PairTableOut, whose assumptions are its class's), SymPy's evaluation of
    that Abs depends only on depth's kind and assumptions (``kept``: them -> whether it leaves the
    Abs as it stands, decided by evaluating it once for them), so the Abs of the other pairs'
    depths is built as it stands.  Why: Abs.eval of the sum asked its sign of SymPy's assumptions
    per pair, 0.15 s of the humanoid's generate for its 109 pairs (session 22); the same
    expression, the same C."""
    from ..contact.table import PairTableOut
    if not (depth.is_Symbol or type(depth) is PairTableOut):
        return sm.Abs(dpos)
    key = (type(depth), tuple(sorted(depth.assumptions0.items())))
    if key not in kept:
        got = sm.Abs(dpos)
        kept[key] = isinstance(got, sm.Abs) and got.args == (dpos,)
        return got
    return sm.Abs(dpos, evaluate=False) if kept[key] else sm.Abs(dpos)


def support_motion(R, A, m, Am, s, let):
    """M (3x3 rows, world, named): an ellipsoid's support point's own motion on its body, δc = M ω
    along a perturbation that turns the body by ω (world) -- what the analytic kernel adds to the
    motion of the body's material point there (block G, compiler/tree/analytic.py).

    The support point in body components is x(m) = c - A m / s, m = Rᵀ n the plane's normal in the
    body, s = sqrt(mᵀ A m); turning the body by ω turns m by δm = Rᵀ(n × ω) = m × Rᵀω, and
    ∂x/∂m = D = -(A/s - (A m)(A m)ᵀ/s³), so δc = R D [m]× Rᵀ ω.  nᵀ R D = 0 (the support point
    is the deepest: the depth moves as for a point fixed on the body), so only the contact
    point's tangential place (the friction's slip velocity and the force's arm) moves.
    Why: without it a model with a ground-touching ellipsoid (dm_control's humanoid_CMU: its
    hands) was refused the kernel, and its jac_x differentiated the whole recursion per column."""
    D = [[let(-(A[a][b] / s - Am[a] * Am[b] / s ** 3)) if b >= a else None for b in range(3)] for a in range(3)]
    D = [[D[a][b] if b >= a else D[b][a] for b in range(3)] for a in range(3)]
    mx = [[0, -m[2], m[1]], [m[2], 0, -m[0]], [-m[1], m[0], 0]]       # [m]×
    N = [[let(sum((D[a][k] * mx[k][b] for k in range(3)), sm.S.Zero)) for b in range(3)] for a in range(3)]
    NRt = [[let(sum((N[a][k] * R[b][k] for k in range(3)), sm.S.Zero)) for b in range(3)] for a in range(3)]
    return [[let(sum((R[a][k] * NRt[k][b] for k in range(3)), sm.S.Zero)) for b in range(3)] for a in range(3)]


def body_guards(reach, poses, slopes=False, world=False, clearances=None):
    """[(clearance, exports, inner guards)] per body with ground contacts
    (compiler/emit/guards.py): the body's force temporaries are exactly zero while the clearance
    is positive; inside, each point's law is guarded by its own depth (-δ_j > 0: out of contact,
    its force is ±0), so a body near the floor evaluates only the laws of its touching points.

    Point j of a body (sphere centre at ``off_j`` from the body origin o, radius r_j, plane
    n·x = h_j) has depth δ_j = r_j + h_j - n·(o + R off_j).  With the points' box in the body
    frame (centre c, half sizes e, when the offsets are numbers) n·R off_j ≥ w·c - Σ|w_k| e_k
    with w = Rᵀn, the box's lowest corner; otherwise (offsets that are parameters) ≥ -|n||off_j|,
    the bounding sphere about the origin.  So with

        clearance = min over the body's normals of  n·o + (lowest point's offset) - max_j(r_j + h_j)

    every δ_j < 0 where the clearance is positive: δ₊ = 0 exactly, and the law's normal force,
    friction and force are ±0 (a MuJoCo margin is in h; the law has no force at δ ≤ 0, no
    onset beyond it).  The box costs a few operations on the body's rotation, and is tight for
    a long body standing on its end (a calf: the sphere about its knee would reach the floor
    at every step).  A body with an ellipsoid (its support point moves) gets no guard.

    ``slopes``: NAME_implicit's guards, whose exports are also each point's K and C
    (:func:`~eomc.compiler.contact.law.ground_jacobians`): exactly ±0 out of contact too, as
    F_n,δ and F_n,δ̇ carry δ₊ and step(F_n), and the friction's slope μ F_n / s carries F_n.
    The depth, point and velocity NAME_implicit writes stay outside every block.
    ``world``: the analytic jac_x's guards (:mod:`.analytic`), whose exports are also each
    point's world force (its kernel reads it; ±0 out of contact as the body-frame one).
    ``clearances``: {body: its clearance}, filled and read so that the rhs's, NAME_implicit's
    and jac_x's guards build each once (SymPy's Min and Max compare their arguments pairwise:
    three times over was 7 % of gymnasium humanoid's generate phase)."""
    out, clearances = [], {} if clearances is None else clearances
    for i, points in reach.items():
        if any(p is None for p in points):
            continue
        if i not in clearances:
            clearances[i] = _clearance(poses, i, points)
        inner = [(-depth, tuple(dict.fromkeys(s for s in (*f_b, *(kc if slopes else ()), *(f_w if world else ()))
                                              if isinstance(s, sm.Symbol))), ())
                 for _, _, _, _, f_b, depth, kc, f_w in points]
        inner = [g for g in inner if g[1]]
        exports = tuple(s for _, ex, _ in inner for s in ex)
        if exports:
            out.append((clearances[i], exports, tuple(inner)))
    return out


def _clearance(poses, i, points):
    """Body i's clearance (:func:`body_guards`): min over its points' normals of the lowest
    point's height above the highest plane."""
    o, R = poses.origin(i), poses.rotation(i)
    by_normal = {}
    for normal, height, r, off, *_ in points:
        by_normal.setdefault(tuple(sm.sympify(x) for x in normal), []).append((height + r, off))
    terms = []
    for n, group in by_normal.items():
        above = sum((a * b for a, b in zip(n, o)), sm.S.Zero) - _max([far for far, _ in group])
        offs = [[sm.sympify(x) for x in off] for _, off in group]
        if all(x.is_Number for off in offs for x in off):
            lo = [min(float(off[k]) for off in offs) for k in range(3)]
            hi = [max(float(off[k]) for off in offs) for k in range(3)]
            w = [sum((n[a] * R[a][k] for a in range(3)), sm.S.Zero) for k in range(3)]
            for k in range(3):
                c, e = (lo[k] + hi[k]) / 2, (hi[k] - lo[k]) / 2
                above += (w[k] * c if c else 0) - (sm.Abs(w[k]) * e if e else 0)
        else:
            size = sm.sqrt(sum((x * x for x in n), sm.S.Zero))
            above -= _sphere_max([size * sm.sqrt(sum((x * x for x in off), sm.S.Zero)) for off in offs])
        terms.append(above)
    # one normal (every ground): the term itself, which is what sm.Min of one argument returns --
    # after asking whether it is real, which SymPy answers down every sqrt of a bounding-sphere Max
    # (example-robot-data's Go2 under --ground, 96 per body: 1.8 of its 22 s of generate)
    return terms[0] if len(terms) == 1 else sm.Min(*terms)


# Above this many arguments a clearance's Max is built as it stands (duplicates still dropped).
MAX_EVALUATED = 16


def _max(args):
    """sm.Max of a body's per-point terms.

    Why not always sm.Max: SymPy looks for arguments that bound others by testing every pair
    (``_find_localzeros``: factor_terms and assumption queries on each difference), quadratic in
    their number.  A URDF mesh under ``--ground`` is its hull thinned to 32 points, whose
    parameter offsets nothing orders: example-robot-data's Go2 spent 536 of its 612 s of
    generate there under cProfile (session 18).  Up to MAX_EVALUATED arguments the evaluated
    Max is kept (the C of every case benchmarks/c_identity.py records is unchanged); above it
    the guard computes every argument's fmax, the same value."""
    if len(args) <= MAX_EVALUATED:
        return sm.Max(*args)
    return sm.Max(*args, evaluate=False)


def _sphere_max(args):
    """sm.Max of a body's bounding-sphere radii (|c_k| of its points' parameter offsets): every
    distinct radius an argument, in SymPy's order, unevaluated unless all are numbers.

    Why not SymPy's evaluation: its pairwise search for radii that bound others
    (``_find_localzeros``) found none in any model built so far, and cost 0.22 s of generate on
    gymnasium's humanoid (8 bodies, 2-5 radii each) and 0.22 s on its ant (session 22): the same
    Max, the same C (benchmarks/c_identity.py).  Where SymPy could drop a radius the guard
    computes one fmax more: the same value."""
    if all(a.is_Number for a in args):
        return sm.Max(*args)
    return sm.Max(*args, evaluate=False)


def _energy(bodies, v, poses, gravity, speeds, let):
    """Kinetic energy (the bodies' translation of their mass centres -- a tree body's origin --
    and rotation, plus the joints' armature) and the potential of gravity, -Σ m g·p.

    Why generated: a passive robot's total energy may only fall; the runtime's verdict reads
    it to fail a run that created energy (runtime/switching.py).  1/2 u'Mu from the mass
    matrix would need a build with mass_matrix and still no potential.

    Each body's share is one named temporary (``let``: the Recorder's let_apart, which leaves the
    other functions' temporaries and their printed order as they were), as is each joint's limit
    energy (lower_contacts), and the energy their sum.  Why: printed as one sum, it was one C statement
    of 33 kB on Talos, which gcc compiles slowly: named, gcc on the whole file took 0.15 s less
    on G1 (2.28 -> 2.14 s; the energy's share was 0.32 s) and 0.17 s less on Talos (3.36 ->
    3.18 s), and the call got faster (G1 960 -> 900-940 ns, Talos 1460-1830 -> 1370 ns; session 20,
    benchmarks/results/derivative_build.md)."""
    total = sm.S.Zero
    for i, b in enumerate(bodies):
        share = _share(b, v[i], poses.origin(i), gravity, speeds)
        total += let(share) if share != 0 else share
    return total


def _share(b, vi, o, gravity, speeds):
    """Body ``b``'s kinetic energy and gravity potential (:func:`_energy`), ``vi`` its spatial velocity
    (body components), ``o`` its placed origin."""
    w, vo = vi[:3], vi[3:]
    m = b.I[3][3]
    # (construct._add/_mul: the sums sum(..., S.Zero) of the products made, built for less)
    Iw = [_add([_mul(b.I[r][c], w[c]) for c in range(3)]) for r in range(3)]
    share = (m * _add([_mul(x, x) for x in vo]) + _add([_mul(w[r], Iw[r]) for r in range(3)])) / 2
    share -= m * _add([_mul(gravity[k], o[k]) for k in range(3)])
    axes = [b.speed] if b.S is not None else [k for k, _ in (b.multi or ())]
    for a, k in zip(b.armature, axes):
        if a != 0 and k is not None:
            share += a * speeds[k] ** 2 / 2
    return share


# The bodies' part of the energy output where the caller decides later how it is computed
# (.lower: NAME_energy's loop over the bodies, .body_loops, or :func:`deferred_energy`): a
# program input the loop's C sets.
BODY_ENERGY = sm.Symbol("_ebodies", real=True)


def _defer_energy(bodies, v, poses, gravity, speeds, rec):
    """The bodies placed as :func:`_energy` places them (the same temporaries in the same order,
    so every later one keeps its name: the other functions' C stays as it was), without their
    shares; returns what :func:`deferred_energy` needs to put the shares in where _energy would
    have: after each body's placement, with the names the recorder would have given then."""
    marks = []
    for i in range(len(bodies)):
        poses.origin(i)
        marks.append(len(rec.assignments))
    return marks, dict(rec._seen), lambda i: _share(bodies[i], v[i], poses.origin(i), gravity, speeds)


def deferred_energy(rec, assignments, deferred):
    """``assignments`` (the program's, which begin with ``rec``'s as they were when the bodies
    were placed) with the bodies' shares computed and named as :func:`_energy` does, each put in
    after its body's placement, and :data:`BODY_ENERGY` replaced by their sum: the program
    lower_contacts gave before the energy could be deferred, assignment for assignment.
    Returns (assignments, the sum): where no assignment reads BODY_ENERGY (the energy is the bodies'
    part alone, an atom the recorder does not name: gymnasium's swimmer, reacher, inverted
    pendulums) the caller puts the sum into the results that read it."""
    marks, seen, share = deferred
    now, rec._seen = rec._seen, seen     # the names known then (a later temporary is no share's)
    inserts, total = [], sm.S.Zero
    try:
        for i, mark in enumerate(marks):
            n0 = len(rec.assignments)
            s = share(i)
            total += rec.let_apart(s) if s != 0 else s
            inserts.append((mark, rec.assignments[n0:]))
            del rec.assignments[n0:]
    finally:
        seen, rec._seen = rec._seen, now
    for key, sym in seen.items():
        now.setdefault(key, sym)
    out = list(assignments)
    for k, (t, e) in enumerate(out[marks[-1]:] if marks else ()):
        if isinstance(e, sm.Basic) and e.has(BODY_ENERGY):
            out[marks[-1] + k] = (t, e.xreplace({BODY_ENERGY: total}))
            break
    for mark, new in reversed(inserts):
        out[mark:mark] = new
    return out, total
