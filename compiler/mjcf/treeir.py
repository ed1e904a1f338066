"""A MuJoCo model (MJCF, compiled by MuJoCo itself) straight to the recursive formulation's Tree IR.

Why MuJoCo's compiler: MJCF's ``<default>`` classes, ``childclass``, frames,
``fromto``, inertia from geoms and the angle conventions are a language of their
own; reading the compiled ``MjModel`` arrays (``body_pos``/``body_quat``,
``body_ipos``/``body_iquat``, ``body_mass``/``body_inertia``, ``jnt_*``,
``dof_damping``, ``jnt_stiffness``, ``qpos_spring``, ``actuator_*``,
``opt.gravity``) gives the kinematic tree with all of that already applied.

Per MuJoCo body, its joints are applied in order as MuJoCo's ``mj_kinematics``
does: a body with k joints becomes k tree bodies, the first k-1 massless (their
frame the body frame after the joints so far), the last carrying the mass.
Per joint, with R0, p the body frame relative to its parent's (identity and
zero for the 2nd.. joint of a body), a the axis and s the anchor (``jnt_pos``)
in the body frame, c the mass centre (``body_ipos``) and c_p the parent's
(both in their body frames), each joint is its kind's row in the table of joint
kinds (:mod:`eomc.compiler.multibody.joint_kinds`, :data:`MJCF_KINDS`: hinge ->
revolute, slide -> prismatic, ball, free) with ref = ``qpos0``; a free joint (on a
world child only) is placed in the world: its speeds are the body origin's velocity
and the angular velocity, both in body components (MuJoCo: the linear velocity in
world components -- map the states to compare).

Armature (``dof_armature``) is each speed's ``TreeBody.armature`` (parameters
``arm_<joint>``, ``arm_<joint>_<axis>`` for ball/free): M_ii += a, as MuJoCo adds
it.  Ball and free-joint angular speeds are body-frame in both, so it carries over;
a free joint's linear armature is on MuJoCo's world-frame velocity, so on eomc's
body-frame speeds it also brings a velocity term (:func:`_free_armature_load`;
the three linear values must be equal, as MJCF's one ``armature`` per joint makes them).

Joint damping, stiffness/springref and actuators (motors, position/velocity
servos, affine ``<general>``: :func:`_actuator_force`, with MuJoCo's ctrlrange and
forcerange clamps as :class:`.clamp.Clamp`) are a joint-space force tau on each
hinge/slide dof: a torque on the child about a and
its reaction on the parent about R0 a (a force along a for a slide).  What the
tree cannot express is refused with the element named (:mod:`.model` decides
what may be ignored).
"""
import numpy as np
import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.tree.model import Load, Tree
from eomc.compiler.tree.recognize import effective_inertias
from eomc.compiler.multibody.joints import identifier
from eomc.compiler.multibody.joint_kinds import KINDS, JointSite
from eomc.compiler.multibody.joints import Parameters, actuation, cross, snapped
from eomc.compiler import fixed_order as fo

__all__ = ["MjcfTree", "tree_ir", "quat_matrix"]


