"""MuJoCo's contact parameters (solref, solimp, friction) as the parameters of eomc's law.

One job: the documented rule of :mod:`eomc.compiler.mjcf.collision` (its module docstring
states it) that turns MuJoCo's soft-constraint parameters into eomc's smooth law's
(:mod:`.law`): k from MuJoCo's resting penetration, c from the damping ratio of
``solref``, mu the sliding friction.  Two readers use it: MJCF files (each geom's own
parameters) and URDF robots put on the ground (MuJoCo's defaults, :data:`MUJOCO_DEFAULTS`,
since URDF has no contact parameters).
"""
import math

__all__ = ["law_parameters", "resting_depth", "limit_spring", "MUJOCO_DEFAULTS", "MINVAL"]

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


def limit_spring(inertia, solref, solimp):
    """(k, c) of MuJoCo's soft limit (a joint's or a tendon's) as a spring-damper: its reference
    acceleration -b v - k r with k = 1/(dmax² tc² z²), b = 2/(dmax tc) (``solref`` = (tc, z),
    dmax = ``solimp[1]``), times the effective ``inertia``; a negative ``solref`` gives k, b
    directly."""
    tc, z = (float(v) for v in solref[:2])
    dmax = float(solimp[1])
    if tc > 0:
        return inertia / (dmax * tc * z) ** 2, 2.0 * inertia / (dmax * tc)
    return -tc * inertia / dmax ** 2, -z * inertia / dmax
