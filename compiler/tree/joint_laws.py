"""Joint-space force laws of a 1-dof joint: soft limits, viscous damping, regularised Coulomb friction.

Why one module: URDF (``<limit>``, ``<dynamics>``) and MJCF (``range``,
``damping``, ``frictionloss``) declare the same three things; both readers and
both formulations (the tree of :mod:`eomc.compiler.urdf.treeir` and the SymPy
System of :mod:`eomc.compiler.urdf.system`) take the torque (force, for a
slide) of :func:`joint_torque` and apply it on the child about the joint axis
with its reaction on the parent, so the laws are written, checked and
defaulted in one place.  Every number is a named parameter (changeable at run
time without a rebuild); the names are in :data:`NAMES`.

For coordinate q, speed u (s = the joint's C name):

- viscous damping: tau = -b u                     (``damping_s``)
- Coulomb friction, regularised: tau = -f tanh(u / v)   (``friction_s``, ``friction_v_s``;
  v defaults to :data:`FRICTION_SPEED` = 0.01 rad/s or m/s: below it the law
  is a steep viscous one, so a stopped joint creeps under a load below f
  instead of sticking -- not stick-slip)
- soft limits past [lo, hi] (``limit_lo_s``, ``limit_hi_s``; an absent or
  infinite side has no limit): with penetrations d_hi = q - hi, d_lo = lo - q,

      tau = -k (s(d_hi) - s(d_lo)) - c u (w(d_hi) + w(d_lo))
      s(d) = d³ / (d + e)²,  w(d) = d³ / (d + e)³  for d > 0, both 0 for d <= 0
      (plus, where a URDF joint has one, the entry spring: kd, cd at d - D in place of k, c at d)

  (``limit_k_s``, ``limit_c_s``, ``limit_e_s``).  s and w are C² at the
  boundary (value, slope and curvature 0 from both sides), so the right-hand
  side is C² in q: no kink for the step-size control, Radau's Newton iteration
  or jac_x to trip on (central differences of the rhs with steps well below e
  agree with jac_x even at a state on the boundary: ``eomc check`` on Panda,
  whose fingers start on their lower limit), hence no events are needed to
  locate the boundary.  A few widths e (default :data:`WIDTH` = 3e-4 rad or m) past the
  boundary the law is the linear spring-damper of MuJoCo and Drake: s -> d - 2e,
  w -> 1.  A static load F holds the joint where k d³/(d + e)² = F past the
  limit (F/k + 2e when F >> k e).
  Default stiffness and damping as Drake's penalty joint limits and MuJoCo's
  default ``solref`` choose them: a critically damped spring-damper of time
  constant tc on the joint's effective inertia m (k = m / tc², c = 2 m / tc),
  tc = :data:`TIME_CONSTANT` = 0.01 s for URDF (MJCF: the joint's own
  ``solref`` time constant, 0.02 s by default).  A URDF joint that carries a load
  (:class:`JointScale`: its subtree's weight on its lever, and on a floating-base robot
  the rest of the robot's weight on the lever to its subtree's farthest body -- a knee
  holding up the body) gets at least the stiffness that holds that load within
  :data:`LOAD_GIVE` past the limit: the inertia rule alone let a collapsing Go2's knees go
  0.46 rad past (issue 29).  On a floating-base robot m is at least the inertia the joint
  carries when its subtree stands on the ground (the rest of the robot's about the joint's
  axis), and c = 2 sqrt(k m) is critically damped about it: a spring stiff enough for the
  load but damped for the shin alone rings with the body on it.  A URDF joint whose subtree may
  enter a limit faster than that spring stops also gets an entry spring-damper: the same law
  :data:`ENTRY_DEPTH` deeper (``limit_kd_s``, ``limit_cd_s``, ``limit_d_s``; :func:`entry_gains`),
  with k + kd stopping the speed its subtree can reach (:class:`JointScale`'s ``speed``: a fall
  through the subtree's reach from the root, at its radius of gyration about the axis) within
  :data:`ENTRY_GIVE` past that depth (natural frequency at most :data:`ENTRY_RATE`): a fixed arm's
  collapse whips its light wrists into their limits at 20-40 rad/s, and the inertia rule's 10 ms
  let them go 0.04-0.06 rad past (first hour s25).  The damping may pull a joint
  that leaves its limit fast back towards it (as in Drake's penalty law; MuJoCo's
  constraint forces never pull).
"""
import math

