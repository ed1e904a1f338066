"""See the motion: a run as one self-contained HTML page (3-D, three.js) or a 2-D GIF/MP4.

Why a single HTML file with three.js inlined: it opens offline, from disk, in
any browser, with no server and no kernel (a file can be mailed or attached to
a report), and the same text is what Jupyter shows inline (an iframe's srcdoc).
three.js is the renderer robotics viewers are built on (MeshCat, viser's
client); r169's minified module (~690 kB) and its OrbitControls are vendored in
``runtime/web/`` from the npm registry with their MIT licence, and nothing is
fetched when a page opens.  viser and rerun would need a running server or a
~50 MB wheel for the same picture.

The numbers come from the generated ``NAME_poses`` (eomc.runtime.poses),
evaluated in C at ``fps`` frames per second of the run (states interpolated
linearly between the run's rows), stored as float32 in base64; meshes are
packed by eomc.runtime.geometry.  The page (``runtime/web/viewer.js``) has a
time slider, play/pause, playback speed, an orbit/zoom camera, traces of chosen
points and the model's outputs plotted beside the scene with a cursor; a URL
ending in ``#t=1.5`` opens paused at t = 1.5.

Planar motion (every position in one coordinate plane) can also be drawn in
2-D with matplotlib (:func:`animate_2d`): GIF through Pillow, MP4 through
ffmpeg when it is installed.
"""
import base64
import html
import json
import re
import shutil
from functools import lru_cache
from pathlib import Path

import numpy as np

from .files import atomic_path
from .poses import evaluate_poses

__all__ = ["animate", "animate_2d", "Animation", "ground_plane", "page_html", "plane_of"]

_WEB = Path(__file__).parent / "web"
_PALETTE = [(0.12, 0.47, 0.71), (0.84, 0.15, 0.16), (0.17, 0.63, 0.17), (1.0, 0.5, 0.05),
            (0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.09, 0.75, 0.81), (0.74, 0.74, 0.13)]


@lru_cache(maxsize=1)
def _three_script():
    """three.js and OrbitControls as one classic script defining ``window.THREE``.

    The vendored files are ES modules; an inline module cannot import another inline
    one, so their ``export``/``import`` statements are rewritten into a global (read once)."""
    core = (_WEB / "three.module.min.js").read_text(encoding="utf-8")
    tail = re.search(r"export\{([^}]*)\};?\s*$", core)
    if tail is None:
        raise RuntimeError("the vendored three.module.min.js has no export list at its end")
    pairs = [p.strip().split(" as ") for p in tail.group(1).split(",") if p.strip()]
    mapping = ",".join(f"{p[-1]}:{p[0]}" for p in pairs)
    core = core[:tail.start()] + f"window.THREE={{{mapping}}};"
    orbit = (_WEB / "OrbitControls.js").read_text(encoding="utf-8")
    orbit = re.sub(r"import\s*\{([^}]*)\}\s*from\s*'three';", r"const {\1} = window.THREE;", orbit)
    orbit = re.sub(r"export\s*\{\s*OrbitControls\s*\};?", "window.THREE.OrbitControls = OrbitControls;", orbit)
    licence = (_WEB / "three.LICENSE").read_text(encoding="utf-8")
    return (f"/* three.js r169 and OrbitControls (https://threejs.org), MIT licence:\n{licence}*/\n"
            f"(function(){{{core}\n}})();\n(function(){{{orbit}\n}})();\n")


def _b64(a):
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode()


def _resample(res, fps):
    """(times, states) at ``fps`` frames per second over the run (linear in the states)."""
    t = np.asarray(res.t, float)
    if len(t) < 2:
        return t, np.asarray(res.x, float)
    n = max(2, int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1)
    times = t[0] + np.arange(n) / fps
    times = times[times <= t[-1] + 1e-12]
    X = np.column_stack([np.interp(times, t, res.x[:, k]) for k in range(res.x.shape[1])])
    return times, X


def plane_of(poses, tol=1e-9):
    """The coordinate axis (0, 1, 2) every frame origin and point keeps constant, or None."""
    allpos = np.concatenate([poses.positions.reshape(-1, 3), poses.points.reshape(-1, 3)])
    if not len(allpos):
        return None
    span = allpos.max(0) - allpos.min(0)
    scale = max(float(span.max()), 1e-12)
    flat = [k for k in (2, 0, 1) if span[k] <= tol * scale]
    if not flat:
        return None
    if poses.rotations.size:   # bodies must turn about that axis only
        k = flat[0]
        axis = np.eye(3)[k]
        if not np.allclose(poses.rotations[..., k, :], axis, atol=1e-9):
            return None
    return flat[0]


def _color(c):
    if c is None:
        return None
    if isinstance(c, str):
        from_hex = re.fullmatch(r"#([0-9a-fA-F]{6})", c)
        if not from_hex:
            raise ValueError(f"colours are '#rrggbb' or (r, g, b) in 0..1, not {c!r}")
        return [int(c[i:i + 2], 16) / 255 for i in (1, 3, 5)]
    return [float(v) for v in c][:3]


