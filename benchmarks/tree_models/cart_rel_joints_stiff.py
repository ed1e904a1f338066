"""A stiff variant of cart_rel_joints.py (issue 8's Radau case): the same n-link pendulum on a
cart in relative joint coordinates (n from EOMC_N_LINKS), plus a torsional spring k and damper c
at every pin joint, torque -(k q_i + c u_i) on link i and its reaction on the parent.  With the
parameters below the fastest (damped joint) modes are ~4e4 times faster than the slowest
nonzero mode at n = 40 (benchmarks/bench_tree_jacobian.py --stiff-radau prints the ratio), so
an explicit integrator's step is bounded by stability while Radau's is set by accuracy alone."""
import os

import sympy as sm
from sympy.physics import mechanics as me

n = int(os.environ.get("EOMC_N_LINKS", "3"))
name = f"cartjointsstiff{n}"
q = me.dynamicsymbols(f"q:{n + 1}")
u = me.dynamicsymbols(f"u:{n + 1}")
m0, m, l, g, k, c = sm.symbols("m0 m l g k_spring c_damper", positive=True)
F = me.dynamicsymbols("F")
ground = me.RigidBody("ground")
cart = me.RigidBody("cart", mass=m0)
cart.inertia = (me.inertia(cart.frame, 0, 0, 0), cart.masscenter)
joints = [me.PrismaticJoint("slider", ground, cart, q[0], u[0], joint_axis=ground.frame.x)]
loads = [me.Force(cart.masscenter, F * ground.frame.x)]
parent = cart
for i in range(1, n + 1):
    link = me.RigidBody(f"link{i}", mass=m)
    link.inertia = (me.inertia(link.frame, 0, 0, 0), link.masscenter)
    # q = 0: the link hangs along -y; its point mass sits l below its pin
    joints.append(me.PinJoint(f"pin{i}", parent, link, q[i], u[i], parent_point=parent.masscenter,
                              child_point=l * link.frame.y, joint_axis=parent.frame.z))
    torque = -(k * q[i] + c * u[i]) * parent.frame.z
    loads += [me.Torque(link.frame, torque), me.Torque(parent.frame, -torque)]
    parent = link
system = me.System.from_newtonian(ground)
system.add_joints(*joints)
system.apply_uniform_gravity(-g * ground.frame.y)
system.add_loads(*loads)
parameters = {m0: 2.0, m: 0.5, l: 0.75, g: 9.81, k: 200.0, c: 300.0}
inputs = [F]
