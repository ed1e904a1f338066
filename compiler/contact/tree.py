"""Ground contacts on the links of a robot read into the joint tree (URDF).

One job: put contact spheres on tree bodies and lower them into the recursion.

- :class:`ContactSpec` is what a user names: a link, a point in the link frame, a
  radius and the law's parameters (``contacts=[...]`` of :func:`eomc.compile`,
  ``--contact LINK[:x,y,z[:radius]]`` on the command line).
- :func:`with_contacts` turns them into :class:`ContactLoad` entries of the Tree (the
  body, the point from the body's origin, the parameters ``k_<name>``, ...) plus the
  model's contact outputs and events, written as placeholders :class:`ContactValue`.
- :func:`eomc.compiler.tree.contacts.lower_contacts` lowers them into the recursion (the
  bodies placed along the tree by :mod:`eomc.compiler.tree.placement`, the law of
  :mod:`.law`); the placeholders become the recursion's temporaries.
"""
from dataclasses import dataclass, field

import sympy as sm

from eomc.runtime.errors import ModelError

from .law import DEFAULTS, SPIN_KEYS, load_stiffness
from .system import contact_symbols, parameter_defaults, unit_normal
from eomc.compiler import fixed_order as fo

__all__ = ["ContactSpec", "ContactLoad", "ContactValue", "ENERGY", "ENERGY_IMPLICIT", "passive_contacts", "energy_blockers", "limited_joints", "COLLISION_SPHERES", "parse_contact",
           "collision_spheres", "link_frame", "with_contacts", "contact_outputs", "body_com",
           "LoweredLoad", "nearest", "with_located", "expanded_specs", "built_weight"]

# what each contact adds to the outputs (placeholders' kind index) and its event
OUTPUT_KINDS = ("Fn", "Ftx", "Fty", "Ftz", "depth")
CLIP_KIND = len(OUTPUT_KINDS)      # the clip_<name> event's kind (contact/law.clip_switch), no output


@dataclass(frozen=True)
class ContactSpec:
    """A contact sphere on ``link``: centre ``point`` (link frame), law parameters as
    :func:`eomc.contact.ground` (None: the defaults of :data:`.law.DEFAULTS`)."""
    link: str
    point: tuple = (0.0, 0.0, 0.0)
    radius: float = None
    name: str = None
    k: float = None
    c: float = None
    mu: float = None
    vs: float = None
    restitution: float = None
    impact_speed: float = None
    normal: tuple = (0.0, 0.0, 1.0)
    height: float = 0.0


def parse_contact(text):
    """``LINK[:x,y,z[:radius]]`` (the command line's --contact) -> ContactSpec."""
    parts = str(text).split(":")
    if not parts[0] or len(parts) > 3:
        raise ValueError(f"--contact {text!r}: expected LINK[:x,y,z[:radius]]")
    point = (0.0, 0.0, 0.0)
    if len(parts) > 1:
        try:
            point = tuple(float(v) for v in parts[1].split(","))
        except ValueError:
            point = ()
        if len(point) != 3:
            raise ValueError(f"--contact {text!r}: the point must be three numbers x,y,z") from None
    radius = None
    if len(parts) > 2:
        try:
            radius = float(parts[2])
        except ValueError:
            raise ValueError(f"--contact {text!r}: the radius must be a number") from None
    return ContactSpec(parts[0], point, radius)


COLLISION_SPHERES = "@collision"     # contacts=[...] entry: every <collision><sphere> of the URDF


