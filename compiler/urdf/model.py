"""URDF files and URDF-built Systems as eomc models: forming, parameter defaults, inputs.

``eomc.compile("robot.urdf")`` and ``eomc.compile(from_urdf(path))`` land
here through :func:`eomc.compiler.model.model_spec`.  A URDF file (or a
:class:`UrdfModel`: the file plus options, what ``--floating-base`` gives) goes
straight to the recursive formulation's tree (:mod:`.treeir`) under the
``recursive`` and ``auto`` formulations: no SymPy System, frames or velocities
are built, which is what made large robots take minutes.  Under ``kane`` (and
for ``mimic=True`` robots that have mimic joints: a constraint the tree cannot
carry) the file becomes the System of :func:`.from_urdf`, formed with eomc's
KanesMethod, as before.  Both give the same coordinates, speeds, parameters
(names and URDF defaults) and inputs, and a robot with joint limits and no contact
the same ``energy`` output (:func:`_kane_energy`).

The URDF's values become the parameter defaults -- on the Kane path only for
the parameters that survive in the equations (a link's mass on a vertical axis
through its centre of mass does not) -- and the joint torques the inputs, in
joint order; what the caller passes overrides them.
"""
import warnings
from dataclasses import dataclass
from pathlib import Path

from eomc.runtime.errors import EomcWarning

from ..multibody.model import merged_defaults, merged_initial_state
from eomc.compiler import fixed_order as fo

__all__ = ["is_urdf_path", "is_urdf_model", "UrdfModel", "urdf_overrides", "load_urdf_model",
           "with_options", "read_model", "model_of_robot", "urdf_formed", "start_in_range"]


@dataclass(frozen=True)
class UrdfModel:
    """A URDF file with the options of :func:`eomc.compiler.urdf.from_urdf`, not yet read."""
    path: Path
    floating_base: object = False  # False, True (= "euler": body XYZ angles) or "quaternion"
    fold_parameters: bool = False
    mimic: bool = False
    gravity: float = 9.81
    limits: bool = True          # the file's joint limits, damping and friction act (False: ignored)
    contacts: tuple = ()        # ground contacts (eomc.compiler.contact.tree.ContactSpec or text)
    allow_nonphysical_inertia: bool = False
    all_inertial_parameters: bool = False   # every body's 10 inertial entries are parameters, the file's
                                            # zeros included (identification; examples/identify_arm.py)
    ground: bool = None         # the <collision> geometry touches the plane z = 0 (.collision); also
                                # contacts=["@ground"] / --ground.  None (the default): the other
                                # bodies' geometry does when contacts are named (_ground); False: never

    def __post_init__(self):
        from .tree import floating_base_type
        floating_base_type(self.floating_base)        # a bad value: a ModelError naming the choices

    def options(self):
        return dict(floating_base=self.floating_base, fold_parameters=self.fold_parameters,
                    mimic=self.mimic, gravity=self.gravity, limits=self.limits,
                    allow_nonphysical_inertia=self.allow_nonphysical_inertia,
                    all_inertial_parameters=self.all_inertial_parameters)


def is_urdf_path(model):
    return isinstance(model, (str, Path)) and Path(model).suffix.lower() == ".urdf"


def is_urdf_model(model):
    """A URDF path or a :class:`UrdfModel`."""
    return isinstance(model, UrdfModel) or is_urdf_path(model)


def urdf_overrides(system, formed, overrides, uses=()):
    """``overrides`` with a from_urdf System's parameter defaults and inputs filled in
    (``uses``: symbols an output reads beside the equations, whose defaults are kept too)."""
    built = getattr(system, "urdf", None)
    if built is None:
        return overrides
    return merged_defaults(overrides, formed, built.parameters, built.inputs, uses)


def read_model(model, poses=False):
    """The :class:`~eomc.compiler.multibody.model.Model` of a URDF file or :class:`UrdfModel`:
    the file parsed once (lxml), its links merged into the joint tree, every link a frame,
    and with ``poses`` the animation's bodies and visuals (eomc.runtime.urdf_scene read from
    the same parsed document).  Nothing after this reads the file."""
    from . import build_tree, read_urdf
    model = model if isinstance(model, UrdfModel) else UrdfModel(Path(model))
    robot = read_urdf(model.path)
    tree = build_tree(robot, floating_base=model.floating_base,
                      allow_nonphysical_inertia=model.allow_nonphysical_inertia)
    return model_of_robot(robot, tree, model, poses)


