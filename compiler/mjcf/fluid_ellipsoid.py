"""MuJoCo's fluid forces, ellipsoid model (``<geom fluidshape="ellipsoid" fluidcoef="...">``).

One job: the force and torque MuJoCo's ``mj_ellipsoidFluidModel`` puts on each geom that asks
for it, written with the recursion's velocities.  A body uses this model when any of its geoms
asks for it, and then only those geoms act (the inertia box of :mod:`.fluid` is off for it).

Each such geom is the ellipsoid of its semi-axes s (sphere r,r,r; capsule r,r,h+r; cylinder
r,r,h; else the three sizes) in the geom's frame.  With ω the body's angular velocity and u the
geom origin's velocity minus the wind, both in geom components, ρ the density and μ the
viscosity, ``geom_fluid`` = [on, C_blunt, C_slender, C_ang, C_kutta, C_magnus, m_v(3), I_v(3)]
(the five ``fluidcoef`` and MuJoCo's compiled virtual mass and inertia), the geom gets
(torque τ, force f, about its origin, geom components), everything times ``on``:

- added mass, velocity part: p = ρ m_v∘u, L = ρ I_v∘ω; f += p×ω, τ += p×u + L×ω.  MuJoCo's
  ``mj_addedMassForces`` leaves the acceleration part -ρ(I_v∘ω̇, m_v∘u̇) out ("disabled due to
  dependency on qacc"), so mj_forward's qacc has no added inertia: neither has this model (it
  would be an added term of M(q), which eomc could hold; it would no longer be MuJoCo's qacc);
- Magnus lift: f += C_magnus ρ V (ω×u), V = 4/3 π s0 s1 s2;
- Kutta lift: with n = ((s1 s2)² u0, (s2 s0)² u1, (s0 s1)² u2), D = Σ (s_j s_k)⁴ u_i²,
  N = Σ (s_j s_k u_i)², A_proj = π sqrt(D / N), cos α = N / (|u| D):
  Γ = C_kutta ρ cos α A_proj (n×u), f += Γ×u;
- drag: f -= (μ 3π d + ρ|u| (C_blunt A_proj + C_slender (A_max - A_proj))) u, with
  d = 2/3 Σ s, A_max = π s_max s_mid; τ -= (μ π d³ + ρ |m|) ω with
  m_i = ω_i (C_ang I_i + C_slender (I_max - I_i)), I_i = 8/15 π s_i max(s_j, s_k)⁴,
  I_max = 8/15 π s_mid s_max⁴;

turned into the body frame and applied at the geom's origin.

A_proj and cos α are computed as MuJoCo 4.0 does (the installed ``mujoco`` 4.0.0; its
upstream change CL 983912679, described in mujoco_warp PR 1679): with the semi-axes over
s_max and u over |u|, so D and N are the scale-free D' = D/(s_max⁸|u|²), N' = N/(s_max⁴|u|²).
MuJoCo 3.x clamped the dimensional N and |u|·D at mjMINVAL = 1e-15, which cut the Kutta lift
and A_proj of millimetre geoms at every speed; 4.0.0 has no such floor (probed: the Kutta force
of a 3x2x1 mm ellipsoid is exactly |u|² times that at |u| = 1 from |u| = 1e-15 to 1e3) and
instead sets A_proj = 0 when N' <= ε (a needle of 1e-5 aspect moving along its axis: no
blunt drag) and the Kutta lift to 0 when |u| <= ε.  Both cut-offs are written with
``step`` (C: a compare), the divisions they guard floored at 1e-150 (finite at rest, and so are their slopes).
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm

from ..contact.law import step
from ..contact.tree import LoweredLoad
from ..tree.joint_laws import ramp
from ..tree.spatial import cross
from .fluid_frame import add_body_load, relative_velocity

__all__ = ["EllipsoidFluidLoad", "semi_axes", "uses_ellipsoid", "geom_fluid_forces", "root"]

MINVAL = 1e-15
_SPHERE, _CAPSULE, _CYLINDER = 2, 3, 5


def semi_axes(size, kind):
    """The semi-axes MuJoCo's fluid model gives a geom of ``size`` and type ``kind``."""
    r, h, z = (float(x) for x in size)
    if kind == _SPHERE:
        return (r, r, r)
    if kind == _CAPSULE:
        return (r, r, h + r)
    if kind == _CYLINDER:
        return (r, r, h)
    return (r, h, z)