def _default_trace(poses):
    """The frame origin or point that travels farthest (a pendulum's tip, a robot's hand)."""
    best, name = -1.0, None
    for names, arr in ((poses.frame_names, poses.positions), (poses.point_names, poses.points)):
        for i, n in enumerate(names):
            length = float(np.sum(np.linalg.norm(np.diff(arr[:, i, :], axis=0), axis=1)))
            if length > best + 1e-12:
                best, name = length, n
    return [name] if name is not None and best > 0 else []


def _reach(geometry, meshes):
    """How far any shape reaches from its body's origin (the camera must see it whole)."""
    reach = 0.0
    for items in geometry.values():
        for s in items:
            offset = float(np.linalg.norm(np.reshape(s["origin"], (4, 4))[:3, 3]))
            if s["kind"] == "mesh" and meshes[s["mesh"]] is not None:
                m = meshes[s["mesh"]]
                size = float(np.max(np.abs([m["lo"], m["hi"]])) * np.sqrt(3))
            elif s["kind"] == "box":
                size = float(np.linalg.norm(s["size"])) / 2
            elif s["kind"] == "cylinder":
                size = float(np.hypot(s["size"][0], s["size"][1] / 2))
            else:
                size = float(s["size"][0]) if s["size"] else 0.0
            reach = max(reach, offset + size)
    return reach


def _framing(poses, reach):
    """(per-frame lo, per-frame hi, lo, hi): the box of the moving bodies and points at each
    frame (each side padded by ``reach``, what the shapes add), and the box of everything over
    the run (fixed points too).  A fixed point (a floating base's world origin) is no part of
    the robot, so it is left out of the per-frame box."""
    nt = poses.positions.shape[0]
    P = np.concatenate([poses.positions.reshape(nt, -1, 3), poses.points.reshape(nt, -1, 3)], axis=1)
    if P.shape[1] == 0:
        zero = np.zeros((max(nt, 1), 3))
        return zero, zero, np.zeros(3), np.zeros(3)
    moving = np.ptp(P, axis=0).max(axis=1) > 1e-12 if nt > 1 else np.ones(P.shape[1], bool)
    if not moving.any():
        moving[:] = True
    lo_t, hi_t = P[:, moving].min(axis=1) - reach, P[:, moving].max(axis=1) + reach
    lo = np.minimum(lo_t.min(0), P[:, ~moving].min(axis=(0, 1)) - reach) if (~moving).any() else lo_t.min(0)
    hi = np.maximum(hi_t.max(0), P[:, ~moving].max(axis=(0, 1)) + reach) if (~moving).any() else hi_t.max(0)
    return lo_t, hi_t, lo, hi


# The camera follows the robot when the run's box is this many times the robot's own size
# (a fall, a walk); otherwise it frames the whole run once (a pendulum, an arm).
FOLLOW_RATIO = 1.6


def _smoothed(centres, window):
    """A centred moving average along the rows (a bouncing robot must not shake the view)."""
    if window <= 1 or len(centres) < 3:
        return centres
    window = min(window, len(centres))
    pad = window // 2
    padded = np.concatenate([np.repeat(centres[:1], pad, 0), centres, np.repeat(centres[-1:], window - 1 - pad, 0)])
    kernel = np.ones(window) / window
    return np.column_stack([np.convolve(padded[:, k], kernel, mode="valid") for k in range(3)])


def ground_plane(model):
    """(unit normal n, height h) of the ground the model touches (n·x = h), or None.

    The plane is the built model's: each contact of NAME.json ``poses.contacts`` carries the
    ``normal`` and ``height`` of the plane it meets (an MJCF floor, ``--ground``, a
    ``--contact`` plane), else a URDF's ``ground_check`` does.  An MJCF contact's height is
    the plane its law acts at, raised by its pair's margin (hopper 2 mm, ant 2 cm), which the
    entry's ``margin`` records: the surface drawn is height - margin.  With contacts on several
    heights the lowest plane of the first contact's normal is drawn."""
    meta = getattr(model, "metadata", None) or {}
    planes = [(c["normal"], float(c["height"]) - float(c.get("margin") or 0.0))
              for c in (meta.get("poses") or {}).get("contacts") or ()
              if c.get("normal") is not None and c.get("height") is not None]
    check = meta.get("ground_check")
    if not planes and isinstance(check, dict):
        planes = [(check.get("normal", (0.0, 0.0, 1.0)), float(check.get("height", 0.0)))]
    if not planes:
        return None
    n = np.asarray(planes[0][0], float)
    size = float(np.linalg.norm(n))
    if not np.isfinite(size) or size == 0:
        return None
    heights = [h / size for m, h in planes if np.allclose(np.asarray(m, float) / size, n / size, atol=1e-12)]
    return n / size, min(heights)


def _axis_of(n):
    """The coordinate axis (0, 1, 2) a unit vector lies along, or None."""
    k = int(np.argmax(np.abs(n)))
    return k if abs(n[k]) > 1 - 1e-9 else None


