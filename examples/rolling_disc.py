"""A thin disc rolling without slip on a horizontal plane, by Kane's method.

Yaw, lean and spin angles; ω's measure numbers in the lean frame as speeds.
Three auxiliary speeds at the contact point C bring the contact force
f1 L.x + f2 (Y.z × L.x) + f3 Y.z into evidence: ``system.auxiliary_eqs`` = 0
is solved for it, with u' from the equations of motion, giving the
``normal_force`` and friction outputs.  Upright rolling is stable for
spin rates ω with ω² > g/(3r).
"""
import sympy as sm

from eomc.mechanics import (KanesMethod, Point, ReferenceFrame, RigidBody, cross, dot,
                            dynamicsymbols, inertia)

q1, q2, q3 = q = dynamicsymbols("q1:4")
u1, u2, u3 = u = dynamicsymbols("u1:4")
u4, u5, u6 = aux = dynamicsymbols("u4:7")
f1, f2, f3 = sm.symbols("f1:4")
r, m, g = sm.symbols("r m g", positive=True)

N = ReferenceFrame("N")
Y = N.orientnew("Y", "Axis", [q1, N.z])      # yaw
L = Y.orientnew("L", "Axis", [q2, Y.x])      # lean
R = L.orientnew("R", "Axis", [q3, L.y])      # spin
w_qd = R.ang_vel_in(N)
R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)

C = Point("C")                               # contact point, moving only through aux speeds
C.set_vel(N, u4 * L.x + u5 * cross(Y.z, L.x) + u6 * Y.z)
D = C.locatenew("D", r * L.z)                # disc centre
D.v2pt_theory(C, N, R)

disc = RigidBody("Disc", D, R, m, (inertia(L, m * r**2 / 4, m * r**2 / 2, m * r**2 / 4), D))
loads = [(D, -m * g * Y.z), (C, f1 * L.x + f2 * cross(Y.z, L.x) + f3 * Y.z)]
system = KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[dot(R.ang_vel_in(N) - w_qd, e) for e in L],
                     u_auxiliary=aux)
system.kanes_equations([disc], loads)

parameters = {m: 1.0, r: 0.5, g: 9.81}
initial_state = {q1: 0.0, q2: 0.05, q3: 0.0, u1: 0.0, u2: 6.0, u3: 0.0}

# Contact force: solve the auxiliary equations, with u' from the equations of motion.
_udot = dict(zip([ui.diff() for ui in u], system.mass_matrix.LUsolve(system.forcing)))
_contact = sm.solve(list(system.auxiliary_eqs.xreplace(_udot)), [f1, f2, f3], dict=True)[0]
_zero_aux = dict.fromkeys(aux, 0)
_v = D.vel(N).xreplace(_zero_aux)
_w = R.ang_vel_in(N)
outputs = {
    "normal_force": _contact[f3],
    "friction_lateral": _contact[f2],
    "friction_longitudinal": _contact[f1],
    "energy": m * _v.dot(_v) / 2 + _w.dot(disc.central_inertia.dot(_w)) / 2
              + m * g * r * sm.cos(q2),
}