def model_of_robot(robot, tree, model, poses=False):
    """The Model of a URDF robot read (``robot``, eomc.compiler.urdf.reader) and merged into
    its link tree (``tree``) with ``model``'s options (see :func:`read_model`)."""
    from eomc.compiler.multibody.model import Frame, Provenance
    from eomc.compiler.multibody.formed import model_of_tree
    from . import system_from_tree
    from .tree import identifier
    from ..multibody.joints import snap
    from .treeir import pose_source, tree_ir
    mimics = [j.name for j in tree.joints if j.mimic is not None]
    refusal = (f"mimic joints ({', '.join(mimics[:5])}{', ...' if len(mimics) > 5 else ''}) are "
               f"constraints, which the URDF reader's tree does not carry") if model.mimic and mimics else None
    built = tree_ir(tree, fold=model.fold_parameters, gravity=model.gravity, laws=model.limits,
                    all_inertial=model.all_inertial_parameters)
    collisions = tuple(c for link in robot.links.values() for c in link.collisions)
    outputs, events = {}, {}
    named, ground = _ground(model)
    scene = []

    def welds():
        """The welded links' placements, from the document the reader parsed (made once)."""
        if not scene:
            from eomc.runtime.geometry import urdf_link_transforms
            from eomc.runtime.urdf_scene import load_scene
            loaded = load_scene(robot.path, robot.xml)
            scene.extend([loaded, urdf_link_transforms(tree, loaded)])
        return scene[1]
    if named:
        from eomc.compiler.contact.tree import with_contacts
        built, outputs, events = with_contacts(built, named, collisions, welds(), fold=model.fold_parameters)
    if ground:
        from eomc.compiler.contact.tree import expanded_specs
        built, more_outputs, more_events = _with_ground(
            built, model.fold_parameters, collisions, welds(), others=ground == "others",
            named=expanded_specs(named, collisions, robot.path) if named else ())
        outputs, events = {**outputs, **more_outputs}, {**events, **more_events}
    extra = {}
    if named or ground:        # a robot that touches the ground: which of it must stay above it
        from .collision import ground_check
        extra["ground_check"] = ground_check(built, collisions, welds())
    if poses:
        from eomc.runtime.geometry import urdf_visuals
        extra["welds"] = welds()
        extra["shapes"] = urdf_visuals(tree, scene[0])
        extra["poses"] = pose_source(built, extra["welds"], extra["shapes"])

    def mechanics():
        """The robot's SymPy System (Kane's formulation), from the tree read above."""
        made = system_from_tree(tree, fold=model.fold_parameters, mimic=model.mimic, gravity=model.gravity,
                                laws=model.limits, all_inertial=model.all_inertial_parameters)
        made.system.urdf = made.system.reading = made
        return made.system

    body_index = {j.child: k for k, j in enumerate(tree.joints)}
    frames = []
    for link, (owner, T) in _link_placements(robot, tree).items():
        rotation = tuple(tuple(snap(float(v)) for v in row) for row in T[:3, :3])
        if owner is None:
            frames.append(Frame(link, -1, rotation, tuple(snap(float(v)) for v in T[:3, 3]),
                                (identifier(link),)))
            continue
        s = identifier(owner)
        c = [_com_symbol(f"c{a}_{s}", v, built.parameters) for a, v in zip("xyz", tree.bodies[owner].com)]
        offset = tuple(snap(float(T[k, 3])) - c[k] for k in range(3))
        frames.append(Frame(link, body_index[owner], rotation, offset, (identifier(link),)))
    # a quaternion floating base starts upright (w = 1), not at the zero quaternion
    quaternion = {f"q_{identifier(j.name)}_qw": 1.0 for j in tree.joints if j.type == "floating_quaternion"}
    inside, moved = start_in_range(tree) if model.limits else ({}, [])
    if quaternion or inside:
        extra["initial_state"] = {**quaternion, **inside}
    if moved:
        extra["start_in_range"] = moved
    if tree.gimbal_locks:       # the run checks it did not pass one (runtime/diagnose.gimbal_passed)
        extra["gimbal_locks"] = tuple(tree.gimbal_locks)
    return model_of_tree(built.tree, Provenance("urdf", str(model.path), robot.line), frames=tuple(frames),
                         defaults=dict(built.parameters), joint_inputs=tuple(built.inputs), outputs=outputs,
                         events=events, mechanics=mechanics, refusal=refusal, frame_noun="link",
                         collisions=collisions, **extra)