def _camera(poses, up, reach=0.0, ground=None):
    """(camera dict for the viewer, scale): where the camera looks from, the floor grid, and
    ``follow`` (per-frame targets, base64) when the run's extent dwarfs the robot: then the
    camera keeps the robot's size on screen and moves with it instead of fitting the run.

    ``ground``: (unit normal, height) of the model's ground (:func:`ground_plane`), or None.
    When its normal lies along an axis the floor grid is that plane (not the run's lowest
    point), its normal is up by default, and a planar motion's view (straight onto its plane)
    sees the floor edge-on under the robot instead of a grid behind it."""
    g_axis = None if ground is None else _axis_of(ground[0])
    lo_t, hi_t, lo, hi = _framing(poses, reach)
    size = max(float(np.max(hi_t - lo_t)), 1e-3)
    whole = max(float(np.max(hi - lo)), 1e-3)
    follow = len(lo_t) > 1 and whole > FOLLOW_RATIO * size and not _anchored(poses)
    center = (lo + hi) / 2
    scale = size if follow else whole
    targets = _smoothed((lo_t + hi_t) / 2, 9) if follow else None
    target = targets[0] if follow else center
    grid_size = (whole + 4 * scale) if follow else 4 * scale
    extra = {"follow": _b64(targets) if follow else None, "gridSize": grid_size,
             "gridDivisions": int(min(400, max(20, round(grid_size / (scale / 5))))),
             "far": float(max(100 * scale, 4 * (whole + scale)))}
    flat = plane_of(poses)
    if flat is not None and up is None:
        normal = np.eye(3)[flat]
        up_axis = {2: 1, 0: 2, 1: 2}[flat]
        position = target + normal * scale * 3.2
        grid = {2: "xy", 0: "yz", 1: "xz"}[flat]
        floor = center - normal * scale * 0.5
        if follow:
            floor[flat] = target[flat] - scale * 0.5
        up_vector = np.eye(3)[up_axis]
        if g_axis is not None and g_axis != flat:       # the ground, seen edge-on below the robot
            up_vector = np.sign(ground[0][g_axis]) * np.eye(3)[g_axis]
            grid = {2: "xy", 1: "xz", 0: "yz"}[g_axis]
            floor = center.copy()
            floor[g_axis] = ground[1] / ground[0][g_axis]
        return {"up": up_vector.tolist(), "position": position.tolist(),
                "target": target.tolist(), "grid": grid, "floor": floor.tolist(), **extra}, scale
    if up is None and g_axis is not None:
        up = ("-" if ground[0][g_axis] < 0 else "") + "xyz"[g_axis]
    up = up or "z"
    if up not in ("x", "y", "z", "-x", "-y", "-z"):
        raise ValueError(f"up must be x, y, z, -x, -y or -z, not {up!r}")
    up_axis = "xyz".index(up[-1])
    u = np.eye(3)[up_axis] * (-1 if up.startswith("-") else 1)
    side = np.eye(3)[(up_axis + 1) % 3]
    depth = np.eye(3)[(up_axis + 2) % 3]
    # following, the robot's own box is the scale: a closer view keeps it large on screen
    position = target + scale * (0.65 if follow else 1.0) * (1.15 * side - 1.35 * depth + 0.7 * u)
    floor = center.copy()
    floor[up_axis] = lo[up_axis] if u[up_axis] > 0 else hi[up_axis]
    if g_axis == up_axis:                               # the model's ground, not the run's lowest point
        floor[up_axis] = ground[1] / ground[0][g_axis]
    grid = {2: "xy", 1: "xz", 0: "yz"}[up_axis]
    return {"up": u.tolist(), "position": position.tolist(), "target": target.tolist(),
            "grid": grid, "floor": floor.tolist(), **extra}, scale


def _frame_part(name):
    """"R", "J", "p", "v", "w" for a frame output (``tool0.R[0][1]``, ``com.p.x``), else None."""
    m = re.fullmatch(r".+\.(R|J)\[\d+\]\[\d+\]|.+\.(p|v|w)\.[xyz]", name)
    return None if m is None else (m.group(1) or m.group(2))


def page_outputs(names):
    """The outputs a page plots by default: every output but the frames' rotations, Jacobians
    and twists; a frame is summed up by its position (three curves in one strip)."""
    return [n for n in names if _frame_part(n) in (None, "p")]


def _strips(names, most=8):
    """Groups of ``names`` drawn in one strip each: a frame's position (x, y, z) together,
    every other output alone; at most ``most`` strips (the rest is left off, counted)."""
    groups, by_frame = [], {}
    for k, name in enumerate(names):
        if _frame_part(name) == "p":
            frame = name[:-4]
            if frame not in by_frame:
                by_frame[frame] = len(groups)
                groups.append({"label": f"{frame}.p", "series": []})
            groups[by_frame[frame]]["series"].append(k)
        else:
            groups.append({"label": name, "series": [k]})
    return groups[:most], max(0, len(groups) - most)


