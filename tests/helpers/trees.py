"""Joint trees for the recursive formulation's tests and benchmarks.

``cart_relative``: SD/FAST's n-link pendulum on a cart in relative joint
coordinates, hand-built (frames oriented from N by q1+...+qk, as in the
performance report's n_link_cart_rel.py).  ``cart_joints``: the same system
as a SymPy ``System`` of a PrismaticJoint and n PinJoints.
"""
import sympy as sm
from sympy.physics import mechanics as sme


def cart_relative(n, mech, torques=False):
    """(KanesMethod, inputs) of the hand-built relative-coordinate cart."""
    me = mech
    q = me.dynamicsymbols(f"q:{n + 1}")
    u = me.dynamicsymbols(f"u:{n + 1}")
    m0, m, l, g = sm.symbols("m0 m l g", positive=True)
    F = me.dynamicsymbols("F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("P0", q[0] * N.x)
    cart.set_vel(N, u[0] * N.x)
    points, frames = [cart], [N]
    for i in range(1, n + 1):
        B = N.orientnew(f"B{i}", "Axis", [sum(q[1:i + 1]), N.z])
        B.set_ang_vel(N, sum(u[1:i + 1]) * N.z)
        P = points[-1].locatenew(f"P{i}", -l * B.y)
        P.v2pt_theory(points[-1], N, B)
        points.append(P)
        frames.append(B)
    masses = [m0] + [m] * n
    particles = [me.Particle(f"Pa{i}", P, mi) for i, (P, mi) in enumerate(zip(points, masses))]
    loads = [(P, -mi * g * N.y) for P, mi in zip(points, masses)] + [(cart, F * N.x)]
    inputs = [F]
    if torques:
        T = me.dynamicsymbols(f"T1:{n + 1}")
        for i in range(n):
            loads.append((frames[i + 1], T[i] * N.z))
            if i > 0:
                loads.append((frames[i], -T[i] * N.z))
        inputs += list(T)
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(particles, loads)
    return kane, inputs


def add_joint_spring(system, index, k, c):
    """A torsional spring-damper -(k q + c u) on ``system.joints[index]`` (a PinJoint): a load
    that depends on the state (the recursive Jacobians then keep their tangent path)."""
    joint = system.joints[index]
    q, u = joint.coordinates[0], joint.speeds[0]
    tau = -(k * q + c * u) * joint.joint_axis
    system.add_loads(sme.Torque(joint.child_interframe, tau), sme.Torque(joint.parent_interframe, -tau))
    return system


def cart_joints(n, rigid=False, tip=False):
    """SymPy System: cart on a PrismaticJoint, n links on PinJoints (relative angles).

    ``rigid``: the links get a full inertia (symbols) instead of point masses.
    ``tip``: one more link after the n equal ones, of its own mass mt and length lt.
    Equations are not formed (System.form_eoms() is the caller's choice).
    """
    links = n + 1 if tip else n
    q = sme.dynamicsymbols(f"q:{links + 1}")
    u = sme.dynamicsymbols(f"u:{links + 1}")
    m0, m, l, g = sm.symbols("m0 m l g", positive=True)
    mt, lt = sm.symbols("mt lt", positive=True) if tip else (m, l)
    F = sme.dynamicsymbols("F")
    ground = sme.RigidBody("ground")
    cart = sme.RigidBody("cart", mass=m0)
    cart.inertia = (sme.inertia(cart.frame, 0, 0, 0), cart.masscenter)
    joints = [sme.PrismaticJoint("slider", ground, cart, q[0], u[0], joint_axis=ground.frame.x)]
    parent = cart
    for i in range(1, links + 1):
        last = tip and i == links
        link = sme.RigidBody(f"link{i}", mass=mt if last else m)
        if rigid:
            ixx, iyy, izz, ixy = sm.symbols(f"ixx{i} iyy{i} izz{i} ixy{i}")
            link.inertia = (sme.inertia(link.frame, ixx, iyy, izz, ixy), link.masscenter)
        else:
            link.inertia = (sme.inertia(link.frame, 0, 0, 0), link.masscenter)
        ppoint = parent.masscenter if i == 1 else -l * parent.frame.y
        joints.append(sme.PinJoint(f"pin{i}", parent, link, q[i], u[i], parent_point=ppoint,
                                   child_point=(lt if last else l) * link.frame.y, joint_axis=parent.frame.z))
        parent = link
    system = sme.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.frame.y)
    system.add_loads(sme.Force(cart.masscenter, F * ground.frame.x))
    return system, [F]