START_INSIDE = 0.01     # how far inside its nearest limit a joint whose zero is outside starts
                        # (rad or m; at most this fraction of the range)


def start_in_range(tree):
    """({state: value}, [moved]): the zero pose projected into each joint's range, for the
    default start.

    Why: a URDF's zero pose need not be a pose the robot can take -- Go2's knees are 0.84 rad
    outside their ranges at q = 0, and a run started there throws 14.8 kJ into the limit
    springs at t = 0 (issue 29).  A joint whose range excludes 0 starts START_INSIDE inside
    its nearest bound (not on it: the limit law's onset is a kink a Jacobian test would see);
    the others stay at 0.  ``moved``: one dict per joint moved (joint, state, value, lower,
    upper), for the note that names them.  Only the default start: a caller's initial_state
    or x0 is never changed (merged_initial_state; it gets the runtime's outside-the-range
    warning instead)."""
    import math

    from .tree import identifier
    inside, moved = {}, []
    for j in tree.joints:
        if j.limit is None or j.type not in ("revolute", "prismatic"):
            continue
        lo, hi = (math.nan if v is None else float(v) for v in j.limit)   # a side may be absent
        lo = lo if math.isfinite(lo) else -math.inf
        hi = hi if math.isfinite(hi) else math.inf
        if lo > hi or lo <= 0.0 <= hi:
            continue
        margin = min(START_INSIDE, START_INSIDE * (hi - lo))
        value = lo + margin if lo > 0.0 else hi - margin
        state = f"q_{identifier(j.name)}"
        inside[state] = value
        moved.append(dict(joint=j.name, state=state, value=value, lower=lo, upper=hi))
    return inside, moved


def _com_symbol(name, value, parameters):
    """The mass-centre coordinate as the tree writes it: its parameter, or the literal
    (a zero, or any value when the parameters were folded)."""
    import sympy as sm
    from ..multibody.joints import snap
    symbol = sm.Symbol(name)
    return symbol if symbol in parameters else snap(float(value))


def _link_placements(robot, source):
    """{link: (body link or None for the ground, 4x4 pose in that body's link frame)} of every
    link of the robot (its merged tree ``source``, eomc.compiler.urdf.tree.Tree): a body's own
    link at the identity, links merged into it (welded, or below a joint locked at 0) through
    their joints' origins."""
    import numpy as np
    parent_joint = {j.child: j for j in robot.joints}
    out = {}
    moving_root = source.root in source.bodies
    for link in robot.links:
        chain, at = [], link
        while at not in out and at not in source.bodies and not (at == source.root and not moving_root):
            joint = parent_joint.get(at)
            if joint is None:     # not reached from the root (build_tree refused such files)
                break
            chain.append(joint)
            at = joint.parent
        if at in out:
            owner, T = out[at]
        elif at in source.bodies:
            owner, T = at, np.eye(4)
            out[at] = (owner, T)
        elif at == source.root:
            owner, T = None, np.eye(4)
            out[at] = (owner, T)
        else:
            continue
        for joint in reversed(chain):
            T = fo.matmul(T, joint.origin)
            out[joint.child] = (owner, T)
    return {link: out[link] for link in robot.links if link in out}