def _drawn_lines(poses):
    """The skeleton's lines but those from a fixed point to a moving one whose length changes:
    a floating base's "line" from the world origin is no part of the robot (a fall would draw
    it metres long)."""
    P = poses.points
    if P.ndim < 3 or len(P) < 2:
        return list(poses.lines)
    fixed = np.ptp(P, axis=0).max(axis=1) < 1e-12
    kept = []
    for j, k in poses.lines:
        length = np.linalg.norm(P[:, j, :] - P[:, k, :], axis=1)
        if not ((fixed[j] or fixed[k]) and np.ptp(length) > 1e-9 * max(1.0, float(length.max()))):
            kept.append((j, k))
    return kept


def _ghost_free(geometry, frame_names):
    """Drop "world" shapes of a link that is itself a moving body: a model built before the
    floating base's root stopped being drawn at the origin too carries that copy in NAME.json."""
    if "world" not in geometry:
        return geometry
    from .geometry import identifier
    moving = set(frame_names)
    kept = [s for s in geometry["world"] if identifier(s.get("link", "")) not in moving]
    out = {k: v for k, v in geometry.items() if k != "world"}
    if kept:
        out["world"] = kept
    return out


# A force of the robot's weight m·g is drawn this many times the camera's scale (the robot's
# own size): a standing robot's arrows are together half its size, one foot's share shorter.
FORCE_SCALE = 0.5


def _contact_values(res, name, times):
    """The run's ``Fn_<name>``, ``Ftx/Fty/Ftz_<name>`` at ``times`` ((n, 4)), or None."""
    keys = [f"{k}_{name}" for k in ("Fn", "Ftx", "Fty", "Ftz")]
    outputs = getattr(res, "outputs", None) or {}
    if any(k not in outputs for k in keys):
        return None
    t_run = np.asarray(res.t, float)
    cols = [np.asarray(outputs[k], float) for k in keys]
    if len(t_run) < 2:
        return np.tile([c[0] for c in cols], (len(times), 1))
    return np.column_stack([np.interp(times, t_run, c) for c in cols])


def _radius(item, model, res):
    """A contact sphere's radius in this run: its parameter ``r_<name>`` (the run's ``p`` when
    given), else the build's number."""
    name = item.get("radius_parameter")
    names = list(getattr(model, "param_names", ()) or ())
    if name and name in names:
        p = getattr(res, "p", None)
        k = names.index(name)
        if p is not None and np.size(p) == len(names):
            return float(np.ravel(p)[k])
        defaults = getattr(model, "param_defaults", None)
        if defaults is not None and len(defaults) == len(names):
            return float(np.ravel(defaults)[k])
    return float(item.get("radius") or 0.0)


def _translation(point, rotation=None):
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, 3] = point
    return [float(v) for v in T.reshape(16)]


def contact_drawing(res, model, poses, times, scale):
    """(collision shapes {frame: [shape]}, arrows [{name, frame, values: base64 (n_t, 6)}],
    metres per newton): what touches, and the contact forces as arrows.

    The shapes are the contacts the model computes with (NAME.json ``poses.contacts``, written
    by the compiler): a contact sphere of its radius (the run's ``r_<name>``), a point
    contact (a box's corner, a hull's vertex: radius 0) as a ``point``, an ellipsoid as its
    semi-axes; each with ``contact`` naming it.  That is the geometry whose forces the
    outputs report, so a sphere drawn here is exactly what meets the ground.

    Each arrow starts at the touching point (a sphere: centre − r·n; an ellipsoid: its support
    point c − A·n/√(nᵀA·n)) and is the force on the body, F_n·n + F_t (the run's ``Fn_<name>``,
    ``Ftx/Fty/Ftz_<name>``, interpolated as the states are), times the scale: the robot's
    weight m·g is ``FORCE_SCALE`` times its size.  A frame where the contact is open (F_n = 0)
    has a zero vector: the page hides it.  A contact whose run has no such outputs gets no
    arrow."""
    meta = model.metadata.get("poses", {})
    items = meta.get("contacts") or []
    if not items or not len(times):
        return {}, [], 0.0
    frames = list(poses.frame_names)
    shapes, arrows, forces = {}, [], []
    for item in items:
        if item["frame"] not in frames:
            continue
        point = np.asarray(item["point"], float)
        r = _radius(item, model, res)
        n = np.asarray(item["normal"], float)
        A = np.reshape(item["ellipsoid"], (3, 3)) if item.get("ellipsoid") else None
        if A is not None:
            w, V = np.linalg.eigh(A)
            shape = {"kind": "ellipsoid", "size": [float(v) for v in np.sqrt(np.maximum(w, 0))],
                     "origin": _translation(point, V)}
        elif r > 0:
            shape = {"kind": "sphere", "size": [r], "origin": _translation(point)}
        else:
            shape = {"kind": "point", "size": [], "origin": _translation(point)}
        shape["contact"] = item["name"]
        shapes.setdefault(item["frame"], []).append(shape)
        F = _contact_values(res, item["name"], times)
        if F is None:
            continue
        R = poses.rotation(item["frame"])                     # (n_t, 3, 3)
        centre = poses[item["frame"]] + R @ point
        if A is not None:
            Aw = R @ A @ np.transpose(R, (0, 2, 1))
            An = Aw @ n
            start = centre - An / np.sqrt(np.maximum(An @ n, 1e-300))[:, None]
        else:
            start = centre - r * n
        vector = F[:, :1] * n + F[:, 1:]
        vector[F[:, 0] <= 0] = 0.0                            # open: no arrow
        arrows.append({"name": item["name"], "frame": item["frame"], "start": start, "force": vector})
        forces.append(np.linalg.norm(vector, axis=1))
    weight = float(meta.get("weight") or 0.0)
    if weight <= 0 and forces:
        weight = float(np.max(forces)) or 1.0
    per_newton = FORCE_SCALE * scale / weight if weight > 0 else 0.0
    out = [{"name": a["name"], "frame": a["frame"],
            "values": _b64(np.concatenate([a["start"], a["force"] * per_newton], axis=1))} for a in arrows]
    return shapes, out, per_newton


