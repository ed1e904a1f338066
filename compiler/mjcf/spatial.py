"""MuJoCo's spatial tendons through sites only (``<spatial>`` of ``<site>``s, no wrapping, no pulley).

One job: such a tendon is a polyline through its sites, L = Σ |p_{i+1} - p_i|, and its
velocity L' = Σ e_i·(v_{i+1} - v_i) (e_i the unit vector of segment i, v the sites'
material velocities).  A tension τ along it (τ > 0 lengthens it) pulls site i+1 by τ e_i
and site i by -τ e_i -- that is Jᵀτ with J = ∂L/∂q, as MuJoCo applies a tendon's force.
τ is the fixed tendons' law (:mod:`.tendon`): spring -k (L - L_s) (a dead band between two
``springlength`` values), damper -b L', and the range limit and ``frictionloss`` of
:mod:`eomc.compiler.tree.joint_laws` with MuJoCo's ``solreflimit``/``solimplimit`` scaled by
the tendon's effective inertia 1/``tendon_invweight0`` (MuJoCo's limit is a soft constraint:
here a spring-damper, as for joints).  dm_control's ball_in_cup string is one.

Lowered with the contacts (``frame == "contact"``: the sites' world positions and velocities
come from the same recursion) by :meth:`SiteTendonLoad.lower`.  Wrapping tendons (spheres,
cylinders) and pulleys are refused by the model check, naming the tendon and its line.
"""
from dataclasses import dataclass

import sympy as sm

from ..contact.tree import LoweredLoad
from ..tree.spatial import cross

__all__ = ["is_site_tendon", "SiteTendonLoad", "with_site_tendons"]

_WRAP_SITE = 3


def is_site_tendon(m, t):
    """True when tendon ``t`` is a spatial tendon through two or more sites and nothing else."""
    adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
    return num >= 2 and all(int(m.wrap_type[w]) == _WRAP_SITE for w in range(adr, adr + num))


@dataclass(frozen=True)
class SiteTendonLoad(LoweredLoad):
    """A site tendon's tension on the bodies its sites are fixed in (no force until :meth:`lower`)."""
    name: str
    sites: tuple               # ((tree body or -1 for the world, offset from its origin: 3 exprs), ...)
    tension: object            # τ as a SymPy expression of the placeholders ``length``, ``speed``
    length: sm.Symbol
    speed: sm.Symbol

    @property
    def body(self):
        return next(b for b, _ in self.sites if b >= 0)

    @property
    def exprs(self):
        # the placeholders as numbers no model has: the tension's form is in the cache key, and
        # they are no parameters of the model (which takes every free symbol of these)
        out = [self.tension.xreplace({self.length: sm.Integer(1000000007), self.speed: sm.Integer(1000000009)})]
        for b, off in self.sites:
            out += [sm.Integer(b)] + [sm.sympify(x) for x in off]
        return out

    def lower(self, bodies, rec, v, rename, poses):
        what = f"tendon {self.name}"
        points, velocities = [], []
        for b, off in self.sites:
            off = [rename(x, what) for x in off]
            if b < 0:
                points.append(off)
                velocities.append([sm.S.Zero] * 3)
                continue
            R, o = poses.world_to_body(b), poses.origin(b)
            points.append([rec.let(o[k] + sum((R[j][k] * off[j] for j in range(3)), sm.S.Zero)) for k in range(3)])
            w, vb = v[b][:3], v[b][3:]
            vp = [vb[k] + c for k, c in enumerate(cross(w, off))]
            velocities.append([rec.let(sum((R[j][k] * vp[j] for j in range(3)), sm.S.Zero)) for k in range(3)])
        units, L, V = [], sm.S.Zero, sm.S.Zero
        for i in range(len(points) - 1):
            d = [rec.let(points[i + 1][k] - points[i][k]) for k in range(3)]
            size = rec.let(sm.sqrt(sum((x * x for x in d), sm.S.Zero)))
            e = [rec.let(x / size) for x in d]
            units.append(e)
            L += size
            V += sum((e[k] * (velocities[i + 1][k] - velocities[i][k]) for k in range(3)), sm.S.Zero)
        L, V = rec.let(L), rec.let(V)
        tension = self.tension.xreplace({s: rename(s, what) for s in self.tension.free_symbols
                                         if s not in (self.length, self.speed)})
        tau = rec.let(tension.xreplace({self.length: L, self.speed: V}))
        for i, e in enumerate(units):
            f = [rec.let(tau * x) for x in e]
            _apply(self.sites[i + 1], f, points[i + 1], poses, bodies, rec)
            _apply(self.sites[i], [-x for x in f], points[i], poses, bodies, rec)


def _apply(site, f, p, poses, bodies, rec):
    b, _ = site
    if b < 0:
        return
    R, o = poses.world_to_body(b), poses.origin(b)
    f_b = [rec.let(sum((R[r][k] * f[k] for k in range(3)), sm.S.Zero)) for r in range(3)]
    lever = [sum((R[r][k] * (p[k] - o[k]) for k in range(3)), sm.S.Zero) for r in range(3)]
    old = bodies[b].fext or [0] * 6
    bodies[b].fext = [old[k] + x for k, x in enumerate(cross(lever, f_b) + f_b)]


def with_site_tendons(built, m, fold=False, limits=True, friction=True):
    """``built`` (an MjcfTree) with a :class:`SiteTendonLoad` per acting site tendon (stiffness,
    damping, limits or frictionloss); parameters ``k_``/``d_``/``L0_``.. ``_tendon_<name>``."""
    import dataclasses
    import mujoco
    from eomc.compiler.contact.tree import body_com
    from eomc.compiler.multibody.joints import Parameters
    from .tendon import tendon_force
    from .treeir import _names
    tendons = [t for t in range(m.ntendon) if is_site_tendon(m, t)]
    if not tendons:
        return built
    params = Parameters(fold)
    names = _names(m, mujoco.mjtObj.mjOBJ_TENDON, m.ntendon, "tendon")
    tree_body = {owner[0]: i for i, owner in enumerate(built.owners) if owner is not None}
    loads = list(built.tree.loads)
    for t in tendons:
        raw, tn = names[t]
        name = f"tendon_{tn}"
        L, V = sm.Symbol(f"_L_{tn}"), sm.Symbol(f"_V_{tn}")
        tau = tendon_force(m, t, raw, name, L, V, params, limits, friction)
        if tau == 0:
            continue
        sites = []
        adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        for w in range(adr, adr + num):
            s = int(m.wrap_objid[w])
            b = int(m.site_bodyid[s])
            if int(m.body_weldid[b]) == 0:
                sites.append((-1, tuple(sm.Float(float(x), 17) for x in d.site_xpos[s])))
                continue
            i = tree_body[b]
            com = body_com(built, built.tree.bodies[i].name, built.owners[i][1])
            sites.append((i, tuple((sm.Float(float(p), 17) if p else sm.S.Zero) - c
                                   for p, c in zip(m.site_pos[s], com))))
        if all(b < 0 for b, _ in sites):
            continue
        loads.append(SiteTendonLoad(raw, tuple(sites), tau, L, V))
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree = dataclasses.replace(built.tree, loads=tuple(loads))
    new.parameters = {**built.parameters, **params.values}
    return new
