"""Read a URDF file into plain numbers: links, joints, line numbers; no SymPy here.

The file is parsed strictly with ``lxml`` (malformed XML is an error with its
line, not "recovered"), each ``<link>``/``<joint>`` element's line is
recorded, the structure (names, ``<parent>``/``<child>``, joint types, every
number) is checked, and then the elements are read directly: origins (URDF's
rpy: R = Rz(yaw) Ry(pitch) Rx(roll)), axes, inertials, mimic tags, mesh names.
``yourdfpy``, the parser this module used before, stays available as
``read_urdf(path, parser="yourdfpy")``: the tests compare the two readings;
it is not the default because importing it (trimesh, scipy) costs more than a
second of every cold build.  Every mistake raises :class:`ModelFileError` as
``file:line: message`` naming the link or joint.
"""
import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from eomc.runtime.errors import EomcWarning, ModelFileError

from ..multibody.model import Collision
from eomc.compiler import fixed_order as fo

__all__ = ["JOINT_TYPES", "UrdfLink", "UrdfJoint", "UrdfRobot", "read_urdf"]

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


@dataclass
class UrdfLink:
    name: str
    line: int
    mass: float = 0.0                 # 0 when the link has no <inertial>
    com: np.ndarray = None            # centre of mass in the link frame
    inertia: np.ndarray = None        # 3x3 about the centre of mass, in the link frame
    has_inertial: bool = False
    meshes: list = field(default_factory=list)   # mesh file names (visual/collision)
    collisions: tuple = ()            # its <collision> elements (eomc.compiler.multibody.Collision)


@dataclass
class UrdfJoint:
    name: str
    line: int
    type: str
    parent: str
    child: str
    origin: np.ndarray                # 4x4: child link frame at q = 0 in the parent link frame
    axis: np.ndarray                  # unit vector in the joint (= child link) frame
    mimic: tuple = None               # (joint, multiplier, offset) or None
    limit: tuple = None               # <limit lower upper> as (lower, upper), None where absent
    dynamics: tuple = (0.0, 0.0)      # <dynamics damping friction>, 0 where absent


@dataclass
class UrdfRobot:
    name: str
    path: Path
    links: dict                       # name -> UrdfLink, in file order
    joints: list                      # UrdfJoint, in file order
    line: int = None                  # the <robot> element's line
    # the parsed document (lxml), for a reader that needs more of it than these records (the
    # visuals: eomc.runtime.urdf_scene reads them from it without parsing again)
    xml: "lxml.etree._Element" = field(default=None, repr=False, compare=False)


def _fail(path, line, message):
    raise ModelFileError(message, str(path), line)


def _strict_xml(path):
    from lxml import etree
    try:
        tree = etree.parse(str(path), etree.XMLParser(remove_comments=True))
    except OSError as exc:
        _fail(path, None, f"cannot read URDF file ({exc})")
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if getattr(exc, "lineno", None) else None
        message = exc.msg if getattr(exc, "msg", None) else str(exc)
        # lxml appends "(file, line N)" to some messages; the location is already in front
        message = message.split(", line ")[0].rstrip(" (")
        _fail(path, line, f"malformed XML: {message}")
    root = tree.getroot()
    if root.tag != "robot":
        _fail(path, root.sourceline, f"the top element is <{root.tag}>, not <robot>: not a URDF file")
    if root.find("link") is None:
        _fail(path, root.sourceline, _empty_robot(path))
    if not (root.get("name") or "").strip():
        # urdfdom refuses it; a robot is still fully described without its name: the file's
        # stem names the model, as `--name` would
        warnings.warn(f"{path}:{root.sourceline}: <robot> has no name attribute (URDF requires "
                      f"<robot name=\"...\">): the model is named '{path.stem}' after the file",
                      EomcWarning, stacklevel=3)
    return root


def _empty_robot(path):
    """The refusal of a <robot> without a <link>, naming the URDF files next to it that share
    its stem (example-robot-data's ur3.urdf is an empty xacro output beside ur3_robot.urdf)."""
    try:
        siblings = sorted(p.name for p in path.parent.glob(f"{path.stem}*.urdf")
                          if p != path and p.is_file())
    except OSError:
        siblings = []
    hint = f"; the URDF files next to it: {', '.join(siblings[:6])}" if siblings else ""
    return f"<robot> has no <link>: the file describes no robot, nothing to build{hint}"


