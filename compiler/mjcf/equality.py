"""MJCF ``<equality><joint joint1 joint2 polycoef>`` couplings as loop-closing constraints on the tree.

MuJoCo's joint equality ties two hinge/slide joints by a quartic (``mj_instantiateEquality``):

    q1 - r1 = p0 + p1 d + p2 d² + p3 d³ + p4 d⁴,   d = q2 - r2

with r1, r2 the joints' reference positions (``qpos0``: their ``ref``); without ``joint2``,
q1 - r1 = p0.  MuJoCo enforces it softly (solref/solimp, solved with the other
constraints); here it is a holonomic constraint solved exactly through the recursion
(:mod:`eomc.compiler.tree.constrained`), so a model drifts off it only by the
integrator's error, and MuJoCo's motion differs from eomc's by its constraint's
softness (tests/compiler/mjcf/test_mjcf_equality.py measures how much).

Why the reordering: the constrained tree's state layout is Kane's -- independent
coordinates and speeds first, the dependent ones (one per constraint) last.  joint1's
coordinate and speed are the dependent ones (its row of the constraint Jacobian has a
1 there, so the dependent block never has a zero pivot for a chain of couplings), so
they are moved to the end, in equality order; every other state keeps MuJoCo's order.

The polycoef numbers are parameters ``eq_<name>_p0`` .. ``_p4`` (zeros stay literal,
like every MJCF number; ``fold_parameters`` folds them).  Which couplings are taken
and which refused is decided in :func:`couplings` (the model check uses it too).
"""
from dataclasses import replace

import sympy as sm

__all__ = ["couplings", "coupled_states", "coupling_loops", "coupled_qpos"]


def couplings(m):
    """[(equality id, joint1 id, joint2 id or None)] of the active joint equalities of ``m``.

    Inactive ones (``active="false"``) are not returned: MuJoCo starts without them (the
    model check warns that they are left out).  ValueError naming the equality for what
    cannot be a coupling of hinge/slide coordinates (the model check places it)."""
    import mujoco
    out, dependent = [], {}
    for e in range(m.neq):
        if int(m.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT) or not _active(m, e):
            continue
        j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        j2 = None if j2 < 0 else j2
        name = _eq_name(m, e)
        for j in (j1, j2):
            if j is not None and int(m.jnt_type[j]) not in (2, 3):
                raise ValueError(f"equality {name}: joint {_jname(m, j)} is a ball or free joint "
                                 f"(a joint coupling ties hinge and slide joints)")
        if j1 == j2:
            raise ValueError(f"equality {name}: joint1 and joint2 are both {_jname(m, j1)}")
        if j1 in dependent:
            raise ValueError(f"equality {name}: joint {_jname(m, j1)} is already joint1 of equality "
                             f"{dependent[j1]}: two couplings cannot both set the same joint")
        dependent[j1] = name
        out.append((e, j1, j2))
    return out


def _active(m, e):
    from .options import disabled
    if {"equality", "constraint"} & disabled(m):      # <flag equality="disable"/>: none acts
        return False
    active = getattr(m, "eq_active0", None)
    return bool(active[e]) if active is not None else True


def _eq_name(m, e):
    import mujoco
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"#{e}"


def _jname(m, j):
    import mujoco
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"


def coupled_states(bodies, coordinates, speeds, kinematics, joints, dependent):
    """The tree's states with the dependent joints' coordinate and speed moved to the end
    (``dependent``: MuJoCo joint ids in equality order).  Returns (bodies, coordinates,
    speeds, kinematics, joints) with every index (a body's speed, ``joints``' first
    coordinate/speed) renumbered."""
    if not dependent:
        return bodies, coordinates, speeds, kinematics, joints
    first = {jid: (iq, iu) for jid, _, iq, iu in joints}
    dep_q = [first[j][0] for j in dependent]
    dep_u = [first[j][1] for j in dependent]
    order_q = [k for k in range(len(coordinates)) if k not in dep_q] + dep_q
    order_u = [k for k in range(len(speeds)) if k not in dep_u] + dep_u
    new_q = {old: new for new, old in enumerate(order_q)}
    new_u = {old: new for new, old in enumerate(order_u)}
    out = []
    for b in bodies:
        if b.speed is not None:
            b = replace(b, speed=new_u[b.speed])
        elif b.speeds:
            b = replace(b, speeds=tuple(new_u[k] for k in b.speeds))
        out.append(b)
    joints = [(jid, kind, new_q[iq], new_u[iu]) for jid, kind, iq, iu in joints]
    return (out, [coordinates[k] for k in order_q], [speeds[k] for k in order_u],
            [kinematics[k] for k in order_q], joints)