import sympy as sm

from ..emit.layout import power_as_it_stands
from ..contact.law import step  # ramp's derivative (defined there for the contact pairs' choices)

__all__ = ["ramp", "step", "JointLaw", "joint_torque", "check_law", "TIME_CONSTANT", "WIDTH", "FRICTION_SPEED", "NAMES",
           "limit_gains", "scale_gains", "limit_spring", "limit_energy", "law_shape", "PUSH_DIVISOR", "JointLawError", "JointScale", "LOAD_GIVE",
           "ENTRY_GIVE", "ENTRY_RATE", "ENTRY_DEPTH", "entry_gains", "scale_entry_gains", "CARRIED_RATE"]

TIME_CONSTANT = 0.01
WIDTH = 3e-4
LOAD_GIVE = 0.002     # rad (m for a slide): the static give past a limit under the joint's load
# rad (m): where the entry spring starts past the limit (limit_d_s): deeper than a joint resting on
# its limit goes under the load rule (LOAD_GIVE + the onset's 2 widths = 8.7 widths), so a resting
# joint sits on the bound's soft spring and only an entry meets the stiff one
ENTRY_DEPTH = 15 * WIDTH
# rad (m): the overshoot past ENTRY_DEPTH of a critically damped linear spring stopping a joint that
# enters its limit at its entry speed; the entry spring's smooth onset adds about 9 widths to it (a
# hinge entering at that speed: 0.0326 rad at 100 widths with the onset at the bound), so the
# stated 100 widths (runtime/switching.LIMIT_OVERSHOOT_WIDTHS) hold at 15 + 9 + 75
ENTRY_GIVE = 75 * WIDTH
# 1/s: the highest natural frequency sqrt(k / inertia) the entry spring reaches (a time constant of
# 0.67 ms): the rule's speed bound is far above what a roll joint along a limb meets (Panda's hand
# roll: 64 rad/s bound, 18.7 met; alex's shoulder yaws, the whole arm about its own axis: 109
# bound, ~9 met, 1487/s uncapped); the whips measured need up to ~700/s at 90 widths (so101's
# gripper and romeo's wrist roll enter at ~50 rad/s), and so101's gripper went 0.0305 past at
# 1000/s with 75 widths past ENTRY_DEPTH.  A resting joint sits on the limit's own spring, so the
# cap costs only while a joint is stopped (session 25's 1000/s, with the stiffness at the bound,
# made alex's 10 s run 40 -> 92 ms CPU uncapped)
ENTRY_RATE = 1500.0
# 1/s: the highest natural frequency sqrt(k / inertia) on its own inertia that the limit's spring of
# a joint its floating-base robot does not stand on gets (limit_gains' own_load); chosen on Talos
# and G1 (session 29, ballbias): at 1500 /s G1's wrist roll went 0.0045 past (0.0033 uncapped),
# Talos's fingertips 0.0073 (its knees' 0.0056 the worst uncapped); at 3000 /s the fingertips 0.004
# with the same CPU (0.57x of uncapped)
CARRIED_RATE = 3000.0
FRICTION_SPEED = 0.01

NAMES = {"lower": "limit_lo", "upper": "limit_hi", "stiffness": "limit_k", "limit_damping": "limit_c",
         "width": "limit_e", "damping": "damping", "friction": "friction", "friction_speed": "friction_v",
         "entry_stiffness": "limit_kd", "entry_damping": "limit_cd", "entry_depth": "limit_d"}


class JointLawError(ValueError):
    """A joint's numbers make no law (the message names the joint and what is wrong; ``joint``
    is its name, for the reader to find its line)."""

    def __init__(self, joint, message):
        super().__init__(message)
        self.joint = joint