def urdf_formed(read, formulation, overrides, formed_system):
    """(FormedSystem or the Model itself, overrides with the URDF's defaults, System or None)
    of a URDF robot's :func:`read_model` under ``formulation`` (see the module docstring).

    ``formed_system(system, formulation)`` forms the robot's System when it takes that
    route (the caller's, :func:`eomc.compiler.model.spec.formed_system`: passed in so
    that the URDF package does not import the model layer that imports it)."""
    if formulation != "kane" and read.refusal is None:
        from eomc.compiler.contact.tree import merged_outputs, passive_contacts
        passive = passive_contacts(read)  # a passive robot with contacts or limits: its energy output
        if read.outputs or read.events or passive:
            overrides = merged_outputs(overrides, dict(read.outputs), dict(read.events), passive)
        values = _reader_start(merged_defaults(overrides, read, read.defaults, read.joint_inputs), read)
        if read.ground_check is not None:      # into the built model's metadata (runtime/ground_check.py)
            values = {**values, "ground_check": read.ground_check}
        return read, values, None
    if read.outputs or read.events:
        from eomc.runtime.errors import ModelError
        raise ModelError(f"{read.source.path}: ground contacts on a URDF robot are lowered by the recursive "
                         f"formulation only (formulation 'recursive' or 'auto'"
                         f"{'; mimic=True robots with mimic joints take Kane' if read.refusal else ''})")
    if formulation != "kane":
        warnings.warn(f"{read.source.path}: {read.refusal}: the robot goes through its SymPy System, whose "
                      f"constraints close the joint tree (formulation {formulation})", EomcWarning,
                      stacklevel=3)
    system = read.mechanics()
    formed = formed_system(system, formulation)
    overrides, energy = _kane_energy(read, system, overrides)
    values = _reader_start(urdf_overrides(system, formed, overrides, energy), read)
    return formed, values, system


def _kane_energy(read, system, overrides):
    """(``overrides`` with the ``energy`` output the recursive route gives the robot, its free
    symbols) on Kane's route: a robot with joint limits and no contact whose only loads are
    passive (:func:`~eomc.compiler.contact.tree.passive_contacts`) gets kinetic + gravity + the
    limits' springs (the reader's tree's ``joint_energy``, the recursive route's term) from its
    System, and NAME.json's "energy" says so as the recursive route's does (``energy_note``: the
    runtime's verdict reads "joint limits" in it).  Why: without it auto kept the recursive form
    of every such robot to keep the output and the run's energy verdict (select._kane_lacks),
    losing Kane's faster rhs on the double pendulum URDF and TwoDofs (1.13-1.26x); and a
    ``formulation="kane"`` build ran without the verdict.  Not for a mimic=True robot's
    constrained System (read.refusal: the recursive route has no form of it, and its limit laws
    act on the independent joints only), nor where the caller names an output ``energy``."""
    if read.refusal is not None or "energy" in (overrides.get("outputs") or {}):
        return overrides, ()
    from eomc.compiler.contact.tree import passive_contacts
    if not passive_contacts(read):
        return overrides, ()
    from eomc.compiler.tree.lower import energy_text
    stored = read.tree.joint_energy
    energy = system.urdf.energy() + (stored if stored is not None else 0)
    result = {**overrides, "outputs": {"energy": energy, **(overrides.get("outputs") or {})},
              "energy_note": energy_text(read.tree)}
    return result, energy.free_symbols


def _reader_start(values, read):
    """``values`` with the reader's default start under the caller's initial_state (a
    quaternion's w = 1; each joint whose range excludes 0 just inside it, start_in_range) and
    the joints that start moved and the caller did not give (``start_in_range``: the note and
    the DefaultStartWarning name them).  Both routes take it: the Kane route (formulation
    "kane", mimic=True robots) used to start Go2 at its zero pose, 0.84 rad outside its knees'
    ranges, where the recursive one starts inside them."""
    values = merged_initial_state(values, read)
    if read.gimbal_locks:       # both routes' metadata (runtime/diagnose.gimbal_passed)
        values = {**values, "gimbal_locks": list(read.gimbal_locks)}
    start = values.get("initial_state") or {}
    moved = [m for m in read.start_in_range if start.get(m["state"]) == m["value"]]   # not the caller's
    return {**values, "start_in_range": moved} if moved else values


GROUND = "@ground"      # contacts=[...] entry: the robot's <collision> geometry on the plane z = 0
NO_GROUND = "@no-ground"    # contacts=[...] entry: only the named contacts touch it (--no-ground)