def page_data(res, model, *, fps=60, trace=None, colors=None, outputs=None, up=None, axes=None,
              package_dirs=(), collision=None, forces=None):
    """The JSON the viewer reads (see the module docstring)."""
    from .geometry import pack_shapes
    times, X = _resample(res, fps)
    poses = evaluate_poses(model, times, X, getattr(res, "p", None), getattr(res, "r", None))
    nt = len(times)
    flat = np.concatenate([np.concatenate([poses.positions, poses.rotations.reshape(nt, -1, 9)], axis=2)
                           .reshape(nt, -1), poses.points.reshape(nt, -1)], axis=1)
    names = list(poses.frame_names) + list(poses.point_names)
    colors = {k: _color(v) for k, v in (colors or {}).items()}
    for k in colors:
        if k not in names:
            raise ValueError(f"colors names {k!r}, which is no body or point; known: {', '.join(names)}")
    traces = []
    for name in (_default_trace(poses) if trace is None else list(trace)):
        if name in poses.frame_names:
            offset = 12 * poses.frame_names.index(name)
        elif name in poses.point_names:
            offset = 12 * len(poses.frame_names) + 3 * poses.point_names.index(name)
        else:
            raise ValueError(f"trace names {name!r}, which is no body or point; known: {', '.join(names)}")
        traces.append({"name": name, "offset": offset})
    t_run = np.asarray(res.t, float)
    idle = 0
    if outputs is None:
        # first hour s27: a1 --floating-base --ground and gymnasium's half_cheetah drew seven flat
        # zeros of a trunk contact that never touched, the strips' first eight: --plot's rule
        from .plotting import contacts_last, idle_outputs, untouched
        left_out = idle_outputs(res)
        # first hour s28: the energy after A1's contacts' 32 outputs missed the 8 strips
        wanted = contacts_last(res, [n for n in page_outputs(res.outputs) if n not in left_out])
        idle = len(untouched(res))
    else:
        wanted = list(outputs)
    series = []
    for name in wanted:
        if name in res.outputs:
            values = res.outputs[name]
        elif name in res.state_names:
            values = res.x[:, res.state_names.index(name)]
        else:
            raise ValueError(f"outputs names {name!r}, which is neither an output nor a state")
        series.append({"name": name, "values": _b64(np.interp(times, t_run, np.asarray(values, float)))
                       if len(t_run) > 1 else _b64(values)})
    geometry, meshes = pack_shapes(_ghost_free(model.metadata.get("poses", {}).get("geometry", {}),
                                               poses.frame_names), package_dirs)
    camera, scale = _camera(poses, up, _reach({k: v for k, v in geometry.items() if k != "world"}, meshes),
                            ground_plane(model))
    fixed = [bool(np.ptp(poses.points[:, j, :], axis=0).max() < 1e-12) if nt else False
             for j in range(len(poses.point_names))]
    lines = [list(p) for p in (_drawn_lines(poses) if geometry else poses.lines)]
    strips, left_off = _strips([s["name"] for s in series])
    robot = any(geometry.get(name) for name in poses.frame_names)
    touching, arrows, per_newton = contact_drawing(res, model, poses, times, scale)
    return {"name": model.name, "t": _b64(times), "poses": _b64(flat), "frames": list(poses.frame_names),
            "points": list(poses.point_names), "lines": lines,
            "geometry": geometry, "meshes": meshes, "outputs": series, "strips": strips,
            "strips_left_off": left_off, "idle_contacts": idle, "traces": traces,
            "colors": colors, "palette": _PALETTE, "camera": camera, "scale": scale,
            "radius": 0.035 * scale, "fixed": fixed, "axes": (not robot) if axes is None else bool(axes),
            "collision": touching, "arrows": arrows, "newtons_per_metre": (1 / per_newton) if per_newton else None,
            "weight": float(model.metadata.get("poses", {}).get("weight") or 0.0),
            # drawn by its own shapes, a robot hides what touches until asked; a model with no
            # shapes of its own (spheres on a SymPy model, bare points) shows it
            "show_collision": (not robot) if collision is None else bool(collision),
            "show_forces": bool(arrows) if forces is None else bool(forces)}, poses


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; font: 13px sans-serif; background: #fff; }}
#eomc-main {{ display: flex; height: calc(100% - 40px); }}
#eomc-view {{ flex: 3; position: relative; min-width: 0; }}
#eomc-plot {{ flex: 2; min-width: 0; height: 100%; border-left: 1px solid #ddd; {plot_display} }}
#eomc-bar {{ height: 40px; display: flex; align-items: center; gap: 10px; padding: 0 10px;
            border-top: 1px solid #ddd; box-sizing: border-box; }}