class JointLaw:
    """The declared numbers of one joint (``None``: not declared / no limit on that side)."""

    def __init__(self, joint, *, lower=None, upper=None, damping=0.0, friction=0.0, stiffness=None,
                 limit_damping=None, width=WIDTH, friction_speed=FRICTION_SPEED, unilateral=False, hold=None,
                 entry_depth=ENTRY_DEPTH):
        self.joint = joint
        # where the entry spring (entry_gains; a default stiffness's only) starts past the limit
        self.entry_depth = entry_depth
        # hold: (G, w) or None -- the limit's spring is G times stiffer within about w of the limit:
        # k·(r + (G - 1)·w·tanh(r/w)) instead of k·r (MuJoCo's soft limit holds a steady load with
        # the give of G·k, and meets an impact with k: mujoco_law.limit_spring)
        self.hold = hold
        # unilateral: the limit only pushes (its spring-damper force clipped at 0, smoothly over the
        # force one width deep: _push; MuJoCo's limit constraint force is >= 0); else its damping
        # may also pull the joint back toward the limit
        self.unilateral = unilateral
        self.lower, self.upper = lower, upper
        self.damping, self.friction = damping, friction
        self.stiffness, self.limit_damping = stiffness, limit_damping
        self.width, self.friction_speed = width, friction_speed

    @property
    def limited(self):
        return any(v is not None and math.isfinite(v) for v in (self.lower, self.upper))

    @property
    def active(self):
        """Whether the law adds anything."""
        return self.limited or bool(self.damping) or bool(self.friction)


def check_law(law):
    """Raise :class:`JointLawError` naming the joint: NaN, lower > upper, negative coefficients."""
    j = law.joint
    for what in ("lower", "upper"):
        v = getattr(law, what)
        if v is not None and math.isnan(v):
            raise JointLawError(j, f"joint '{j}': limit {what} is NaN")
    if law.lower is not None and law.upper is not None and law.lower > law.upper:
        raise JointLawError(j, f"joint '{j}': limit lower {law.lower:g} > upper {law.upper:g}")
    for what in ("damping", "friction", "stiffness", "limit_damping", "width", "friction_speed", "entry_depth"):
        v = getattr(law, what)
        if v is None:
            continue
        if not math.isfinite(v):
            raise JointLawError(j, f"joint '{j}': {what} {v} is not a finite number")
        if v < 0:
            raise JointLawError(j, f"joint '{j}': negative {what} ({v:g}): it would feed energy in")
    if law.width is not None and law.width <= 0 and law.limited:
        raise JointLawError(j, f"joint '{j}': limit width must be > 0 (got {law.width:g})")
    if law.friction and not law.friction_speed:
        raise JointLawError(j, f"joint '{j}': friction speed must be > 0 (got {law.friction_speed:g})")


class JointScale(tuple):
    """(inertia, load, carried, speed): the effective inertia a joint moves, the static torque
    (force) it may have to hold at a limit, the inertia it carries when it holds that load (on a
    floating-base robot the rest of the robot's inertia about the joint's axis; at least
    ``inertia``) and the speed (rad/s, m/s) at which it may enter a limit (0: not known); the
    scales of its default limit stiffness and damping.  ``own_load`` (an attribute, None: not
    set): the load of the joint's own subtree alone, for a joint of a floating-base robot whose
    subtree does not hold what the robot stands on (:func:`limit_gains`: its stiffness capped)."""

    def __new__(cls, inertia, load=0.0, carried=None, speed=0.0, own_load=None):
        inertia = float(inertia)
        out = super().__new__(cls, (inertia, float(load), max(inertia, float(carried or 0.0)), float(speed)))
        out.own_load = None if own_load is None else float(own_load)
        return out


