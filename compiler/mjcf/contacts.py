"""Contacts on an MJCF model's bodies: named bodies and their sphere geoms (``@collision``).

Why here: where a contact sits is the format's business (MuJoCo body names and ids, geoms of
the compiled MjModel); what a contact is, its parameters, loads, outputs and events are
:mod:`eomc.compiler.contact.tree`'s, which this hands the located points to.
"""
from eomc.compiler.contact.tree import COLLISION_SPHERES, ContactSpec, as_spec, nearest, with_located
from eomc.runtime.errors import ModelError

__all__ = ["with_mjcf_contacts"]


def with_mjcf_contacts(built, m, contacts, fold=False):
    """As :func:`eomc.compiler.contact.tree.with_contacts` for an MJCF model (``built``: its MjcfTree, ``m``: the compiled
    MjModel): contacts on MuJoCo bodies, points in the body frame; ``@collision`` takes every
    sphere geom on a body that is not the world."""
    import mujoco
    import numpy as np
    from eomc.runtime.geometry import identifier
    by_body = {b.name: i for i, b in enumerate(built.tree.bodies)}
    names = {(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"): b for b in range(m.nbody)}
    specs = []
    for spec in (as_spec(c) for c in contacts):
        if spec.link != COLLISION_SPHERES:
            specs.append(spec)
            continue
        found = []
        for g in range(m.ngeom):
            b = int(m.geom_bodyid[g])
            if int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_SPHERE) or b == 0:
                continue
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
            found.append(ContactSpec(body, tuple(float(v) for v in m.geom_pos[g]), float(m.geom_size[g][0]),
                                     name=identifier(gname) if gname else f"{identifier(body)}_geom{g}"))
        if not found:
            raise ModelError(f"contacts {COLLISION_SPHERES}: the model has no sphere geom on a moving body")
        specs += found
    known = sorted(n for n, b in names.items() if b != 0)

    def locate(spec, point):
        b = names.get(spec.link)
        if b is None:
            raise ModelError(f"contact on body {spec.link!r}: the model has no such body"
                             f"{nearest(spec.link, known)} (bodies: {', '.join(known[:12])}"
                             f"{', ...' if len(known) > 12 else ''})")
        if b == 0:
            raise ModelError(f"contact on body {spec.link!r}: the world cannot touch the ground")
        i = by_body.get(identifier(spec.link) if spec.link in names else spec.link)
        if i is None:
            raise ModelError(f"contact on body {spec.link!r}: it is not in the tree")
        return i, np.array(point, dtype=float), tuple(float(v) for v in m.body_ipos[b])
    return with_located(built, specs, locate, fold, "body", identifier)
