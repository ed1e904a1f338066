"""PyDy's n-link pendulum on a cart, by Kane's method (n from EOMC_N_LINKS, default 3).

A cart slides along N.x under a specified force F(t); n point masses hang on
massless links with absolute angles q1..qn (0 = straight up).  This is the
benchmark mechanism of the project; ``energy`` is conserved when F = 0.
"""
import os

import sympy as sm

from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols, kinetic_energy

n = int(os.environ.get("EOMC_N_LINKS", "3"))
if n < 1:
    raise ValueError(f"EOMC_N_LINKS must be a positive integer, got {n}")

q = dynamicsymbols(f"q:{n + 1}")
u = dynamicsymbols(f"u:{n + 1}")
m = sm.symbols(f"m:{n + 1}", positive=True)
l = sm.symbols(f"l:{n}", positive=True)
g = sm.symbols("g", positive=True)
F = dynamicsymbols("F")

N = ReferenceFrame("N")
O = Point("O")
O.set_vel(N, 0)
cart = O.locatenew("P0", q[0] * N.x)
cart.set_vel(N, u[0] * N.x)
points = [cart]
for i in range(n):
    B = N.orientnew(f"B{i}", "Axis", [q[i + 1], N.z])
    B.set_ang_vel(N, u[i + 1] * N.z)
    P = points[-1].locatenew(f"P{i + 1}", l[i] * B.y)
    P.v2pt_theory(points[-1], N, B)
    points.append(P)

particles = [Particle(f"Pa{i}", P, m[i]) for i, P in enumerate(points)]
loads = [(P, -mi * g * N.y) for P, mi in zip(points, m)] + [(cart, F * N.x)]

system = KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
system.kanes_equations(particles, loads)

parameters = {**{mi: 1.0 for mi in m}, **{li: 1.0 / n for li in l}, g: 9.81}
inputs = [F]
initial_state = {**{qi: 0.1 for qi in q[1:]}, q[0]: 0.0, **{ui: 0.0 for ui in u}}
# kinetic_energy squares each velocity in N: SymPy's v.dot(v) pairs the DCMs of
# every two links and takes ~15 s at n = 20
outputs = {
    "energy": kinetic_energy(N, *particles)
              + sum(p.mass * g * p.point.pos_from(O).dot(N.y) for p in particles),
    "cart_x": q[0],
}
