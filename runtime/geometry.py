"""What the bodies look like: shapes as plain dicts, URDF visuals, meshes packed for a web page.

A shape is a JSON-ready dict (it travels in NAME.json, so a built directory
animates without its model file)::

    {"kind": "sphere", "size": [r]}            {"kind": "box", "size": [a, b, c]}
    {"kind": "cylinder", "size": [r, h]}       (axis along the body's z, as in URDF)
    {"kind": "mesh", "path": "/abs/file.stl", "scale": [sx, sy, sz]}

each with ``origin`` (the shape's pose in the body frame: a 4x4 row-major
list of 16 numbers) and ``color`` ([r, g, b] in 0..1, or None).

Meshes are read with trimesh (and DAE files with pycollada: the ``mesh`` extra, kept out of
the base install because trimesh's usual extras weigh about 95 MB) when a page is written,
never when a model is built.  Without the extra, a model's meshes are drawn as boxes with one
warning naming the extra; a mesh that is missing or unreadable is drawn as a small box, with one warning
naming the body and the file.  Vertices are
quantized to 16 bits over the mesh's bounding box (error below 1/65535 of its
size, invisible on screen) and big meshes are thinned by vertex clustering, so
a robot's page stays a few megabytes.
"""
import base64
import importlib.util
import logging
import re
import warnings
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import numpy as np

from eomc.runtime.errors import EomcWarning, MissingExtraError
from eomc.runtime.urdf_scene import load_scene, resolve_filename

__all__ = ["shape", "urdf_visuals", "urdf_link_transforms", "packed_mesh", "quiet_mesh_loggers", "MAX_MESH_FACES"]

# A mesh with more triangles than this is thinned (vertex clustering) before it is written.
MAX_MESH_FACES = 20_000

_IDENTITY = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]