def coupling_loops(m, params, found, coordinates, speeds, joints, joint_names, tendons=()):
    """The :class:`eomc.compiler.tree.constrained.Loops` of the couplings ``found`` (from
    :func:`couplings`) on the reordered states: per coupling

        f_h = q1 - r1 - P(d),  f_v = u1 - P'(d) u2,  J = ∂f_v/∂u,  γ = -P''(d) u2²

    (hinge and slide coordinates have q' = u; γ is d f_v/dt at u' = 0)."""
    from eomc.compiler.tree.constrained import Loops
    from eomc.compiler.multibody.joints import snap
    first = {jid: (iq, iu) for jid, _, iq, iu in joints}
    n = len(speeds)
    hol, vel, jac, bias, tied = [], [], [], [], []
    for e, j1, j2 in found:
        ename = _param_name(m, e)
        p = [params(f"eq_{ename}_p{k}", m.eq_data[e, k]) for k in range(5)]
        q1, u1 = coordinates[first[j1][0]], speeds[first[j1][1]]
        r1 = snap(float(m.qpos0[int(m.jnt_qposadr[j1])]))
        row = [sm.S.Zero] * n
        row[first[j1][1]] = sm.S.One
        tied.append(joint_names[j1][0])
        if j2 is None:
            hol.append(q1 - r1 - p[0])
            vel.append(u1)
            bias.append(sm.S.Zero)
        else:
            q2, u2 = coordinates[first[j2][0]], speeds[first[j2][1]]
            r2 = snap(float(m.qpos0[int(m.jnt_qposadr[j2])]))
            d = q2 - r2 if r2 != 0 else q2
            poly = p[0] + p[1] * d + p[2] * d ** 2 + p[3] * d ** 3 + p[4] * d ** 4
            slope = p[1] + 2 * p[2] * d + 3 * p[3] * d ** 2 + 4 * p[4] * d ** 3
            curve = 2 * p[2] + 6 * p[3] * d + 12 * p[4] * d ** 2
            hol.append(q1 - r1 - poly)
            vel.append(u1 - slope * u2)
            row[first[j2][1]] = -slope
            bias.append(-curve * u2 ** 2)
            tied.append(joint_names[j2][0])
        jac.append(tuple(row))
    if tendons:          # <equality><tendon> couplings (tendon_couplings), after the joint couplings
        more = tendon_coupling_loops(m, params, tendons, coordinates, speeds, joints)
        for mine, extra in zip((hol, vel, jac, bias, tied), more):
            mine += list(extra)
    count = len(found) + len(tendons)
    return Loops(holonomic=tuple(hol), velocity=tuple(vel), jacobian=tuple(jac), bias=tuple(bias),
                 n_dependent_coordinates=count, n_dependent_speeds=count,
                 joints=tuple(dict.fromkeys(tied)))


def _param_name(m, e):
    """The equality's name as a C identifier part (``eq<k>`` when unnamed)."""
    import mujoco
    from eomc.compiler.multibody.joints import identifier
    raw = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e)
    return identifier(raw) if raw else f"eq{e}"


def coupled_qpos(m):
    """MuJoCo's qpos0 with each coupling's joint1 set from its joint2 by the polynomial
    (a chain of couplings, in any order of the file: one pass per coupling)."""
    import numpy as np
    qpos = np.array(m.qpos0, dtype=float)
    found = couplings(m)
    for _ in range(len(found)):
        for e, j1, j2 in found:
            a1 = int(m.jnt_qposadr[j1])
            value = float(m.eq_data[e, 0])
            if j2 is not None:
                a2 = int(m.jnt_qposadr[j2])
                d = qpos[a2] - m.qpos0[a2]
                value += sum(float(m.eq_data[e, k]) * d ** k for k in range(1, 5))
            qpos[a1] = m.qpos0[a1] + value
    for e, dep, p1, p2 in tendon_couplings(m, [j1 for _, j1, _ in found]):   # at qpos0: d = 0, so L1 - L1_0 = p0
        c = dict(p1)[dep]
        rest = sum(cc * (qpos[int(m.jnt_qposadr[j])] - m.qpos0[int(m.jnt_qposadr[j])]) for j, cc in p1 if j != dep)
        d = sum(cc * (qpos[int(m.jnt_qposadr[j])] - m.qpos0[int(m.jnt_qposadr[j])]) for j, cc in p2) if p2 else 0.0
        value = sum(float(m.eq_data[e, k]) * d ** k for k in range(5))
        a = int(m.jnt_qposadr[dep])
        qpos[a] = m.qpos0[a] + (value - rest) / c
    return qpos