def limit_gains(inertia, time_constant=TIME_CONSTANT, load=0.0, carried=None, own_load=None):
    """(k, c) of the spring-damper at the limit: critically damped, of time constant
    ``time_constant`` on the inertia the joint carries (``carried``, at least ``inertia``),
    stiffened where needed so that a static ``load`` gives at most :data:`LOAD_GIVE`, and
    critically damped about the carried inertia.

    ``own_load`` (a joint whose subtree does not hold what its floating-base robot stands on: an
    arm, a head, a gripper's finger): k at most the stiffness that rings the joint's own inertia at
    :data:`CARRIED_RATE`, and never below what the own subtree's load and inertia need; c still
    critically damped about the carried inertia.  Why: such a joint carries the rest of the robot
    only when that lands on it (a hand, a fingertip), and the load rule sized a Talos gripper's
    fingertip (own inertia 9e-6 kg m^2) to hold the robot on its reach: k 3e5, a mode of 2e5 /s,
    half of the BDF steps of Talos's first second (session 28, runctl).  The damping about the
    carried inertia is what holds a landing (session 29, ballbias: the own subtree's k and c alone
    let Talos's fingertips go 0.28 rad past, G1's elbows 0.059; with this cap 0.007 and 0.0045)."""
    m = max(inertia, carried or 0.0)
    k, c = m / time_constant ** 2, 2.0 * m / time_constant
    if load / LOAD_GIVE > k:
        k = load / LOAD_GIVE
        c = 2.0 * math.sqrt(k * m)
    if own_load is not None and m > inertia:
        cap = max(inertia * CARRIED_RATE ** 2, inertia / time_constant ** 2, own_load / LOAD_GIVE)
        if k > cap:
            k = cap
            c = 2.0 * math.sqrt(k * m)
    return k, c


def entry_gains(inertia, k, carried=None, speed=0.0):
    """(kd, cd) of the entry spring-damper, which starts :data:`ENTRY_DEPTH` past the limit and
    is added to the limit's own (k, c = 2 sqrt(k m)): with it the joint's own ``inertia``
    entering at ``speed`` is stopped within :data:`ENTRY_GIVE` past ENTRY_DEPTH (a critically
    damped spring of natural frequency w stops a speed v within v / (e w)) -- w at most
    :data:`ENTRY_RATE` --, the sum critically damped about the carried inertia m; (0, 0) where
    the limit's own spring does that already.

    Why a second spring, not a stiffer one: a stiffness that stops a whipped wrist (up to
    1000/s) also holds a joint that rests on its limit, and made the integrators' steps follow
    it there (session 25: alex and Talos full resting on their limits, integration CPU up to
    1.98x); a joint resting on its limit sits within LOAD_GIVE plus 2 widths of it, on the
    limit's own spring, and only an entry goes deeper."""
    m = max(inertia, carried or 0.0)
    stiff = inertia * min(speed / (math.e * ENTRY_GIVE), ENTRY_RATE) ** 2
    if not stiff > k:
        return 0.0, 0.0
    return stiff - k, 2.0 * math.sqrt(m) * (math.sqrt(stiff) - math.sqrt(k))


def scale_gains(inertia):
    """:func:`limit_gains` of a :class:`JointScale` (or of a bare inertia): the limit's own (k, c)."""
    if isinstance(inertia, JointScale):
        return limit_gains(inertia[0], load=inertia[1], carried=inertia[2], own_load=inertia.own_load)
    return limit_gains(inertia)


def scale_entry_gains(inertia):
    """:func:`entry_gains` of a :class:`JointScale` ((0, 0) for a bare inertia: no entry speed known)."""
    if not isinstance(inertia, JointScale):
        return 0.0, 0.0
    return entry_gains(inertia[0], scale_gains(inertia)[0], carried=inertia[2], speed=inertia[3])


class ramp(sm.Function):
    """max(x, 0), as a SymPy function the C printer writes as ``fmax(x, 0.0)`` and the
    differentiation passes take through :meth:`fdiff` (SymPy's ``Max`` differentiates to a
    Heaviside that C99 cannot print, ``Piecewise`` leaves relationals that the passes
    cannot differentiate)."""
    nargs = 1

    @classmethod
    def eval(cls, x):
        if x.is_Number:
            return x if x > 0 else sm.S.Zero

    def fdiff(self, argindex=1):
        return step(self.args[0])

    def _eval_is_extended_real(self):
        return self.args[0].is_extended_real

    def _eval_is_finite(self):
        return True if self.args[0].is_finite else None

    def _eval_evalf(self, prec):
        x = self.args[0].evalf(prec)
        return (x if x > 0 else sm.S.Zero) if x.is_Number else None

    def _ccode(self, printer):
        from ..emit.printer import c_minmax
        return c_minmax(printer, "fmax", printer._print(self.args[0]), "0.0")

    def _numpycode(self, printer):
        return f"numpy.maximum({printer._print(self.args[0])}, 0.0)"

    def _pythoncode(self, printer):
        return f"max({printer._print(self.args[0])}, 0.0)"