def _check_structure(path, root):
    """What yourdfpy assumes without checking; returns {('link'|'joint', name): line}."""
    lines = {}
    for tag in ("link", "joint"):
        for element in root.findall(tag):
            name = element.get("name")
            if not name:
                _fail(path, element.sourceline, f"a <{tag}> has no name attribute")
            if (tag, name) in lines:
                _fail(path, element.sourceline, f"{tag} '{name}' is defined twice "
                                                 f"(first on line {lines[tag, name]})")
            lines[tag, name] = element.sourceline
    for element in root.findall("joint"):
        name = element.get("name")
        kind = element.get("type")
        mimic = element.find("mimic")
        if mimic is not None and not mimic.get("joint"):
            _fail(path, mimic.sourceline, f"joint '{name}': <mimic> has no joint attribute")
        if kind not in JOINT_TYPES:
            what = f"unknown type '{kind}'" if kind else "no type attribute"
            _fail(path, element.sourceline, f"joint '{name}' has {what}; URDF joint types are "
                                            f"{', '.join(JOINT_TYPES)}")
        for tag in ("parent", "child"):
            sub = element.find(tag)
            if sub is None or not sub.get("link"):
                _fail(path, element.sourceline, f"joint '{name}' has no <{tag} link=\"...\"/>")
            if ("link", sub.get("link")) not in lines:
                _fail(path, sub.sourceline, f"joint '{name}' names {tag} link '{sub.get('link')}', "
                                            f"which the file does not define")
    _check_numbers(path, root)
    _check_loose_numbers(path, root)
    return lines


def _check_numbers(path, root):
    """Numeric attributes that yourdfpy would turn into a ValueError without a location."""
    wanted = {"origin": {"xyz": 3, "rpy": 3}, "axis": {"xyz": 3}, "mass": {"value": 1},
              "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
              "mimic": {"multiplier": 1, "offset": 1}}
    for element in root.iter(*wanted):
        for attribute, count in wanted[element.tag].items():
            text = element.get(attribute)
            if text is None:
                continue
            try:
                values = [float(v) for v in text.split()]
            except ValueError:
                values = None
            if values is None or len(values) != count or not np.all(np.isfinite(values)):
                who = _owner(element)
                _fail(path, element.sourceline,
                      f"<{element.tag} {attribute}=\"{text}\">{who}: expected {count} finite "
                      f"number{'s' if count > 1 else ''}")


def _owner(element):
    owner = element.getparent()
    while owner is not None and owner.tag not in ("link", "joint"):
        owner = owner.getparent()
    return f" in {owner.tag} '{owner.get('name')}'" if owner is not None else ""


def _check_loose_numbers(path, root):
    """Attributes yourdfpy converts to float: text is an error with a line; any number passes
    here (limits and dynamics are checked where they are used, naming the joint:
    :func:`eomc.compiler.urdf.treeir.joint_law`; the others are not used)."""
    wanted = {"limit": ("lower", "upper", "effort", "velocity"), "dynamics": ("damping", "friction"),
              "safety_controller": ("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"),
              "calibration": ("rising", "falling")}
    for element in root.iter(*wanted):
        for attribute in wanted[element.tag]:
            text = element.get(attribute)
            if text is None:
                continue
            try:
                float(text)
            except ValueError:
                _fail(path, element.sourceline, f"<{element.tag} {attribute}=\"{text}\">"
                                                f"{_owner(element)}: expected a number")


def _parse(path):
    """yourdfpy's model of the file, without meshes or scene graphs."""
    import yourdfpy
    quiet = logging.getLogger("yourdfpy")
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        return yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False)
    except Exception as exc:   # what the checks above did not foresee: still one line, no traceback
        _fail(path, None, f"the URDF parser (yourdfpy) rejected the file: {type(exc).__name__}: {exc}")
    finally:
        quiet.setLevel(level)


def _link(link, line):
    meshes = [g.geometry.mesh.filename for g in (*link.visuals, *link.collisions)
              if g.geometry is not None and g.geometry.mesh is not None]
    inertial = link.inertial
    if inertial is None:
        return UrdfLink(link.name, line, 0.0, np.zeros(3), np.zeros((3, 3)), False, meshes)
    origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
    rotation = origin[:3, :3]
    tensor = np.eye(3) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
    mass = float(inertial.mass or 0.0)
    return UrdfLink(link.name, line, mass, origin[:3, 3].copy(), fo.matmul(rotation, tensor, rotation.T),
                    True, meshes)


def _joint(path, joint, line):
    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=float)
    biggest = float(np.max(np.abs(axis)))
    if joint.type in ("revolute", "continuous", "prismatic", "planar") and biggest < 1e-300:
        _fail(path, line, f"joint '{joint.name}' has a zero <axis>")
    if biggest >= 1e-300:     # scaled first: the norm of 1e200-sized entries would overflow
        axis = axis / biggest
    norm = fo.norm(axis)
    origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
    mimic = None
    if joint.mimic is not None:
        mimic = (joint.mimic.joint, float(joint.mimic.multiplier if joint.mimic.multiplier is not None
                                          else 1.0),
                 float(joint.mimic.offset if joint.mimic.offset is not None else 0.0))
    limit = getattr(joint, "limit", None)
    if limit is not None:
        limit = tuple(None if v is None else float(v) for v in (limit.lower, limit.upper))
    dynamics = getattr(joint, "dynamics", None)
    dynamics = (0.0, 0.0) if dynamics is None else tuple(float(v or 0.0) for v in (dynamics.damping,
                                                                                     dynamics.friction))
    return UrdfJoint(joint.name, line, joint.type, joint.parent, joint.child, origin,
                     axis / norm if norm else axis, mimic, limit, dynamics)