def tendon_couplings(m, taken=()):
    """[(equality id, dependent joint id, [(joint, c)] of tendon1, [(joint, c)] of tendon2 or None)]
    of the active ``<equality><tendon>`` couplings between fixed tendons:

        L1 - L1_0 = p0 + p1 d + ... + p4 d⁴,   d = L2 - L2_0

    (L = Σ c q, L_0 its length at qpos0).  Tendon1's first joint that is not in tendon2 and not
    already dependent (``taken``: joint couplings' joint1) becomes the dependent coordinate.
    ValueError naming the equality for what cannot be one (a spatial tendon; no free joint)."""
    import mujoco
    from .tendon import is_fixed, tendon_joints
    out, dependent = [], set(taken)
    for e in range(m.neq):
        if int(m.eq_type[e]) != int(mujoco.mjtEq.mjEQ_TENDON) or not _active(m, e):
            continue
        name = _eq_name(m, e)
        t1, t2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        t2 = None if t2 < 0 else t2
        for t in (t1, t2):
            if t is not None and not is_fixed(m, t):
                raise ValueError(f"equality {name}: tendon {_tname(m, t)} is a spatial tendon (only fixed "
                                 f"tendons are coupled)")
        p1 = tendon_joints(m, t1)
        p2 = tendon_joints(m, t2) if t2 is not None else None
        second = {j for j, _ in p2} if p2 else set()
        dep = next((j for j, c in p1 if c != 0 and j not in second and j not in dependent), None)
        if dep is None:
            raise ValueError(f"equality {name}: every joint of tendon {_tname(m, t1)} is in tendon2 or already "
                             f"set by another coupling: no coordinate to make dependent")
        dependent.add(dep)
        out.append((e, dep, p1, p2))
    return out


def _tname(m, t):
    import mujoco
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TENDON, t) or f"#{t}"


def tendon_coupling_loops(m, params, found, coordinates, speeds, joints):
    """(holonomic, velocity, jacobian rows, bias, joint names) of the tendon couplings ``found``
    (:func:`tendon_couplings`): f_h = L1 - L1_0 - P(d), f_v = L1' - P'(d) L2', γ = -P''(d) L2'²."""
    import mujoco
    first = {jid: (iq, iu) for jid, _, iq, iu in joints}
    n = len(speeds)
    hol, vel, jac, bias, tied = [], [], [], [], []
    for e, _, p1, p2 in found:
        ename = _param_name(m, e)
        p = [params(f"eq_{ename}_p{k}", m.eq_data[e, k]) for k in range(5)]

        def length(pairs):
            L = sum((sm.Float(c, 17) * (coordinates[first[j][0]] - sm.Float(float(m.qpos0[int(m.jnt_qposadr[j])]), 17))
                     for j, c in pairs), sm.S.Zero)
            V = sum((sm.Float(c, 17) * speeds[first[j][1]] for j, c in pairs), sm.S.Zero)
            return L, V
        L1, V1 = length(p1)
        row = [sm.S.Zero] * n
        for j, c in p1:
            row[first[j][1]] += sm.Float(c, 17)
        tied += [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j, _ in p1]
        if p2 is None:
            hol.append(L1 - p[0])
            vel.append(V1)
            bias.append(sm.S.Zero)
        else:
            d, V2 = length(p2)
            poly = p[0] + p[1] * d + p[2] * d ** 2 + p[3] * d ** 3 + p[4] * d ** 4
            slope = p[1] + 2 * p[2] * d + 3 * p[3] * d ** 2 + 4 * p[4] * d ** 3
            curve = 2 * p[2] + 6 * p[3] * d + 12 * p[4] * d ** 2
            hol.append(L1 - poly)
            vel.append(V1 - slope * V2)
            for j, c in p2:
                row[first[j][1]] += -slope * sm.Float(c, 17)
            bias.append(-curve * V2 ** 2)
            tied += [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j, _ in p2]
        jac.append(tuple(row))
    return hol, vel, jac, bias, tied
