"""MuJoCo's contact parameters (solref, solimp, friction) as the parameters of eomc's law.

One job: the documented rule of :mod:`eomc.compiler.mjcf.collision` (its module docstring
states it) that turns MuJoCo's soft-constraint parameters into eomc's smooth law's
(:mod:`.law`): k from MuJoCo's resting penetration, c from the damping ratio of
``solref``, mu the sliding friction.  Two readers use it: MJCF files (each geom's own
parameters) and URDF robots put on the ground (MuJoCo's defaults, :data:`MUJOCO_DEFAULTS`,
since URDF has no contact parameters).
"""
import math

__all__ = ["law_parameters", "resting_depth", "limit_spring", "HOLD_WIDTH", "MUJOCO_DEFAULTS", "MINVAL", "MINMU", "spin_parameters"]

MINVAL = 1e-15                 # mjMINVAL
# MuJoCo's default contact: solref, solimp, friction (sliding, torsional, rolling)
MUJOCO_DEFAULTS = {"solref": (0.02, 1.0), "solimp": (0.9, 0.95, 0.001, 0.5, 2.0), "friction": (1.0, 0.005, 1e-4)}


def _impedance(solimp, r):
    """MuJoCo's d(r) (mju_impedance-like: solimp = d0, dmax, width, midpoint, power)."""
    d0, dmax, width, mid, power = (float(x) for x in solimp[:5])
    d0, dmax = min(max(d0, 1e-4), 0.9999), min(max(dmax, 1e-4), 0.9999)
    if width <= MINVAL or d0 == dmax:
        return 0.5 * (d0 + dmax)
    x = min(abs(r) / width, 1.0)
    if x >= 1.0:
        return dmax
    power = max(power, 1.0)
    if power == 1:
        y = x
    elif x <= mid:
        y = x ** power / mid ** (power - 1)
    else:
        y = 1 - (1 - x) ** power / (1 - mid) ** (power - 1)
    return d0 + y * (dmax - d0)


def resting_depth(solref, solimp, g, timestep=None):
    """(δ_ref, damping ratio z): MuJoCo's penetration of a contact at rest under gravity ``g``
    and the ratio of its damping (see the module docstring)."""
    tc, z = float(solref[0]), float(solref[1])
    dmax = min(max(float(solimp[1]), 1e-4), 0.9999)
    if tc > 0 and timestep:
        tc = max(tc, 2.0 * timestep)
    r = 1e-3
    for _ in range(200):
        d = _impedance(solimp, r)
        if tc > 0:
            k = d / (dmax * tc * z) ** 2 if z > 0 else d / (dmax * tc) ** 2
        else:
            k = d * -tc / dmax ** 2
        new = (1 - d) * g / (d * k)
        if abs(new - r) <= 1e-15 + 1e-12 * r:
            r = new
            break
        r = 0.5 * (r + new)
    if tc > 0:
        ratio = z if z > 0 else 1.0
    else:
        ratio = (-z / dmax) / (2.0 * math.sqrt(-tc / dmax ** 2)) if tc < 0 and z < 0 else 1.0
    return r, ratio


def law_parameters(solref, solimp, friction, condim, g, weight, timestep=None):
    """(k, c, mu) of eomc's law for MuJoCo's contact parameters (the module docstring's rule);
    ``weight`` (N) is what the geom carries when it alone holds its robot."""
    depth, ratio = resting_depth(solref, solimp, g, timestep)
    k = weight / depth ** 1.5
    omega = math.sqrt(1.5 * g / depth)
    c = 2.0 * ratio * omega / (1.5 * g)
    mu = 0.0 if condim == 1 else float(friction[0])
    return k, c, mu


MINMU = 1e-5       # MuJoCo's mjMINMU: mj_assignFriction raises every friction coefficient to at least this


def spin_parameters(friction, condim):
    """(mut, mur): the torsional and rolling friction of a contact of MuJoCo's ``condim`` with
    ``friction`` = (sliding, torsional, rolling) -- a geom's three numbers, or a mixed pair's
    (:func:`eomc.compiler.mjcf.collision._mix`: the larger of each) -- None where the condim has
    no such rows: torsional from condim 4, rolling from 6 (MuJoCo's rows 4 and 5-6,
    engine_core_constraint.c).  Lengths (m), the bound of the moment per newton of normal force,
    as MuJoCo uses them, raised to MINMU as mj_assignFriction raises them
    (eomc.compiler.contact.law.spin_moment)."""
    mut = max(MINMU, float(friction[1])) if condim >= 4 else None
    mur = max(MINMU, float(friction[2])) if condim >= 6 else None
    return mut, mur


