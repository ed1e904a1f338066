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
    parts = n_link_pendulum_on_cart_kinematics(n, mech, cart_force, joint_torques)
    kane = mech.KanesMethod(parts["frame"], q_ind=parts["q"], u_ind=parts["u"],
                            kd_eqs=parts["kd_eqs"])
    kane.kanes_equations(parts["bodies"], parts["loads"])
    return kane, parts["specified"]


def n_link_pendulum_on_cart_kinematics(n, mech, cart_force=True, joint_torques=False):
    """Everything :func:`n_link_pendulum_on_cart` builds before Kane's method runs.

    Returns a dict with frame, q, u, kd_eqs, bodies, loads and specified, so a
    benchmark can time the derivation (KanesMethod + kanes_equations) alone.
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
    return {"frame": I, "q": q, "u": u, "kd_eqs": kindiffs, "bodies": particles,
            "loads": forces, "specified": specified}


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


def heavy_top(mech, torque_input=True):
    """A symmetric top on a fixed pivot, body-fixed 3-1-3 Euler angles.

    The generalized speeds are ω's body-frame measure numbers, so the
    kinematic differential equations are not q' = u.  An optional specified
    torque T(t) acts about the inertial vertical.  Returns (kane, specified).
    """
    me = mech
    q = me.dynamicsymbols("q1:4")
    u = me.dynamicsymbols("u1:4")
    m, g, l, I1, I3 = sm.symbols("m g l I1 I3")
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Body", q, "313")
    B.set_ang_vel(N, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    kd = me.kinematic_equations(u, q, "body", "313")
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", l * B.z)
    G.v2pt_theory(O, N, B)
    top = me.RigidBody("Top", G, B, m, (me.inertia(B, I1, I1, I3), G))
    loads = [(G, -m * g * N.z)]
    specified = []
    if torque_input:
        T = me.dynamicsymbols("T")
        loads.append((B, T * N.z))
        specified.append(T)
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations([top], loads)
    return kane, specified


def rolling_disc(mech):
    """A thin disc rolling without slip on a plane (SymPy's linearization example).

    Coordinates: yaw, lean, spin, contact x, y (independent) and centre
    height (dependent, one configuration constraint); speeds: ω's measure
    numbers in the lean frame (independent) and the centre's velocity in the
    disc frame (dependent, three velocity constraints: the contact point does
    not slip).  Returns (kane, specified).
    """
    me = mech
    t = me.dynamicsymbols._t
    r, m, g = sm.symbols("r m g")
    q = me.dynamicsymbols("q1:7")
    u = me.dynamicsymbols("u1:7")
    N = me.ReferenceFrame("N")
    NO = me.Point("NO")
    A = N.orientnew("A", "Axis", [q[0], N.z])
    B = A.orientnew("B", "Axis", [q[1], A.x])
    C = B.orientnew("C", "Axis", [q[2], B.y])
    CO = NO.locatenew("CO", q[3] * N.x + q[4] * N.y + q[5] * N.z)
    w_c_n_qd = C.ang_vel_in(N)
    w_b_n_qd = B.ang_vel_in(N)
    C.set_ang_vel(N, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    v_co_n_qd = CO.pos_from(NO).dt(N)
    CO.set_vel(N, u[3] * C.x + u[4] * C.y + u[5] * C.z)
    P = CO.locatenew("P", r * B.z)
    P.v2pt_theory(CO, N, C)
    f_c = [q[5] - me.dot(CO.pos_from(P), N.z)]
    f_v = [me.dot(P.vel(N), uv) for uv in C]
    kd = [me.dot(w_c_n_qd - C.ang_vel_in(N), uv) for uv in B] + \
         [me.dot(v_co_n_qd - CO.vel(N), uv) for uv in N]
    qd = [qi.diff(t) for qi in q]
    qdots = sm.solve(kd, qd)
    B.set_ang_vel(N, w_b_n_qd.subs(qdots))
    disc = me.RigidBody("Disc", CO, C, m,
                        (me.inertia(C, m * r**2 / 4, m * r**2 / 2, m * r**2 / 4), CO))
    kane = me.KanesMethod(N, q[:5], u[:3], kd_eqs=kd, q_dependent=[q[5]],
                          configuration_constraints=f_c, u_dependent=u[3:],
                          velocity_constraints=f_v)
    kane.kanes_equations([disc], [(CO, m * g * A.z)])
    return kane, []


def rolling_disc_aux(mech):
    """The rolling disc with auxiliary speeds at the contact point (SymPy's test_aux, 3D).

    Minimal coordinates (yaw, lean, spin) and speeds (ω in the lean frame);
    u4, u5, u6 are auxiliary speeds of the contact point C, where unknown
    contact forces f1 L.x + f2 (Y.z × L.x) + f3 Y.z act.  ``kane.auxiliary_eqs``
    = 0 then gives the contact force.  Returns (kane, specified) where
    specified is empty and the contact forces are ``sm.symbols('f1:4')``.
    """
    me = mech
    q1, q2, q3 = q = me.dynamicsymbols("q1:4")
    u1, u2, u3 = u = me.dynamicsymbols("u1:4")
    u4, u5, u6 = me.dynamicsymbols("u4:7")
    f1, f2, f3 = sm.symbols("f1:4")
    r, m, g = sm.symbols("r m g")
    N = me.ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [q1, N.z])
    L = Y.orientnew("L", "Axis", [q2, Y.x])
    R = L.orientnew("R", "Axis", [q3, L.y])
    w_R_N_qd = R.ang_vel_in(N)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    C = me.Point("C")
    C.set_vel(N, u4 * L.x + u5 * me.cross(Y.z, L.x) + u6 * Y.z)
    Dmc = C.locatenew("Dmc", r * L.z)
    Dmc.v2pt_theory(C, N, R)
    I = me.inertia(L, m / 4 * r**2, m / 2 * r**2, m / 4 * r**2)
    kd = [me.dot(R.ang_vel_in(N) - w_R_N_qd, uv) for uv in L]
    loads = [(Dmc, -m * g * Y.z), (C, f1 * L.x + f2 * me.cross(Y.z, L.x) + f3 * Y.z)]
    disc = me.RigidBody("Disc", Dmc, R, m, (I, Dmc))
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd, u_auxiliary=[u4, u5, u6])
    kane.kanes_equations([disc], loads)
    return kane, []


def four_bar(mech):
    """A planar four-bar linkage: one independent and two dependent coordinates.

    Links A, B, C (angles q1, q2, q3 from N.x, rigid bodies at their
    midpoints) close the loop on a ground link of length l4: two
    configuration constraints, and two velocity constraints (the loop end
    does not move) for the dependent speeds u2, u3.  Gravity along −N.y and a
    specified torque T(t) on link A.  Returns (kane, specified).
    """
    me = mech
    q = me.dynamicsymbols("q1:4")
    u = me.dynamicsymbols("u1:4")
    T = me.dynamicsymbols("T")
    l1, l2, l3, l4, g = sm.symbols("l1 l2 l3 l4 g")
    ms = sm.symbols("m1:4")
    Izz = sm.symbols("I1:4")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    frames = []
    for i in range(3):
        F = N.orientnew(f"L{i + 1}", "Axis", [q[i], N.z])
        F.set_ang_vel(N, u[i] * N.z)
        frames.append(F)
    ends, bodies = [O], []
    for i, (F, li) in enumerate(zip(frames, (l1, l2, l3))):
        mid = ends[-1].locatenew(f"G{i + 1}", li / 2 * F.x)
        mid.v2pt_theory(ends[-1], N, F)
        end = ends[-1].locatenew(f"P{i + 1}", li * F.x)
        end.v2pt_theory(ends[-1], N, F)
        ends.append(end)
        bodies.append(me.RigidBody(f"Link{i + 1}", mid, F, ms[i],
                                   (me.inertia(F, 0, 0, Izz[i]), mid)))
    loop = ends[-1].pos_from(O) - l4 * N.x
    config = [me.dot(loop, N.x), me.dot(loop, N.y)]
    vel = [me.dot(ends[-1].vel(N), N.x), me.dot(ends[-1].vel(N), N.y)]
    kd = [qi.diff() - ui for qi, ui in zip(q, u)]
    loads = [(b.masscenter, -b.mass * g * N.y) for b in bodies] + [(frames[0], T * N.z)]
    kane = me.KanesMethod(N, [q[0]], [u[0]], kd_eqs=kd, q_dependent=q[1:],
                          configuration_constraints=config, u_dependent=u[1:],
                          velocity_constraints=vel)
    kane.kanes_equations(bodies, loads)
    return kane, [T]


def spring_damper_chain(n, mech):
    """n particles on a line, each tied to the previous one (the first to a wall)
    by a linear spring k_i and damper c_i; a specified force F(t) pulls the
    last one.  Returns (kane, specified)."""
    me = mech
    q = me.dynamicsymbols(f"x1:{n + 1}")
    u = me.dynamicsymbols(f"v1:{n + 1}")
    m = sm.symbols(f"m1:{n + 1}")
    k = sm.symbols(f"k1:{n + 1}")
    c = sm.symbols(f"c1:{n + 1}")
    F = me.dynamicsymbols("F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    points, particles, loads = [], [], []
    for i in range(n):
        P = O.locatenew(f"P{i + 1}", q[i] * N.x)
        P.set_vel(N, u[i] * N.x)
        points.append(P)
        particles.append(me.Particle(f"M{i + 1}", P, m[i]))
    for i in range(n):
        stretch = q[i] - (q[i - 1] if i else 0)
        rate = u[i] - (u[i - 1] if i else 0)
        f = (-k[i] * stretch - c[i] * rate) * N.x
        loads.append((points[i], f))
        if i:
            loads.append((points[i - 1], -f))
    loads.append((points[-1], F * N.x))
    kd = [qi.diff() - ui for qi, ui in zip(q, u)]
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(particles, loads)
    return kane, [F]


ACTUATOR_KINDS = ("force", "spring", "damper", "duffing", "muscle")
PATHWAY_KINDS = ("linear", "obstacle", "cylinder", "sphere")


def actuators_on_pathways(mech, actuators=ACTUATOR_KINDS, pathways=PATHWAY_KINDS):
    """(System, inputs, parameters, labels): one small subsystem per actuator x pathway pair,
    side by side in one System (so the whole matrix costs one build per formulation).

    Each subsystem: body A slides on ground's x (PrismaticJoint), body B turns about A's z
    through A's centre (PinJoint), with a gravity field along -y; the pathway runs from a
    point on the ground (linear, obstacle via a point on A) or on A (sphere) to a point on
    B at radius r from the pin, so it stays on the surface of a sphere fixed in A at A's
    centre -- the wrapping reaction then acts on A, a body point, not the ground.  The
    cylinder (SymPy needs a numeric central angle) lies along the slide, fixed in the
    ground, its path from the ground to a point on A.  Plus a TorqueActuator between A and B in every
    subsystem (a joint torque with its reaction).  ``labels[k]``: the pair speed k belongs to.
    """
    me = mech
    from sympy.physics import biomechanics as bm
    ground = me.RigidBody("ground")
    N = ground.frame
    system = me.System.from_newtonian(ground)
    g = sm.Symbol("g")
    inputs, params, labels = [], {g: 9.81}, []
    for k, (act, path) in enumerate((a, p) for p in pathways for a in actuators):
        tag = f"{act}_{path}"
        mA, mB, r, c = sm.symbols(f"mA_{k} mB_{k} r_{k} c_{k}", positive=True)
        IA = sm.symbols(f"IAxx_{k} IAyy_{k} IAzz_{k}", positive=True)
        IB = sm.symbols(f"IBxx_{k} IByy_{k} IBzz_{k} IBxy_{k}", positive=True)
        A = me.RigidBody(f"A_{k}", mass=mA)
        A.central_inertia = me.inertia(A.frame, *IA)
        B = me.RigidBody(f"B_{k}", mass=mB)
        B.central_inertia = me.inertia(B.frame, IB[0], IB[1], IB[2], IB[3])
        q = me.dynamicsymbols(f"qa_{k} qb_{k}")
        u = me.dynamicsymbols(f"ua_{k} ub_{k}")
        anchor = ground.masscenter.locatenew(f"O_{k}", 3 * k * N.z)
        slide = me.PrismaticJoint(f"slide_{k}", ground, A, q[0], u[0], parent_point=anchor,
                                  joint_axis=N.x)
        pin = me.PinJoint(f"pin_{k}", A, B, q[1], u[1], child_point=-c * B.frame.y,
                          joint_axis=A.frame.z)
        system.add_joints(slide, pin)
        # B's centre moves with the pin; said once, so SymPy need not guess between the pin
        # and the pathway's point pB (its "automatically calculated" warning)
        B.masscenter.v2pt_theory(pin.child_point, N, B.frame)
        pB = B.masscenter.locatenew(f"pB_{k}", -c * B.frame.y + r * B.frame.x)   # r from the pin
        if path == "linear":
            pG = anchor.locatenew(f"pG_{k}", -2 * r * N.y)
            pathway = me.LinearPathway(pG, pB)
        elif path == "obstacle":
            pG = anchor.locatenew(f"pG_{k}", -2 * r * N.y)
            pO = A.masscenter.locatenew(f"pO_{k}", r * A.frame.y)
            pathway = me.ObstacleSetPathway(pG, pO, pB)
        elif path == "cylinder":
            # SymPy computes a cylinder's geodesic only for a numeric central angle: the
            # cylinder lies along the slide (ground x through the anchor), the path runs
            # from the ground at angle 0 to A at a quarter turn, a helix as A slides
            pG = anchor.locatenew(f"pG_{k}", r * N.y)
            pA = A.masscenter.locatenew(f"pA_{k}", r * A.frame.z)
            pathway = me.WrappingPathway(pG, pA, me.WrappingCylinder(r, anchor, N.x))
        else:
            pA = A.masscenter.locatenew(f"pA_{k}", r * A.frame.y)
            pathway = me.WrappingPathway(pA, pB, me.WrappingSphere(r, A.masscenter))
        if act == "force":
            F = me.dynamicsymbols(f"F_{k}")
            inputs.append(F)
            actuator = me.ForceActuator(F, pathway)
        elif act == "spring":
            kk, l0 = sm.symbols(f"k_{k} l0_{k}", positive=True)
            params.update({kk: 40.0, l0: 0.5})
            actuator = me.LinearSpring(kk, pathway, l0)
        elif act == "damper":
            cc = sm.Symbol(f"cd_{k}", positive=True)
            params[cc] = 3.0
            actuator = me.LinearDamper(cc, pathway)
        elif act == "duffing":
            k1, k3, l0 = sm.symbols(f"k1_{k} k3_{k} l0_{k}", positive=True)
            params.update({k1: 30.0, k3: 5.0, l0: 0.4})
            actuator = me.DuffingSpring(k1, k3, pathway, l0)
        else:
            activation = bm.ZerothOrderActivation(f"m{k}")
            actuator = bm.MusculotendonDeGroote2016.with_defaults(
                f"m{k}", pathway, activation, tendon_slack_length=sm.Symbol(f"lts_{k}"),
                peak_isometric_force=sm.Symbol(f"fmax_{k}"),
                optimal_fiber_length=sm.Symbol(f"lmopt_{k}"))
            params.update({sm.Symbol(f"lts_{k}"): 0.3, sm.Symbol(f"fmax_{k}"): 20.0,
                           sm.Symbol(f"lmopt_{k}"): 0.6})
            inputs.extend(activation.r)
        T = me.dynamicsymbols(f"T_{k}")
        inputs.append(T)
        system.add_actuators(actuator, me.TorqueActuator(T, A.frame.z, B, A))
        # A only slides and B turns about z: the other inertias are in no equation
        params.update({mA: 2.0, mB: 1.0, r: 0.3, c: 0.2, IB[2]: 0.07})
        labels += [tag, tag]
    system.apply_uniform_gravity(-g * N.y)
    return system, inputs, params, labels
