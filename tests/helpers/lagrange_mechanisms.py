"""Mechanisms for the Lagrange tests, each built with a given mechanics module.

Every builder takes ``mech`` (``eomc.mechanics`` or ``sympy.physics.mechanics``)
and returns a formed LagrangesMethod, so eomc and SymPy can be compared on
exactly the same description.  ``seed_coneqs`` selects how velocity-level
constraints are passed (eomc/seed ``coneqs`` vs SymPy's ``nonhol_coneqs``).
"""
import sympy as sm

__all__ = ["particle_on_sphere", "knife_edge", "spring_damper_chain",
           "moving_support_pendulum", "spherical_pendulum_body"]


def particle_on_sphere(mech):
    """A particle on a sphere of radius R (hol_coneqs), gravity, a drag and an input force."""
    me = mech
    x, y, z = me.dynamicsymbols("x y z")
    F = me.dynamicsymbols("F")
    m, g, R, c = sm.symbols("m g R c", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, x.diff() * N.x + y.diff() * N.y + z.diff() * N.z)
    pa = me.Particle("pa", P, m)
    pa.potential_energy = m * g * z
    L = me.Lagrangian(N, pa)
    loads = [(P, F * N.x - c * P.vel(N))]
    lm = me.LagrangesMethod(L, [x, y, z], forcelist=loads, frame=N,
                            hol_coneqs=[x**2 + y**2 + z**2 - R**2])
    lm.form_lagranges_equations()
    return lm


def knife_edge(mech, use_seed_coneqs=False):
    """A knife edge (sled) on a plane: x' sin(th) - y' cos(th) = 0, torque and thrust inputs."""
    me = mech
    x, y, th = me.dynamicsymbols("x y theta")
    T, P_in = me.dynamicsymbols("T P")
    m, I, b = sm.symbols("m I b", positive=True)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, th.diff() * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x + y * N.y)
    C.set_vel(N, x.diff() * N.x + y.diff() * N.y)
    body = me.RigidBody("body", C, B, m, (me.inertia(B, I, I, I), C))
    L = me.Lagrangian(N, body)
    cons = [x.diff() * sm.sin(th) - y.diff() * sm.cos(th)]
    loads = [(B, T * N.z - b * th.diff() * N.z), (C, P_in * B.x)]
    kw = {"coneqs": cons} if use_seed_coneqs else {"nonhol_coneqs": cons}
    lm = me.LagrangesMethod(L, [x, y, th], forcelist=loads, frame=N, **kw)
    lm.form_lagranges_equations()
    return lm


def spring_damper_chain(n, mech):
    """n masses on a line joined by springs (in L) and dampers (forcelist), input on the last."""
    me = mech
    xs = me.dynamicsymbols(f"x1:{n + 1}")
    F = me.dynamicsymbols("F")
    m = sm.symbols(f"m1:{n + 1}")
    k = sm.symbols(f"k1:{n + 1}")
    c = sm.symbols(f"c1:{n + 1}")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    points, particles, loads, V = [], [], [], 0
    for i in range(n):
        P = O.locatenew(f"P{i + 1}", xs[i] * N.x)
        P.set_vel(N, xs[i].diff() * N.x)
        points.append(P)
        particles.append(me.Particle(f"pa{i + 1}", P, m[i]))
        prev_x = xs[i - 1] if i else 0
        V += k[i] * (xs[i] - prev_x) ** 2 / 2
        rel = xs[i].diff() - (xs[i - 1].diff() if i else 0)
        loads.append((P, -c[i] * rel * N.x))
        if i:
            loads.append((points[i - 1], c[i] * rel * N.x))
    loads.append((points[-1], F * N.x))
    L = me.kinetic_energy(N, *particles) - V
    lm = me.LagrangesMethod(L, list(xs), forcelist=loads, frame=N)
    lm.form_lagranges_equations()
    return lm


def moving_support_pendulum(mech):
    """A pendulum whose support moves as a specified h(t): explicit time dependence in L."""
    me = mech
    th = me.dynamicsymbols("theta")
    h = me.dynamicsymbols("h")
    t = me.dynamicsymbols._t
    m, g, l, w = sm.symbols("m g l omega", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    S = O.locatenew("S", (h + sm.sin(w * t)) * N.y)
    S.set_vel(N, (h.diff() + w * sm.cos(w * t)) * N.y)
    A = N.orientnew("A", "Axis", [th, N.z])
    A.set_ang_vel(N, th.diff() * N.z)
    P = S.locatenew("P", -l * A.y)
    P.v2pt_theory(S, N, A)
    pa = me.Particle("pa", P, m)
    pa.potential_energy = m * g * P.pos_from(O).dot(N.y)
    lm = me.LagrangesMethod(me.Lagrangian(N, pa), [th])
    lm.form_lagranges_equations()
    return lm


def spherical_pendulum_body(mech):
    """A rigid body on a ball joint (two angles), general central inertia, gravity."""
    me = mech
    q1, q2 = me.dynamicsymbols("q1 q2")
    m, g, d = sm.symbols("m g d", positive=True)
    Ixx, Iyy, Izz, Ixy = sm.symbols("I_xx I_yy I_zz I_xy")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q1, N.z])
    B = A.orientnew("B", "Axis", [q2, A.x])
    A.set_ang_vel(N, q1.diff() * N.z)
    B.set_ang_vel(A, q2.diff() * A.x)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", -d * B.z)
    G.v2pt_theory(O, N, B)
    body = me.RigidBody("body", G, B, m, (me.inertia(B, Ixx, Iyy, Izz, Ixy), G))
    body.potential_energy = m * g * G.pos_from(O).dot(N.z)
    lm = me.LagrangesMethod(me.Lagrangian(N, body), [q1, q2], bodies=[body], frame=N)
    lm.form_lagranges_equations()
    return lm