def uses_ellipsoid(m, b):
    """The geoms of MuJoCo body ``b`` that ask for the ellipsoid model (empty: the inertia box)."""
    start = int(m.body_geomadr[b])
    return [g for g in range(start, start + int(m.body_geomnum[b])) if m.geom_fluid[g][0] != 0]


class root(sm.Function):
    """sqrt(s) for s >= 0 whose derivative is taken as 0 at s = 0 (printed ``sqrt`` in C).
    Why: |u| = root(u·u) has the bounded slope u/|u|, but SymPy's sqrt differentiates to
    u/sqrt(u·u), 0/0 at rest -- jac_x of a swimmer at rest was non-finite.  Here the slope is
    step(s)/max(2 root(s), 1e-150): 1/(2 sqrt(s)) for every s > 0 a double holds,
    0 at s = 0."""
    nargs = 1

    @classmethod
    def eval(cls, x):
        if x.is_Number:
            return sm.sqrt(x)

    def fdiff(self, argindex=1):
        return step(self.args[0]) / _at_least(2 * self)

    def _eval_evalf(self, prec):
        return sm.sqrt(self.args[0]).evalf(prec)

    def _ccode(self, printer):
        return f"sqrt({printer._print(self.args[0])})"

    def _numpycode(self, printer):
        return f"numpy.sqrt({printer._print(self.args[0])})"

    def _pythoncode(self, printer):
        return f"math.sqrt({printer._print(self.args[0])})"


TINY = 1e-150


def _at_least(x):
    """max(x, 1e-150) for x >= 0, written TINY + ramp(x - TINY) (C: fmax; its slope a step):
    a division's floor that leaves every x above 1e-134 exact (x ± 1e-150 rounds to x) and
    keeps 0/0 at rest finite (0).  Not 1e-300: a quotient's slope divides by its square."""
    return TINY + ramp(x - TINY)


def _f(x):
    return sm.Float(float(x), 17)


def geom_fluid_forces(w, u, rho, mu, s, coef, let=lambda x: x):
    """(τ, f) of the module docstring: ``w``, ``u`` in geom components (SymPy or numbers),
    ``s`` the semi-axes, ``coef`` the geom's 12 ``geom_fluid`` numbers; ``let`` names a
    temporary (the recursion's Recorder)."""
    on, blunt, slender, ang, kutta, magnus = (float(x) for x in coef[:6])
    vmass, vinertia = [float(x) for x in coef[6:9]], [float(x) for x in coef[9:12]]
    s0, s1, s2 = s
    # added mass, velocity part
    p = [let(rho * _f(vmass[k]) * u[k]) for k in range(3)]
    L = [let(rho * _f(vinertia[k]) * w[k]) for k in range(3)]
    force = list(cross(p, w))
    torque = [a + b for a, b in zip(cross(p, u), cross(L, w))]
    # Magnus lift
    volume = 4.0 / 3.0 * np.pi * s0 * s1 * s2
    wxu = cross(w, u)
    force = [force[k] + _f(magnus * volume) * rho * wxu[k] for k in range(3)]
    # Kutta lift, in MuJoCo 4's scale-free form (module docstring)
    d_max = max(s)
    pair = tuple(a * b / d_max ** 2 for a, b in ((s1, s2), (s2, s0), (s0, s1)))
    usq = [let(x * x) for x in u]
    uu = let(usq[0] + usq[1] + usq[2])
    denom = let(sum((_f(pair[k] ** 4) * usq[k] for k in range(3)), sm.S.Zero))
    num = let(sum((_f(pair[k] ** 2) * usq[k] for k in range(3)), sm.S.Zero))
    speed = let(root(uu))
    seen = let(step(num - _f(MINVAL) * uu))           # N' > ε: else A_proj = 0
    a_proj = let(_f(np.pi * d_max ** 2) * seen * root(denom / _at_least(num)))
    moving = let(step(speed - _f(MINVAL)))           # |u| > ε: else no Kutta lift
    cos_alpha = moving * num / _at_least(speed * denom)
    normal = [_f(pair[k] ** 2) * u[k] for k in range(3)]
    scale = let(_f(kutta) * rho * cos_alpha * a_proj)
    circ = [let(scale * x) for x in cross(normal, u)]
    lift = cross(circ, u)
    # drag: Stokes plus blunt/slender (linear), angular
    d_min = min(s)
    d_mid = s0 + s1 + s2 - d_max - d_min
    a_max = np.pi * d_max * d_mid
    diam = 2.0 / 3.0 * (s0 + s1 + s2)
    i_max = 8.0 / 15.0 * np.pi * d_mid * d_max ** 4
    moment = [8.0 / 15.0 * np.pi * s[k] * max(s[(k + 1) % 3], s[(k + 2) % 3]) ** 4 for k in range(3)]
    mom = [_f(ang * moment[k] + slender * (i_max - moment[k])) * w[k] for k in range(3)]
    drag_lin = let(_f(3.0 * np.pi * diam) * mu
                   + rho * speed * (_f(blunt - slender) * a_proj + _f(slender * a_max)))
    drag_ang = let(_f(np.pi * diam ** 3) * mu + rho * root(sum((x * x for x in mom), sm.S.Zero)))
    torque = [torque[k] - drag_ang * w[k] for k in range(3)]
    force = [force[k] + lift[k] - drag_lin * u[k] for k in range(3)]
    if on != 1.0:
        torque, force = [_f(on) * x for x in torque], [_f(on) * x for x in force]
    return [let(x) for x in torque], [let(x) for x in force]


