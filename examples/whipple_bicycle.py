"""The Whipple bicycle, by Kane's method with a dependent coordinate and dependent speeds.

Four rigid bodies -- rear wheel R, rear frame with rider B, front frame
(handlebar and fork) H, front wheel F -- with knife-edge wheels rolling
without slip on flat ground, no rider control and no friction in the joints.
This is the benchmark bicycle of

    J. P. Meijaard, J. M. Papadopoulos, A. Ruina and A. L. Schwab,
    "Linearized dynamics equations for the balance and steer of a bicycle:
    a benchmark and review", Proc. R. Soc. A 463 (2007) 1955-1982,
    doi:10.1098/rspa.2007.1857,

and the parameters are the paper's, in its own axes and symbols (Table 1):
x forward, y to the right, z down, lengths from the rear contact point in
the upright reference configuration.  Why ship it: it is the standard
published oracle for nonholonomic multibody codes, and it exercises exactly
what a simple chain does not -- a configuration constraint fixing a
dependent coordinate, three velocity constraints fixing dependent speeds,
wheels that are only given angular velocities, and a closed kinematic loop
through the ground.  ``tests/compiler/mechanics/test_whipple_bicycle.py``
checks the linearized lean/steer equations against the paper's M, C1, K0,
K2, its eigenvalue table and its weave and capsize speeds.

Coordinates: yaw psi, lean (roll) phi, steer delta, and the rear frame's
pitch theta, which the front wheel touching the ground determines (the
dependent coordinate; theta = 0 is the paper's reference configuration).
Wheel rotation angles and the contact point's position on the ground are
ignorable and left out.  Speeds: u1..u4 the rates of psi, phi, theta, delta,
u5 and u6 the rear and front wheels' spin rates relative to their frames.
Independent: lean rate u2, steer rate u4, rear wheel rate u5 (forward speed
v = -rR u5); dependent: yaw rate u1, pitch rate u3, front wheel rate u6, from
the front contact point being at rest (rolling without slip, and the
derivative of the contact condition).  The rear contact is at rest by
construction: the rear wheel centre's velocity is taken from it.

Both contact conditions do no work, so ``energy`` is conserved.  Upright
straight-ahead running is asymptotically stable (self-stable) for forward
speeds between the weave speed 4.292 m/s and the capsize speed 6.024 m/s;
the initial state rolls at 5 m/s with a small lean rate.
"""
import numpy as np
import sympy as sm

from eomc.mechanics import (KanesMethod, Point, ReferenceFrame, RigidBody, dot,
                            dynamicsymbols, inertia)

psi, phi, delta, theta = dynamicsymbols("psi phi delta theta")
u1, u2, u3, u4, u5, u6 = dynamicsymbols("u1:7")

# Benchmark parameters (the paper's names): wheelbase, trail, steer axis tilt, gravity,
# wheel radii, masses, mass-centre coordinates and inertia components in the
# reference configuration.
w, c, lam, g = sm.symbols("w c lam g")
rR, rF, mR, mB, mH, mF = sm.symbols("rR rF mR mB mH mF")
xB, zB, xH, zH = sm.symbols("xB zB xH zH")
IRxx, IRyy, IFxx, IFyy = sm.symbols("IRxx IRyy IFxx IFyy")
IBxx, IByy, IBzz, IBxz = sm.symbols("IBxx IByy IBzz IBxz")
IHxx, IHyy, IHzz, IHxz = sm.symbols("IHxx IHyy IHzz IHxz")

# Frames.  N is inertial with N.z down; A yaws about N.z, B leans about A.x, the
# rear frame C pitches about B.y (its axes are the paper's global axes when
# theta = 0), and the front frame E turns by delta about the steer axis, which
# is tilted back by lam from the vertical: E = C at delta = 0.
N = ReferenceFrame("N")
A = N.orientnew("A", "Axis", [psi, N.z])
B = A.orientnew("B", "Axis", [phi, A.x])
C = B.orientnew("C", "Axis", [theta, B.y])
E = ReferenceFrame("E")
E.orient_body_fixed(C, (lam, delta, -lam), "YZY")
steer_axis = sm.sin(lam) * C.x + sm.cos(lam) * C.z
WR = ReferenceFrame("WR")          # the wheels: angular velocity only (axisymmetric)
WF = ReferenceFrame("WF")

A.set_ang_vel(N, u1 * N.z)
B.set_ang_vel(A, u2 * A.x)
C.set_ang_vel(B, u3 * B.y)
E.set_ang_vel(C, u4 * steer_axis)
WR.set_ang_vel(C, u5 * C.y)
WF.set_ang_vel(E, u6 * E.y)

