"""Compliant ground contact (Hunt–Crossley normal force, regularised Coulomb friction).

- :mod:`.law`     the force law on SymPy scalars, its defaults and why (both routes use it)
- :mod:`.system`  ``ground(point, body, world, ...)``: loads, parameters, outputs and events
                  for a model written with SymPy mechanics (Kane or recursive formulation)
- :mod:`.tree`    contacts on URDF links and MJCF bodies as the joint tree's loads (lowered by
                  eomc.compiler.tree.contacts, placed along the tree)
- :mod:`.geometry` collision shapes (boxes, cylinders, meshes) as contact points
- :mod:`.mujoco_law` MuJoCo's contact parameters as this law's (MJCF geoms, a URDF's ground)
"""
from .law import DEFAULTS, damping_from_restitution
from .system import GroundContact, ground

__all__ = ["DEFAULTS", "GroundContact", "ground", "damping_from_restitution"]
