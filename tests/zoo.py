"""Mechanisms used as test oracles and benchmarks.

Every builder takes the mechanics module to build with (``eomc.mechanics`` or
``sympy.physics.mechanics``), so the same mechanism is formed by eomc and by
SymPy and the two can be compared numerically.  Kinematics objects are
SymPy's in both cases; only KanesMethod/LagrangesMethod differ.
"""
import sympy as sm


def n_link_pendulum_on_cart(n, mech, cart_force=True, joint_torques=False):
    """PyDy's ``pydy.models.n_link_pendulum_on_cart``, formed with Kane's method.

    Returns (kane, specified) where specified lists the input dynamic symbols.
    """
    me = mech
    q = me.dynamicsymbols(f"q:{n + 1}")
    u = me.dynamicsymbols(f"u:{n + 1}")
    m = sm.symbols(f"m:{n + 1}")
    l = sm.symbols(f"l:{n}")
    g, t = sm.symbols("g t")
    I = me.ReferenceFrame("I")
    O = me.Point("O")
    O.set_vel(I, 0)
    P0 = me.Point("P0")
    P0.set_pos(O, q[0] * I.x)
    P0.set_vel(I, u[0] * I.x)
    points = [P0]
    particles = [me.Particle("Pa0", P0, m[0])]
    forces = [(P0, -m[0] * g * I.y)]
    kindiffs = [q[0].diff(t) - u[0]]
    specified = []
    torques = me.dynamicsymbols(f"T1:{n + 1}") if joint_torques else []
    frames = [I]
    for i in range(n):
        Bi = I.orientnew(f"B{i}", "Axis", [q[i + 1], I.z])
        Bi.set_ang_vel(I, u[i + 1] * I.z)
        frames.append(Bi)
        Pi = points[-1].locatenew(f"P{i + 1}", l[i] * Bi.y)
        Pi.v2pt_theory(points[-1], I, Bi)
        points.append(Pi)
        particles.append(me.Particle(f"Pa{i + 1}", Pi, m[i + 1]))
        forces.append((Pi, -m[i + 1] * g * I.y))
        kindiffs.append(q[i + 1].diff(t) - u[i + 1])
    if joint_torques:
        for i in range(n):
            forces.append((frames[i + 1], torques[i] * I.z))
            if i + 1 < n:
                forces.append((frames[i + 2], -torques[i] * I.z))
        specified.extend(torques)
    if cart_force:
        F = me.dynamicsymbols("F")
        forces.append((P0, F * I.x))
        specified.append(F)
    kane = me.KanesMethod(I, q_ind=q, u_ind=u, kd_eqs=kindiffs)
    kane.kanes_equations(particles, forces)
    return kane, specified


def n_link_pendulum_on_cart_lagrange(n, mech, cart_force=True):
    """The same mechanism as :func:`n_link_pendulum_on_cart`, by Lagrange's method.

    The generalized speeds are the coordinates' time derivatives.
    Returns (lagrange, specified).
    """
    me = mech
    q = me.dynamicsymbols(f"q:{n + 1}")
    qd = [qi.diff() for qi in q]
    m = sm.symbols(f"m:{n + 1}")
    l = sm.symbols(f"l:{n}")
    g = sm.symbols("g")
    I = me.ReferenceFrame("I")
    O = me.Point("O")
    O.set_vel(I, 0)
    P0 = me.Point("P0")
    P0.set_pos(O, q[0] * I.x)
    P0.set_vel(I, qd[0] * I.x)
    points = [P0]
    particles = [me.Particle("Pa0", P0, m[0])]
    particles[0].potential_energy = 0
    for i in range(n):
        Bi = I.orientnew(f"B{i}", "Axis", [q[i + 1], I.z])
        Bi.set_ang_vel(I, qd[i + 1] * I.z)
        Pi = points[-1].locatenew(f"P{i + 1}", l[i] * Bi.y)
        Pi.v2pt_theory(points[-1], I, Bi)
        points.append(Pi)
        pa = me.Particle(f"Pa{i + 1}", Pi, m[i + 1])
        pa.potential_energy = m[i + 1] * g * Pi.pos_from(O).dot(I.y)
        particles.append(pa)
    L = me.Lagrangian(I, *particles)
    forces, specified = [], []
    if cart_force:
        F = me.dynamicsymbols("F")
        forces.append((P0, F * I.x))
        specified.append(F)
    lm = me.LagrangesMethod(L, q, forcelist=forces, frame=I)
    lm.form_lagranges_equations()
    return lm, specified
