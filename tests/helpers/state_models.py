"""Mechanisms with extra first-order states, built with eomc's or SymPy's mechanics.

``torque_chain(n, mech)``: an n-link planar chain of pins (a joint tree, so both
formulations take it) whose joint torques come from first-order "motor" states
z_i (z_i' = (e_i - z_i)/tau_i + c·sin(q_i)·u_i: the mechanics depends on z, and z'
on q, u, z and an input), plus one integrator state s' = q_1 (a controller's).
Returns a dict: system (unformed System), states, parameters, inputs and the
symbol lists, so a test can form the same thing with SymPy and compare.
"""
import sympy as sm


def torque_chain(n, mech):
    me = mech
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    z = me.dynamicsymbols(f"z1:{n + 1}")
    e = me.dynamicsymbols(f"e1:{n + 1}")
    s = me.dynamicsymbols("s")
    m = sm.symbols(f"m1:{n + 1}")
    l = sm.symbols(f"l1:{n + 1}")
    tau = sm.symbols(f"tau1:{n + 1}")
    g, c, kz, ki = sm.symbols("g c kz ki")
    ground = me.RigidBody("ground")
    bodies, joints = [], []
    parent = ground
    for i in range(n):
        frame = me.ReferenceFrame(f"L{i + 1}")
        body = me.RigidBody(f"link{i + 1}", frame=frame, mass=m[i])
        body.central_inertia = me.inertia(frame, 0, 0, m[i] * l[i] ** 2 / 12)
        joint = me.PinJoint(f"J{i + 1}", parent, body, q[i], u[i], joint_axis=parent.frame.z,
                            parent_point=(l[i - 1] / 2 * parent.frame.x if i else parent.masscenter),
                            child_point=-l[i] / 2 * frame.x)
        bodies.append(body)
        joints.append(joint)
        parent = body
    system = me.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.frame.y)
    for i in range(n):
        torque = kz * z[i] - (ki * s if i == 0 else 0)
        prev = ground if i == 0 else bodies[i - 1]
        system.add_actuators(me.TorqueActuator(torque, bodies[i].frame.z, bodies[i], prev))
    states = {z[i]: (e[i] - z[i]) / tau[i] + c * sm.sin(q[i]) * u[i] for i in range(n)}
    states[s] = q[0] + q[0].diff() / 10     # q' is allowed (the kinematics)
    parameters = {g: 9.81, c: 0.3, kz: 2.0, ki: 0.5}
    parameters.update({m[i]: 1.0 + 0.2 * i for i in range(n)})
    parameters.update({l[i]: 0.5 + 0.1 * i for i in range(n)})
    parameters.update({tau[i]: 0.05 + 0.01 * i for i in range(n)})
    return {"system": system, "states": states, "parameters": parameters, "inputs": list(e),
            "q": list(q), "u": list(u), "z": list(z) + [s], "e": list(e)}


# A mass hanging from one De Groote 2016 musculotendon with first-order activation
# (the first-hour report's muscle_first_order.py), as a model file.  {mech}: the mechanics
# module (eomc.mechanics or sympy.physics.mechanics), {formulation}: RIGID_TENDON or
# FIBER_LENGTH_EXPLICIT.  No `states`: the System's musculotendon brings its own.
MUSCLE = '''\
from sympy import symbols
from {mech} import *
from sympy.physics.biomechanics import (MusculotendonDeGroote2016, MusculotendonFormulation,
                                        FirstOrderActivationDeGroote2016)

q, u = dynamicsymbols('q u')
m, g = symbols('m g', positive=True)
F_M_max, l_M_opt, l_T_slack, v_M_max, alpha_opt, beta = symbols(
    'F_M_max l_M_opt l_T_slack v_M_max alpha_opt beta')

ground = RigidBody('ground')
block = RigidBody('block', mass=m)
block.central_inertia = inertia(block.frame, 1, 1, 1)
slider = PrismaticJoint('slider', ground, block, q, u, joint_axis=-ground.y)
system = System.from_newtonian(ground)
system.add_joints(slider)
pathway = LinearPathway(ground.masscenter, block.masscenter)
activation = FirstOrderActivationDeGroote2016.with_defaults('muscle')
muscle = MusculotendonDeGroote2016.with_defaults(
    'muscle', pathway, activation, musculotendon_dynamics=MusculotendonFormulation.{formulation},
    tendon_slack_length=l_T_slack, peak_isometric_force=F_M_max, optimal_fiber_length=l_M_opt,
    maximal_fiber_velocity=v_M_max, optimal_pennation_angle=alpha_opt, fiber_damping_coefficient=beta)
system.add_actuators(muscle)
system.apply_uniform_gravity(-g * ground.y)

name = 'muscle_{formulation}'.lower()
inputs = list(activation.r)
parameters = {{m: 5.0, g: 9.81, F_M_max: 500.0, l_M_opt: 0.3, l_T_slack: 0.25, v_M_max: 10.0,
               alpha_opt: 0.0}}
if MusculotendonFormulation.{formulation} == MusculotendonFormulation.RIGID_TENDON:
    parameters[beta] = 0.1      # fibre damping: the elastic-tendon equations do not use it
initial_state = {{q: 0.55, u: 0.0, activation.a: 0.1}}
if len(muscle.x) == 2:      # elastic tendon: the normalized fibre length, tendon 1 % past slack
    initial_state[muscle.x[0]] = (0.55 - 0.2525) / 0.3
'''


# A pendulum driven by a first-order motor torque k·z, z' = (e - z)/tau: the smallest model
# file with `states`.  BAD_STATES: (states text, expected message, offset of the line from
# the `states` line) for the bad-input tests.
PENDULUM_Z = '''\
import sympy as sm
from eomc.mechanics import *

q, u = dynamicsymbols("q u")
z, e, w = dynamicsymbols("z e w")
m, l, g, k, tau = sm.symbols("m l g k tau")
N = ReferenceFrame("N")
A = N.orientnew("A", "Axis", [q, N.z])
A.set_ang_vel(N, u * N.z)
O = Point("O")
O.set_vel(N, 0)
P = O.locatenew("P", l * A.x)
P.v2pt_theory(O, N, A)
bob = Particle("bob", P, m)
kane = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
kane.kanes_equations([bob], [(P, -m * g * N.y), (A, k * z * N.z)])
system = kane
name = "pendz"
parameters = {m: 1.0, l: 0.5, g: 9.81, k: 2.0, tau: 0.1}
inputs = [e]
'''