def read_urdf(path, parser="lxml"):
    """The robot in ``path`` as a :class:`UrdfRobot` (raises ModelFileError with file:line).

    ``parser``: "lxml" reads the checked elements directly (the default: importing yourdfpy
    pulls trimesh and scipy, over a second of every cold build); "yourdfpy" goes through
    yourdfpy's model, which the tests use as the reference for the direct reading."""
    path = Path(path)
    from eomc.runtime.readable import check_regular_file
    check_regular_file(path, "URDF file")        # a FIFO or device: refused before it is opened
    if not path.is_file():
        _fail(path, None, "no such URDF file")
    root = _strict_xml(path)
    lines = _check_structure(path, root)
    if parser == "lxml":
        links = {e.get("name"): _link_element(e) for e in root.findall("link")}
        joints = [_joint(path, _JointElement(e), e.sourceline) for e in root.findall("joint")]
        name = (root.get("name") or "").strip() or path.stem
        return UrdfRobot(name, path, links, joints, root.sourceline, root)
    robot = _parse(path).robot
    links = {link.name: _link(link, lines.get(("link", link.name))) for link in robot.links}
    for element in root.findall("link"):       # collision geometry: read from the document either way
        if element.get("name") in links:
            links[element.get("name")].collisions = _collisions(element)
    joints = [_joint(path, j, lines.get(("joint", j.name))) for j in robot.joints]
    return UrdfRobot(robot.name or path.stem, path, links, joints, root.sourceline, root)


def _numbers(element, attribute, default):
    text = element.get(attribute) if element is not None else None
    return np.array([float(v) for v in text.split()]) if text is not None else np.array(default, dtype=float)


def _origin(element):
    """4x4 of an <origin xyz rpy> (URDF: R = Rz(yaw) Ry(pitch) Rx(roll)); identity if absent."""
    transform = np.eye(4)
    if element is None:
        return transform
    r, p, y = _numbers(element, "rpy", (0.0, 0.0, 0.0))
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    transform[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                         [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                         [-sp, cp * sr, cp * cr]]
    transform[:3, 3] = _numbers(element, "xyz", (0.0, 0.0, 0.0))
    return transform


def _collisions(element):
    """The <collision> elements of a <link> as Collision records (origin read, shape as written)."""
    out = []
    for col in element.findall("collision"):
        geometry = col.find("geometry")
        item = geometry[0] if geometry is not None and len(geometry) else None
        tag = item.tag if item is not None and isinstance(item.tag, str) else None
        out.append(Collision(element.get("name"), tuple(map(tuple, _origin(col.find("origin")))), tag,
                             tuple(item.attrib.items()) if tag is not None else (), col.sourceline,
                             item.sourceline if tag is not None else None))
    return tuple(out)


def _link_element(element):
    meshes = [m.get("filename") for tag in ("visual", "collision") for g in element.findall(tag)
              for m in g.findall("geometry/mesh")]
    inertial = element.find("inertial")
    if inertial is None:
        return UrdfLink(element.get("name"), element.sourceline, 0.0, np.zeros(3), np.zeros((3, 3)),
                        False, meshes, _collisions(element))
    origin = _origin(inertial.find("origin"))
    rotation = origin[:3, :3]
    mass_element = inertial.find("mass")
    mass = float(_numbers(mass_element, "value", (0.0,))[0]) if mass_element is not None else 0.0
    box = inertial.find("inertia")
    if box is None:
        tensor = np.eye(3)
    else:
        v = {k: float(box.get(k, 0.0)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        tensor = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                           [v["ixz"], v["iyz"], v["izz"]]])
    return UrdfLink(element.get("name"), element.sourceline, mass, origin[:3, 3].copy(),
                    fo.matmul(rotation, tensor, rotation.T), True, meshes, _collisions(element))


class _JointElement:
    """A <joint> element with the attributes :func:`_joint` reads (as yourdfpy's Joint)."""

    def __init__(self, element):
        self.name, self.type = element.get("name"), element.get("type")
        self.parent = element.find("parent").get("link")
        self.child = element.find("child").get("link")
        axis = element.find("axis")
        self.axis = _numbers(axis, "xyz", (1.0, 0.0, 0.0)) if axis is not None else None
        self.origin = _origin(element.find("origin"))
        limit, dynamics = element.find("limit"), element.find("dynamics")
        self.limit = None if limit is None else _Limit(*(float(limit.get(k)) if limit.get(k) is not None
                                                         else None for k in ("lower", "upper")))
        self.dynamics = None if dynamics is None else _Dynamics(*(float(dynamics.get(k, 0.0))
                                                                  for k in ("damping", "friction")))
        mimic = element.find("mimic")
        self.mimic = None
        if mimic is not None:
            self.mimic = _Mimic(mimic.get("joint"),
                                float(mimic.get("multiplier")) if mimic.get("multiplier") else None,
                                float(mimic.get("offset")) if mimic.get("offset") else None)


@dataclass
class _Mimic:
    joint: str
    multiplier: float
    offset: float


@dataclass
class _Limit:
    lower: float
    upper: float


@dataclass
class _Dynamics:
    damping: float
    friction: float
