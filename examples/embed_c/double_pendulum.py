"""A planar double pendulum (two point masses on massless rods): the model main.c integrates.

Build it with `eomc build double_pendulum.py -o build` (the Makefile does).
"""
import sympy as sm

from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols

q1, q2, u1, u2 = dynamicsymbols("q1 q2 u1 u2")
m1, m2, l1, l2, g = sm.symbols("m1 m2 l1 l2 g")

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

kane = KanesMethod(N, q_ind=[q1, q2], u_ind=[u1, u2], kd_eqs=[q1.diff() - u1, q2.diff() - u2])
kane.kanes_equations([Particle("bob1", P1, m1), Particle("bob2", P2, m2)],
                     [(P1, -m1 * g * N.y), (P2, -m2 * g * N.y)])

system = kane
name = "double_pendulum"
parameters = {m1: 1.0, m2: 0.5, l1: 1.0, l2: 0.7, g: 9.81}
initial_state = {q1: 1.0, q2: -0.5}
