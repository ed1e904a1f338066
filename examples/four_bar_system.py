"""A four-bar linkage: a closed kinematic loop, as SymPy 1.14's docs build it.

Three PinJoints chain the crank, the coupler and the rocker to the ground
link; the loop is closed by two holonomic constraints (the rocker's free end
must meet the ground link's other end), which makes the coupler and rocker
angles ``q2, q3`` dependent on the crank angle ``q1``, and their speeds on
``u1``.  Gravity acts along -y, and a motor torque ``T`` drives the crank
(TorqueActuator, reaction on the ground): the model's input.

The links form a parallelogram (ground = coupler, crank = rocker), so a
consistent state is known in closed form: q2 = pi - q1, q3 = q1, u2 = -u1,
u3 = u1.  The run starts at q1 = -1 rad and swings about q1 = -pi/2,
away from the linkage's collinear (singular) configurations.
"""
import sympy as sm

from eomc.mechanics import (Inertia, PinJoint, RigidBody, System, TorqueActuator,
                            dynamicsymbols)

q1, q2, q3 = dynamicsymbols("q1:4")
u1, u2, u3 = dynamicsymbols("u1:4")
T = dynamicsymbols("T")
l1, l2, l3, l4 = sm.symbols("l1:5", positive=True)
m2, m3, m4, g = sm.symbols("m2:5 g", positive=True)

ground = RigidBody("ground")
crank, coupler, rocker = (RigidBody(name, mass=m) for name, m in
                          (("crank", m2), ("coupler", m3), ("rocker", m4)))
for body, length in ((crank, l2), (coupler, l3), (rocker, l4)):   # slender rods about z
    body.inertia = Inertia.from_inertia_scalars(body.masscenter, body.frame,
                                                0, 0, body.mass * length**2 / 12)

joints = [
    PinJoint("J1", ground, crank, q1, u1, parent_point=l1 / 2 * ground.x,
             child_point=-l2 / 2 * crank.x, joint_axis=ground.z),
    PinJoint("J2", crank, coupler, q2, u2, parent_point=l2 / 2 * crank.x,
             child_point=-l3 / 2 * coupler.x, joint_axis=crank.z),
    PinJoint("J3", coupler, rocker, q3, u3, parent_point=l3 / 2 * coupler.x,
             child_point=-l4 / 2 * rocker.x, joint_axis=coupler.z),
]
system = System.from_newtonian(ground)
system.add_joints(*joints)

# close the loop: the rocker's free end coincides with the ground link's left end
loop = (rocker.masscenter.pos_from(ground.masscenter)
        + l4 / 2 * rocker.x + l1 / 2 * ground.x)
system.add_holonomic_constraints(loop.dot(ground.x), loop.dot(ground.y))
system.q_ind, system.q_dep = [q1], [q2, q3]
system.u_ind, system.u_dep = [u1], [u2, u3]

system.add_actuators(TorqueActuator(T, ground.z, crank, ground))
system.apply_uniform_gravity(-g * ground.y)
system.validate_system()

inputs = [T]
parameters = {l1: 1.0, l2: 0.5, l3: 1.0, l4: 0.5, m2: 1.0, m3: 2.0, m4: 1.0, g: 9.81}
_q1 = -1.0
initial_state = {q1: _q1, q2: float(sm.pi) - _q1, q3: _q1, u1: 0.0, u2: 0.0, u3: 0.0}
outputs = {
    "coupler_x": coupler.masscenter.pos_from(ground.masscenter).dot(ground.x),
    "coupler_y": coupler.masscenter.pos_from(ground.masscenter).dot(ground.y),
}