class secant_tanh(sm.Function):
    """tanh(x) whose derivative is taken as its secant from 0, tanh(x)/x (1 at x = 0): the joint
    friction's slope in NAME_implicit (compiler/tree/lower._implicit_results), never its force.

    Why: the fixed step's matrix holds each joint law's damping slope -dtau/du (eomc_fixedstep.c,
    linearly implicit Euler).  Regularised Coulomb friction -f tanh(u/v) has the tangent slope
    f/v sech²(u/v): nil along a fast slip, so the step took the friction as an explicit force, which
    overshoots and gains energy where f h / I is large -- example-robot-data's Allegro hands (f = 10
    N m on finger links of grams, v = 0.01): the first 1 ms step of a start at 0.2-0.5 rad/s gained
    1.7 % of the hand's energy, 5-6 of 16 rollout rows failed for created energy at any dt down to
    10 us, where an accurate Radau run's energy only falls (session 53).  The secant f tanh(u/v)/u
    (the contacts' friction takes the same: fs_secant_friction) is f/v at rest, where the two agree,
    and in a slip the damping that stops the joint within the step without reversing it.  Only the
    linearisation changes: the step still solves the same law (its residual test is the law's)."""
    nargs = 1

    def fdiff(self, argindex=1):
        return tanhc(self.args[0])


class tanhc(sm.Function):
    """tanh(x)/x, 1 at x = 0: :class:`secant_tanh`'s slope, printed as one call ``eomc_tanhc(x)``
    (compiler/emit/printer.MINMAX_C; in lanes batch._VECTOR_EXACT).  Why a function: written as
    (tanh(x) + z)/(x + z) with z = 1 at x = 0 from steps, SymPy's sum printed as 1 - (-x) - z1 - z2
    cancels x below 1e-16 to 0/0 -- a fast-path step of a joint coming to rest stopped on a NaN."""
    nargs = 1

    @classmethod
    def eval(cls, x):
        if x.is_Number:
            return sm.S.One if x == 0 else sm.tanh(x) / x

    def _eval_is_extended_real(self):
        return self.args[0].is_extended_real

    def _eval_evalf(self, prec):
        x = self.args[0].evalf(prec)
        return (sm.S.One if x == 0 else (sm.tanh(x) / x).evalf(prec)) if x.is_Number else None

    def _ccode(self, printer):
        return f"eomc_tanhc({printer._print(self.args[0])})"

    def _numpycode(self, printer):
        a = printer._print(self.args[0])
        return f"numpy.where(({a}) != 0, numpy.tanh({a}) / numpy.where(({a}) != 0, {a}, 1.0), 1.0)"

    def _pythoncode(self, printer):
        a = printer._print(self.args[0])
        return f"(math.tanh({a}) / ({a}) if ({a}) != 0 else 1.0)"


def secant_friction(t, u):
    """The law ``t`` with each tanh of the speed ``u`` (regularised Coulomb friction) as
    :class:`secant_tanh`: what NAME_implicit differentiates for the joint's slope in u.  A tanh of
    the coordinate alone (MJCF's held limit stretch) stays tanh."""
    return t.replace(lambda e: isinstance(e, sm.tanh) and e.args[0].has(u), lambda e: secant_tanh(e.args[0]))


def limit_spring(d, e):
    """s(d) of the module docstring (numbers or SymPy)."""
    r = ramp(d)
    return r ** 3 / (r + e) ** 2




def _stored_sum(r, E):
    """∫₀^r s(d) dd of :func:`limit_spring` with width E: with t = d + E, d³/t² = t - 3E + 3E²/t
    - E³/t², so r²/2 - 2Er + 3E² ln(1 + r/E) + E³/(r + E) - E² (0 at r = 0, r²/2 - 2Er + O(ln r)
    far past the limit: the linear spring's k(d - 2E) stores k(r²/2 - 2Er))."""
    return r ** 2 / 2 - 2 * E * r + 3 * E ** 2 * sm.log(1 + r / E) + E ** 3 / (r + E) - E ** 2