#eomc-slider {{ flex: 1; }}
#eomc-time {{ width: 90px; font-variant-numeric: tabular-nums; }}
</style></head>
<body>
<div id="eomc-main"><div id="eomc-view"></div><canvas id="eomc-plot"></canvas></div>
<div id="eomc-bar"><button id="eomc-play">pause</button>
<input id="eomc-slider" type="range" min="0" value="0" step="1">
<span id="eomc-time"></span>
<label>speed <select id="eomc-speed"><option>0.25</option><option>0.5</option>
<option selected>1</option><option>2</option><option>4</option></select></label>
<label><input id="eomc-axes" type="checkbox"> axes</label>
<label id="eomc-collision-label"{collision_hidden}><input id="eomc-collision" type="checkbox"> collision</label>
<label id="eomc-forces-label"{forces_hidden}><input id="eomc-forces" type="checkbox"> forces<span id="eomc-force-scale"></span></label>
<span>{title}</span></div>
<div id="eomc-status" hidden></div>
<script type="application/json" id="eomc-data">{data}</script>
<script>{three}</script>
<script>{viewer}</script>
</body></html>
"""


def page_html(data, title):
    """The page's text: data as JSON (``</`` escaped) and the scripts inlined."""
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return _PAGE.format(title=html.escape(title), data=text, three=_three_script(),
                        viewer=(_WEB / "viewer.js").read_text(encoding="utf-8"),
                        plot_display="" if data.get("strips", data["outputs"]) else "display: none;",
                        collision_hidden="" if data.get("collision") else " hidden",
                        forces_hidden="" if data.get("arrows") else " hidden")


class Animation:
    """An animation page: ``html`` (its text), ``path`` (where it was written, or None),
    ``poses`` (the numbers it shows); a Jupyter notebook displays it inline."""

    def __init__(self, html_text, path=None, poses=None):
        self.html, self.path, self.poses = html_text, path, poses

    def save(self, path):
        with atomic_path(path) as tmp:
            Path(tmp).write_text(self.html, encoding="utf-8")
        self.path = Path(path)
        return self.path

    def _repr_html_(self):
        return (f'<iframe srcdoc="{html.escape(self.html, quote=True)}" style="width: 100%; '
                f'height: 520px; border: 1px solid #ddd;" sandbox="allow-scripts"></iframe>')

    def __repr__(self):
        return f"<Animation {len(self.html) / 1e6:.2f} MB{'' if self.path is None else f' at {self.path}'}>"


def animate(res, path=None, *, model, fps=60, trace=None, colors=None, outputs=None, up=None,
            title=None, axes=None, package_dirs=(), collision=None, forces=None):
    """A self-contained HTML animation of ``res`` (a SimulationResult of ``model``).

    ``fps``: frames per second of the run stored in the page; ``trace``: names of bodies or
    points whose paths are drawn (default: the one that travels farthest); ``colors``:
    {name: '#rrggbb' or (r, g, b)}; ``outputs``: names plotted beside the scene (default:
    the model's outputs); ``up``: 'x', 'y', 'z', '-x', '-y' or '-z' (default z, or the view
    straight onto the plane of a planar motion; '-z' for a z-down convention such as the
    Whipple bicycle's); ``axes``: draw each body's frame axes (default: only for a model
    without shapes; a robot's meshes would be buried under them; the page has a toggle).
    Frame outputs' rotations, Jacobians and twists are never plotted by default (a frame is
    shown by its position), and at most 8 strips are drawn: the model's own outputs (the
    energy) first, then the contacts' normal forces, then their other outputs.  When the run covers much more
    ground than the robot (a fall, a walk) the camera follows it.
    ``package_dirs``: folders holding the ROS packages a URDF's ``package://`` meshes name
    (Pinocchio's argument; ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the example-robot-data
    layout are searched after them: eomc.runtime.packages).
    ``collision``: draw what touches (the contact spheres and points the model computes
    with, translucent; default: only for a model without shapes of its own -- a robot drawn
    by its meshes would hide its feet's spheres inside them, and a user looking at a robot
    first wants the robot; the bar's "collision" toggle shows them); ``forces``: draw each
    contact's force as an arrow from its touching point (default: on whenever the run has
    contact forces; the bar's "forces" toggle, whose label gives the scale in N per metre).
    Writes ``path`` when given.  Returns an :class:`Animation`.
    """
    if fps <= 0:
        raise ValueError(f"fps must be positive, not {fps}")
    data, poses = page_data(res, model, fps=fps, trace=trace, colors=colors, outputs=outputs, up=up,
                            axes=axes, package_dirs=package_dirs, collision=collision, forces=forces)
    anim = Animation(page_html(data, title or f"{model.name} (eomc)"), None, poses)
    if path is not None:
        anim.save(path)
    return anim


