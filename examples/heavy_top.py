"""A heavy symmetric top on a fixed pivot, by Kane's method.

Body-fixed 3-1-3 Euler angles (precession, nutation, spin) and the angular
velocity's body-frame measure numbers as speeds, so the kinematic
differential equations are not q' = u.  Energy and the angular momentum
about the vertical (``h_vertical``) are conserved.
"""
import sympy as sm

from eomc.mechanics import (KanesMethod, Point, ReferenceFrame, RigidBody, dynamicsymbols,
                            inertia, kinematic_equations)

q1, q2, q3 = q = dynamicsymbols("q1:4")
u1, u2, u3 = u = dynamicsymbols("u1:4")
m, g, l, I1, I3 = sm.symbols("m g l I1 I3", positive=True)

N = ReferenceFrame("N")
B = N.orientnew("B", "Body", q, "313")
B.set_ang_vel(N, u1 * B.x + u2 * B.y + u3 * B.z)
O = Point("O")
O.set_vel(N, 0)
G = O.locatenew("G", l * B.z)
G.v2pt_theory(O, N, B)

top = RigidBody("Top", G, B, m, (inertia(B, I1, I1, I3), G))
system = KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kinematic_equations(u, q, "body", "313"))
system.kanes_equations([top], [(G, -m * g * N.z)])

parameters = {m: 1.0, g: 9.81, l: 0.1, I1: 0.01, I3: 0.004}
initial_state = {q1: 0.0, q2: 0.3, q3: 0.0, u1: 0.0, u2: 0.0, u3: 40.0}

_w = B.ang_vel_in(N)
_v = G.vel(N)
outputs = {
    "energy": m * _v.dot(_v) / 2 + _w.dot(top.central_inertia.dot(_w)) / 2
              + m * g * G.pos_from(O).dot(N.z),
    "h_vertical": top.angular_momentum(O, N).dot(N.z),
    "nutation": q2,
}
