"""SymPy 1.14's "Biomechanical Model Example": an arm pressing a lever, moved by a biceps and
a triceps (De Groote 2016 musculotendons with first-order activation dynamics).

The model is written exactly as SymPy's tutorial writes it (doc/src/tutorials/physics/
biomechanics/biomechanical-model-example.rst), with ``eomc.mechanics`` in place of
``sympy.physics.mechanics``.  Where the tutorial then lambdifies ``kane.mass_matrix``,
``kane.forcing`` and the muscles' ``rhs()`` and assembles x = [q; u; a] by hand for
``solve_ivp``, this file names the activation states and their rates in ``states``:
eomc appends them to the state after q and u and compiles all of it to C.

    eomc simulate examples/biomechanical_arm.py --t-final 3 --input e_biceps=0.8 -o arm.csv

Lever angle q1 is independent; q2, q3, q4 (shoulder extension and rotation, elbow
flexion) and their speeds follow from the hand staying on the lever (three holonomic
constraints).  Inputs: the muscles' excitations e_biceps, e_triceps (0..1).  Outputs: each
muscle's musculotendon length l_biceps, l_triceps (m) and tension F_biceps, F_triceps (N).
"""
import sympy as sm
import sympy.physics.biomechanics as bm

import eomc.mechanics as me

q1, q2, q3, q4 = me.dynamicsymbols('q1, q2, q3, q4', real=True)
u1, u2, u3, u4 = me.dynamicsymbols('u1, u2, u3, u4', real=True)

dx, dy, dz = sm.symbols('dx, dy, dz', real=True, nonnegative=True)
lA, lC, lD = sm.symbols('lA, lC, lD', real=True, positive=True)
mA, mC, mD = sm.symbols('mA, mC, mD', real=True, positive=True)
g, k, c, r = sm.symbols('g, k, c, r', real=True, positive=True)

N, A, B, C, D = sm.symbols('N, A, B, C, D', cls=me.ReferenceFrame)
O, P1, P2, P3, P4 = sm.symbols('O, P1, P2, P3, P4 ', cls=me.Point)
Ao, Co, Cm, Dm, Do = sm.symbols('Ao, Co, Cm, Dm, Do', cls=me.Point)

A.orient_axis(N, q1, N.z)
B.orient_axis(N, q2, N.y)
C.orient_axis(B, q3, B.z)
D.orient_axis(C, q4, C.y)
A.set_ang_vel(N, u1*N.z)
B.set_ang_vel(N, u2*N.y)
C.set_ang_vel(B, u3*B.z)
D.set_ang_vel(C, u4*C.y)

Ao.set_pos(O, dx*N.x)
P1.set_pos(Ao, lA*A.y)
P2.set_pos(O, dy*N.y + dz*N.z)
Co.set_pos(P2, lC/2*C.z)
Cm.set_pos(P2, 1*lC/3*C.z)
P3.set_pos(P2, lC*C.z)
Dm.set_pos(P3, 1*lD/3*D.z)
Do.set_pos(P3, lD/2*D.z)
P4.set_pos(P3, lD*D.z)

O.set_vel(N, 0)
Ao.set_vel(N, 0)
P1.v2pt_theory(Ao, N, A)
P2.set_vel(N, 0)
Co.v2pt_theory(P2, N, C)
Cm.v2pt_theory(P2, N, C)
P3.v2pt_theory(P2, N, C)
Dm.v2pt_theory(P3, N, D)
Do.v2pt_theory(P3, N, D)
P4.v2pt_theory(P3, N, D)

holonomic = (P4.pos_from(O) - P1.pos_from(O)).to_matrix(N)

IA = me.Inertia(me.inertia(A, mA/12*lA**2, mA/2*lA**2, mA/12*lA**2), Ao)
IC = me.Inertia(me.inertia(C, mC/12*lC**2, mC/12*lC**2, mC/2*lC**2), Co)
ID = me.Inertia(me.inertia(D, mD/12*lD**2, mD/12*lD**2, mD/2*lD**2), Do)

lever = me.RigidBody('lever', masscenter=Ao, frame=A, mass=mA, inertia=IA)
u_arm = me.RigidBody('upper arm', masscenter=Co, frame=C, mass=mC, inertia=IC)
l_arm = me.RigidBody('lower arm', masscenter=Do, frame=D, mass=mD, inertia=ID)

gravC = me.Force(u_arm, mC*g*N.z)
gravD = me.Force(l_arm, mD*g*N.z)
lever_resistance = me.Torque(A, (-k*q1 - c*u1)*N.z)

biceps_pathway = me.LinearPathway(Cm, Dm)
biceps_activation = bm.FirstOrderActivationDeGroote2016.with_defaults('biceps')
biceps = bm.MusculotendonDeGroote2016.with_defaults('biceps', biceps_pathway, biceps_activation)


