"""A pendulum on a cart, written as SymPy 1.14 teaches it: System, joints, actuators.

The cart slides on a PrismaticJoint along the ground's x axis and is tied to
a wall by a spring (LinearSpring) and a damper (LinearDamper) along a
LinearPathway; a motor force ``F`` pushes it (ForceActuator on the same
pathway) and a motor torque ``T`` turns the pole on its PinJoint relative to
the cart (TorqueActuator, with the reaction on the cart).  ``F`` and ``T``
are the model's inputs.  ``system`` is the System itself: eomc forms the
equations with its own KanesMethod when it compiles it.  ``geometry`` says
how ``eomc animate`` draws the cart and the pole.
"""
import sympy as sm

from eomc.mechanics import (ForceActuator, Inertia, LinearDamper, LinearPathway, LinearSpring,
                            PinJoint, PrismaticJoint, RigidBody, System, TorqueActuator,
                            dynamicsymbols)
from eomc.geometry import box

q_cart, q_pole = dynamicsymbols("q_cart q_pole")
u_cart, u_pole = dynamicsymbols("u_cart u_pole")
F, T = dynamicsymbols("F T")
m_cart, m_pole, l, k, c, d, g = sm.symbols("m_cart m_pole l k c d g", positive=True)

ground = RigidBody("ground")
cart = RigidBody("cart", mass=m_cart)
pole = RigidBody("pole", mass=m_pole)
pole.inertia = Inertia.from_inertia_scalars(pole.masscenter, pole.frame,
                                            0, 0, m_pole * l**2 / 12)

system = System.from_newtonian(ground)
slider = PrismaticJoint("slider", ground, cart, q_cart, u_cart, joint_axis=ground.x)
hinge = PinJoint("hinge", cart, pole, q_pole, u_pole, joint_axis=cart.z,
                 child_point=l / 2 * pole.y)          # the pole hangs down from the cart at q_pole = 0
system.add_joints(slider, hinge)

wall = ground.masscenter.locatenew("wall", -d * ground.x)    # the spring's anchor, fixed
wall.set_vel(ground.frame, 0)
path = LinearPathway(wall, cart.masscenter)
system.add_actuators(
    LinearSpring(k, path, equilibrium_length=d),
    LinearDamper(c, path),
    ForceActuator(F, path),
    TorqueActuator(T, cart.z, pole, cart),
)
system.apply_uniform_gravity(-g * ground.y)
system.validate_system()

inputs = [F, T]
parameters = {m_cart: 1.0, m_pole: 0.5, l: 1.0, k: 20.0, c: 0.5, d: 1.0, g: 9.81}
initial_state = {q_cart: 0.1, q_pole: 0.5, u_cart: 0.0, u_pole: 0.0}
outputs = {
    "tip_x": pole.masscenter.pos_from(ground.masscenter).dot(ground.x) * 2 - q_cart,
    "tip_y": pole.masscenter.pos_from(ground.masscenter).dot(ground.y) * 2,
}
# how `eomc animate` draws the bodies (without it: spheres, lines and small axes)
geometry = {cart: box(0.4, 0.2, 0.2, color="blue"), pole: box(0.05, 1.0, 0.05, color="orange")}
