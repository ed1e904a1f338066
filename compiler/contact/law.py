"""The compliant ground-contact law, on plain SymPy scalars: Hunt–Crossley + regularised Coulomb.

One job: given the world position and velocity of a contact sphere's centre, the
body's angular velocity and the ground plane, return the penetration, the normal
force and the friction force (world components).  Both routes use it -- the SymPy
System route (:mod:`.system`, nested expressions) and the joint tree's
(:mod:`.tree`, where every argument is already a named temporary of the recursion),
so both compute the same numbers.

Normal force (Hunt & Crossley 1975, Hertz exponent p = 3/2 for a sphere):

    δ = r - (n·c - h)            penetration of the sphere (centre c, radius r) into
                                 the plane {x: n·x = h}; δ > 0 in contact
    F_n = k·δ₊^p·(1 + (3/2)·c_d·δ̇),   δ̇ = -n·v_c,   clipped at F_n ≥ 0

written without branches, δ₊ = (δ + |δ|)/2 and F_n = (F + |F|)/2, so the C code
has no ``if`` and its derivatives (jac_x) exist everywhere but at δ = 0 and F = 0
(F_n is C¹ in δ there: δ₊^{3/2} has a zero slope at 0).

Friction (regularised Coulomb): the slip velocity of the material point at the
bottom of the sphere, v_p = v_c + ω × (-r·n), has the tangential part
v_t = v_p - (n·v_p)·n, and

    F_t = -μ·F_n·v_t / sqrt(|v_t|² + v_s²)

which is Coulomb's μ·F_n opposing the slip for |v_t| ≫ v_s and a viscous
μ·F_n/v_s for |v_t| ≪ v_s (no true sticking: a body on a slope creeps at about
v_s·tanθ/μ).  The force acts at the contact point p = c - r·n.
"""
import sympy as sm

__all__ = ["DEFAULTS", "LOAD_SINK", "load_stiffness", "EXPONENT", "ContactForces", "ground_forces", "ground_jacobians", "clip_switch",
           "damping_from_restitution", "check_value", "SPIN_KEYS", "spin_moment"]

# Default parameters per contact (SI units), and why:
# k   1e6 N/m^1.5  Hertz for a sphere of radius R = 2 cm of rubber-like stiffness on a rigid
#                  plane, k = (4/3)·E*·sqrt(R) with E* ≈ 5 MPa: a 10 kg robot on four feet
#                  sinks by about 0.3 mm, stiff enough to stand, soft enough that explicit
#                  methods are not forced to microsecond steps.
# c   2 s/m        Hunt–Crossley damping: restitution e ≈ 1 - c·v_in = 0.4 for a 0.3 m/s
#                  touch-down (a foot landing: most of the impact is absorbed), and it damps
#                  a standing robot's bounce on its feet within a few tenths of a second.
# mu  1.0          rubber on a hard floor; MuJoCo's default sliding friction too.
# vs  0.01 m/s     the regularisation's speed: slip slower than this is viscous.  Smaller is
#                  closer to Coulomb (less creep) but stiffer (slope μ·F_n/v_s).
# r   0 m          a point (a sphere of radius 0).
DEFAULTS = {"k": 1.0e6, "c": 2.0, "mu": 1.0, "vs": 0.01, "r": 0.0}
# A robot's named contacts (URDF links) that carry its weight: the default k is at least the
# stiffness at which each, sharing the robot's weight W equally with the others, sinks
# LOAD_SINK of its radius at rest (load_stiffness); the 1e6 above stays the floor.
LOAD_SINK = 0.05
EXPONENT = sm.Rational(3, 2)      # Hertz: a sphere on a plane

_MEANING = {"k": "stiffness", "c": "damping", "mu": "friction coefficient",
            "vs": "friction regularisation speed", "r": "radius",
            "mut": "torsional friction coefficient", "mur": "rolling friction coefficient"}
# A contact's optional torsional and rolling friction (MJCF condim 4 and 6: spin_moment): the
# parameters mut_<name> (condim 4, 6) and mur_<name> (condim 6), lengths in m as MuJoCo's, and
# the length rho (a build-time number, not a parameter) that turns v_s into the angular
# regularisation speed ω_s = v_s/rho.  A contact without them has no moment and no code for one.
SPIN_KEYS = ("mut", "mur")