@dataclass(frozen=True)
class EllipsoidFluidLoad(LoweredLoad):
    """A body's ellipsoid-model fluid force (its asking geoms'), computed in :meth:`lower` from
    its velocity (``frame == "contact"`` keeps it out of the plain loads)."""
    body: int
    name: str
    com: tuple                          # the mass centre (the tree body's origin) in the body frame
    geoms: tuple                        # per geom: (position (body frame), rotation rows geom -> body,
    #                                     semi-axes, geom_fluid's 12 numbers)
    density: object                     # Symbol (or number when folded)
    viscosity: object
    wind: tuple                         # world

    @property
    def passive_fluid(self):
        """Does the force only take energy out (compiler/contact/tree.energy_blockers)?  With no
        wind u is the geom origin's velocity, where the force acts, so the power is f·u + τ·ω:
        the added mass's (p×ω)·u + (p×u)·ω = p·(ω×u + u×ω) = 0, (L×ω)·ω = 0; the Magnus
        (ω×u)·u = 0 and Kutta (Γ×u)·u = 0 lifts do no work; the drag is -c u, -c' ω with c, c'
        >= 0 when the blunt, slender and angular coefficients and ``on`` are >= 0 (A_proj <= A_max,
        I_i <= I_max) and ρ, μ >= 0.  MuJoCo's qfrc_fluid·qvel <= 0 measured on dm_control's fish
        (tests/compiler/contact/test_energy_kinds.py).  A wind is a source."""
        return not self.why_not_passive

    @property
    def why_not_passive(self):
        if any(self.wind):
            return "a wind"
        bad = [k for _, _, _, coef in self.geoms for k in (0, 1, 2, 3) if coef[k] < 0]
        return "a negative drag coefficient (fluidcoef)" if bad else ""

    @property
    def exprs(self):
        out = [sm.Integer(self.body), self.density, self.viscosity] + [sm.sympify(x) for x in self.com]
        for pos, rot, s, coef in self.geoms:
            out += [_f(x) for x in (*pos, *(x for row in rot for x in row), *s, *coef)]
        return out + [_f(x) for x in self.wind]

    def lower(self, bodies, rec, v, rename, poses):
        """Add every geom's force to body ``self.body``'s fext (body components, about its
        origin: the mass centre)."""
        i = self.body
        what = f"the fluid force on body {self.name}"
        rho, mu = rename(self.density, what), rename(self.viscosity, what)
        com = [rename(x, what) for x in self.com]
        total = [sm.S.Zero] * 6
        for pos, rot, s, coef in self.geoms:
            A = [[_f(x) if abs(x) > 1e-300 else sm.S.Zero for x in row] for row in rot]
            arm = [rec.let(_f(pos[k]) - com[k]) if pos[k] or com[k] else sm.S.Zero for k in range(3)]
            w_l, u_l = relative_velocity(v[i], arm, A, self.wind, poses, i, rec)
            torque, force = geom_fluid_forces(w_l, u_l, rho, mu, s, coef, rec.let)
            n_b = [sum((A[r][k] * torque[k] for k in range(3)), sm.S.Zero) for r in range(3)]
            f_b = [rec.let(sum((A[r][k] * force[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
            n_b = [n_b[k] + c for k, c in enumerate(cross(arm, f_b))]
            total = [total[k] + x for k, x in enumerate(n_b + f_b)]
        add_body_load(bodies, i, total)