HOLD_WIDTH = 0.001     # rad (m): within about this of its limit a MuJoCo limit's spring holds (limit_spring)


def limit_spring(inertia, solref, solimp, timestep=None, carried=0.0):
    """(K, C, hold) of MuJoCo's soft limit (a joint's or a tendon's) as eomc's spring-damper
    (:class:`eomc.compiler.tree.joint_laws.JointLaw`): it meets an impact as MuJoCo's does and
    gives under a steady load as MuJoCo's does.

    MuJoCo's limit is a soft constraint with reference acceleration -b v - k r, k = 1/(dmax² tc²
    z²), b = 2/(dmax tc) (``solref`` = (tc, z), tc at least 2 time steps unless refsafe is off;
    a negative ``solref`` gives k = -tc/dmax², b = -z/dmax), impedance d (``solimp``; dmax past
    its width); its force is -d·τ - d·m̃·(b v + k r), τ the load, m̃ the effective ``inertia``.
    Far past the limit (an impact, a start outside the range) the reference acceleration
    dominates: K = m̃·k, C = m̃·b.  Under a steady load the cancelled fraction d of τ does: it
    rests where d·k·r = (1 - d)·τ/m̃, the give of a spring G·K, G = d/(1 - d) (19 at MuJoCo's
    default dmax 0.95).  ``hold`` = (G, HOLD_WIDTH): the spring's stretch is
    r + (G - 1)·w·tanh(r/w), slope G within about w = 1 mrad (mm) of the limit and 1 beyond,
    where it pushes (G - 1)·w·K more than K·r.  Why both: gymnasium's hopper and walker rest
    leaning on their limits (with K alone the hopper came to rest 27 mm below MuJoCo's after 15 s,
    the walker's feet 0.036 rad further past their limits at MuJoCo's rest pose), while the ant
    starts 0.52 rad outside its ankle ranges and its touch-down time follows the limits' throw
    (G·K throughout: 40 % late).  w was chosen by measurement (benchmarks/bench_mjcf_drops.py,
    15 s): 5 mrad: ant touch-down +10 %, hopper rest -3.6 mm; 2.5 mrad: +3.9 %, -3.7 mm; 1 mrad:
    +1.6 %, -3.7 mm, walker +3.2 mm (as MuJoCo's default solimp width, where its impedance
    reaches dmax, by coincidence).  No spring-damper is MuJoCo's limit: its force cancels a
    fraction of whatever load there is, which a function of r and v alone cannot.

    ``carried``: the inertia m_c the joint moves when it stops more than itself (a knee catching
    the body it stands under: :mod:`eomc.compiler.mjcf.carried`).  MuJoCo's solver sees the
    limit's row with the effective inertia m_s = 1/(J M⁻¹ Jᵀ) the other constraints leave it
    (a Schur complement), but regularises it with R = (1 - d)/d·A₀, A₀ = 1/``inertia``
    (``dof_invweight0``, its diagonal approximation): the row's force on the reference
    acceleration is aref/(1/m_s + R).  So the scale saturates: m̃ = m·m_c/(d·m + (1 - d)·m_c)
    (m at m_c = m, at most m/(1 - d), 20 m at dmax 0.95, however much the joint carries; the
    carried inertia itself as the scale held gymnasium's humanoid knees 20 times too tight).
    At rest the same algebra gives MuJoCo's give d·k·r = (1 - d)·τ/(d·m): the carried inertia
    drops out, so ``hold``'s G is divided by m̃/m (at least 1) and the spring still gives
    under a steady load what the joint's own inertia makes it give."""
    tc, z = (float(v) for v in solref[:2])
    dmax = min(max(float(solimp[1]), 1e-4), 0.9999)
    if tc > 0:
        if timestep:
            tc = max(tc, 2.0 * timestep)
        k = 1.0 / (dmax * tc * z) ** 2 if z > 0 else 1.0 / (dmax * tc) ** 2
        b = 2.0 / (dmax * tc)
    else:
        k, b = -tc / dmax ** 2, -z / dmax
    G = dmax / (1.0 - dmax)
    scale = inertia
    if carried > inertia:
        scale = inertia * carried / (dmax * inertia + (1.0 - dmax) * carried)
    return scale * k, scale * b, (max(1.0, G * inertia / scale), HOLD_WIDTH)