def collision_spheres(collisions, path):
    """[ContactSpec] of every ``<collision>`` whose geometry is a ``<sphere>`` among the reader's
    ``collisions`` (eomc.compiler.multibody.Collision records, in file order; ``path``: the
    file, for messages): on its link, centred at the collision's origin, of its radius; named
    ``<link>`` (``<link>_<k>`` for the k-th sphere of a link that has several)."""
    from eomc.runtime.geometry import identifier
    by_link = {}
    for col in collisions:
        if col.geometry != "sphere":
            continue
        try:
            radius = float(col.attribute("radius"))
        except (TypeError, ValueError):
            raise ModelError(f"{path}:{col.geometry_line}: link {col.frame!r}: a collision "
                             f"sphere with a bad radius or origin") from None
        point = tuple(float(v) for v in (row[3] for row in col.origin[:3]))
        by_link.setdefault(col.frame, []).append((point, radius))
    out = []
    for link, spheres in by_link.items():
        for k, (point, radius) in enumerate(spheres):
            name = identifier(link) + (f"_{k}" if len(spheres) > 1 else "")
            out.append(ContactSpec(link, point, radius, name=name))
    return out


def expanded_specs(specs, collisions, path):
    out = []
    for spec in specs:
        if spec.link == COLLISION_SPHERES:
            found = collision_spheres(collisions, path)
            if not found:
                raise ModelError(f"{path}: contacts {COLLISION_SPHERES}: the robot has no "
                                 f"<collision> with a <sphere> geometry; name the contact links instead")
            out += found
        else:
            out.append(spec)
    return out


def as_spec(item):
    """A ContactSpec of a link name, 'LINK:x,y,z:radius', '@collision', a dict or a ContactSpec."""
    if isinstance(item, ContactSpec):
        return item
    if isinstance(item, str):
        return ContactSpec(COLLISION_SPHERES) if item == COLLISION_SPHERES else parse_contact(item)
    if isinstance(item, dict):
        try:
            return ContactSpec(**item)
        except TypeError as exc:
            raise ValueError(f"contact {item!r}: {exc}") from None
    raise ValueError(f"a contact is a link name, 'LINK:x,y,z:radius', a dict or an "
                     f"eomc.contact.ContactSpec, not {item!r}")


class ContactValue(sm.Function):
    """Placeholder for a contact's computed quantity in outputs and events:
    ContactValue(contact index, kind index into OUTPUT_KINDS); replaced by the
    recursion's temporaries in :func:`eomc.compiler.tree.contacts.lower_contacts`."""
    nargs = 2

    def _eval_derivative(self, s):       # never differentiated before it is replaced
        return sm.S.Zero


@dataclass(frozen=True, kw_only=True)
class LoweredLoad:
    """A load of the Tree that computes its force itself when the recursion is lowered
    (``lower(bodies, rec, v, rename, placement)``, eomc.compiler.tree.contacts): MJCF fluid
    forces, body-body contact pairs, site tendons.  ``frame == "contact"`` keeps it out of the
    plain loads, whose moment, force and offset it has as zeros."""
    frame: str = "contact"
    moment: sm.Matrix = field(default_factory=lambda: sm.zeros(3, 1))
    force: sm.Matrix = field(default_factory=lambda: sm.zeros(3, 1))
    offset: sm.Matrix = field(default_factory=lambda: sm.zeros(3, 1))


@dataclass(frozen=True)
class ContactLoad:
    """A contact in the Tree's loads: no force of its own until it is lowered
    (:func:`eomc.compiler.tree.contacts.lower_contacts`)."""
    body: int
    name: str
    offset: sm.Matrix                  # sphere centre from the body origin, body frame
    params: dict                       # "k", "c", "mu", "vs", "r" -> Symbol (or literal if folded);
    #                                    with torsional/rolling friction also "mut" and/or "mur", and
    #                                    "rho" (a number): .law.spin_moment
    normal: tuple                      # unit, world
    height: object
    frame: str = "contact"
    moment: sm.Matrix = field(default_factory=lambda: sm.zeros(3, 1))
    force: sm.Matrix = field(default_factory=lambda: sm.zeros(3, 1))
    # an ellipsoid's A = R diag(a²) Rᵀ (body frame, 3x3 rows): the point is its support point
    # in the plane's normal, found at each call (eomc.compiler.contact.geometry); else None
    shape: tuple = None
    # how far ``height`` lies above the plane's surface (an MJCF pair's margin: MuJoCo's force
    # acts from there): drawn, not computed with, so not in ``exprs`` (the C has it in height)
    margin: float = 0.0

    @property
    def exprs(self):
        """Everything that defines it, for the generation cache's key (tree_exprs)."""
        more = [x for row in self.shape for x in row] if self.shape is not None else []
        # a torsional/rolling friction's parameters (law.spin_moment), only where it has them
        keys = SPIN_KEYS + ("rho",)
        spin = [x for j, k in enumerate(keys) if k in self.params for x in (sm.Integer(-1 - j), self.params[k])]
        return ([sm.Integer(self.body)] + list(self.offset)
                + [self.params[k] for k in DEFAULTS] + list(self.normal) + [self.height] + more + spin)


