"""Compliant ground contact (Hunt–Crossley normal force, regularised Coulomb friction).

- :mod:`.law`     the force law on SymPy scalars, its defaults and why (both routes use it)
- :mod:`.system`  ``ground(point, body, world, ...)``: loads, parameters, outputs and events
                  for a model written with SymPy mechanics (Kane or recursive formulation)
- :mod:`.tree`    contacts on URDF links, lowered into the joint tree's recursion
"""
from .law import DEFAULTS, damping_from_restitution
from .system import GroundContact, ground

__all__ = ["DEFAULTS", "GroundContact", "ground", "damping_from_restitution"]