# Points.  The rear contact P is the wheel's material point touching the ground,
# at rest; the rear wheel centre lies rR above it in the lean plane.  S is the
# point where the steer axis meets the ground in the reference configuration
# (a distance w + c ahead of P), fixed in both C and E.
P = Point("P")
P.set_vel(N, 0)
Dr = P.locatenew("Dr", -rR * B.z)
Dr.v2pt_theory(P, N, WR)
Bo = Dr.locatenew("Bo", xB * C.x + (zB + rR) * C.z)
Bo.v2pt_theory(Dr, N, C)
S = Dr.locatenew("S", (w + c) * C.x + rR * C.z)
S.v2pt_theory(Dr, N, C)
Ho = S.locatenew("Ho", (xH - w - c) * E.x + zH * E.z)
Ho.v2pt_theory(S, N, E)
Df = S.locatenew("Df", -c * E.x - rF * E.z)
Df.v2pt_theory(S, N, E)
# Front contact: from the wheel centre, rF along the steepest downward
# direction in the wheel plane (normal E.y).
_s = dot(E.y, A.z)
Pf = Df.locatenew("Pf", rF * (A.z - _s * E.y) / sm.sqrt(1 - _s**2))
Pf.v2pt_theory(Df, N, WF)

rear_wheel = RigidBody("rear_wheel", Dr, WR, mR, (inertia(C, IRxx, IRyy, IRxx), Dr))
rear_frame = RigidBody("rear_frame", Bo, C, mB, (inertia(C, IBxx, IByy, IBzz, 0, 0, IBxz), Bo))
front_frame = RigidBody("front_frame", Ho, E, mH, (inertia(E, IHxx, IHyy, IHzz, 0, 0, IHxz), Ho))
front_wheel = RigidBody("front_wheel", Df, WF, mF, (inertia(E, IFxx, IFyy, IFxx), Df))
bodies = [rear_wheel, rear_frame, front_frame, front_wheel]
loads = [(Dr, mR * g * A.z), (Bo, mB * g * A.z), (Ho, mH * g * A.z), (Df, mF * g * A.z)]

contact_height = Pf.pos_from(P).dot(A.z)               # = 0: the front wheel touches the ground
contact_velocity = [Pf.vel(N).dot(e) for e in (A.x, A.y, A.z)]   # = 0: it rolls without slip

# The dependent speeds are solved for by Cramer's rule (eomc's default for up to
# 3 of them): an LU solve without pivoting, SymPy's default, would divide by the
# x-constraint's yaw-rate coefficient, which is zero upright (0/0 there).
system = KanesMethod(
    N, q_ind=[psi, phi, delta], u_ind=[u2, u4, u5],
    kd_eqs=[psi.diff() - u1, phi.diff() - u2, theta.diff() - u3, delta.diff() - u4],
    q_dependent=[theta], configuration_constraints=[contact_height],
    u_dependent=[u1, u3, u6], velocity_constraints=contact_velocity)
system.kanes_equations(bodies, loads)

# Table 1 of the paper, unchanged: the model's parameters are the benchmark's.
parameters = {
    w: 1.02, c: 0.08, lam: float(sm.pi / 10), g: 9.81,
    rR: 0.3, mR: 2.0, IRxx: 0.0603, IRyy: 0.12,
    xB: 0.3, zB: -0.9, mB: 85.0, IBxx: 9.2, IByy: 11.0, IBzz: 2.8, IBxz: 2.4,
    xH: 0.9, zH: -0.7, mH: 4.0, IHxx: 0.05892, IHyy: 0.06, IHzz: 0.00708, IHxz: -0.00756,
    rF: 0.35, mF: 3.0, IFxx: 0.1405, IFyy: 0.28,
}


def consistent_speeds(point):
    """The dependent speeds u1, u3, u6 that satisfy the velocity constraints at ``point``.

    ``point`` maps the coordinates, the independent speeds and (optionally) the
    parameters to numbers; missing parameters take the benchmark values.
    """
    values = {**parameters, **point}
    k_nh, f_nh, _ = system.velocity_constraint_matrices
    dep = [list(system.u).index(s) for s in (u1, u3, u6)]
    ind = [i for i in range(len(system.u)) if i not in dep]
    known = sm.Matrix([values[system.u[i]] for i in ind])
    rows = list(range(k_nh.rows))
    lhs = np.array(k_nh.extract(rows, dep).xreplace(values).evalf(), dtype=float)
    rhs = -np.array((k_nh.extract(rows, ind).xreplace(values) * known
                     + f_nh.xreplace(values)).evalf(), dtype=float).ravel()
    return dict(zip((u1, u3, u6), np.linalg.solve(lhs, rhs).tolist()))   # pivoting: no 0/0


# Upright, steer straight, at 5 m/s (inside the self-stable speed range), with a
# lean-rate kick; theta = 0 satisfies the contact condition whenever delta = 0.
_speed = 5.0
initial_state = {psi: 0.0, phi: 0.0, delta: 0.0, theta: 0.0,
                 u2: 0.5, u4: 0.0, u5: -_speed / parameters[rR]}
initial_state.update(consistent_speeds(initial_state))

# The bicycle has fallen when the lean passes 45 degrees either way: the run stops there.
events = {"fallen": {"expr": phi**2 - (sm.pi / 4)**2, "terminal": True, "direction": 1}}

_height = -sum((b.masscenter.pos_from(P).dot(A.z) * b.mass for b in bodies), sm.S.Zero)
outputs = {
    "energy": sum((b.kinetic_energy(N) for b in bodies), sm.S.Zero) + g * _height,
    "lean": phi,
    "steer": delta,
    "pitch": theta,
    "forward_speed": Dr.vel(N).dot(A.x),        # the rear wheel centre, along the heading
    "contact_height": contact_height,
}