def link_frame(source, link, placements):
    """(body key or "world", 4x4 pose of ``link`` in that body's frame), or None if no such link.
    ``source``: the URDF's merged tree (eomc.compiler.urdf.tree.Tree); ``placements``: the
    welded links' poses the reader found ({link: (body key or "world", 4x4)},
    eomc.runtime.geometry.urdf_link_transforms of the document it parsed)."""
    import numpy as np
    from eomc.runtime.geometry import identifier
    for b in source.bodies.values():
        if b.name == link:
            return identifier(b.name), np.eye(4)
    members = {name for b in source.bodies.values() for name in b.links} | set(source.ground_links)
    if link not in members and link != source.root:
        return None
    return placements.get(link)


def _all_links(source):
    return sorted({name for b in source.bodies.values() for name in b.links} | set(source.ground_links)
                  | {source.root})


def with_contacts(built, contacts, collisions, placements, fold=False):
    """(UrdfTree with the contacts in its tree's loads and their parameters, outputs, events).

    ``built``: eomc.compiler.urdf.treeir.UrdfTree; ``collisions`` and ``placements``: what the
    reader found (see :func:`collision_spheres`, :func:`link_frame`).  Errors name the
    contact and link."""
    import numpy as np
    from eomc.runtime.geometry import identifier
    specs = expanded_specs([as_spec(c) for c in contacts], collisions, built.source.path)
    by_body = {b.name: i for i, b in enumerate(built.tree.bodies)}
    bodies_by_key = {identifier(b.name): b for b in built.source.bodies.values()}
    known = _all_links(built.source)

    def locate(spec, point):
        link = spec.link
        found = link_frame(built.source, link, placements)
        if found is None:
            parts = [part.strip() for part in link.split(",")]
            if len(parts) > 1 and all(link_frame(built.source, part, placements) is not None for part in parts):
                # `--contact FL_foot,FR_foot`: a list where one link was meant (the commas belong to
                # the centre x,y,z); say how to ask for several instead of "no such link"
                raise ModelError(f"contact on link {link!r}: one link per --contact; for several, repeat it: "
                                 + " ".join(f"--contact {part}" for part in parts))
            raise ModelError(f"contact on link {link!r}: the robot has no such link{nearest(link, known)} "
                             f"(links: {', '.join(known[:12])}{', ...' if len(known) > 12 else ''})")
        body_link, T = found
        if body_link == "world":
            raise ModelError(f"contact on link {link!r}: the link is welded to the ground, "
                             f"so it cannot touch it")
        i = by_body.get(body_link)
        if i is None:
            raise ModelError(f"contact on link {link!r}: its body {body_link!r} does not move "
                             f"(locked or welded), so it is not in the tree")
        T = np.asarray(T, dtype=float)
        source = bodies_by_key.get(body_link)
        com = getattr(source, "com", (0.0, 0.0, 0.0)) if source is not None else (0.0, 0.0, 0.0)
        return i, fo.matmul(T[:3, :3], point) + T[:3, 3], com     # point in the body's first link frame
    weight = built_weight(built)
    return with_located(built, specs, locate, fold, "link", identifier, weight)