class stored(sm.Function):
    """stored(r, E): :func:`_stored_sum` as one call, printed ``eomc_limit_stored(r, E)`` (the C
    the generated file defines once where it is called, compiler/emit/printer.CALLED_C; its
    float twin is the c99-f32 pass's).  Why: spelled out per
    joint and side, the limits' springs were 17 kB of NAME_energy's 67 kB of C on G1 and 26 of
    94 kB on Talos, which the build lowered, printed and compiled joint by joint: as calls, G1's
    default build took 6.2 -> 5.7-5.9 s CPU and Talos' 7.1-7.5 -> 6.8-7.2 s, and NAME_energy ran as
    fast or faster (session 20, benchmarks/results/derivative_build.md).  Values: the same to
    4e-16 relative (the C's order of the sum)."""
    nargs = 2
    is_real = True

    def fdiff(self, argindex=1):
        r, E = self.args
        return sm.diff(_stored_sum(r, E), (r, E)[argindex - 1])

    def _eval_evalf(self, prec):
        return _stored_sum(*self.args).evalf(prec)

    def _ccode(self, printer):
        return f"eomc_limit_stored({printer._print(self.args[0])}, {printer._print(self.args[1])})"

    def _numpycode(self, printer):
        return printer._print(_stored_sum(*self.args))

    def _pythoncode(self, printer):
        return printer._print(_stored_sum(*self.args))


def _stored(r, E):
    """The stored energy of one side of a limit past it by ``r`` (:class:`stored`)."""
    return stored(r, E)


def limit_energy(q, law, params, name, inertia):
    """The elastic energy a joint's limit springs store past their limits (the potential whose
    slope is the spring part of :func:`joint_torque`'s limit torque), or None where the law's
    spring is not such a potential's slope (a unilateral limit: its force is clipped together
    with its damping; a ``hold``: its tanh term has no closed integral) -- MJCF's limits.

    Why: a passive robot's generated ``energy`` output (eomc.compiler.tree.contacts) judges
    runs by their energy; without this term a start past a limit (Go2's zero pose has its
    knees 0.84 rad past, 14.8 kJ in the springs) was reported as a 367 J energy gain."""
    if not law.limited:
        return sm.S.Zero
    if law.unilateral or law.hold:
        return None
    k, _ = scale_gains(inertia)
    K = params(f"{NAMES['stiffness']}_{name}", law.stiffness if law.stiffness is not None else k)
    E = params(f"{NAMES['width']}_{name}", law.width)
    entry = _entry_parameters(law, params, name, inertia)
    out = deep = sm.S.Zero
    for past in _past(q, law, params, name):
        out += _stored(ramp(past), E)
        if entry is not None:       # the entry spring's: the same law, entry[2] deeper (joint_torque)
            deep += _stored(ramp(past - entry[2]), E)
    return K * out + (entry[0] * deep if entry is not None else sm.S.Zero)


def _past(q, law, params, name):
    """How far q is past each finite side of the limit (q - hi, lo - q; negative inside)."""
    out = []
    if law.upper is not None and math.isfinite(law.upper):
        out.append(q - params(f"{NAMES['upper']}_{name}", law.upper, keep=True))
    if law.lower is not None and math.isfinite(law.lower):
        out.append(params(f"{NAMES['lower']}_{name}", law.lower, keep=True) - q)
    return out


def _entry_parameters(law, params, name, inertia):
    """(Kd, Cd, D) of the entry spring-damper (:func:`entry_gains`) as parameters, or None where
    the joint has none: a stiffness given for the limit (MJCF's solref) is the whole law."""
    if law.stiffness is not None or law.limit_damping is not None or law.unilateral or law.hold:
        return None
    kd, cd = scale_entry_gains(inertia)
    if not (kd > 0 or cd > 0):
        return None
    return (params(f"{NAMES['entry_stiffness']}_{name}", kd), params(f"{NAMES['entry_damping']}_{name}", cd),
            params(f"{NAMES['entry_depth']}_{name}", law.entry_depth))


def _held(r, hold):
    """The spring's stretch: r, or with ``hold`` = (G, w) r + (G - 1)·w·tanh(r/w) (slope G at the
    limit, 1 far past it: JointLaw.hold)."""
    if not hold:
        return r
    G, w = hold
    return r + sm.Float(repr(float((G - 1.0) * w))) * sm.tanh(r / sm.Float(repr(float(w))))