def _ground(model):
    """(the named contact specs, "all" | "others" | None: which bodies' collision geometry
    touches the ground).

    "all": asked for (``ground=True``, ``@ground``, --ground).  "others", the default when
    contacts are named: the collision geometry of every body that carries no named contact
    meets the same ground, so a robot whose feet are its contacts does not pass its trunk and
    legs through the floor when it collapses (Go2 and Solo12 ended with their trunks 0.07 and
    0.24 m under it: issue 29).  The bodies with named contacts keep only those (Go2's calf
    mesh reaches within 8 mm of its foot's centre: it would stand on its shin).  None:
    ``ground=False``, ``@no-ground`` or --no-ground, or no contacts named."""
    from eomc.compiler.contact.tree import as_spec
    specs = [as_spec(c) for c in model.contacts]
    named = [s for s in specs if s.link not in (GROUND, NO_GROUND)]
    if model.ground or any(s.link == GROUND for s in specs):
        return named, "all"
    if model.ground is False or any(s.link == NO_GROUND for s in specs) or not named:
        return named, None
    return named, "others"


def _named_spheres(built):
    """{tree body index: [(centre in its link frame, radius)]} of the named contacts."""
    import numpy as np
    import sympy as sm
    from eomc.compiler.contact.tree import ContactLoad, body_com
    values = {**built.parameters}
    out = {}
    for ld in built.tree.loads:
        if isinstance(ld, ContactLoad):
            body = built.tree.bodies[ld.body]
            source = {b.name: b for b in built.source.bodies.values()}.get(body.name)
            com = body_com(built, body.name, getattr(source, "com", (0.0, 0.0, 0.0)))
            centre = [float(sm.sympify(ld.offset[k] + com[k]).xreplace(values)) for k in range(3)]
            radius = float(sm.sympify(ld.params["r"]).xreplace(values))
            out.setdefault(ld.body, []).append((np.array(centre), radius))
    return out


def _with_ground(built, fold, collisions, placements, others=False, named=()):
    """(built, outputs, events) with the <collision> shapes on the ground (.collision):
    ``collisions`` and ``placements`` as the reader found them; ``others``: the default ground
    beside the ``named`` contacts (ContactSpecs): their links' own geometry is theirs, the
    rest as bounding boxes, near the named spheres left to them (collision.collision_shapes)."""
    from eomc.compiler.contact.geometry import with_shapes
    from eomc.compiler.contact.tree import body_com
    from eomc.runtime.errors import ModelError
    from .collision import collision_shapes
    from .tree import identifier
    if others:
        shapes = collision_shapes(built, collisions, placements, skip={s.link for s in named}, boxes=True,
                                  near=_named_spheres(built))
        if not shapes:
            return built, {}, {}
    else:
        shapes = collision_shapes(built, collisions, placements)
    if not shapes:
        raise ModelError(f"{built.source.path}: a ground was asked for (--ground, ground=True), but no moving "
                         f"link has <collision> geometry")
    coms = {identifier(b.name): tuple(float(x) for x in b.com) for b in built.source.bodies.values()}
    return with_shapes(built, shapes, lambda i: body_com(built, built.tree.bodies[i].name,
                                                     coms.get(built.tree.bodies[i].name, (0.0, 0.0, 0.0))),
                       fold=fold)


def with_options(model, name=None, *, floating_base=False, allow_nonphysical_inertia=False, limits=True):
    """(model, name) for the driver: a URDF path with options becomes a :class:`UrdfModel`.

    The CLI's ``--floating-base``, ``--allow-nonphysical-inertia`` and ``--limits off`` land
    here (an MJCF path with ``--limits off`` is the CLI's own:
    :func:`eomc.cli.common.with_options`); without options the path goes through unchanged
    (the driver reads URDF paths itself).
    """
    given = {k: v for k, v in (("floating_base", floating_base),
                               ("allow_nonphysical_inertia", allow_nonphysical_inertia)) if v}
    if not limits:
        given["limits"] = False
    if not given:
        return model, name
    if not is_urdf_path(model):
        from eomc.runtime.errors import ModelError
        flags = " and ".join("--limits off" if k == "limits" else "--" + k.replace("_", "-") for k in given)
        raise ModelError(f"{flags} applies to URDF robots (.urdf){' and MJCF models' if given == {'limits': False} else ''}, "
                         f"not to {model}")
    from eomc.compiler.emit.layout import sanitize_name
    return UrdfModel(Path(model), **given), name or sanitize_name(Path(model).stem)


def load_urdf_model(path, **options):
    """The System of the URDF file ``path`` (``options`` as :func:`eomc.compiler.urdf.from_urdf`)."""
    from . import from_urdf
    return from_urdf(path, **options)