def ffmpeg_path():
    """The ffmpeg that writes MP4: the one on PATH, else the binary the imageio-ffmpeg wheel
    ships (the video extra: ``pip install ".[video]"`` in eomc's clone); ValueError with that
    line when there is none."""
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        raise ValueError('writing .mp4 needs ffmpeg: install the video extra (pip install ".[video]" in '
                         "eomc's clone; the imageio-ffmpeg wheel ships one), or write a .gif") from None


# The short side of a GIF/MP4 in pixels, at least (a tall robot is not drawn as a sliver).
MIN_SHORT_SIDE = 320


def _anchored(poses):
    """Whether a fixed point holds the mechanism: a drawn line of constant length joins it to a
    moving point (a pendulum's pivot, an arm's base).  Such a mechanism never leaves its pivot's
    reach, so its view frames the whole run; following its moving bodies alone cut the pivot
    and the upper link off the double pendulum's GIF (first-hour report, s20)."""
    P = poses.points
    if P.ndim < 3 or len(P) < 2:
        return False
    fixed = np.ptp(P, axis=0).max(axis=1) < 1e-12
    return any(fixed[j] != fixed[k] for j, k in _drawn_lines(poses))


def _window_2d(poses, a, b, reach=0.0):
    """(per-frame centres (n_t, 2) or None, half-widths (ha, hb), fixed centre or None) of
    the 2-D view: the whole run when it is not much larger than the robot, else a window of
    the robot's own size that follows it (as the 3-D page's camera does)."""
    lo_t, hi_t, lo, hi = _framing(poses, reach)
    size = hi_t - lo_t
    whole = hi - lo
    robot = max(float(np.max(size[:, [a, b]])), 1e-3)
    if len(lo_t) > 1 and float(np.max(whole[[a, b]])) > FOLLOW_RATIO * robot and not _anchored(poses):
        half = size[:, [a, b]].max(axis=0) / 2 + 0.2 * robot
        centres = _smoothed((lo_t + hi_t) / 2, 9)[:, [a, b]]
        return centres, half, None
    pad = 0.1 * max(float(np.max(whole)), 1e-3)
    return None, ((whole[a] / 2 + pad), (whole[b] / 2 + pad)), (lo + hi) / 2


def _draw_ground(ax, model, poses, flat, a, b):
    """The model's ground (:func:`ground_plane`) as a line across the 2-D view, where it has
    one and the plane crosses the drawing plane: contact is seen where the feet meet it.  The
    line is the plane's trace in the drawing plane (the motion's constant coordinate c):
    n2·y = h − n_flat·c, through its point nearest the origin, along n2 turned by 90°."""
    ground = ground_plane(model)
    if ground is None:
        return None
    n, h = ground
    n2 = n[[a, b]]
    if float(n2 @ n2) < 1e-12:                          # the ground is parallel to the drawing
        return None
    P = np.concatenate([poses.positions.reshape(-1, 3), poses.points.reshape(-1, 3)])
    c = float(P[0, flat]) if len(P) else 0.0
    through = (h - n[flat] * c) * n2 / float(n2 @ n2)
    return ax.axline(tuple(through), tuple(through + np.array([-n2[1], n2[0]])), color="#8c6d31",
                     lw=1.5, zorder=0.5, gid="ground")


def _touching_2d(res, model, poses):
    """[(centres (n_t, 3), radius)]: the contact spheres and points the model computes with
    (NAME.json ``poses.contacts``, as the page's collision shapes), placed at each frame; an
    ellipsoid is drawn as its centre.  The 2-D drawing shows bodies by their frames' origins,
    which need not be on the surface that touches (hopper's foot frame sits below its capsule's
    end spheres), so the spheres are what is seen meeting the ground."""
    out = []
    for item in (model.metadata.get("poses") or {}).get("contacts") or ():
        if item["frame"] not in poses.frame_names:
            continue
        R = poses.rotation(item["frame"])
        centres = poses[item["frame"]] + R @ np.asarray(item["point"], float)
        out.append((centres, 0.0 if item.get("ellipsoid") else _radius(item, model, res)))
    return out


