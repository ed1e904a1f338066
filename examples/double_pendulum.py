"""A planar double pendulum: two point masses on massless rods, by Kane's method.

Coordinates are the rods' absolute angles from the downward vertical; the
speeds are their rates.  With no friction the energy is conserved, which the
``energy`` output lets a simulation check.
"""
import sympy as sm

from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols

q1, q2 = dynamicsymbols("q1 q2")
u1, u2 = dynamicsymbols("u1 u2")
m1, m2, l1, l2, g = sm.symbols("m1 m2 l1 l2 g", positive=True)

N = ReferenceFrame("N")
A = N.orientnew("A", "Axis", [q1, N.z])
B = N.orientnew("B", "Axis", [q2, N.z])
A.set_ang_vel(N, u1 * N.z)
B.set_ang_vel(N, u2 * N.z)

O = Point("O")
O.set_vel(N, 0)
P1 = O.locatenew("P1", -l1 * A.y)
P1.v2pt_theory(O, N, A)
P2 = P1.locatenew("P2", -l2 * B.y)
P2.v2pt_theory(P1, N, B)

bobs = [Particle("Bob1", P1, m1), Particle("Bob2", P2, m2)]
loads = [(P1, -m1 * g * N.y), (P2, -m2 * g * N.y)]

system = KanesMethod(N, q_ind=[q1, q2], u_ind=[u1, u2],
                     kd_eqs=[q1.diff() - u1, q2.diff() - u2])
system.kanes_equations(bobs, loads)

parameters = {m1: 1.0, m2: 1.0, l1: 1.0, l2: 1.0, g: 9.81}
initial_state = {q1: 1.0, q2: 0.5, u1: 0.0, u2: 0.0}

_kinetic = sum(b.mass * b.point.vel(N).dot(b.point.vel(N)) / 2 for b in bobs)
_potential = sum(b.mass * g * b.point.pos_from(O).dot(N.y) for b in bobs)
outputs = {
    "energy": sm.expand(_kinetic + _potential),
    "tip_x": P2.pos_from(O).dot(N.x),
    "tip_y": P2.pos_from(O).dot(N.y),
}
