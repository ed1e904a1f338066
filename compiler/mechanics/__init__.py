"""eomc's mechanics front end: ``from eomc.mechanics import *`` replaces
``from sympy.physics.mechanics import *``.

Kinematics (frames, points, vectors, dyadics, bodies) are SymPy's objects,
re-exported unchanged, so bodies and frames built with SymPy are accepted as
they are.  The methods that form equations of motion -- :class:`KanesMethod`
and :class:`LagrangesMethod` -- are eomc's own.
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