class ExtensorPathway(me.PathwayBase):
    """The tutorial's pathway wrapping a circular arc of radius ``radius`` around a pin joint
    (valid for coordinate >= 0): two fixed segments and an arc that changes with the joint."""

    def __init__(self, origin, insertion, axis_point, axis, parent_axis,
                 child_axis, radius, coordinate):
        super().__init__(origin, insertion)
        self.origin = origin
        self.insertion = insertion
        self.axis_point = axis_point
        self.axis = axis.normalize()
        self.parent_axis = parent_axis.normalize()
        self.child_axis = child_axis.normalize()
        self.radius = radius
        self.coordinate = coordinate
        self.origin_distance = axis_point.pos_from(origin).magnitude()
        self.insertion_distance = axis_point.pos_from(insertion).magnitude()
        self.origin_angle = sm.asin(self.radius/self.origin_distance)
        self.insertion_angle = sm.asin(self.radius/self.insertion_distance)

    @property
    def length(self):
        angle = self.origin_angle + self.coordinate + self.insertion_angle
        arc_length = self.radius*angle
        origin_segment_length = self.origin_distance*sm.cos(self.origin_angle)
        insertion_segment_length = self.insertion_distance*sm.cos(self.insertion_angle)
        return origin_segment_length + arc_length + insertion_segment_length

    @property
    def extension_velocity(self):
        return self.radius*self.coordinate.diff(me.dynamicsymbols._t)

    def to_loads(self, force_magnitude):
        parent_tangency_point = me.Point('Aw')  # fixed in parent
        child_tangency_point = me.Point('Bw')  # fixed in child
        parent_tangency_point.set_pos(
            self.axis_point,
            -self.radius*sm.cos(self.origin_angle)*self.parent_axis.cross(self.axis)
            + self.radius*sm.sin(self.origin_angle)*self.parent_axis,
        )
        child_tangency_point.set_pos(
            self.axis_point,
            self.radius*sm.cos(self.insertion_angle)*self.child_axis.cross(self.axis)
            + self.radius*sm.sin(self.insertion_angle)*self.child_axis),
        parent_force_direction_vector = self.origin.pos_from(parent_tangency_point)
        child_force_direction_vector = self.insertion.pos_from(child_tangency_point)
        force_on_parent = force_magnitude*parent_force_direction_vector.normalize()
        force_on_child = force_magnitude*child_force_direction_vector.normalize()
        return [
            me.Force(self.origin, force_on_parent),
            me.Force(self.axis_point, -(force_on_parent + force_on_child)),
            me.Force(self.insertion, force_on_child),
        ]


triceps_pathway = ExtensorPathway(Cm, Dm, P3, B.y, -C.z, D.z, r, q4)
triceps_activation = bm.FirstOrderActivationDeGroote2016.with_defaults('triceps')
triceps = bm.MusculotendonDeGroote2016.with_defaults('triceps', triceps_pathway, triceps_activation)

loads = biceps.to_loads() + triceps.to_loads() + [lever_resistance, gravC, gravD]

kane = me.KanesMethod(
    N,
    (q1,),
    (u1,),
    kd_eqs=(
        u1 - q1.diff(),
        u2 - q2.diff(),
        u3 - q3.diff(),
        u4 - q4.diff(),
    ),
    q_dependent=(q2, q3, q4),
    configuration_constraints=holonomic,
    velocity_constraints=holonomic.diff(me.dynamicsymbols._t),
    u_dependent=(u2, u3, u4),
)
Fr, Frs = kane.kanes_equations((lever, u_arm, l_arm), loads)

# --- eomc's part: what the tutorial assembles by hand for solve_ivp ----------------------
a = biceps.x.col_join(triceps.x)                  # activation states, after q and u
dadt = biceps.rhs().col_join(triceps.rhs())       # their first-order ODEs
e = biceps.r.col_join(triceps.r)                  # excitations: the inputs

system = kane
name = "biomechanical_arm"
states = dict(zip(a, dadt))
inputs = list(e)
parameters = {                                    # the tutorial's p_vals
    dx: 0.31, dy: 0.15, dz: -0.31, lA: 0.2, lC: 0.3, lD: 0.3, mA: 1.0, mC: 2.3, mD: 1.7,
    g: 9.81, k: 5.0, c: 0.5, r: 0.03,
    biceps.F_M_max: 500.0, biceps.l_M_opt: 0.6*0.3, biceps.l_T_slack: 0.55*0.3,
    triceps.F_M_max: 500.0, triceps.l_M_opt: 0.6*0.3, triceps.l_T_slack: 0.65*0.3,
}
# what a biomechanics user reads off the run (CSV columns, --plot panels, the animate page's
# strips): each musculotendon's length along its pathway and its tension, the pull it exerts
# (SymPy's ForceActuator.force is positive when it pushes: the tension is minus it; De Groote's
# passive curve is below zero for a fibre shorter than its optimum: this biceps at rest, its
# fibre at a third of its optimal length, reads F_biceps = -9.2 N, at 80 % activation -1.2 N)
outputs = {
    "l_biceps": biceps.pathway.length, "l_triceps": triceps.pathway.length,       # m
    "F_biceps": -biceps.force, "F_triceps": -triceps.force,                       # N
}
# the tutorial's start: q1 = 5 degrees, q2..q4 solved from the constraints (its fsolve, here
# to full precision), at rest and with both muscles deactivated
initial_state = {q1: 0.08726646259971647, q2: -0.010644176007473792,
                 q3: 0.1649194054829283, q4: 1.5478998484180495}