def quat_matrix(q):
    """The rotation matrix of MuJoCo's unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / fo.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class MjcfTree:
    """What :func:`tree_ir` returns: the Tree and the names and values beside it."""

    def __init__(self, tree, coordinates, speeds, kinematics, parameters, inputs, joints, owners=()):
        self.tree = tree
        self.coordinates = coordinates
        self.speeds = speeds
        self.kinematics = kinematics
        self.parameters = parameters      # Symbol -> value from the model
        self.inputs = inputs              # one per actuator, actuator order
        self.joints = joints              # per MuJoCo joint: (id, type, first coordinate, first speed)
        # per tree body: (MuJoCo body id, its mass centre in its frame) when it carries a MuJoCo
        # body (its last joint's tree body, or a welded one), else None (the massless 1st.. of
        # several joints); the animation's poses place the MuJoCo body frames from these
        self.owners = owners


_HINGE, _SLIDE, _BALL, _FREE = 3, 2, 1, 0
# each MuJoCo joint type's row in the table of joint kinds (eomc.compiler.multibody.joint_kinds)
MJCF_KINDS = {_HINGE: "revolute", _SLIDE: "prismatic", _BALL: "ball", _FREE: "free"}


def _names(m, kind, count, prefix):
    """C-identifier names of ``count`` MuJoCo objects of ``kind``, unnamed ones numbered, made unique."""
    import mujoco
    seen, out = set(), []
    for i in range(count):
        raw = mujoco.mj_id2name(m, kind, i) or f"{prefix}{i}"
        name = identifier(raw)
        while name in seen:
            name += f"_{i}"
        seen.add(name)
        out.append((raw, name))
    return out


def tree_ir(m, *, fold=False, actuators=None, limits=True, friction=True, quaternion=False):
    """The :class:`MjcfTree` of a compiled ``mujoco.MjModel`` ``m`` (see the module docstring);
    ``limits``/``friction``: hinge and slide range limits / frictionloss act (:func:`_law`);
    ``quaternion``: ball and free joints turn by a quaternion (w, x, y, z) as in MuJoCo's qpos
    (4 coordinates, no singularity; the integrators keep it unit) instead of body-XYZ angles.

    ``m`` must already have passed :func:`eomc.compiler.mjcf.model.check_model`."""
    import mujoco
    params = Parameters(fold)
    body_names = _names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody, "body")
    joint_names = _names(m, mujoco.mjtObj.mjOBJ_JOINT, m.njnt, "joint")
    act_names = _names(m, mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu, "actuator")
    actuators = range(m.nu) if actuators is None else actuators
    inputs = [dynamicsymbols(f"ctrl_{act_names[k][1]}") for k in actuators]
    drive = {}   # joint id -> sum of the actuators' joint forces (see _actuator_force)
    from .tendon import tendon_forces, tendon_length
    tendon_names = _names(m, mujoco.mjtObj.mjOBJ_TENDON, m.ntendon, "tendon")
    activations = []      # (act(t), act') of actuators with activation dynamics, actuator order
    servo_springs = []    # (potential, parameter names) of each servo's bias at zero control: into the energy
    for i, k in enumerate(actuators):
        j = int(m.actuator_trnid[k, 0])
        drive_by = _activation(m, params, k, act_names[k][1], inputs[i], activations)
        if int(m.actuator_trntype[k]) == int(mujoco.mjtTrn.mjTRN_TENDON):    # a fixed tendon: L = Σ c q
            L, V, pairs = tendon_length(m, j, joint_names)
            force = _actuator_force(m, params, k, act_names[k][1], drive_by, L, V, servo_springs)
            for jj, coef in pairs:
                drive[jj] = drive.get(jj, sm.S.Zero) + sm.Float(coef, 17) * force
            continue
        jn = joint_names[j][1]
        force = _actuator_force(m, params, k, act_names[k][1], drive_by, dynamicsymbols(f"q_{jn}"),
                                dynamicsymbols(f"u_{jn}"), servo_springs)
        drive[j] = drive.get(j, sm.S.Zero) + force
    tendon_springs = []      # (potential, parameter names) per fixed tendon's spring: into the energy
    for j, tau in tendon_forces(m, params, joint_names, tendon_names, limits, friction, tendon_springs).items():
        drive[j] = drive.get(j, sm.S.Zero) + tau         # fixed tendons' springs, dampers, limits, friction
    from .carried import carried_inertias
    carried = carried_inertias(m) if limits else {}    # joint id -> the inertia its limit carries
    bodies, coordinates, speeds, kinematics, loads, joints, owners = [], [], [], [], [], [], []
    quaternions = []        # each ball/free joint's w coordinate, with quaternion=True
    torques = []
    springs = [e for e, _ in tendon_springs + servo_springs]   # the joints', fixed tendons' and servos' springs
    spring_names = [n for _, names in tendon_springs + servo_springs for n in names]
    limit_laws = {}       # joint C name -> its limit law's shape, for the runtime's energy verdict
    last = {0: -1}          # MuJoCo body -> index of its mass-carrying tree body (-1: world)
    com = {0: [0, 0, 0]}
    for b in range(1, m.nbody):
        raw, s = body_names[b]
        parent = last[int(m.body_parentid[b])]
        cp = com[int(m.body_parentid[b])]
        jids = list(range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])))
        mass = params(f"m_{s}", m.body_mass[b])
        Ri = quat_matrix(m.body_iquat[b])
        I = snapped(fo.matmul(Ri, np.diag(m.body_inertia[b]), Ri.T))
        e = {key: params(f"I{key}_{s}", I[i, j]) for key, (i, j) in
             (("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("xy", (0, 1)), ("xz", (0, 2)), ("yz", (1, 2)))}
        inertia = sm.Matrix([[e["xx"], e["xy"], e["xz"]], [e["xy"], e["yy"], e["yz"]],
                             [e["xz"], e["yz"], e["zz"]]])
        c_mass = [params(f"{k}_{s}", v) for k, v in zip(("cx", "cy", "cz"), m.body_ipos[b])]
        p_body = [params(f"{k}_{s}", v) for k, v in zip(("px", "py", "pz"), m.body_pos[b])]
        R0_body = snapped(quat_matrix(m.body_quat[b]))
        if not jids:   # welded to its parent
            c = c_mass
            weld = KINDS["fixed"].mobilize(JointSite(R0_body, None, [p_body[r] - cp[r] for r in range(3)], c), (), ())
            bodies.append(weld.body(None, name=s, joint=f"{raw} (welded)", parent=parent, mass=mass, inertia=inertia))
            last[b], com[b] = len(bodies) - 1, c
            owners.append((b, tuple(c)))
            continue
        for n_j, jid in enumerate(jids):
            final = n_j == len(jids) - 1
            jraw, jn = joint_names[jid]
            kind = int(m.jnt_type[jid])
            if n_j == 0:
                p, R0, base_c = p_body, R0_body, cp
            else:
                p, R0, base_c = [0, 0, 0], np.eye(3), [0, 0, 0]
            c = c_mass if final else [0, 0, 0]
            name = s if final else f"{s}__{jn}"
            bm = mass if final else sm.S.Zero
            bI = inertia if final else sm.zeros(3, 3)
            base = [p[r] - base_c[r] for r in range(3)]
            a = snapped(m.jnt_axis[jid])
            anchor = [params(f"{k}_{jn}", v) for k, v in zip(("sx", "sy", "sz"), m.jnt_pos[jid])]
            qadr, dadr = int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])
            first_q, first = len(coordinates), len(speeds)
            joints.append((jid, kind, first_q, first))
            common = dict(name=name, joint=jraw, parent=parent, mass=bm, inertia=bI,
                          armature=_armature(m, params, jn, kind, dadr))
            names_q, names_u = KINDS[MJCF_KINDS[kind]].suffixes(quaternion)
            qs = [dynamicsymbols(f"q_{jn}" + (f"_{x}" if x else "")) for x in names_q]
            us = [dynamicsymbols(f"u_{jn}" + (f"_{x}" if x else "")) for x in names_u]
            coordinates += qs
            speeds += us
            site = JointSite(R0, a, base, c, anchor=anchor, ref=float(m.qpos0[qadr]), quaternion=quaternion,
                             placed=kind != _FREE)
            joint = KINDS[MJCF_KINDS[kind]].mobilize(site, qs, us)
            bodies.append(joint.body(first, **common))
            kinematics += joint.kinematics
            if joint.w is not None:
                quaternions.append(joint.w)
            if kind == _FREE and common["armature"] and common["armature"][0] != 0:
                loads.append(_free_armature_load(len(bodies) - 1, common["armature"][0], us, c))
            child = len(bodies) - 1
            owners.append((b, tuple(c_mass)) if final else None)
            if kind in (_HINGE, _SLIDE):
                tau = drive.get(jid, sm.S.Zero)
                damping = params(f"d_{jn}", m.dof_damping[dadr])
                stiffness = params(f"k_{jn}", m.jnt_stiffness[jid])
                if damping != 0:
                    tau = tau - damping * speeds[first]
                if stiffness != 0:
                    rest = params(f"q0_{jn}", m.qpos_spring[qadr])
                    tau = tau - stiffness * (coordinates[first_q] - rest)
                    springs.append(stiffness * (coordinates[first_q] - rest) ** 2 / 2)
                    spring_names += [str(s) for s in (stiffness, rest) if isinstance(s, sm.Symbol)]
                tau = tau + _law(m, jid, jraw, jn, coordinates[first_q], speeds[first], params,
                                 limits, friction, carried.get(jid, 0.0), limit_laws)
                torques.append((coordinates[first_q], speeds[first], tau))
                if tau != 0:
                    loads += actuation(kind == _SLIDE, tau, a, R0, c, p, base_c, child, parent)
            elif kind == _BALL and m.dof_damping[dadr] != 0:
                ds = [params(f"d_{jn}_{x}", m.dof_damping[dadr + x]) for x in range(3)]
                moment = sm.Matrix([-ds[x] * speeds[first + x] for x in range(3)])
                loads.append(Load(body=child, frame="body", moment=moment, force=sm.zeros(3, 1),
                                  offset=sm.zeros(3, 1)))
                if parent >= 0:
                    body_R = bodies[child].rotation.T   # R_PC: the child's moment in parent components
                    back = [sum((body_R[r, k] * (-moment[k]) for k in range(3)), sm.S.Zero) for r in range(3)]
                    loads.append(Load(body=parent, frame="body", moment=sm.Matrix(back), force=sm.zeros(3, 1),
                                      offset=sm.zeros(3, 1)))
            parent = child
        last[b], com[b] = len(bodies) - 1, c_mass
    gravity = sm.Matrix([params(f"g{x}", v) for x, v in zip("xyz", m.opt.gravity)])
    # joint equalities: holonomic constraints, joint1's state last (compiler/mjcf/equality.py)
    from .equality import coupled_states, coupling_loops, couplings, tendon_couplings
    found = couplings(m)
    tied = tendon_couplings(m, [j1 for _, j1, _ in found])      # <equality><tendon>: after them
    bodies, coordinates, speeds, kinematics, joints = coupled_states(
        bodies, coordinates, speeds, kinematics, joints, [j1 for _, j1, _ in found] + [t[1] for t in tied])
    bodies = effective_inertias(bodies, coordinates, speeds, kinematics)
    ir = Tree(bodies=tuple(bodies), coordinates=tuple(coordinates), speeds=tuple(speeds),
              kinematics=tuple(kinematics), gravity=gravity, loads=tuple(loads),
              quaternions=tuple(coordinates.index(w) for w in quaternions),
              joint_torques=tuple(torques),
              spring_energy=sum(springs, sm.S.Zero) if springs else None, spring_parameters=tuple(spring_names),
              activations=tuple(a for a, _ in activations))
    if found or tied:
        from eomc.compiler.tree.constrained import attach
        ir = attach(ir, coupling_loops(m, params, found, coordinates, speeds, joints, joint_names, tied))
    out = MjcfTree(ir, tuple(coordinates), tuple(speeds), tuple(kinematics), params.values, inputs,
                   tuple(joints), tuple(owners))
    out.activations = tuple(activations)
    out.limit_laws = limit_laws
    return out


_DYN_INTEGRATOR, _DYN_FILTER, _DYN_FILTEREXACT = 1, 2, 3


def _activation(m, params, k, name, ctrl, activations):
    """What drives actuator ``k``'s force: its control, or -- with activation dynamics -- its
    activation state act(t) (``act_<actuator>``, appended to ``activations`` with its rate), as
    MuJoCo's mj_fwdActuation has it: the control clamped to ``ctrlrange`` when ctrllimited, then
    act' = ctrl (``dyntype="integrator"``) or act' = (ctrl - act)/τ with τ = ``dynprm[0]``
    (``filter``, ``filterexact``: the same rate; MuJoCo's step integrates the latter exactly),
    and the force gain·act + bias.  ``actlimited``, ``actearly`` and muscle/user dynamics are
    refused by the model check."""
    dyn = int(m.actuator_dyntype[k])
    if dyn == 0:
        return ctrl
    u = _clamped(ctrl, *m.actuator_ctrlrange[k]) if m.actuator_ctrllimited[k] else ctrl
    act = dynamicsymbols(f"act_{name}")
    if dyn == _DYN_INTEGRATOR:
        rate = u
    else:
        tau = params(f"tau_{name}", max(float(m.actuator_dynprm[k, 0]), 1e-15))
        rate = (u - act) / tau
    activations.append((act, rate))
    return _Activation(act)


class _Activation:
    """An activation state given to :func:`_actuator_force` in place of the control: not clamped
    again (MuJoCo clamps the control before the dynamics, not the activation)."""

    def __init__(self, symbol):
        self.symbol = symbol


def _clamped(value, low, high):
    from .clamp import Clamp
    return Clamp(value, sm.Float(float(low)), sm.Float(float(high)))


def _actuator_force(m, params, k, name, ctrl, q, u, springs=None):
    """The joint force of actuator ``k`` on its hinge/slide joint (coordinate ``q``, speed ``u``),
    as MuJoCo's mj_fwdActuation computes it without activation dynamics: the control clamped to
    ``ctrlrange`` when ctrllimited, force = gain·ctrl + bias with gain = g0 (+ g1 L + g2 V when
    affine), bias = b0 + b1 L + b2 V (affine; a position servo is b1 = -kp, a velocity servo
    b2 = -kv), L = gear·q and V = gear·u the actuator's length and velocity, the force clamped to
    ``forcerange`` when forcelimited, and gear·force on the joint.  A plain motor keeps one
    parameter ``gear_<actuator>`` = gear·gain.

    ``springs``: a list to which a servo's bias at zero control is appended as (its potential,
    the parameter names it holds) when that bias is a spring and a damper: F = b0 + b1 L + b2 V
    with b2 <= 0 does the work of the potential -(b0 L + b1 L²/2) plus a damper's (gear·F on
    the joint, L = gear·q; on a fixed tendon's coordinates c_i gear·F, L = gear·Σ c_i q_i); with
    activation dynamics the force is gain·act + bias, the bias alone at act = 0 (the runtime judges
    only runs that start there).  Not with a force or control range that clamps (a clamped spring and damper are one law; a range without 0 pushes at zero
    control), or b2 > 0: such a bias stays out, and the model gets no energy output
    (compiler/contact/tree.energy_blockers)."""
    gear = float(m.actuator_gear[k, 0])
    if isinstance(ctrl, _Activation):
        ctrl = ctrl.symbol
    elif m.actuator_ctrllimited[k]:
        ctrl = _clamped(ctrl, *m.actuator_ctrlrange[k])
    affine_gain, affine_bias = int(m.actuator_gaintype[k]) == 1, int(m.actuator_biastype[k]) == 1
    if not (affine_gain or affine_bias or m.actuator_forcelimited[k]):    # a plain motor
        return params(f"gear_{name}", gear * float(m.actuator_gainprm[k, 0])) * ctrl
    g = params(f"gear_{name}", gear)
    length, velocity = g * q, g * u
    gp, bp = m.actuator_gainprm[k], m.actuator_biasprm[k]
    gain = params(f"gain_{name}", gp[0])
    if affine_gain:
        gain += params(f"gain1_{name}", gp[1]) * length + params(f"gain2_{name}", gp[2]) * velocity
    force = gain * ctrl
    if affine_bias:
        b0, b1, b2 = (params(f"bias{x}_{name}", bp[x]) for x in range(3))
        force += b0 + b1 * length + b2 * velocity
        low, high = (float(x) for x in m.actuator_ctrlrange[k])
        # with activation dynamics too: at act = 0 the force is the bias (a run is judged only
        # from act = 0, where a zero control keeps it: compiler/contact/tree.energy_blockers)
        if springs is not None and not m.actuator_forcelimited[k] \
                and (not m.actuator_ctrllimited[k] or low <= 0.0 <= high) and float(bp[2]) <= 0.0:
            springs.append((-(b0 * length + b1 * length ** 2 / 2),
                            [str(x) for x in (g, b0, b1, b2) if isinstance(x, sm.Symbol)]))
    if m.actuator_forcelimited[k]:
        force = _clamped(force, *m.actuator_forcerange[k])
    return g * force


def _free_armature_load(body, a, us, c):
    """The velocity term of a free joint's linear armature ``a`` (the same on its three linear
    dofs: check_model refuses others).  MuJoCo adds a·I to M on its world-frame linear dofs, so
    its generalized force there is a·d(R v)/dt = R a (v' + ω × v) with v, ω eomc's body-frame
    speeds: on eomc's linear speeds a (v' + ω × v) -- a v' is the armature on D, and this load is
    the rest, -a ω × v, a force at the MuJoCo body origin (offset -c from the mass centre) so
    that it does no work on the angular speeds."""
    v, w = us[:3], us[3:]
    force = sm.Matrix([-a * x for x in cross(list(w), list(v))])
    return Load(body=body, frame="body", moment=sm.zeros(3, 1), force=force,
                offset=sm.Matrix([-sm.sympify(x) for x in c]))


def _armature(m, params, jn, kind, dadr):
    """The joint's armature per speed (MuJoCo's ``dof_armature``; () when all zero); a free
    joint's linear ones come with :func:`_free_armature_load`."""
    n = {_HINGE: 1, _SLIDE: 1, _BALL: 3, _FREE: 6}[kind]
    values = [float(x) for x in m.dof_armature[dadr:dadr + n]]
    if not any(values):
        return ()
    if n == 1:
        return (params(f"arm_{jn}", values[0]),)
    axes = ("x", "y", "z") if kind == _BALL else ("vx", "vy", "vz", "wx", "wy", "wz")
    return tuple(params(f"arm_{jn}_{x}", v) for x, v in zip(axes, values))


