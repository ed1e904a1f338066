"""The n-link pendulum on a cart in relative joint coordinates (SD/FAST's system) as a SymPy
System of a PrismaticJoint and n PinJoints (n from EOMC_N_LINKS).  Equations are not formed:
only the recursive formulation builds it without System.form_eoms()."""
import os

import sympy as sm
from sympy.physics import mechanics as me

n = int(os.environ.get("EOMC_N_LINKS", "3"))
name = f"cartjoints{n}"
q = me.dynamicsymbols(f"q:{n + 1}")
u = me.dynamicsymbols(f"u:{n + 1}")
m0, m, l, g = sm.symbols("m0 m l g", positive=True)
F = me.dynamicsymbols("F")
ground = me.RigidBody("ground")
cart = me.RigidBody("cart", mass=m0)
cart.inertia = (me.inertia(cart.frame, 0, 0, 0), cart.masscenter)
joints = [me.PrismaticJoint("slider", ground, cart, q[0], u[0], joint_axis=ground.frame.x)]
parent = cart
for i in range(1, n + 1):
    link = me.RigidBody(f"link{i}", mass=m)
    link.inertia = (me.inertia(link.frame, 0, 0, 0), link.masscenter)
    # q = 0: the link hangs along -y; its point mass sits l below its pin
    ppoint = parent.masscenter if i == 1 else parent.masscenter
    joints.append(me.PinJoint(f"pin{i}", parent, link, q[i], u[i], parent_point=ppoint,
                              child_point=l * link.frame.y, joint_axis=parent.frame.z))
    parent = link
system = me.System.from_newtonian(ground)
system.add_joints(*joints)
system.apply_uniform_gravity(-g * ground.frame.y)
system.add_loads(me.Force(cart.masscenter, F * ground.frame.x))
parameters = {m0: 2.0, m: 0.5, l: 0.75, g: 9.81}
inputs = [F]