def built_weight(built):
    """The robot's weight m g (N) from its bodies' masses (URDF: the merged tree's) and its
    gravity (the tree's gravity vector, 0 without gravity)."""
    import math
    try:
        mass = sum(float(getattr(b, "mass", 0.0) or 0.0) for b in built.source.bodies.values())
        g = math.sqrt(sum(float(x) ** 2 for x in built.tree.gravity.xreplace(built.parameters)))
    except (AttributeError, TypeError, ValueError):
        return 0.0
    return mass * g


def nearest(name, known):
    """"; did you mean X?" for a misspelt link or body name (a contact is named before the build)."""
    import difflib
    near = difflib.get_close_matches(name, list(known), n=2, cutoff=0.6)
    return f"; did you mean {', '.join(near)}?" if near else ""


def with_located(built, specs, locate, fold, what, identifier, weight=0.0):
    """The common part of a reader's contacts: checks, parameters, ContactLoads, outputs and events.
    ``locate(spec, point)`` -> (tree body index, point in its frame (numpy), its mass centre);
    ``weight``: the robot's weight (N) its contacts share, for the default stiffness
    (law.load_stiffness; 0: the plain default)."""
    import dataclasses
    import numpy as np
    tree = built.tree
    names = set()
    loads, outputs, events = list(tree.loads), {}, {}
    parameters = dict(built.parameters)
    for j, spec in enumerate(specs):
        link = spec.link
        name = spec.name or identifier(link)
        try:
            k = spec.k
            if k is None and weight > 0 and spec.radius:
                k = load_stiffness(weight, len(specs), float(spec.radius))
            values = parameter_defaults(name, k, spec.c, spec.mu, spec.vs, spec.radius,
                                        spec.restitution, spec.impact_speed, where=f"{what} {link}")
            n = unit_normal(spec.normal, name)
            point = [float(x) for x in spec.point]
            height = float(spec.height)
            if len(point) != 3 or not all(np.isfinite(point + [height])):
                raise ValueError(f"contact {name!r}: point and height must be finite numbers")
        except (ValueError, TypeError) as exc:
            raise ModelError(str(exc)) from None
        i, p_body, com_values = locate(spec, point)
        if not name.isidentifier() or name in names:
            raise ModelError(f"contact name {name!r} on {what} {link!r} is "
                             + ("used twice" if name in names else "not an identifier"))
        names.add(name)
        com = body_com(built, tree.bodies[i].name, com_values)
        offset = sm.Matrix([sm.Float(p_body[r], 17) - com[r] for r in range(3)])
        syms = contact_symbols(name)
        if fold:
            params = {k: sm.Float(values[k], 17) for k in syms}
        else:
            params = dict(syms)
            for key, symbol in syms.items():
                if symbol in parameters:
                    raise ModelError(f"contact {name!r}: its parameter {symbol} is already a "
                                     f"parameter of the model; name the contact differently")
                parameters[symbol] = values[key]
        loads.append(ContactLoad(i, name, offset, params, tuple(n),
                                 sm.Float(height, 17) if height else sm.S.Zero))
        for kind, label in enumerate(OUTPUT_KINDS):
            outputs[f"{label}_{name}"] = ContactValue(j, kind)
        events[f"contact_{name}"] = ContactValue(j, OUTPUT_KINDS.index("depth"))
        events[f"clip_{name}"] = ContactValue(j, CLIP_KIND)
    new_tree = dataclasses.replace(tree, loads=tuple(loads))
    new = type(built).__new__(type(built))
    new.__dict__.update(built.__dict__)
    new.tree, new.parameters = new_tree, parameters
    return new, outputs, events


# The placeholder of the ``energy`` output of a passive tree with ground contacts (lowered
# by eomc.compiler.tree.contacts.lower_contacts): kinetic + gravity + the contacts' elastic energy.
ENERGY = ContactValue(-1, -1)
# NAME_implicit's energy slot (compiler/tree/lower.implicit_layout) where a pairs' table holds
# body-body pairs: the energy with the table's points' elastic energy summed by its slopes loop
# (contact/table.Table.energy_at; compiler/tree/contacts.lower_contacts)
ENERGY_IMPLICIT = ContactValue(-1, -2)
# parameters of the joint laws that only take energy out (damping, friction) or store it past a
# limit only (compiler/tree/joint_laws.NAMES; MJCF's damping d_<joint>)
PASSIVE_LAWS = ("d_", "damping_", "friction_", "limit_")


