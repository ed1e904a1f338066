"""MuJoCo's fixed tendons (``<tendon><fixed>``) as joint-space forces on the tree.

One job: a fixed tendon's length is L = Σ c_j q_j over its joints (hinge or slide
coordinates, MuJoCo's ``qpos``), its velocity L' = Σ c_j u_j; a force f along the tendon acts
on joint j as c_j f.  The tendon's own forces, as MuJoCo's ``mj_passive`` and limit/friction
constraints act:

- spring: -k (L - L_s) with L_s the ``springlength`` (``tendon_lengthspring``; with two
  values, a dead band: no force between them);
- damper: -b L';
- range limits and ``frictionloss``: the joint-limit law of :mod:`eomc.compiler.tree.joint_laws`
  on L (soft limit with MuJoCo's ``solreflimit``/``solimplimit`` gains scaled by the
  tendon's effective inertia 1/``tendon_invweight0``; regularised Coulomb friction), with
  parameters named ``..._tendon_<name>``;
- an actuator whose transmission is the tendon: its force (length gear·L) times gear on L.

Spatial tendons (sites, wrapping) are not here: :func:`eomc.compiler.mjcf.model.check_model`
refuses them when they act.
"""
import sympy as sm
from sympy.physics.vector import dynamicsymbols

__all__ = ["is_fixed", "tendon_joints", "tendon_length", "tendon_force", "tendon_forces"]

_WRAP_JOINT = 1


def is_fixed(m, t):
    """True when tendon ``t`` is a fixed tendon (every wrap is a joint)."""
    adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
    return num > 0 and all(int(m.wrap_type[w]) == _WRAP_JOINT for w in range(adr, adr + num))


def tendon_joints(m, t):
    """[(joint id, coefficient)] of fixed tendon ``t``."""
    adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
    return [(int(m.wrap_objid[w]), float(m.wrap_prm[w])) for w in range(adr, adr + num)]


def tendon_length(m, t, joint_names, params=None):
    """(L, L', [(joint id, coefficient)]) of fixed tendon ``t`` in the tree's coordinates
    ``q_<joint>`` and speeds ``u_<joint>``."""
    pairs = tendon_joints(m, t)
    L = sum((sm.Float(c, 17) * dynamicsymbols(f"q_{joint_names[j][1]}") for j, c in pairs), sm.S.Zero)
    V = sum((sm.Float(c, 17) * dynamicsymbols(f"u_{joint_names[j][1]}") for j, c in pairs), sm.S.Zero)
    return L, V, pairs


def tendon_force(m, t, raw, name, L, V, params, limits=True, friction=True, springs=None):
    """Tendon ``t``'s force along its length L (speed V): MuJoCo's spring (a dead band between
    ``lengthspring``'s two lengths), damper, limits (its solref/solimp as a stiff law) and
    friction loss, in the parameters ``k_``/``L0_``/``d_`` ... ``<name>`` (0: none acts).
    Fixed tendons (here) and site tendons (:mod:`.spatial`) share it.  ``springs``: a list to
    append the spring's (potential, names of its parameters) to -- k/2 (L - L0)², or with the dead
    band k/2 (ramp(L - L0hi)² + ramp(L0lo - L)²): minus its gradient in L is the spring's force."""
    from eomc.compiler.contact.mujoco_law import limit_spring
    from eomc.compiler.tree.joint_laws import JointLaw, joint_torque, ramp
    f = sm.S.Zero
    if m.tendon_stiffness[t]:
        k = params(f"k_{name}", float(m.tendon_stiffness[t]))
        low, high = (float(x) for x in m.tendon_lengthspring[t])
        if low == high:
            rest = (params(f"L0_{name}", low),)
            f += -k * (L - rest[0])
            energy = k * (L - rest[0]) ** 2 / 2
        else:
            rest = (params(f"L0hi_{name}", high), params(f"L0lo_{name}", low))
            f += -k * (ramp(L - rest[0]) - ramp(rest[1] - L))
            energy = k * (ramp(L - rest[0]) ** 2 + ramp(rest[1] - L) ** 2) / 2
        if springs is not None:
            springs.append((energy, [str(s) for s in (k, *rest) if isinstance(s, sm.Symbol)]))
    if m.tendon_damping[t]:
        f += -params(f"d_{name}", float(m.tendon_damping[t])) * V
    lower = upper = None
    if limits and m.tendon_limited[t]:
        lower, upper = (float(x) for x in m.tendon_range[t])
    fl = float(m.tendon_frictionloss[t]) if friction else 0.0
    if lower is not None or fl:
        inertia = 1.0 / float(m.tendon_invweight0[t]) if m.tendon_invweight0[t] > 0 else 1.0
        from .options import refsafe_step
        kl, cl, hold = limit_spring(inertia, m.tendon_solref_lim[t], m.tendon_solimp_lim[t], refsafe_step(m))
        law = JointLaw(f"tendon {raw}", lower=lower, upper=upper, friction=fl, stiffness=kl, limit_damping=cl,
                       unilateral=True, hold=hold)
        f += joint_torque(L, V, law, params, name, inertia)
    return f


def tendon_forces(m, params, joint_names, tendon_names, limits=True, friction=True, springs=None):
    """{joint id: generalized force} of every fixed tendon's spring, damper, limits and friction;
    ``springs``: a list to append each spring's (potential, parameter names) to (:func:`tendon_force`)."""
    out = {}
    for t in range(m.ntendon):
        if not is_fixed(m, t):
            continue
        raw, tn = tendon_names[t]
        name = f"tendon_{tn}"
        L, V, pairs = tendon_length(m, t, joint_names)
        f = tendon_force(m, t, raw, name, L, V, params, limits, friction, springs)
        if f == 0:
            continue
        for j, c in pairs:
            out[j] = out.get(j, sm.S.Zero) + sm.Float(c, 17) * f
    return out
