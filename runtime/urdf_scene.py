"""A URDF's links as drawn: their visuals, and link placements at the zero configuration.

Why this module: the animation's shapes and the placement of welded links (``tool0``, a
foot) were read with yourdfpy, which imports trimesh at import time and requires
``trimesh[easy]`` (embree, manifold3d, shapely, networkx, ...: about 95 MB of a fresh
install).  Reading visuals and zero-configuration placements needs only lxml, so the base
install stays light and trimesh is needed only to read mesh *files* (the ``mesh`` extra,
eomc.runtime.geometry.packed_mesh).

The numbers are yourdfpy 0.0.60's, operation for operation (origins by trimesh's
``compose_matrix`` with static-XYZ Euler angles, joint motion at q = 0, the scene graph's
product of edge matrices with near-identity edges dropped and ``fix_rigid`` repair), so
the poses and frames compiled into a robot's C are unchanged; a test compares this reader
with yourdfpy on every robot of example-robot-data, bit for bit.  The few transformation
routines below follow Christoph Gohlke's transformations.py (BSD-3-Clause), as trimesh
ships it.
"""
import logging
import os
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

__all__ = ["UrdfScene", "load_scene", "resolve_filename"]

_log = logging.getLogger(__name__)
_IDENTITY = np.eye(4)


@dataclass
class Box:
    size: np.ndarray


@dataclass
class Cylinder:
    radius: float
    length: float


@dataclass
class Sphere:
    radius: float


@dataclass
class Mesh:
    filename: str
    scale: object = None        # None, a float or an array of three


@dataclass
class Geometry:
    box: Box = None
    cylinder: Cylinder = None
    sphere: Sphere = None
    mesh: Mesh = None


@dataclass
class Color:
    rgba: np.ndarray


@dataclass
class Material:
    name: str = None
    color: Color = None


@dataclass
class Visual:
    geometry: Geometry = None
    origin: np.ndarray = None   # 4x4 in the link frame, None when the file gives none
    material: Material = None


@dataclass
class Link:
    name: str
    visuals: list = field(default_factory=list)


@dataclass
class Robot:
    name: str
    links: list = field(default_factory=list)


# -- transformations (trimesh.transformations, the code paths yourdfpy takes) -------------

def _unit_vector(data):
    data = np.array(data, dtype=np.float64)
    data /= np.sqrt(np.dot(data, data))
    return data


def _euler_sxyz(ai, aj, ak):
    """Static-XYZ Euler angles (URDF's rpy): R = Rz(yaw) Ry(pitch) Rx(roll)."""
    M = np.eye(4)
    si, sj, sk = np.sin(ai), np.sin(aj), np.sin(ak)
    ci, cj, ck = np.cos(ai), np.cos(aj), np.cos(ak)
    cc, cs = ci * ck, ci * sk
    sc, ss = si * ck, si * sk
    M[0, 0] = cj * ck
    M[0, 1] = sj * sc - cs
    M[0, 2] = sj * cc + ss
    M[1, 0] = cj * sk
    M[1, 1] = sj * ss + cc
    M[1, 2] = sj * cs - sc
    M[2, 0] = -sj
    M[2, 1] = cj * si
    M[2, 2] = cj * ci
    return M


def _compose(translate, angles):
    M = np.identity(4)
    T = np.identity(4)
    T[:3, 3] = translate[:3]
    M = np.dot(M, T)
    M = np.dot(M, _euler_sxyz(angles[0], angles[1], angles[2]))
    M /= M[3, 3]
    return M


def _rotation(angle, direction):
    sina, cosa = np.sin(angle), np.cos(angle)
    direction = _unit_vector(direction[:3])
    M = np.diag([cosa, cosa, cosa, 1.0])
    M[:3, :3] += np.outer(direction, direction) * (1.0 - cosa)
    direction = direction * sina
    M[:3, :3] += np.array([[0.0, -direction[2], direction[1]],
                           [direction[2], 0.0, -direction[0]],
                           [-direction[1], direction[0], 0.0]])
    return M


def _translation(direction):
    M = np.identity(4)
    M[:3, 3] = direction[:3]
    return M


def _fix_rigid(matrix, max_deviance=1e-5):
    """Re-orthonormalize a rotation that products left almost rigid (trimesh's scene graph)."""
    check = np.abs(np.dot(matrix[:3, :3], matrix[:3, :3].T) - _IDENTITY[:3, :3]).max()
    if 1e-13 < check < max_deviance:
        U, _, V = np.linalg.svd(matrix[:3, :3])
        repaired = np.eye(4)
        repaired[:3, :3] = np.dot(U, V)
        repaired[:3, 3] = matrix[:3, 3]
        return repaired
    return matrix


# -- reading ------------------------------------------------------------------------------

def _floats(text):
    return np.array(list(map(float, text.split())))


def _origin(element):
    if element is None:
        return None
    return _compose(_floats(element.get("xyz", "0 0 0")), _floats(element.get("rpy", "0 0 0")))


def _scale(element):
    if "scale" not in element.attrib:
        return None
    s = element.get("scale").replace(",", " ").split()
    if not s:
        return None
    return float(s[0]) if len(s) == 1 else np.array(list(map(float, s)))


def _geometry(element):
    shapes = [] if element is None else [e for e in element if isinstance(e.tag, str)]   # not comments
    if not shapes:
        return None
    g, shape = Geometry(), shapes[0]
    if shape.tag == "box":
        g.box = Box(np.array(shape.attrib["size"].replace(",", " ").split(), dtype=np.float64))
    elif shape.tag == "cylinder":
        g.cylinder = Cylinder(float(shape.attrib["radius"]), float(shape.attrib["length"]))
    elif shape.tag == "sphere":
        g.sphere = Sphere(float(shape.attrib["radius"]))
    elif shape.tag == "mesh":
        g.mesh = Mesh(shape.get("filename"), _scale(shape))
    else:
        return None
    return g