def passive_contacts(read):
    """True for a robot (a multibody Model read from a file) with ground contacts or joint
    limits whose only loads are those, body-body pairs whose elastic energy the ``energy``
    output holds, springs whose potential it holds (joints', fixed tendons', servos' bias) and
    dissipative laws (damping, friction, fluid forces with no wind): with its inputs (joint torques, actuators) at zero
    nothing feeds energy in, so its total energy may only fall, and the runtime judges such
    runs by it (runtime/switching.verdict, issue 29).  :func:`energy_blockers` says why not."""
    return not energy_blockers(read)


def energy_blockers(read):
    """[why the model gets no ``energy`` output] (empty: it gets one, :func:`passive_contacts`):
    neither a ground contact nor a joint limit (nothing the runtime judges a run by); a spring
    the energy does not hold (a ``k_``/``q0_`` parameter that Tree.spring_parameters does not
    list: a site tendon's, a SymPy model's); a load this check does not know to be passive (a
    servo with a clamped bias, an activation a zero control moves from 0, fluid forces in a wind,
    a site tendon); a
    body-body pair whose force is not the gradient of its depth's energy (none since session 19:
    .pairs.counted_kinds).  Counted: the ground contacts' and the
    other pairs' elastic energy, joint, fixed-tendon and servo-bias springs, URDF limit
    springs; passive without a term: damping, friction, MJCF limits (runtime/limit_energy.py
    sizes a start past one), fluid forces with no wind (mjcf/fluid.py: dissipative)."""
    tree = getattr(read, "tree", None)
    loads = getattr(tree, "loads", ())
    names = {str(s) for s in getattr(read, "parameters", ())}
    # the springs whose potential the energy holds (Tree.spring_energy: MJCF's joints' k_/q0_<joint>,
    # fixed tendons' k_/L0_tendon_<name>)
    counted = set(getattr(tree, "spring_parameters", ()) or ())
    out = []
    if not any(isinstance(ld, ContactLoad) for ld in loads) and not limited_joints(read):
        # nothing the runtime judges a run by (runtime/switching.find_switches: the ground
        # contacts' events, the joint limits' limit_lo_/limit_hi_<joint> of a coordinate q_<joint>)
        out.append("no ground contact and no joint limit")
    # a spring the energy does not hold (a joint's stiffness with its rest q0_<joint>, a
    # tendon's k_<tendon>): its start energy could come out as a gain, so no energy verdict
    springs = sorted(n for n in names - counted
                     if n.startswith("q0_") or (n.startswith("k_") and "mu_" + n[2:] not in names))
    if springs:
        out.append(f"springs whose potential the energy leaves out ({', '.join(springs[:3])}"
                   f"{', ...' if len(springs) > 3 else ''})")
    zero = {r: sm.S.Zero for r in tuple(getattr(read, "inputs", ()) or ())}
    # the actuators' activation states (MJCF's act_<actuator>, the Model's extra states): a run
    # is judged only from a start with every one at 0 (runtime/switching.energy_verdict), where
    # a zero control keeps it when its rate vanishes there -- act' = (clamp(ctrl) - act)/τ or
    # clamp(ctrl), so a control range holding 0; then the actuators push with their bias only
    acts = tuple(getattr(read, "extra_states", ()) or ())
    rest = {**zero, **{a: sm.S.Zero for a in acts}}
    for a, rate in zip(acts, tuple(getattr(read, "extra_rhs", ()) or ())):
        if sm.sympify(rate).xreplace(rest) != 0:
            out.append(f"the activation {getattr(a, 'func', a)} moves from 0 at zero control "
                       f"(its rate there: {sm.sympify(rate).xreplace(rest)})")
    zero = rest

    def passive(load):
        """The parameters that make ``load`` a possible source ([]: passive): with the inputs at
        zero (an actuator's torque vanishes), only the joint laws' damping, friction and limits
        act (compiler/tree/joint_laws.py; MJCF's d_<joint>) and the counted springs (a servo's
        bias among them, mjcf/treeir._actuator_force; with its activation at 0): no other spring,
        no servo with a clamped bias, nothing else this check does not know."""
        found = set()
        for x in list(load.moment) + list(load.force):
            e = sm.sympify(x).xreplace(zero)
            found |= {s.name for s in e.free_symbols
                      if s.name != "t" and not s.name.startswith(PASSIVE_LAWS) and s.name not in counted}
        return sorted(found)
    sources = set()
    for ld in loads:
        if isinstance(ld, ContactLoad):
            continue
        stores = getattr(ld, "stores_energy", None)     # a body-body pair (.pairs.PairLoad)
        if stores is not None:
            if not stores:
                out.append(f"the contact {ld.name} ({ld.a.kind}-{ld.b.kind}: its force is not the gradient of "
                           f"the energy counted, pairs.counted_kinds)")
        elif getattr(ld, "passive_fluid", None) is not None:     # MJCF's fluid forces (mjcf/fluid.py)
            if not ld.passive_fluid:
                out.append(f"{type(ld).__name__} {ld.name} (fluid forces that are not provably "
                           f"dissipative: {ld.why_not_passive})")
        elif getattr(ld, "frame", None) == "contact":
            out.append(f"{type(ld).__name__} {getattr(ld, 'name', '')}".rstrip())
        else:
            sources.update(passive(ld))
    if sources:
        names = sorted(sources)
        out.append(f"loads that may push energy in with the inputs at zero (their parameters "
                   f"{', '.join(names[:4])}{', ...' if len(names) > 4 else ''}: a servo with a clamped "
                   f"bias or whose control range holds no 0, an uncounted spring)")
    return out


