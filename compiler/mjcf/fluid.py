"""MuJoCo's fluid forces (``<option density viscosity wind>``) on the tree: the inertia-box model.

One job: each MuJoCo body with mass gets the force and torque of MuJoCo's
``mj_inertiaBoxFluidModel``, written with the recursion's own velocities.  The body is
replaced by the box of equal mass and inertia (sides b_k = sqrt(6·(I_j + I_l - I_k)/m) along
its principal axes); with ω and v the body's angular velocity and its mass centre's velocity
minus the wind, both in the principal (inertial) frame:

- viscous (Stokes): torque -π·d³·μ·ω, force -3π·d·μ·v, with d = (b_0 + b_1 + b_2)/3;
- quadratic drag (density ρ): torque_k = -ρ·b_k·(b_j⁴ + b_l⁴)·|ω_k|·ω_k/64,
  force_k = -½·ρ·b_j·b_l·|v_k|·v_k;

applied at the mass centre.  ``fluid_density`` and ``fluid_viscosity`` are parameters
(defaults from the file), the wind and box sides constants (the sides follow the file's
inertia, not the inertia parameters).  A body with a geom that asks for MuJoCo's ellipsoid
model (``fluidshape="ellipsoid"``) gets that model instead, on those geoms only
(:mod:`.fluid_ellipsoid`), as MuJoCo's ``mj_fluid`` chooses.
"""
from dataclasses import dataclass

import numpy as np
import sympy as sm

from ..contact.tree import LoweredLoad
from .fluid_frame import add_body_load, relative_velocity

__all__ = ["FluidLoad", "with_fluid", "box_sides"]

MINVAL = 1e-15


def box_sides(inertia, mass):
    """MuJoCo's equivalent inertia box of principal ``inertia`` and ``mass``."""
    i0, i1, i2 = (float(x) for x in inertia)
    m = float(mass)
    return tuple(float(np.sqrt(max(MINVAL, a) / m * 6.0)) for a in (i1 + i2 - i0, i0 + i2 - i1, i0 + i1 - i2))


@dataclass(frozen=True)
class FluidLoad(LoweredLoad):
    """A body's fluid force, computed in :func:`lower` from its velocity (lowered beside the
    ground contacts: ``frame == "contact"`` keeps it out of the plain loads)."""
    body: int
    name: str
    box: tuple                          # the inertia box's sides
    axes: tuple                         # principal axes (3x3 rows): inertial -> body components
    density: object                     # Symbol (or number when folded)
    viscosity: object
    wind: tuple                         # world

    @property
    def passive_fluid(self):
        """Does the force only take energy out (the energy verdict may judge its runs,
        compiler/contact/tree.energy_blockers)?  With no wind each term is -c·|x|·x or -c·x on a
        component of ω or of the mass centre's velocity, where the force acts: its power is a sum
        of -c·x² <= 0 for ρ, μ >= 0 (their run-time values: runtime/law_parameters.py).  A wind
        is a source."""
        return not any(self.wind)

    @property
    def why_not_passive(self):
        return "a wind" if any(self.wind) else ""

    @property
    def exprs(self):
        return ([sm.Integer(self.body), self.density, self.viscosity] + [sm.Float(x, 17) for x in self.box]
                + [sm.Float(x, 17) for row in self.axes for x in row] + [sm.Float(x, 17) for x in self.wind])

    def lower(self, bodies, rec, v, rename, poses):
        """Add the force to body ``self.body``'s fext (body components, about its mass centre)."""
        i = self.body
        what = f"the fluid force on body {self.name}"
        rho, mu = rename(self.density, what), rename(self.viscosity, what)
        A = [[sm.Float(x, 17) if abs(x) > 1e-300 else sm.S.Zero for x in row] for row in self.axes]
        w, u = relative_velocity(v[i], None, A, self.wind, poses, i, rec)
        b = self.box
        diam = sum(b) / 3.0
        torque = [-sm.Float(np.pi * diam ** 3, 17) * mu * w[k] for k in range(3)]
        force = [-sm.Float(3.0 * np.pi * diam, 17) * mu * u[k] for k in range(3)]
        for k in range(3):
            j, l = (k + 1) % 3, (k + 2) % 3
            torque[k] += -rho * sm.Float(b[k] * (b[j] ** 4 + b[l] ** 4) / 64.0, 17) * sm.Abs(w[k]) * w[k]
            force[k] += -rho * sm.Float(0.5 * b[j] * b[l], 17) * sm.Abs(u[k]) * u[k]
        torque = [rec.let(x) for x in torque]
        force = [rec.let(x) for x in force]
        n_b = [sum((A[r][k] * torque[k] for k in range(3)), sm.S.Zero) for r in range(3)]
        f_b = [sum((A[r][k] * force[k] for k in range(3)), sm.S.Zero) for r in range(3)]
        add_body_load(bodies, i, n_b + f_b)


def with_fluid(built, m, fold=False):
    """``built`` (an MjcfTree) with a fluid load on every body with mass when the file's
    ``<option>`` has a density or viscosity: :class:`.fluid_ellipsoid.EllipsoidFluidLoad` when
    one of its geoms has ``fluidshape="ellipsoid"`` (as MuJoCo's mj_fluid chooses), else a
    :class:`FluidLoad`; the parameters ``fluid_density``/``fluid_viscosity``."""
    import dataclasses
    from eomc.compiler.contact.tree import body_com
    from .fluid_ellipsoid import EllipsoidFluidLoad, semi_axes, uses_ellipsoid
    from .treeir import quat_matrix
    density, viscosity = float(m.opt.density), float(m.opt.viscosity)
    if not (density > 0 or viscosity > 0):
        return built
    params = dict(built.parameters)
    if fold:
        rho, mu = sm.Float(density, 17), sm.Float(viscosity, 17)
    else:
        rho, mu = sm.Symbol("fluid_density", real=True), sm.Symbol("fluid_viscosity", real=True)
        params[rho], params[mu] = density, viscosity
    loads = list(built.tree.loads)
    wind = tuple(float(x) for x in m.opt.wind)
    for i, owner in enumerate(built.owners):
        if owner is None:
            continue
        b = owner[0]
        if m.body_mass[b] < MINVAL or int(m.body_weldid[b]) == 0:
            continue
        name = built.tree.bodies[i].name
        geoms = uses_ellipsoid(m, b)
        if geoms:
            shapes = tuple((tuple(float(x) for x in m.geom_pos[g]),
                            tuple(tuple(float(x) for x in row) for row in quat_matrix(m.geom_quat[g])),
                            semi_axes(m.geom_size[g], int(m.geom_type[g])),
                            tuple(float(x) for x in m.geom_fluid[g])) for g in geoms)
            loads.append(EllipsoidFluidLoad(i, name, tuple(body_com(built, name, owner[1])), shapes,
                                            rho, mu, wind))
            continue
        axes = tuple(tuple(float(x) for x in row) for row in quat_matrix(m.body_iquat[b]))
        loads.append(FluidLoad(i, name, box_sides(m.body_inertia[b], m.body_mass[b]), axes, rho, mu, wind))
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree = dataclasses.replace(built.tree, loads=tuple(loads))
    new.parameters = params
    return new