PUSH_DIVISOR = 10     # a unilateral limit's smoothing scale is its force one width deep over this (_push)


def law_shape(law):
    """What the runtime needs, beside the parameters limit_k_/limit_e_, to integrate a limit's
    spring at rest (u = 0) from its limit to a depth r: the smoothing of a unilateral limit
    (``push``: 1/:data:`PUSH_DIVISOR`, or 0) and ``hold`` (G, w) or None
    (eomc.runtime.limit_energy; NAME.json ``limit_laws``).

    Why: MJCF's limits are unilateral and held, so their spring has no closed-form potential
    and the generated ``energy`` output leaves it out; a run that starts outside a joint's range
    (gymnasium's ant, dm_control's hopper) releases that spring's energy, which the energy
    verdict must tell from a gain the integrator made.  The law at rest is a potential's slope,
    and the damping only ever takes energy out (its smoothed clip included), so kinetic +
    gravity + this potential can only fall: the verdict adds the potential at the start."""
    return {"push": 1.0 / PUSH_DIVISOR if law.unilateral else 0.0,
            "hold": [float(law.hold[0]), float(law.hold[1])] if law.hold else None}


def _signs(law):
    """The direction each of :func:`_past`'s sides pushes back: -1 from the upper, +1 from the lower
    (as the torque's factor -sign; sign·u is the speed deeper past that side)."""
    return [s for s, v in ((1, law.upper), (-1, law.lower)) if v is not None and math.isfinite(v)]


def _push(force, scale):
    """max(force, 0) made smooth over ``scale`` (a tenth of the limit's force one width e deep,
    k·e/10): (f + sqrt(f² + scale²))/2.  Why smooth: a kink where the damping would start to pull
    stops an implicit method's steps (dm_control's humanoid: radau's step fell to 1e-15 at
    0.83 s); why a tenth: at k·e gymnasium's hopper, which falls onto its limits, came to rest
    37 mm off MuJoCo's pose (4 mm with the kink and with k·e/10)."""
    root = power_as_it_stands(force ** 2 + scale ** 2, sm.S.Half)   # sm.sqrt's, without its queries
    return (force + (sm.sqrt(force ** 2 + scale ** 2) if root is None else root)) / 2


def joint_torque(q, u, law, params, name, inertia):
    """The torque (force) of ``law`` on the joint's child, a SymPy expression in q, u and parameters.

    ``params(name, value)`` makes the parameters (a symbol, or a literal: 0 stays 0);
    ``name`` is the joint's C name; ``inertia`` its effective inertia (for the default
    limit stiffness and damping)."""
    check_law(law)
    tau = sm.S.Zero
    if law.limited:
        k, c = scale_gains(inertia)
        k = law.stiffness if law.stiffness is not None else k
        c = law.limit_damping if law.limit_damping is not None else c
        K = params(f"{NAMES['stiffness']}_{name}", k)
        C = params(f"{NAMES['limit_damping']}_{name}", c)
        E = params(f"{NAMES['width']}_{name}", law.width)
        if E == 0:
            raise JointLawError(law.joint, f"joint '{law.joint}': limit width must be > 0")
        # per side, with r = ramp(d) and g = r/(r + e): k s + c u w = g² (k r + c u g)
        # (one division per side; the same numbers as the docstring's form)
        entry = _entry_parameters(law, params, name, inertia)
        # the entry spring-damper (Kd, Cd) is the same law entry[2] deeper (limit_energy's too)
        for past, sign in zip(_past(q, law, params, name), _signs(law)):
            r = ramp(past)
            g = r / (r + E)
            side = K * _held(r, law.hold) + sign * C * u * g
            tau += -sign * g ** 2 * (_push(side, K * E / PUSH_DIVISOR) if law.unilateral else side)
            if entry is not None:
                rd = ramp(past - entry[2])
                gd = rd / (rd + E)
                tau += -sign * gd ** 2 * (entry[0] * rd + sign * entry[1] * u * gd)
    if law.damping:
        tau += -params(f"{NAMES['damping']}_{name}", law.damping) * u
    if law.friction:
        V = params(f"{NAMES['friction_speed']}_{name}", law.friction_speed)
        tau += -params(f"{NAMES['friction']}_{name}", law.friction) * sm.tanh(u / V)
    return tau