def limited_joints(read):
    """[joint] whose limit the runtime judges (its ``limit_lo_``/``limit_hi_<joint>`` parameter on
    a coordinate ``q_<joint>``: runtime/switching.find_switches finds them so)."""
    tree = getattr(read, "tree", None)
    coordinates = {getattr(getattr(q, "func", q), "__name__", str(q))
                   for q in getattr(tree, "coordinates", ()) or ()}
    out = []
    for s in getattr(read, "parameters", ()):
        name = str(s)
        for side in ("limit_lo_", "limit_hi_"):
            if name.startswith(side) and "q_" + name[len(side):] in coordinates \
                    and name[len(side):] not in out:
                out.append(name[len(side):])
    return out


def merged_outputs(overrides, outputs, events, energy=False):
    """``overrides`` (the model_spec keyword arguments) with the contacts' outputs and
    events added after the caller's own (whose names win); ``energy``: with the ``energy``
    output (:data:`ENERGY`) unless the caller names an output so."""
    result = dict(overrides)
    given = overrides.get("outputs") or {}
    if energy and "energy" not in given and "energy" not in outputs:
        outputs = {**outputs, "energy": ENERGY}
    result["outputs"] = {**outputs, **given}
    given = overrides.get("events")
    if given is not False and (events or given is not None):   # a model with no events of its own: none added
        result["events"] = {**events, **(given or {})}
    return result


def body_com(built, body_name, values):
    """The body origin (its mass centre) in its frame, as the tree writes it: the parameters
    cx_/cy_/cz_<body> where they are symbols, else the literal ``values``."""
    # a Symbol's str is its name (str through the printer cost the humanoid's 218 pair shapes ~0.25 s)
    by_name = {s.name if type(s) is sm.Symbol else str(s): s for s in built.parameters}
    out = []
    for axis, value in zip(("cx", "cy", "cz"), values):
        symbol = by_name.get(f"{axis}_{body_name}")
        out.append(symbol if symbol is not None else (sm.Float(float(value), 17) if value else sm.S.Zero))
    return out


def contact_outputs(tree):
    return [ld for ld in tree.loads if isinstance(ld, ContactLoad)]
