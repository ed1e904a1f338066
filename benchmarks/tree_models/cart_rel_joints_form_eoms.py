"""The n-link cart of cart_rel_joints.py (SD/FAST's system: one PrismaticJoint and n PinJoints,
EOMC_N_LINKS) as eomc's System, written the way SymPy's documentation writes it: the file
calls ``system.form_eoms()`` itself.  EOMC_READ_EOMS=1 also reads the returned equations
(their shape), which forms Kane's equations in the file whatever the build does with them;
EOMC_FORM_EOMS=0 leaves form_eoms() out (the unformed System, for comparison)."""
import os

import sympy as sm
from eomc import mechanics as me

n = int(os.environ.get("EOMC_N_LINKS", "3"))
name = f"cartformeoms{n}"
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
    joints.append(me.PinJoint(f"pin{i}", parent, link, q[i], u[i], parent_point=parent.masscenter,
                              child_point=l * link.frame.y, joint_axis=parent.frame.z))
    parent = link
system = me.System.from_newtonian(ground)
system.add_joints(*joints)
system.apply_uniform_gravity(-g * ground.frame.y)
system.add_loads(me.Force(cart.masscenter, F * ground.frame.x))
if os.environ.get("EOMC_FORM_EOMS", "1") == "1":
    eoms = system.form_eoms()
    if os.environ.get("EOMC_READ_EOMS") == "1":
        assert eoms.shape == (n + 1, 1)
parameters = {m0: 2.0, m: 0.5, l: 0.75, g: 9.81}
inputs = [F]