@contextmanager
def quiet_mesh_loggers():
    """yourdfpy and trimesh log what they cannot find or read ("Unable to resolve filename:
    ...") straight to stderr; eomc says it once itself (a warning naming the body and the
    file, in :func:`pack_shapes`), so their records below ERROR are dropped meanwhile."""
    loggers = [logging.getLogger(name) for name in ("yourdfpy", "trimesh")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def shape(kind, size=(), *, path=None, scale=None, origin=None, color=None):
    """A shape dict (see the module docstring), its numbers checked."""
    size = [float(s) for s in size]
    if any(not np.isfinite(s) or s <= 0 for s in size):
        raise ValueError(f"{kind} sizes must be positive finite numbers, not {size}")
    out = {"kind": kind, "size": size,
           "origin": _IDENTITY if origin is None else [float(v) for v in np.asarray(origin, float).reshape(16)]}
    if path is not None:
        out["path"] = str(path)
        out["scale"] = [1.0, 1.0, 1.0] if scale is None else [float(s) for s in np.broadcast_to(scale, 3)]
    if color is not None:
        out["color"] = [float(c) for c in color][:3]
    return out


def urdf_visuals(tree, urdf=None):
    """{body name (a C identifier, as the System names it) or "world": [shapes]} of a URDF robot.

    ``tree``: eomc.compiler.urdf's merged tree.  A link welded into a body (or into the
    ground) is placed by the fixed joints between them, read at the zero configuration.
    ``urdf``: the file's :func:`~eomc.runtime.urdf_scene.load_scene` when the caller has it
    (a reader that parsed the file already), else the file is read.
    """
    with quiet_mesh_loggers():
        return _urdf_visuals(tree, urdf if urdf is not None else load_scene(tree.path))


def _urdf_visuals(tree, urdf):
    path = Path(tree.path)
    links = {link.name: link for link in urdf.robot.links}
    groups = [("world", tree.root, list(tree.ground_links))]   # none on a floating base
    groups += [(identifier(b.name), b.name, b.links) for b in tree.bodies.values()]
    out = {}
    for key, frame_link, members in groups:
        items = []
        for name in members:
            link = links.get(name)
            if link is None:
                continue
            T_body_link = np.asarray(urdf.get_transform(frame_to=name, frame_from=frame_link), float)
            for visual in link.visuals:
                item = _visual(visual, path.parent, T_body_link)
                if item is not None:
                    item["link"] = name
                    items.append(item)
        if items:
            out[key] = items
    return out


def urdf_link_transforms(tree, urdf=None):
    """{link name: (body name or "world", 4x4 pose of the link in that body's frame)} of every
    link that is not a body's own frame: links welded to a body or to the ground.  ``urdf``:
    the file's :func:`~eomc.runtime.urdf_scene.load_scene` when the caller has it."""
    if urdf is None:
        urdf = load_scene(tree.path)
    out = {}
    groups = [("world", tree.root, list(tree.ground_links))]   # none on a floating base
    groups += [(identifier(b.name), b.name, b.links) for b in tree.bodies.values()]
    for key, frame_link, members in groups:
        for name in members:
            if name != frame_link or key == "world":
                out[name] = (key, np.asarray(urdf.get_transform(frame_to=name, frame_from=frame_link), float))
    return out


def identifier(name):
    """A link name as the URDF System names its body (eomc.compiler.urdf.system.identifier;
    repeated here because the runtime does not import the compiler)."""
    text = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return text if text and not text[0].isdigit() else f"_{text}"


def _visual(visual, directory, T_body_link):
    g = visual.geometry
    if g is None:
        return None
    origin = T_body_link @ (np.eye(4) if visual.origin is None else np.asarray(visual.origin, float))
    color = None
    material = visual.material
    if material is not None and material.color is not None and material.color.rgba is not None:
        color = [float(c) for c in material.color.rgba[:3]]
    if g.box is not None:
        return shape("box", g.box.size, origin=origin, color=color)
    if g.cylinder is not None:
        return shape("cylinder", (g.cylinder.radius, g.cylinder.length), origin=origin, color=color)
    if g.sphere is not None:
        return shape("sphere", (g.sphere.radius,), origin=origin, color=color)
    if g.mesh is not None:
        resolved = resolve_filename(g.mesh.filename, str(directory))
        return shape("mesh", path=resolved, scale=g.mesh.scale if g.mesh.scale is not None else None,
                     origin=origin, color=color)
    return None


def _thin(vertices, faces, max_faces):
    """Vertex clustering on a grid until at most ``max_faces`` triangles remain (crude, fast, no deps)."""
    lo, hi = vertices.min(0), vertices.max(0)
    extent = float(np.max(hi - lo)) or 1.0
    cells = 256
    while len(faces) > max_faces and cells >= 8:
        key = np.floor((vertices - lo) / extent * (cells - 1e-9)).astype(np.int64)
        flat = (key[:, 0] * cells + key[:, 1]) * cells + key[:, 2]
        uniq, inverse = np.unique(flat, return_inverse=True)
        sums = np.zeros((len(uniq), 3))
        np.add.at(sums, inverse, vertices)
        counts = np.bincount(inverse, minlength=len(uniq))[:, None]
        f = inverse[faces]
        keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
        f = f[keep]
        if len(f):   # drop repeated triangles; keep each one's winding (its normal's side)
            f = f[np.sort(np.unique(np.sort(f, axis=1), axis=0, return_index=True)[1])]
        if len(f) <= max_faces or cells <= 8:
            return sums / counts, f
        cells //= 2
    return vertices, faces


def packed_mesh(path, scale=(1.0, 1.0, 1.0), max_faces=MAX_MESH_FACES):
    """{"lo", "hi", "v" (base64 uint16 xyz), "f" (base64 uint32), "nv", "nf"} of a mesh file.

    Raises OSError/ValueError when the file is missing or unreadable.  Kept per process
    (keyed by the file's path, size and mtime): a robot's meshes are read once.
    """
    if not Path(path).is_file():
        raise OSError(f"no such file {path}")
    st = Path(path).stat()
    return _packed(str(path), tuple(float(s) for s in np.broadcast_to(scale, 3)), max_faces,
                   st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=64)
def _packed(path, scale, max_faces, size, mtime):
    import trimesh
    with quiet_mesh_loggers():
        loaded = trimesh.load(str(path), force="mesh")   # process: merged vertices, smooth normals
    vertices = np.asarray(loaded.vertices, float) * np.asarray(scale, float)
    faces = np.asarray(loaded.faces, np.int64)
    if len(vertices) == 0 or len(faces) == 0:
        raise ValueError(f"{path} holds no triangles")
    if len(faces) > max_faces:
        vertices, faces = _thin(vertices, faces, max_faces)
    lo, hi = vertices.min(0), vertices.max(0)
    span = np.where(hi > lo, hi - lo, 1.0)
    q = np.round((vertices - lo) / span * 65535).astype("<u2")
    return {"lo": lo.tolist(), "hi": hi.tolist(), "nv": int(len(q)), "nf": int(len(faces)),
            "v": base64.b64encode(q.tobytes()).decode(),
            "f": base64.b64encode(faces.astype("<u4").tobytes()).decode()}


# the modules that read a mesh file of each kind (trimesh reads STL and OBJ itself)
_READERS = {".dae": ("trimesh", "collada")}


def _missing_mesh_readers(geometry):
    """The MissingExtraError naming the ``mesh`` extra when the model has mesh files and a module
    that reads them is not installed, else None."""
    files = sorted({item["path"] for items in geometry.values() for item in items
                    if item.get("kind") == "mesh"})
    needed = {"trimesh"} if files else set()
    for path in files:
        needed.update(_READERS.get(Path(path).suffix.lower(), ()))
    missing = sorted(m for m in needed if importlib.util.find_spec(m) is None)
    if missing:
        names = {"collada": "pycollada"}
        return MissingExtraError(f"drawing this model's meshes ({len(files)} file{'s' * (len(files) > 1)}, "
                                 f"e.g. {Path(files[0]).name})", "mesh", [names.get(m, m) for m in missing])
    return None


def _located(geometry, package_dirs):
    """``geometry`` with each mesh still named ``package://...`` (not found when the model
    was built) looked up in the package folders (``package_dirs`` first)."""
    from .packages import find_package_file
    out = {}
    for name, items in geometry.items():
        out[name] = []
        for item in items:
            if item.get("kind") == "mesh" and str(item.get("path", "")).startswith("package://"):
                found = find_package_file(item["path"], package_dirs)
                if found is not None:
                    item = {**item, "path": found}
            out[name].append(item)
    return out


def pack_shapes(geometry, package_dirs=()):
    """{name: [shapes]} with each mesh's file replaced by its packed triangles (shared by path).

    A mesh that cannot be read becomes a small box; one warning names the first such body and
    file and counts the others (with a hint for ``package://`` files: where packages are
    looked for, eomc.runtime.packages).  Without the ``mesh`` extra every mesh is drawn as a box,
    with one warning naming the extra (first hour s21 L1: ``eomc animate robot.urdf`` after the
    README's ``.[plot]`` install stopped there on every mesh robot).
    """
    geometry = _located(geometry, package_dirs)
    missing = _missing_mesh_readers(geometry)
    if missing is not None:
        warnings.warn(f"{missing}; drawn as boxes meanwhile", EomcWarning, stacklevel=2)
    meshes, out, failed = {}, {}, []
    for name, items in geometry.items():
        packed = []
        for item in items:
            item = dict(item)
            if item.get("kind") == "mesh" and missing is not None:
                item = shape("box", (0.05, 0.05, 0.05), origin=np.reshape(item["origin"], (4, 4)),
                             color=item.get("color"))
            elif item.get("kind") == "mesh":
                key = (item["path"], tuple(item.get("scale", (1, 1, 1))))
                if key not in meshes:
                    try:
                        meshes[key] = packed_mesh(*key)
                    except Exception as exc:   # trimesh raises many kinds; the page must still open
                        meshes[key] = None
                        failed.append((item.get("link", name), item["path"], exc))
                if meshes[key] is None:
                    item = shape("box", (0.05, 0.05, 0.05), origin=np.reshape(item["origin"], (4, 4)),
                                 color=item.get("color"))
                else:
                    item["mesh"] = list(meshes).index(key)
            packed.append(item)
        out[name] = packed
    if failed:
        link, path, exc = failed[0]
        more = f" and {len(failed) - 1} more mesh{'es' * (len(failed) > 2)}" if len(failed) > 1 else ""
        hint = ""
        if any(str(p).startswith("package://") for _, p, _ in failed):
            from .packages import PACKAGE_HINT
            hint = f"; a package:// file: {PACKAGE_HINT}"
        warnings.warn(f"{link}: cannot read mesh {path} ({type(exc).__name__}: {exc}){more}; drawn as "
                      f"{'boxes' if more else 'a box'}{hint}", EomcWarning, stacklevel=2)
    return out, [m for m in meshes.values()]