def _law(m, jid, jraw, jn, q, u, params, limits, friction, carried=0.0, record=None):
    """The range limit and frictionloss of a hinge or slide (:mod:`eomc.compiler.tree.joint_laws`).

    The limit's stiffness and damping follow the joint's ``solref`` and ``solimp`` by
    :func:`eomc.compiler.contact.mujoco_law.limit_spring` (it gives under a steady load as
    MuJoCo's limit does; damping ratio z), with the joint's effective inertia
    1/``dof_invweight0`` (MuJoCo's own scale).  MuJoCo's limit is a soft constraint solved with
    the other constraints (impedance, ``margin``): here it is a spring-damper, so the motion
    past the limit differs (docs/contact.md says how); inside the range both exert nothing.
    On a free-floating robot the scale grows with the inertia the joint ``carried`` when its
    subtree holds the robot up (:mod:`.carried`), saturating as MuJoCo's regularised solver
    does (``limit_spring``'s ``carried``): MuJoCo's limit stops what the joint moves within
    its time constant, up to 1/(1 - dmax) times the joint's own inertia."""
    from eomc.compiler.contact.mujoco_law import limit_spring
    from eomc.compiler.tree.joint_laws import JointLaw, joint_torque, law_shape
    from .options import refsafe_step
    dadr = int(m.jnt_dofadr[jid])
    lower = upper = None
    if limits and m.jnt_limited[jid]:
        lower, upper = (float(v) for v in m.jnt_range[jid])
    fl = float(m.dof_frictionloss[dadr]) if friction else 0.0
    inertia = 1.0 / float(m.dof_invweight0[dadr]) if m.dof_invweight0[dadr] > 0 else 1.0
    k, c, hold = limit_spring(inertia, m.jnt_solref[jid], m.jnt_solimp[jid], refsafe_step(m), carried)
    law = JointLaw(jraw, lower=lower, upper=upper, friction=fl, stiffness=k, limit_damping=c, unilateral=True,
                   hold=hold)
    tau = joint_torque(q, u, law, params, jn, inertia)      # JointLawError: the caller places it
    if record is not None and law.limited:
        record[jn] = law_shape(law)
    return tau
