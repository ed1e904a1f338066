"""Which bodies of a robot went under its ground during a run: a part of the run's verdict.

One job: read the points each body must keep above the ground (NAME.json ``ground_check``,
written for a URDF robot with ground contacts: its collision geometry's points in the body's
frame, or its origin when it has none; eomc.compiler.urdf.collision.ground_check), place
them along the run with the generated ``NAME_poses``, and name every body one of whose
points went deeper than a point contact may (a sphere: that fraction of its radius, if more):
the contacts' own verdict's numbers, which the caller (runtime/switching.verdict) passes.

Why: the contacts' own verdict (runtime/switching.py) sees only the contacts.  A robot whose
feet are its only contacts passed its trunk through the floor with status 0 and no warning
(Go2 ended 0.07 m, Solo12 0.24 m under it: issue 29); a body whose geometry is no contact
(``--no-ground``), or a link with no geometry at all, is caught here.
"""
import numpy as np

__all__ = ["NAMED_AT_MOST", "below_ground", "depth_span"]

NAMED_AT_MOST = 4           # contacts (bodies) a warning names, the deepest; the rest are counted


def depth_span(lo, hi):
    """"0.029 to 0.327 m", or "0.35 m" when the two read the same."""
    a, b = f"{lo:.3g}", f"{hi:.3g}"
    return f"{a} m" if a == b else f"{a} to {b} m"




def below_ground(model, t, X, p, allowed, fraction):
    """Notes naming each body that went under the ground by more than ``allowed`` (m; a point
    with a radius: ``fraction`` of it, if more): how deep and when; [] when the model has no
    ``ground_check`` or no ``poses``."""
    meta = model.metadata.get("ground_check")
    if not isinstance(meta, dict) or "poses" not in model.functions:
        return []
    X = np.asarray(X, dtype=float)
    t = np.asarray(t, dtype=float)
    if X.ndim != 2 or len(X) == 0 or not np.all(np.isfinite(X)):
        return []
    from .poses import evaluate_poses, pose_layout
    frames = pose_layout(model)[0]
    bodies = {name: np.asarray(points, dtype=float).reshape(-1, 4)
              for name, points in (meta.get("bodies") or {}).items() if name in frames}
    if not bodies:
        return []
    n = np.asarray(meta.get("normal", (0.0, 0.0, 1.0)), dtype=float)
    n = n / np.linalg.norm(n)
    h = float(meta.get("height", 0.0))
    p = None if p is None else np.asarray(p, dtype=float)[:model.nparam]     # the run's (a padded copy)
    poses = evaluate_poses(model, t, X, p)
    # the contacts' names (their contact_<name> events, as switching.find_switches reads them):
    # a link's own name is a contact named on it
    named = {str(d.get("name", ""))[len("contact_"):] for d in model.metadata.get("events", ())
             if str(d.get("name", "")).startswith("contact_")}
    found = {}      # (what, why) -> [(depth, body, t, allowed)]
    for name, pts in bodies.items():
        i = frames.index(name)
        o, R = poses.positions[:, i, :], poses.rotations[:, i, :, :]
        # world points (rows, points, 3): o + R p
        world = o[:, None, :] + np.einsum("tij,kj->tki", R, pts[:, :3])
        depth = h - world @ n + pts[None, :, 3]          # > 0: the point's sphere is under the ground
        limit = np.maximum(allowed, fraction * pts[:, 3])
        excess = depth - limit[None, :]
        if np.max(excess) > 0:
            row, k = np.unravel_index(int(np.argmax(excess)), excess.shape)
            what = "its origin" if not np.any(pts) else "its collision geometry"
            why = ("--no-ground, or a link without <collision> geometry, leaves it no contact; a contact too "
                   "soft for the load sinks")
            if name in named and np.any(pts):
                # first hour s23: G1 with --contact left_ankle_roll_link (a point at the ankle, 3 cm
                # above the sole) sank its feet 0.088 m, the named points never touching
                why = (f"the contact named on link {name} takes the place of its <collision> geometry: put it "
                       f"where the link touches, --contact {name}:x,y,z:radius, or --contact @collision for "
                       f"the file's collision spheres")
            found.setdefault((what, why), []).append((float(depth[row, k]), name, float(t[row]), float(limit[k])))
    return [_note(what, why, sank) for (what, why), sank in found.items()]


def _note(what, why, sank):
    """One note for the bodies that went under the ground the same way (``what`` of theirs, the
    same remedy ``why``): one body as it always was; several by the deepest NAMED_AT_MOST, the
    rest counted (first hour s27: a1.urdf --ground, a fixed base welded with its legs in the
    floor, gave twelve notes of 300 characters, each with the same remedy)."""
    if len(sank) == 1:
        d, name, t, limit = sank[0]
        return (f"body {name} went {d:.3g} m under the ground ({what}, at t = {t:.4g}), more than "
                f"{limit:.3g} m: the robot passed through the floor there ({why})")
    sank = sorted(sank, key=lambda item: -item[0])
    named = ", ".join(f"{name} {d:.3g} m (at t = {t:.4g})" for d, name, t, _ in sank[:NAMED_AT_MOST])
    rest = sank[NAMED_AT_MOST:]
    more = f" and {len(rest)} more ({depth_span(rest[-1][0], rest[0][0])})" if rest else ""
    limits = sorted({limit for *_, limit in sank})
    allowed = (f"{limits[0]:.3g} m" if len(limits) == 1 else
               f"{limits[0]:.3g} to {limits[-1]:.3g} m (each its own)")
    whose = "their origins" if what == "its origin" else "their collision geometry"
    return (f"bodies {named}{more} went under the ground ({whose}), more than {allowed}: the robot "
            f"passed through the floor there ({why})")