def animate_2d(res, path, *, model, fps=20, trace=None, dpi=80, size=4.0, t_max=None):
    """A 2-D drawing of a planar motion as GIF (Pillow) or MP4 (ffmpeg: on PATH or from the
    imageio-ffmpeg wheel, the ``video`` extra).

    The view is straight onto the plane the motion keeps; a motion that leaves every
    coordinate plane is refused with the reason.  The picture's short side is at least
    ``size`` inches (``MIN_SHORT_SIDE`` pixels at the default dpi) and its long side at most
    twice that; when the run covers much more ground than the robot (a fall, a hop) the view
    follows the robot at its own size.  The model's ground, when it has one (an MJCF floor,
    ``--ground``, a ``--contact`` plane: :func:`ground_plane`), is drawn as a line and the
    contact spheres and points the model computes with as circles and dots, so contact is
    seen.  Returns the path."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib import animation as mpl_animation
    path = Path(path)
    kind = path.suffix.lower()
    if kind not in (".gif", ".mp4"):
        raise ValueError(f"{path}: a 2-D animation is written as .gif or .mp4")
    ffmpeg = ffmpeg_path() if kind == ".mp4" else None
    times, X = _resample(res, fps)
    if t_max is not None:
        keep = times <= times[0] + t_max + 1e-12
        times, X = times[keep], X[keep]
    poses = evaluate_poses(model, times, X, getattr(res, "p", None), getattr(res, "r", None))
    flat = plane_of(poses)
    if flat is None:
        raise ValueError(f"{model.name}: the motion is not planar (no coordinate x, y or z stays constant "
                         f"for every body and point), so it has no 2-D drawing; use the HTML animation")
    a, b = [k for k in range(3) if k != flat]
    P = poses.points
    O = poses.positions
    # the view keeps what touches (its spheres reach their radius beyond their centres), so a
    # resting ball's ground is in the picture
    touching = _touching_2d(res, model, poses)
    seen = poses
    if touching:
        from types import SimpleNamespace
        seen = SimpleNamespace(positions=poses.positions, lines=poses.lines,
                               points=np.concatenate([P] + [c[:, None, :] for c, _ in touching], axis=1))
    framing = _window_2d(seen, a, b, max([r for _, r in touching], default=0.0))
    follow, (ha, hb) = framing[0], framing[1]
    centre = None if follow is not None else framing[2][[a, b]]
    ha, hb = max(ha, 1e-3), max(hb, 1e-3)
    # width / height of the picture within 1/2..2: a tall thin robot gets room beside it
    ha, hb = max(ha, hb / 2), max(hb, ha / 2)
    ratio = ha / hb
    width, height = (size * ratio, size) if ratio >= 1 else (size, size / ratio)
    title = 0.35
    fig = plt.figure(figsize=(width, height + title), dpi=dpi)
    ax = fig.add_axes([0.0, 0.0, 1.0, height / (height + title)])

    def window(i):
        c = centre if follow is None else follow[i]
        ax.set_xlim(c[0] - ha, c[0] + ha)
        ax.set_ylim(c[1] - hb, c[1] + hb)
    window(0)
    ax.set_aspect("equal")
    ax.set_xticks([]), ax.set_yticks([])
    ax.set_title(model.name, fontsize=10)
    fixed = [j for j in range(P.shape[1]) if np.ptp(P[:, j, :], axis=0).max() <= 1e-12]
    ax.plot(P[0, fixed, a], P[0, fixed, b], "o", ms=5, color="#555")
    _draw_ground(ax, model, poses, flat, a, b)
    from matplotlib.patches import Circle
    spheres = [(ax.add_patch(Circle((c[0, a], c[0, b]), r, fill=False, lw=1, color="#1f77b4", alpha=0.7,
                                    gid="contact")), c) for c, r in touching if r > 0]
    bare = [c for c, r in touching if r <= 0]
    (contact_points,) = ax.plot([], [], ".", ms=4, color="#1f77b4", gid="contact")
    traced = _default_trace(poses) if trace is None else list(trace)
    trace_lines = []
    for name in traced:
        arr = poses[name]
        (ln,) = ax.plot([], [], "-", lw=1, color="#d62728", alpha=0.6)
        trace_lines.append((ln, arr))
    drawn = _drawn_lines(poses)
    segs = [ax.plot([], [], "-", lw=2.5, color="#333")[0] for _ in drawn]
    moving = [j for j in range(P.shape[1]) if np.ptp(P[:, j, :], axis=0).max() > 1e-12]
    (dots,) = ax.plot([], [], "o", ms=9, color="#1f77b4")
    (centres,) = ax.plot([], [], "s", ms=7, color="#2ca02c")
    label = ax.text(0.02, 0.96, "", transform=ax.transAxes, fontsize=9, va="top")

    def frame(i):
        for ln, (j, k) in zip(segs, drawn):
            ln.set_data([P[i, j, a], P[i, k, a]], [P[i, j, b], P[i, k, b]])
        dots.set_data(P[i, moving, a], P[i, moving, b])
        centres.set_data(O[i, :, a], O[i, :, b])
        for ln, arr in trace_lines:
            ln.set_data(arr[:i + 1, a], arr[:i + 1, b])
        for patch, c in spheres:
            patch.set_center((c[i, a], c[i, b]))
        contact_points.set_data([c[i, a] for c in bare], [c[i, b] for c in bare])
        label.set_text(f"t = {times[i]:.2f} s")
        if follow is not None:
            window(i)
        return segs + [dots, centres, label, contact_points] + [ln for ln, _ in trace_lines] + [p for p, _ in spheres]

    anim = mpl_animation.FuncAnimation(fig, frame, frames=len(times), interval=1000 / fps, blit=False)
    if ffmpeg is not None:
        matplotlib.rcParams["animation.ffmpeg_path"] = ffmpeg
    writer = (mpl_animation.PillowWriter(fps=fps) if kind == ".gif"
              else mpl_animation.FFMpegWriter(fps=fps))
    with atomic_path(path) as tmp:
        anim.save(str(tmp), writer=writer)
    plt.close(fig)
    return path
