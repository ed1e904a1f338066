"""Joints SymPy lacks for URDF: floating (6 dof) and planar (3 dof), with body-frame speeds.

:class:`FloatingJoint` follows SymPy's ``Joint`` protocol, so a ``System``
and anything that reads ``System.joints`` sees it like SymPy's own joints.

Coordinates (6): the child joint point's position in the parent joint frame
(x, y, z), then body-fixed XYZ Euler angles (rx about x, ry about the new y,
rz about the newest z; child orientation R = Rx(rx) Ry(ry) Rz(rz)).  The
angles are singular at ry = ±90°.

Speeds (6): the velocity of the child joint point and the angular velocity of
the child, both in child-frame components -- Pinocchio's free-flyer
convention, so mass matrix, generalized forces and u' match its ``M``, ``tau``
and ``ddq`` entry for entry.  Hence q' ≠ u: the kinematic equations are
position' = R v and the Euler-rate relation ω = E(angles) angles'.
"""
import sympy as sm
from sympy.physics.mechanics import ReferenceFrame
from sympy.physics.mechanics.joint import Joint
from sympy.physics.vector import dynamicsymbols

__all__ = ["FloatingJoint", "PlanarJoint"]


class FloatingJoint(Joint):
    """Six-dof joint (see the module docstring for its coordinates and speeds)."""

    def __init__(self, name, parent, child, coordinates=None, speeds=None, parent_point=None,
                 child_point=None, parent_interframe=None, child_interframe=None):
        super().__init__(name, parent, child, coordinates, speeds, parent_point, child_point,
                         parent_interframe, child_interframe)

    def __str__(self):
        return f"FloatingJoint: {self.name}  parent: {self.parent}  child: {self.child}"

    def _generate_coordinates(self, coordinates):
        return self._fill_coordinate_list(coordinates, 6, "q")

    def _generate_speeds(self, speeds):
        return self._fill_coordinate_list(speeds, 6, "u")

    def _generate_kdes(self):
        """q' = f(q, u) solved: position' = R v, and the Euler rates of body XYZ angles from
        the body-frame angular velocity, in closed form (one division by cos ry) rather than
        the implicit ω = E(angles) angles' (whose generic solve leaves nested fractions in
        every formulation's q').  tests/compiler/urdf/test_joint_types.py checks it against
        SymPy's ang_vel of the same orientation."""
        t = dynamicsymbols._t
        q, u = self.coordinates, self.speeds
        # the rotation on scratch frames
        fixed, moving = ReferenceFrame(f"{self.name}_kde_P"), ReferenceFrame(f"{self.name}_kde_C")
        moving.orient_body_fixed(fixed, tuple(q[3:]), "xyz")
        rotation = fixed.dcm(moving)
        velocity = rotation * sm.Matrix(u[:3])
        kdes = [q[i].diff(t) - velocity[i] for i in range(3)]
        wx, wy, wz = u[3:]
        cy, sz, cz = sm.cos(q[4]), sm.sin(q[5]), sm.cos(q[5])
        rate_x = (wx * cz - wy * sz) / cy
        rates = [rate_x, wx * sz + wy * cz, wz - rate_x * sm.sin(q[4])]
        kdes += [q[3 + i].diff(t) - rates[i] for i in range(3)]
        return sm.Matrix(kdes)

    def _orient_frames(self):
        self.child_interframe.orient_body_fixed(self.parent_interframe, tuple(self.coordinates[3:]),
                                                "xyz")

    def _set_angular_velocity(self):
        frame, u = self.child_interframe, self.speeds
        self.child_interframe.set_ang_vel(self.parent_interframe,
                                          u[3] * frame.x + u[4] * frame.y + u[5] * frame.z)

    def _set_linear_velocity(self):
        parent, child, q, u = self.parent_interframe, self.child_interframe, self.coordinates, self.speeds
        self.child_point.set_pos(self.parent_point, q[0] * parent.x + q[1] * parent.y + q[2] * parent.z)
        self.parent_point.set_vel(self._parent_frame, 0)
        self.child_point.set_vel(self._child_frame, 0)
        self.child_point.set_vel(self._parent_frame, u[0] * child.x + u[1] * child.y + u[2] * child.z)
        self.child.masscenter.v2pt_theory(self.child_point, self._parent_frame, self._child_frame)


class PlanarJoint(Joint):
    """URDF's planar joint: translation in the interframes' x-y plane and rotation about z.

    Coordinates (x, y, th): the child point's position in the parent
    interframe's x-y plane and the rotation about its z axis (the URDF
    ``<axis>``, the plane's normal).  Speeds (vx, vy, w): the child point's
    velocity and the angular velocity in child interframe components -- the
    convention of Pinocchio's JointModelPlanar, so q' ≠ u again:
    x' = cos th vx − sin th vy, y' = sin th vx + cos th vy, th' = w.
    (SymPy's own PlanarJoint takes rates in the parent frame and rotates
    about x; this one follows URDF and Pinocchio.)
    """

    def __init__(self, name, parent, child, coordinates=None, speeds=None, parent_point=None,
                 child_point=None, parent_interframe=None, child_interframe=None):
        super().__init__(name, parent, child, coordinates, speeds, parent_point, child_point,
                         parent_interframe, child_interframe)

    def __str__(self):
        return f"PlanarJoint: {self.name}  parent: {self.parent}  child: {self.child}"

    def _generate_coordinates(self, coordinates):
        return self._fill_coordinate_list(coordinates, 3, "q")

    def _generate_speeds(self, speeds):
        return self._fill_coordinate_list(speeds, 3, "u")

    def _generate_kdes(self):
        t = dynamicsymbols._t
        (x, y, th), (vx, vy, w) = self.coordinates, self.speeds
        c, s = sm.cos(th), sm.sin(th)
        return sm.Matrix([x.diff(t) - (c * vx - s * vy), y.diff(t) - (s * vx + c * vy), th.diff(t) - w])

    def _orient_frames(self):
        self.child_interframe.orient_axis(self.parent_interframe, self.parent_interframe.z,
                                          self.coordinates[2])

    def _set_angular_velocity(self):
        self.child_interframe.set_ang_vel(self.parent_interframe, self.speeds[2] * self.parent_interframe.z)

    def _set_linear_velocity(self):
        parent, child, q, u = self.parent_interframe, self.child_interframe, self.coordinates, self.speeds
        self.child_point.set_pos(self.parent_point, q[0] * parent.x + q[1] * parent.y)
        self.parent_point.set_vel(self._parent_frame, 0)
        self.child_point.set_vel(self._child_frame, 0)
        self.child_point.set_vel(self._parent_frame, u[0] * child.x + u[1] * child.y)
        self.child.masscenter.v2pt_theory(self.child_point, self._parent_frame, self._child_frame)