def _material(element):
    if element is None:
        return None
    color = element.find("color")
    return Material(element.get("name"),
                    None if color is None else Color(_floats(color.get("rgba", "1 1 1 1"))))


def _joint_matrix(joint, actuated):
    """The joint's placement of its child at q = 0 (a mimic joint sits at its offset)."""
    origin = _origin(joint.find("origin"))
    origin = np.eye(4) if origin is None else origin
    kind = joint.get("type")
    if kind not in ("revolute", "prismatic", "continuous"):
        return origin
    mimic = joint.find("mimic")
    q = np.float64(0.0)
    if mimic is not None:
        multiplier = float(mimic.get("multiplier", 1.0))
        offset = float(mimic.get("offset", 0.0))
        q = q * multiplier + offset if mimic.get("joint") in actuated else 0.0 + offset
    axis = joint.find("axis")
    axis = np.array([1.0, 0, 0]) if axis is None else _floats(axis.get("xyz", "1 0 0"))
    if kind == "prismatic":
        return origin @ _translation(q * axis)
    return origin @ _rotation(float(q), axis)


class UrdfScene:
    """The links of a URDF file with their visuals, and ``get_transform`` between link frames
    at the zero configuration (the subset of yourdfpy.URDF that drawing needs)."""

    def __init__(self, path, root=None):
        root = etree.parse(str(path)).getroot() if root is None else root
        self.path = str(path)
        self.robot = Robot(root.get("name"))
        for element in root.findall("link"):
            link = Link(element.get("name"))
            for v in element.findall("visual"):
                link.visuals.append(Visual(_geometry(v.find("geometry")), _origin(v.find("origin")),
                                           _material(v.find("material"))))
            self.robot.links.append(link)
        joints = root.findall("joint")
        actuated = {j.get("name") for j in joints if j.find("mimic") is None and j.get("type") != "fixed"}
        self._parent = {}       # child link -> (parent link, 4x4 of the child in the parent)
        for j in joints:
            self._parent[j.find("child").get("link")] = (j.find("parent").get("link"), _joint_matrix(j, actuated))

    def _up(self, link):
        path = [link]
        while path[-1] in self._parent:
            path.append(self._parent[path[-1]][0])
        return path

    def get_transform(self, frame_to, frame_from):
        """4x4 pose of link ``frame_to`` in the frame of link ``frame_from`` at q = 0."""
        if frame_to == frame_from:
            return _IDENTITY.copy()
        up_to, up_from = self._up(frame_to), self._up(frame_from)
        if frame_from in up_to:           # frame_from above frame_to: along the joints, forward
            chain = up_to[:up_to.index(frame_from) + 1][::-1]
        elif frame_to in up_from:
            chain = up_from[:up_from.index(frame_to) + 1]
        else:
            common = next(link for link in up_from if link in set(up_to))
            chain = up_from[:up_from.index(common)] + up_to[:up_to.index(common) + 1][::-1]
        if len(chain) == 2 and self._parent.get(chain[1], (None,))[0] == chain[0]:
            return _fix_rigid(self._parent[chain[1]][1])   # one joint: its matrix, as the graph stores it
        matrices = []
        for u, v in zip(chain, chain[1:]):
            if self._parent.get(v, (None,))[0] == u:
                matrices.append(self._parent[v][1])
            else:
                matrices.append(np.linalg.inv(self._parent[u][1]))
        matrices = [m for m in matrices if np.abs(m - _IDENTITY).max() > 1e-8]
        if not matrices:
            return _IDENTITY.copy()
        matrix = matrices[0] if len(matrices) == 1 else np.linalg.multi_dot(matrices)
        return _fix_rigid(matrix)


def load_scene(path, root=None):
    """The URDF at ``path`` as a :class:`UrdfScene`; ``root``: its document when a reader
    parsed it already (lxml; eomc.compiler.urdf.reader), so the file is read once."""
    return UrdfScene(path, root)


def _strip_directive(fname):
    if "://" in fname or ":\\\\" in fname:
        return ":".join(fname.split(":")[1:])[2:]
    return fname


def _strip_package(fname):
    """``package://pkg/a/b.stl`` -> ``a/b.stl``; any other ``scheme://`` removed."""
    if fname.startswith("package://"):
        parts = os.path.normpath(fname[len("package://"):]).split(os.path.sep)[1:]
        return os.path.join(*parts) if parts else ""
    return _strip_directive(fname)


def resolve_filename(fname, directory):
    """A mesh's file as the URDF names it, found as yourdfpy finds it: next to the URDF (the
    ``package://NAME/`` prefix dropped), as given, then relative to each folder above the URDF's;
    then a ``package://`` file in the package folders (eomc.runtime.packages: ROS_PACKAGE_PATH,
    AMENT_PREFIX_PATH, the example-robot-data layout).  Returns the input when none exists."""
    candidates = [os.path.join(directory, _strip_package(fname)), _strip_directive(fname)]
    folder = directory
    for _ in range(len(os.path.normpath(directory).split(os.path.sep))):
        folder = os.path.dirname(folder)
        candidates.append(os.path.join(folder, _strip_package(fname)))
    for candidate in candidates:
        if os.path.isfile(candidate):
            return candidate
    from .packages import find_package_file     # a URDF copied out of its package: ROS's way
    found = find_package_file(fname)
    if found is not None:
        return found
    _log.debug("unable to resolve mesh file %s", fname)
    return fname