def load_stiffness(weight, count, radius, sink=LOAD_SINK):
    """The default stiffness of a contact sphere of ``radius`` that is one of ``count`` contacts
    sharing a robot's ``weight`` (N): Hertz's F = k δ^(3/2) at F = W/count and δ = sink·r, but
    never below DEFAULTS["k"].

    Why from the load (as the limits' default stiffness comes from the joint's load,
    compiler/tree/joint_laws.limit_gains): a fixed k holds a light robot on large feet and lets
    a heavy one on small feet sink through them.  G1 (35 kg) stands on eight 5 mm heel and toe
    spheres; at k = 1e6 each sinks 1.2 mm (a quarter of its radius) at rest and its collapse
    took them 7.5 mm deep, past their radius.  Go2 (15 kg, four 22 mm feet) keeps 1e6: its
    rule's value is 1.0e6; Solo12 (2.5 kg) too (its rule: 2.6e5).  A point contact (r = 0) has
    no radius to sink a fraction of: DEFAULTS["k"]."""
    floor = DEFAULTS["k"]
    if not (weight > 0 and count > 0 and radius and radius > 0):
        return floor
    return max(floor, (weight / count) / (sink * radius) ** 1.5)


def check_value(name, key, value, where=None):
    """A contact parameter's default: a finite number, ≥ 0 (> 0 for v_s); ValueError naming it."""
    import math
    label = f"contact {name!r}" + (f" ({where})" if where else "")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{label}: {_MEANING[key]} {key} must be a number, not {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{label}: {_MEANING[key]} {key} must be finite, not {value!r}")
    if x < 0 or (key == "vs" and x == 0):
        need = "> 0" if key == "vs" else ">= 0"
        raise ValueError(f"{label}: {_MEANING[key]} {key} = {x:g} must be {need}")
    return x


def damping_from_restitution(e, impact_speed):
    """The damping c of this law for a restitution ``e`` at ``impact_speed``: c = (1 - e)/v_in.

    Hunt & Crossley's relation is λ/k = 3(1 - e)/(2·v_in) for F = k·δ^p + λ·δ^p·δ̇; this
    law writes λ/k = (3/2)·c, so c = (1 - e)/v_in.  First order in (1 - e): the simulated
    restitution is close to ``e`` only near ``impact_speed`` and for e near 1
    (tests/compiler/contact/test_sphere.py measures how close)."""
    e, v = float(e), float(impact_speed)
    if not 0.0 <= e <= 1.0:
        raise ValueError(f"restitution e = {e:g} must be in [0, 1]")
    if not v > 0.0:
        raise ValueError(f"impact speed {v:g} must be > 0 to turn a restitution into a damping")
    return (1.0 - e) / v


class ContactForces:
    """What :func:`ground_forces` returns: SymPy expressions (world components)."""

    def __init__(self, depth, normal, friction, force, point_offset, parts=None):
        self.depth = depth            # δ (signed: < 0 out of contact)
        # the law's intermediate values (named temporaries), for ground_jacobians
        self.parts = parts or {}
        self.normal = normal          # F_n ≥ 0 (scalar, along n)
        self.friction = friction      # F_t, 3 world components
        self.force = force            # F_n·n + F_t, 3 world components
        self.point_offset = point_offset   # contact point from the sphere centre, world: -r·n


def _dot(a, b):
    return sum((x * y for x, y in zip(a, b)), sm.S.Zero)


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _pos(x):
    return (x + sm.Abs(x)) / 2


def ground_forces(centre, velocity, omega, params, normal=(0, 0, 1), height=0, let=None, twin=False):
    """:class:`ContactForces` of a sphere (centre, its velocity, the body's angular velocity:
    3 world components each) on the plane n·x = height.

    ``params``: {"k", "c", "mu", "vs", "r"} -> SymPy symbols or numbers.  ``let``: a
    function naming an intermediate value (the tree's Recorder.let), identity by default.
    ``twin``: the law is a straight-line twin of the ground points' loop
    (compiler/contact/ground_table.py), only ever differentiated: the clip's |.| is built as it
    stands (:func:`clip_switch`)."""
    let = let or (lambda e: e)
    n = [sm.sympify(x) for x in normal]
    k, c, mu, vs, r = (params[x] for x in ("k", "c", "mu", "vs", "r"))
    depth = let(r - (_dot(n, centre) - height))
    rate = let(-_dot(n, velocity))
    dpos = let(_pos(depth))
    elastic = k * sm.Abs(dpos) ** EXPONENT     # |.|: rounding can leave δ₊ at -1e-17, and (-x)^1.5 is NaN
    fn = let(_pos(let(elastic * (1 + sm.Rational(3, 2) * c * rate))))
    arm = [-r * x for x in n]                       # centre -> contact point
    w_arm = _cross(omega, arm)
    vp = [velocity[i] + w_arm[i] for i in range(3)]
    vn = let(_dot(n, vp))
    vt = [let(vp[i] - vn * n[i]) for i in range(3)]
    scale = let(-mu * fn / sm.sqrt(_dot(vt, vt) + vs ** 2))
    ft = [let(scale * vt[i]) for i in range(3)]
    force = [let(fn * n[i] + ft[i]) for i in range(3)]
    parts = {"rate": rate, "dpos": dpos, "elastic": elastic, "slip": vp, "vt": vt, "scale": scale,
             "normal": n, "k": k, "c": c, "vs": vs, "mu": mu, "clip": clip_switch(depth, c, rate, evaluate=not twin)}
    return ContactForces(depth, fn, ft, force, arm, parts)


def spin_moment(omega, normal, fn, params, let=None):
    """The torsional and rolling friction moment (3 world components) on the body whose angular
    velocity relative to the other surface is ``omega`` (world), at a contact of normal force
    ``fn`` (:func:`ground_forces`' F_n) and unit ``normal``:

        M = -μ_t·F_n·ω_n/sqrt(ω_n² + ω_s²)·n  -  μ_r·F_n·ω_t/sqrt(|ω_t|² + ω_s²)
        ω_n = n·ω (spin about the normal), ω_t = ω - ω_n·n (rolling), ω_s = v_s/ρ

    MuJoCo's definition (engine_core_constraint.c, mj_instantiateContact): a condim-4 contact's
    fourth row is the relative angular velocity about the normal, condims 5 and 6 the two about the
    tangents (contact frame times the bodies' rotational Jacobian difference), and its cone bounds
    each row's force by its coefficient times the normal force (pyramid edges n ± μ_k e_k), so the
    moment's bound is μ_t·F_n and μ_r·F_n with μ_t, μ_r lengths (``friction``'s 2nd and 3rd
    numbers; not μ·r_eff).  Regularised as the sliding law is (Coulomb's bound opposing the
    motion, viscous below the regularisation speed), with ω_s = v_s/ρ: a geom of size ρ
    (``params["rho"]``, MuJoCo's bounding radius of the geom) spinning or rolling at ω_s moves its
    surface at v_s, where the sliding friction turns viscous too.  Both parts vanish with F_n, so
    out of contact the moment is ±0 as the force is.

    ``params``: "mut" and/or "mur" (symbols or numbers; a missing key: no such part), "vs", "rho".
    None when neither is there."""
    let = let or (lambda e: e)
    mut, mur = params.get("mut"), params.get("mur")
    if mut is None and mur is None:
        return None
    n = [sm.sympify(x) for x in normal]
    ws2 = let((params["vs"] / params["rho"]) ** 2)
    wn = let(_dot(n, omega))
    out = [sm.S.Zero] * 3
    if mut is not None:
        st = let(-mut * fn * wn / sm.sqrt(wn ** 2 + ws2))
        out = [out[i] + st * n[i] for i in range(3)]
    if mur is not None:
        wt = [let(omega[i] - wn * n[i]) for i in range(3)]
        sr = let(-mur * fn / sm.sqrt(_dot(wt, wt) + ws2))
        out = [out[i] + sr * wt[i] for i in range(3)]
    return [let(x) for x in out]


def clip_switch(depth, c, rate, evaluate=True):
    """The switching function of the F_n >= 0 clip: max(1 + (3/2) c δ̇, -δ/(1 m)).

    Why: F_n = max(0, k δ₊^{3/2} (1 + (3/2) c δ̇)) has a kink where the damped law would pull
    (1 + (3/2) c δ̇ = 0) while in contact -- the damped contact's real lift-off, before δ
    reaches 0.  The runtime ends adaptive steps at this function's zeros as at touch-down
    (runtime/switching.py), so no step straddles the kink.  Out of contact (δ < 0) it is
    positive, so a fast rebound in flight ends no step; with c = 0 it never vanishes.

    ``evaluate`` False: the |.| as it stands, without SymPy's questions about the sign of the
    sum (its assumptions walk every temporary in it): a third of the SymPy time of Solo12's
    544 ground points' laws (session 28), where the law is the loop's twin."""
    a = 1 + sm.Rational(3, 2) * c * rate
    return (a - depth + sm.Abs(a + depth, evaluate=evaluate)) / 2


def ground_jacobians(forces, step, let=None):
    """(K, C): 3x3 nested lists (row i, column j), K = -dF/dp and C = -dF/dv of the force F
    of :func:`ground_forces` in the contact point p and its velocity v, world components;
    what the fixed-step implicit integrator treats implicitly (runtime/c/eomc_fixedstep.c):

        K = F_n,δ · (n - μ v_t/s) nᵀ           F_n,δ = (3/2) k δ₊^½ (1 + (3/2) c δ̇)
        C = F_n,δ̇ · (n - μ v_t/s) nᵀ + (μ F_n / s)(P - v_t v_tᵀ / s²)
                                              F_n,δ̇ = (3/2) c k δ₊^{3/2},
                                              P = I - n nᵀ, s² = |v_t|² + v_s²

    the normal force's stiffness and damping (with the friction they carry: a sliding
    contact's friction grows with its normal force, as stiff in the penetration as the
    normal force itself) and the regularised friction's slope in the slip.  Not symmetric:
    the integrator factors with an LU.  Both vanish out of contact and where F_n is clipped
    at 0 (the factor step(F_n): ``step`` is eomc.compiler.tree.joint_laws.step, handed in by
    the caller, which sits above this module)."""
    let = let or (lambda e: e)
    q = forces.parts
    n, k, c, vs = q["normal"], q["k"], q["c"], q["vs"]
    on = step(forces.normal)
    half = sm.Rational(3, 2)
    # δ₊^{3/2} as δ₊·sqrt(δ₊), 1/s once: one sqrt and one division per contact besides the
    # law's own (sqrt(|v_t|² + v_s²) written as the law writes it, so the passes share it)
    depth = sm.Abs(q["dpos"])
    sq = let(sm.sqrt(depth))
    kn = let(half * k * sq * (1 + half * c * q["rate"]) * on)
    cn = let(half * c * k * depth * sq * on)
    vt = q["vt"]
    inv_s = let(1 / let(sm.sqrt(_dot(vt, vt) + vs ** 2)))
    gf = let(-q["scale"])                    # μ F_n / s
    ms = let(q["mu"] * inv_s)                # μ / s
    gs = let(gf * inv_s * inv_s)             # μ F_n / s³
    carry = [let(n[i] - ms * vt[i]) for i in range(3)]
    K = [[kn * carry[i] * n[j] for j in range(3)] for i in range(3)]
    C = [[cn * carry[i] * n[j] + gf * ((1 if i == j else 0) - n[i] * n[j]) - gs * vt[i] * vt[j]
          for j in range(3)] for i in range(3)]
    return K, C


class step(sm.Function):
    """1 for x > 0, else 0: the derivative of eomc.compiler.tree.joint_laws.ramp, and the choice
    between a body-body pair's candidate nearest points (.pairs).  Its own derivative is taken as
    0 (it multiplies ramp(x), which vanishes where step jumps, in every law here; a pair's choice
    switches where the candidates' distances tie).  Here, below the tree, so both can use it."""
    nargs = 1

    @classmethod
    def eval(cls, x):
        if x.is_Number:
            return sm.S.One if x > 0 else sm.S.Zero

    def fdiff(self, argindex=1):
        return sm.S.Zero

    def _eval_evalf(self, prec):
        x = self.args[0].evalf(prec)
        return (sm.S.One if x > 0 else sm.S.Zero) if x.is_Number else None

    def _ccode(self, printer):
        return f"(({printer._print(self.args[0])}) > 0.0 ? 1.0 : 0.0)"

    def _numpycode(self, printer):
        return f"numpy.heaviside({printer._print(self.args[0])}, 0.0)"

    def _pythoncode(self, printer):
        return f"(1.0 if ({printer._print(self.args[0])}) > 0 else 0.0)"
