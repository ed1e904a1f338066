"""eomc's mechanics front end: ``from eomc.mechanics import *`` replaces
``from sympy.physics.mechanics import *``.

Kinematics (frames, points, vectors, dyadics, bodies) are SymPy's objects,
re-exported unchanged, so bodies and frames built with SymPy are accepted as
they are.  The methods that form equations of motion -- :class:`KanesMethod`
and :class:`LagrangesMethod` -- are eomc's own, and so are :class:`System`
and :class:`JointsMethod` (SymPy's, subclassed so that they form equations
with eomc's methods).  Every other public name of ``sympy.physics.mechanics``
1.14 -- joints, actuators, pathways, wrapping geometries, loads, ``Inertia``,
``SymbolicSystem``, printing helpers -- is SymPy's own object, re-exported, so
``__all__`` here contains SymPy's.
"""
from sympy.physics.mechanics import (  # noqa: F401
    Body, Dyadic, Linearizer, Particle, Point, ReferenceFrame,
    RigidBody, Vector, cross, curl, divergence, dot, dynamicsymbols,
    express, find_dynamicsymbols, gradient, inertia, inertia_of_point_mass,
    init_vprinting, kinematic_equations, linear_momentum,
    angular_momentum, mechanics_printing, mlatex, mpprint, mprint,
    msubs, outer, partial_velocity, potential_energy, time_derivative,
    vlatex, vpprint, vprint, Force, Torque,
)

from .formed import FormedSystem
from .energy import Lagrangian, kinetic_energy
from .convert import from_sympy

__all__ = [
    "Body", "Dyadic", "Lagrangian", "Linearizer", "Particle", "Point",
    "ReferenceFrame", "RigidBody", "Vector", "cross", "curl", "divergence",
    "dot", "dynamicsymbols", "express", "find_dynamicsymbols", "gradient",
    "inertia", "inertia_of_point_mass", "init_vprinting",
    "kinematic_equations", "kinetic_energy", "linear_momentum",
    "angular_momentum", "mechanics_printing", "mlatex", "mpprint", "mprint",
    "msubs", "outer", "partial_velocity", "potential_energy",
    "time_derivative", "vlatex", "vpprint", "vprint", "Force", "Torque",
    "FormedSystem", "from_sympy",
]

from .kane import KanesMethod  # noqa: E402
from .lagrange import LagrangesMethod  # noqa: E402

__all__ += ["KanesMethod", "LagrangesMethod"]

# The rest of SymPy 1.14's public names, as SymPy's own objects (see above).
from sympy.physics.mechanics import (  # noqa: E402,F401
    ActuatorBase, CoordinateSym, CoulombKineticFriction, CylindricalJoint, DuffingSpring,
    ForceActuator, Inertia, LinearDamper, LinearPathway, LinearSpring, ObstacleSetPathway,
    PathwayBase, PinJoint, PlanarJoint, PrismaticJoint, SphericalJoint, SymbolicSystem,
    TorqueActuator, WeldJoint, WrappingCylinder, WrappingGeometryBase, WrappingPathway,
    WrappingSphere, get_motion_params, is_conservative, is_solenoidal, msprint,
    scalar_potential, scalar_potential_difference, vector, vsprint, vsstrrepr,
)
from .system import JointsMethod, System  # noqa: E402

__all__ += [
    "ActuatorBase", "CoordinateSym", "CoulombKineticFriction", "CylindricalJoint",
    "DuffingSpring", "ForceActuator", "Inertia", "LinearDamper", "LinearPathway",
    "LinearSpring", "ObstacleSetPathway", "PathwayBase", "PinJoint", "PlanarJoint",
    "PrismaticJoint", "SphericalJoint", "SymbolicSystem", "TorqueActuator", "WeldJoint",
    "WrappingCylinder", "WrappingGeometryBase", "WrappingPathway", "WrappingSphere",
    "get_motion_params", "is_conservative", "is_solenoidal", "msprint", "scalar_potential",
    "scalar_potential_difference", "vector", "vsprint", "vsstrrepr",
    "JointsMethod", "System",
]
