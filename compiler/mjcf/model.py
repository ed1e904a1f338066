"""MJCF files as eomc models: MuJoCo compiles the file, we check it fits a rigid-body tree.

``eomc.compile("model.xml")`` and ``eomc build model.xml`` land here through
:func:`eomc.compiler.model.model_spec`.  MuJoCo (the optional extra
``eomc[mujoco]``) reads the file with its defaults and classes applied; what
its model holds that an open-chain rigid-body tree with joint-space forces
cannot express is refused with the element named (file:line where the tag is
found in the file), or dropped with a warning when the caller names it in
``ignore``.  MuJoCo's own contacts are off (ground contacts: ``contacts=``,
:mod:`eomc.compiler.contact`).  Joint range limits
(soft, see :mod:`eomc.compiler.tree.joint_laws`) and ``frictionloss``
(regularised Coulomb friction, not MuJoCo's constraint) act unless
``limits=False`` (or ``ignore`` names ``"limits"`` / ``"frictionloss"``).
"""
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sm

from eomc.runtime.errors import BuildNote, EomcWarning, ModelError, ModelFileError
from eomc.compiler import fixed_order as fo

__all__ = ["MjcfModel", "is_mjcf_path", "is_mjcf_model", "load_mjmodel", "check_model", "mjcf_formed",
           "IGNORABLE", "with_ignore"]

IGNORABLE = ("tendons", "equality", "actuators", "armature", "frictionloss", "limits", "fluid", "plugins")


@dataclass(frozen=True)
class MjcfModel:
    """An MJCF file with options, not yet read."""
    path: Path
    ignore: tuple = ()
    fold_parameters: bool = False
    contacts: tuple = ()        # ground contacts on bodies (eomc.compiler.contact.tree)
    limits: bool = True          # range limits and frictionloss act (False: both ignored)
    # the file's collision geoms touch its ground planes as MuJoCo collides them (mjcf/collision.py):
    # None = yes unless ``contacts`` names contacts without "@collision"; True/False = yes/no
    geoms: bool = None
    # body–body contacts between the file's geoms (mjcf/collision.body_pairs), when its geoms are
    # contacts: None (the default) or True = every pair MuJoCo's filters let through (contype/conaffinity,
    # parent-child), self-collisions within one tree included; "trees" = only between different
    # kinematic trees (and the world's geoms) and the file's <pair>s; False = none
    pairs: object = None
    # how ball and free joints turn: "quaternion" (the default: MuJoCo's own (w, x, y, z), a
    # MuJoCo user's qpos layout; the integrators keep it unit) or "euler" (body-XYZ angles,
    # singular at pitch +-90 deg)
    orientation: str = "quaternion"

    def __post_init__(self):
        if self.pairs not in (None, True, False, "trees"):
            raise ModelError(f"{self.path}: pairs={self.pairs!r}: choose None/True (every pair MuJoCo "
                             f"collides), 'trees' (none within one tree) or False (none)")
        if self.orientation not in ("euler", "quaternion"):
            raise ModelError(f"{self.path}: orientation={self.orientation!r}: choose 'euler' (body XYZ "
                             f"angles) or 'quaternion'")


def is_mjcf_path(model):
    return isinstance(model, (str, Path)) and Path(model).suffix.lower() in (".xml", ".mjcf")


def is_mjcf_model(model):
    return isinstance(model, MjcfModel) or is_mjcf_path(model)


def with_ignore(model, name=None, ignore=(), limits=True, orientation=None, pairs=None):
    """(model, name) for the driver: an MJCF path with ``ignore`` (the CLI's ``--ignore
    WHAT[,WHAT]``: a string or a sequence), ``limits=False`` (``--limits off``),
    ``orientation="euler"`` (``--orientation euler``) or ``pairs`` "trees"/False
    (``--pairs trees|none``) becomes an :class:`MjcfModel`; without them the model goes through
    unchanged (the driver then reads the path as ``MjcfModel(path)``: its defaults decide)."""
    if isinstance(ignore, str):
        ignore = [ignore]
    items = tuple(x.strip() for text in (ignore or ()) for x in text.split(",") if x.strip())
    if items and not is_mjcf_path(model):
        raise ModelError(f"--ignore applies to MuJoCo models (.xml), not to {model}")
    orientation = orientation or MjcfModel.orientation
    if not items and ((limits and orientation == MjcfModel.orientation and pairs is None)
                      or not is_mjcf_path(model)):
        return model, name
    _known(items)
    from eomc.compiler.emit.layout import sanitize_name
    return (MjcfModel(Path(model), ignore=items, limits=limits, orientation=orientation, pairs=pairs),
            name or sanitize_name(Path(model).stem))


def load_mjmodel(path):
    """MuJoCo's compiled model of the file ``path``; its errors as a ModelFileError."""
    try:
        import mujoco
    except ImportError:
        raise ModelError(f"{path}: MJCF models are read by MuJoCo's compiler: install the mujoco extra "
                          "(pip install '.[mujoco]' in eomc's clone)") \
            from None
    from .files import check_files
    check_files(path)           # a FIFO or device as the file, an <include> or an asset: refused unopened
    if not Path(path).is_file():
        raise ModelFileError("no such file", str(path))
    # MuJoCo's warnings go to a MUJOCO_LOG.TXT in the working directory by default: ours instead
    previous, messages = mujoco.get_mju_user_warning(), []
    mujoco.set_mju_user_warning(messages.append)
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        from .files import locate_mujoco_error
        file, line = locate_mujoco_error(path, str(exc))
        text = str(exc).strip() if line is None else re.sub(r", line 0\b", "", str(exc).strip())
        raise ModelFileError(f"MuJoCo could not compile the model: {text}", file, line) from None
    finally:
        mujoco.set_mju_user_warning(previous)
    for message in messages:
        # a deprecation is about the file, nothing to act on in a run: a BuildNote, said when the
        # model is built and not on every later command (first hour s27: gymnasium's and
        # dm_control's half_cheetah repeated MuJoCo's settotalmass deprecation, 260 characters,
        # as a warning on every simulate, animate, check and report)
        category = BuildNote if "deprecated" in message else EomcWarning
        warnings.warn(f"{path}: MuJoCo: {message}", category, stacklevel=3)
    return model


def _where(path, tag, name=None):
    """(file, line) of the element: in the main file or an ``<include>``d one (.files.locate)."""
    from .files import locate
    return locate(path, tag, name)


def _name(m, kind, i, prefix):
    import mujoco
    return mujoco.mj_id2name(m, kind, i) or f"{prefix} #{i}"


def _known(ignore):
    unknown = [x for x in ignore if x not in IGNORABLE]
    if unknown:
        raise ModelError(f"ignore {', '.join(map(str, unknown))}: unknown; what may be ignored: "
                         f"{', '.join(IGNORABLE)}")


def check_model(m, path, ignore=()):
    """The actuator ids to drive as inputs; raises ModelFileError on what the tree cannot express
    unless ``ignore`` names it (then warns).  ``m`` is changed where ignoring needs it: its
    ``dof_armature`` is zeroed when ``"armature"`` is ignored (the tree reads it from ``m``)."""
    import mujoco
    _known(ignore)
    path = str(path)
    if "armature" in ignore and np.any(m.dof_armature):
        warnings.warn(f"{path}: ignored: armature on {int(np.count_nonzero(m.dof_armature))} dof(s) "
                      f"(MuJoCo adds it to the joint-space inertia)", EomcWarning, stacklevel=3)
        m.dof_armature[:] = 0
    problems = []   # (ignore key, tag, message[, element name])
    J = mujoco.mjtObj.mjOBJ_JOINT
    # fixed tendons (joint coefficients) act as joint-space forces (.tendon); a spatial one (sites,
    # wrapping) acts only through its stiffness, damping, friction, armature, limits and the actuators
    # on it: one with none of these changes nothing here
    from .tendon import is_fixed
    zero = np.zeros(m.ntendon)
    armature = [t for t in range(m.ntendon) if getattr(m, "tendon_armature", zero)[t]]
    from .spatial import is_site_tendon
    spatial = [t for t in range(m.ntendon) if not is_fixed(m, t) and not is_site_tendon(m, t) and (
        m.tendon_stiffness[t] or m.tendon_damping[t] or m.tendon_frictionloss[t] or m.tendon_limited[t]
        or any(int(m.actuator_trntype[k]) == int(mujoco.mjtTrn.mjTRN_TENDON) and int(m.actuator_trnid[k, 0]) == t
               for k in range(m.nu)))]
    for t, why in [(t, "armature (an inertia along the tendon)") for t in armature] + \
                  [(t, "a spatial tendon that wraps around geoms or has a pulley: fixed tendons and spatial "
                       "ones through sites only are modelled") for t in spatial]:
        tn = _name(m, mujoco.mjtObj.mjOBJ_TENDON, t, 'tendon')
        problems.append(("tendons", "tendon", f"tendon {tn}: {why}", tn))
        break
    if "tendons" in ignore and m.ntendon:
        acting = [t for t in range(m.ntendon) if m.tendon_stiffness[t] or m.tendon_damping[t]
                  or m.tendon_frictionloss[t] or m.tendon_limited[t]]
        if acting:
            warnings.warn(f"{path}: ignored: {len(acting)} tendon(s) with stiffness, damping, friction or limits "
                          f"(e.g. {_name(m, mujoco.mjtObj.mjOBJ_TENDON, acting[0], 'tendon')})", EomcWarning,
                          stacklevel=3)
        m.tendon_stiffness[:] = 0
        m.tendon_damping[:] = 0
        m.tendon_frictionloss[:] = 0
        m.tendon_limited[:] = 0
    from .options import disabled
    if not {"equality", "constraint"} & disabled(m):     # <flag equality="disable"/>: none acts
        problems += _equality_problems(m, path, ignore)
    if m.nplugin:
        problems.append(("plugins", "plugin", f"{m.nplugin} plugin(s)"))
    if m.nflex:
        problems.append(("", "flex", f"{m.nflex} flex(es): deformable bodies"))
    if m.nmocap:
        problems.append(("", "body", f"{m.nmocap} mocap body(ies): moved by the user, not by dynamics"))
    if np.any(m.body_gravcomp):
        b = int(np.flatnonzero(m.body_gravcomp)[0])
        problems.append(("", "body", f"body {_name(m, mujoco.mjtObj.mjOBJ_BODY, b, 'body')}: gravcomp"))
    for j in range(m.njnt):
        jn = _name(m, J, j, "joint")
        kind, d = int(m.jnt_type[j]), int(m.jnt_dofadr[j])
        ndof = {0: 6, 1: 3, 2: 1, 3: 1}[kind]
        if np.any(m.dof_armature[d:d + ndof] < 0):
            raise ModelFileError(f"<joint>: joint {jn}: negative armature {min(m.dof_armature[d:d + ndof]):g}: "
                                 f"an inertia cannot be negative", *_where(path, "joint", jn))
        if kind == 0 and len(set(m.dof_armature[d:d + 3])) > 1:
            problems.append(("armature", "joint", f"joint {jn}: armature on a free joint's linear dofs "
                             f"differs between them ({', '.join(f'{x:g}' for x in m.dof_armature[d:d + 3])}; "
                             f"MuJoCo's are world-frame velocities, eomc's body-frame: only an equal one "
                             f"carries over)", jn))
        if np.any(m.dof_frictionloss[d:d + ndof]) and kind in (0, 1):
            problems.append(("frictionloss", "joint", f"joint {jn}: frictionloss on a {('free', 'ball')[kind]} "
                             f"joint (eomc models it on hinges and slides)", jn))
        if np.any(m.dof_frictionloss[d:d + ndof] < 0) or np.any(~np.isfinite(m.dof_frictionloss[d:d + ndof])):
            raise ModelFileError(f"<joint>: joint {jn}: frictionloss {m.dof_frictionloss[d]:g}: it must be a "
                                 f"finite number >= 0", *_where(path, "joint", jn))
        if m.jnt_limited[j] and kind in (2, 3) and (not np.all(np.isfinite(m.jnt_range[j]))
                                                    or m.jnt_range[j][0] > m.jnt_range[j][1]):
            raise ModelFileError(f"<joint>: joint {jn}: range {m.jnt_range[j][0]:g} {m.jnt_range[j][1]:g}: "
                                 f"lower must be <= upper, both finite", *_where(path, "joint", jn))
        if kind == 0 and int(m.body_parentid[m.jnt_bodyid[j]]) != 0:
            problems.append(("", "freejoint", f"joint {jn}: a free joint on a body that is not a child of "
                             f"the world"))
        if np.any(m.dof_damping[d:d + ndof] < 0) or m.jnt_stiffness[j] < 0:
            raise ModelFileError(f"<joint>: joint {jn}: negative damping or stiffness "
                                 f"({m.dof_damping[d]:g}, {m.jnt_stiffness[j]:g}): it would feed energy in",
                                 *_where(path, "joint", jn))
        if kind == 0 and int(m.body_jntnum[m.jnt_bodyid[j]]) > 1:
            problems.append(("", "freejoint", f"joint {jn}: a free joint with other joints on its body"))
        if kind in (0, 1) and m.jnt_stiffness[j]:
            problems.append(("", "joint", f"joint {jn}: stiffness on a {('free', 'ball')[kind]} joint"))
        if kind == 0 and np.any(m.dof_damping[d:d + 6]):
            problems.append(("", "joint", f"joint {jn}: damping on a free joint"))
        if m.jnt_limited[j] and kind in (0, 1) and "limits" not in ignore:
            warnings.warn(f"{path}: joint {jn}: range limits of {('free', 'ball')[kind]} joints are not "
                          f"modelled (hinges' and slides' are; ignore=('limits',) silences this)",
                          EomcWarning, stacklevel=4)
    motors = []
    for k in range(m.nu):
        an = _name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, k, "actuator")
        j = int(m.actuator_trnid[k, 0])
        why = None
        if int(m.actuator_trntype[k]) == int(mujoco.mjtTrn.mjTRN_TENDON):
            if not is_fixed(m, j):
                why = "its transmission is a spatial tendon (only fixed tendons drive actuators here)"
            elif "tendons" in ignore:
                why = "its transmission is a tendon, and tendons are ignored"
        elif int(m.actuator_trntype[k]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            why = "its transmission is not a joint or a fixed tendon"
        elif int(m.jnt_type[j]) not in (2, 3):
            why = "it drives a ball or free joint"
        if why:
            pass
        elif int(m.actuator_dyntype[k]) not in (0, 1, 2, 3):
            why = "it has muscle or user-defined activation dynamics (dyntype; integrator and filter are modelled)"
        elif int(m.actuator_dyntype[k]) != 0 and (m.actuator_actlimited[k] or getattr(m, "actuator_actearly",
                                                                                     np.zeros(m.nu))[k]):
            why = "its activation is limited (actlimited) or acts early (actearly): not modelled"
        elif int(m.actuator_gaintype[k]) not in (0, 1) or int(m.actuator_biastype[k]) not in (0, 1):
            why = "its gain or bias is not fixed or affine (a muscle or a user-defined one)"
        if why:
            problems.append(("actuators", "actuator", f"actuator {an}: {why}", an))
        else:
            motors.append(k)
    for key, tag, message, *named in problems:
        if key and key in ignore:
            warnings.warn(f"{path}: ignored: {message}", EomcWarning, stacklevel=4)
            continue
        hint = f" (ignore=('{key}',), or --ignore {key} on the command line, drops it with a warning)" if key else ""
        raise ModelFileError(f"<{tag}>: {message}: a rigid-body tree cannot express it{hint}", 
                             *_where(path, tag, named[0] if named else None))
    return motors


_EQ_KINDS = {0: ("connect", "a ball-joint loop closure between bodies"),
             1: ("weld", "a weld between bodies"), 3: ("tendon", "a tendon coupling"),
             4: ("flex", "a flex constraint"), 5: ("flexvert", "a flex constraint"),
             6: ("flexstrain", "a flex constraint"), 7: ("distance", "a distance constraint")}


def _equality_problems(m, path, ignore):
    """Joint couplings (``<equality><joint>``) become holonomic constraints on the tree
    (:mod:`.equality`); every other equality kind is a problem (ignorable, element named),
    and a coupling that cannot be one is an error with its line (``ignore`` drops the other
    kinds, never a coupling: it is modelled).  Inactive couplings
    (``active="false"``: MuJoCo starts without them) are left out with a warning."""
    import mujoco
    from .equality import couplings
    out = []
    for e in range(m.neq):
        name = _name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e, "equality")
        kind = int(m.eq_type[e])
        if kind in (int(mujoco.mjtEq.mjEQ_JOINT), int(mujoco.mjtEq.mjEQ_TENDON)):
            if not m.eq_active0[e]:
                warnings.warn(f"{path}: equality {name}: inactive (active=\"false\"): left out (MuJoCo "
                              f"starts without it; eomc cannot switch it on later)", EomcWarning, stacklevel=4)
            continue
        tag, what = _EQ_KINDS.get(kind, (f"type {kind}", "an equality constraint"))
        out.append(("equality", tag, f"equality {name}: <{tag}> is {what}: only joint couplings "
                    f"(<joint joint1 joint2 polycoef>) and couplings of fixed tendons (<tendon>) are modelled", None if name.startswith("equality #")
                    else name))
    try:
        found = couplings(m)
    except ValueError as exc:
        named = re.match(r"equality (\S+):", str(exc))
        raise ModelFileError(f"<equality><joint>: {exc}",
                             *_where(path, "equality", named.group(1) if named else None)) from None
    try:
        from .equality import tendon_couplings
        tendon_couplings(m, [j1 for _, j1, _ in found])
    except ValueError as exc:      # the <tendon> element of the equality's name first (dm_control names them so)
        named = re.match(r"equality (\S+):", str(exc))
        raise ModelFileError(f"<equality><tendon>: {exc}", *_where(path, "tendon", named.group(1) if named else None)) \
            from None
    return out


def read_model(model, poses=False):
    """The :class:`~eomc.compiler.multibody.model.Model` of an MJCF file or :class:`MjcfModel`:
    MuJoCo's compiler run once, its model checked and read into the joint tree, every
    MuJoCo body a frame, qpos0 the initial state, and with ``poses`` the animation's bodies
    and geoms.  Nothing after this reads the file."""
    import mujoco
    from eomc.compiler.multibody.model import Frame, Provenance
    from eomc.compiler.multibody.formed import model_of_tree
    from .treeir import _names, tree_ir
    model = model if isinstance(model, MjcfModel) else MjcfModel(Path(model))
    _known(model.ignore)
    m = load_mjmodel(model.path)
    from .options import apply_flags
    limits_flag, friction_flag, actuation = apply_flags(m, model.path, _where)     # <option><flag>: on eomc's copy of m
    motors = check_model(m, model.path, model.ignore)
    if not actuation and motors:
        warnings.warn(f"{model.path}: <flag actuation=\"disable\"/>: the {len(motors)} actuator(s) are left out "
                      f"(MuJoCo applies no actuator force; the model has no inputs)", EomcWarning, stacklevel=3)
        motors = []
    from eomc.compiler.tree.joint_laws import JointLawError
    try:
        built = tree_ir(m, fold=model.fold_parameters, actuators=motors,
                        limits=model.limits and limits_flag and "limits" not in model.ignore,
                        friction=model.limits and friction_flag and "frictionloss" not in model.ignore,
                        quaternion=model.orientation == "quaternion")
    except JointLawError as exc:     # the numbers of a joint's limit or friction: its line
        raise ModelFileError(f"<joint>: {exc}", *_where(model.path, "joint", exc.joint)) \
            from None
    limit_laws = built.limit_laws
    if "fluid" not in model.ignore:
        from .fluid import with_fluid
        built = with_fluid(built, m, fold=model.fold_parameters)     # <option density viscosity wind>
    if "tendons" not in model.ignore:       # spatial tendons through sites (ball_in_cup's string)
        from .spatial import with_site_tendons
        built = with_site_tendons(built, m, fold=model.fold_parameters,
                                  limits=model.limits and limits_flag and "limits" not in model.ignore,
                                  friction=model.limits and friction_flag and "frictionloss" not in model.ignore)
    built, outputs, events = _with_contacts(model, m, built)
    extra = {}
    if getattr(built, "pair_check", None):      # runtime/pair_check.py: pairs that passed into each other
        extra["pair_check"] = built.pair_check
    if poses:
        from .poses import mjcf_pose_source
        extra["poses"] = mjcf_pose_source(built, m)
    index = {b.name: i for i, b in enumerate(built.tree.bodies)}
    frames = []
    for b, (raw, s) in enumerate(_names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody, "body")):
        if b == 0:        # the world body
            frames.append(Frame(raw, -1, _IDENTITY, (0, 0, 0), (s,)))
            continue
        # the tree body carrying the MuJoCo body's mass sits at its mass centre body_ipos
        c = [_com_symbol(f"c{a}_{s}", v, built.parameters) for a, v in zip("xyz", m.body_ipos[b])]
        frames.append(Frame(raw, index[s], _IDENTITY, tuple(-x for x in c), (s,)))
    frames += _site_frames(m, frames)
    read = model_of_tree(built.tree, Provenance("mjcf", str(model.path)), frames=tuple(frames),
                         defaults=dict(built.parameters), joint_inputs=tuple(built.inputs),
                         frame_noun="body or site", outputs=outputs, events=events, initial_state=reference_state(m, built),
                         timestep=float(m.opt.timestep), limit_laws=limit_laws or None,
                         kane_refusal="an MJCF model has the recursive formulation only: MuJoCo's model is "
                                      "read straight into the joint tree, with no SymPy System to form "
                                      "Kane's equations of", **extra)
    return _with_activations(read, getattr(built, "activations", ()))


def _with_activations(read, activations):
    """The Model with the actuators' activation states (MuJoCo's ``act``, after q and u, in
    actuator order; zero at the start as in mj_resetData) as extra first-order states: taken out
    of the inputs the tree's loads made of them, the controls and time constants that only their
    rates name added."""
    if not activations:
        return read
    import dataclasses
    acts = tuple(a for a, _ in activations)
    rates = tuple(r for _, r in activations)
    inputs = set(read.inputs) - set(acts)
    params = set(read.parameters)
    t = sm.Symbol("t")
    from sympy.core.function import AppliedUndef
    for r in rates:
        inputs |= {a for a in r.atoms(AppliedUndef) if a not in set(acts) and a.args == (t,)}
        params |= {s for s in r.free_symbols if s != t}
    return dataclasses.replace(read, extra_states=acts, extra_rhs=rates,
                               inputs=tuple(sorted(inputs, key=str)),
                               parameters=tuple(sorted(params, key=lambda s: s.name)))


_IDENTITY = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def _site_frames(m, body_frames):
    """A Frame per named ``<site>`` (MuJoCo's ``site_xpos``/``site_xmat``): the site's body's
    frame (``body_frames``, in MuJoCo's body order) moved by ``site_pos`` and turned by
    ``site_quat``.  Sites are where models mark tools, sensors and feet; MuJoCo keeps their names
    apart from the bodies', so a site named like a body is left to the body (``--frame NAME`` is the
    body's frame, as it was before sites were frames: no build changes its outputs' meaning)."""
    import mujoco
    from eomc.compiler.multibody.joints import identifier, snap
    from eomc.compiler.multibody.model import Frame
    from .treeir import quat_matrix
    taken = {f.name for f in body_frames} | {a for f in body_frames for a in f.aliases}
    out = []
    for i in range(m.nsite):
        raw = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, i)
        if not raw:
            continue                 # an unnamed site cannot be asked for
        if raw in taken:
            continue
        body = body_frames[int(m.site_bodyid[i])]
        assert body.rotation == _IDENTITY        # a body's frame has the MuJoCo body's axes
        rotation = tuple(tuple(snap(float(v)) for v in row) for row in quat_matrix(m.site_quat[i]))
        offset = tuple(o + snap(float(v)) for o, v in zip(body.offset, m.site_pos[i]))
        alias = identifier(raw)
        out.append(Frame(raw, body.body, rotation, offset, () if alias == raw or alias in taken else (alias,)))
        taken |= {raw, alias}
    return out


def _com_symbol(name, value, parameters):
    """A mass-centre coordinate as the tree writes it: its parameter, or the literal."""
    from eomc.compiler.multibody.joints import snap
    symbol = sm.Symbol(name)
    return symbol if symbol in parameters else snap(float(value))


def mjcf_formed(read, overrides):
    """(the Model, overrides with the model's parameter defaults, inputs, contact outputs and
    initial state) of an MJCF model's :func:`read_model`."""
    from eomc.compiler.contact.tree import merged_outputs, passive_contacts
    from eomc.compiler.multibody.model import merged_defaults
    passive = passive_contacts(read)      # a passive model with contacts or limits: its energy output
    if read.outputs or read.events or passive:
        overrides = merged_outputs(overrides, dict(read.outputs), dict(read.events), passive)
    values = merged_defaults(overrides, read, read.defaults, read.joint_inputs)
    if values.get("initial_state") is None:
        values["initial_state"] = dict(read.initial_state)
    elif getattr(read.tree, "quaternions", ()):
        from eomc.compiler.multibody.model import merged_initial_state
        values = merged_initial_state(values, read)     # the quaternions' start under the caller's
    values["timestep"] = read.timestep       # into the built model's metadata (model.timestep)
    if read.limit_laws:                      # ... and the limits' shapes (runtime/limit_energy.py)
        values["limit_laws"] = read.limit_laws
    if read.pair_check:                      # ... and the pairs' shapes (runtime/pair_check.py)
        values["pair_check"] = read.pair_check
    return read, values


def _with_contacts(model, m, built):
    """(built, outputs, events) with the ground contacts: the ones ``model.contacts`` names (spheres
    on bodies), and the file's collision geoms against its ground planes (:mod:`.collision`) unless
    contacts are named without ``"@collision"`` (or ``"@none"``: no contacts), or ``geoms`` says."""
    from eomc.compiler.contact.tree import COLLISION_SPHERES, as_spec
    from .contacts import with_mjcf_contacts
    specs = [as_spec(c) for c in model.contacts]
    named = [s for s in specs if s.link not in (COLLISION_SPHERES, "@none", "@ground", "@no-ground")]
    geoms = model.geoms
    if geoms is None:
        geoms = not specs or any(s.link in (COLLISION_SPHERES, "@ground") for s in specs)
    outputs, events = {}, {}
    if named:
        built, outputs, events = with_mjcf_contacts(built, m, named, fold=model.fold_parameters)
    if geoms:
        from eomc.compiler.contact.geometry import with_shapes
        from eomc.compiler.contact.tree import body_com
        from .collision import ground_geoms
        found = ground_geoms(m, model.path)
        if found:
            built, more_outputs, more_events = with_shapes(built, _shapes(built, found), lambda i: body_com(
                built, built.tree.bodies[i].name, built.owners[i][1]), fold=model.fold_parameters)
            outputs, events = {**outputs, **more_outputs}, {**events, **more_events}
        if model.pairs is not False:
            built, more_outputs, more_events = _with_pairs(model, m, built)
            outputs, events = {**outputs, **more_outputs}, {**events, **more_events}
    return built, outputs, events


def _with_pairs(model, m, built):
    """``built`` with the body–body contacts MuJoCo's filters let through (:func:`.collision.body_pairs`);
    pairs of kinds eomc does not model are named in one warning.

    Self-collisions within one tree are in by default, as MuJoCo collides them (a model behaves like
    itself without flags; gymnasium's humanoid rests at MuJoCo's height with them, 22 mm higher
    without).  Their number grows as the square of a tree's geoms (the humanoid: 109), so they go
    through one table-driven C loop (compiler/contact/pairs.PAIR_TABLE, the default): the humanoid's
    rhs 1.98x its no-contact rhs, rhs-only build 8.1 s CPU against 6.4 s without them, default
    function set 24.5 against 19.4 s (benchmarks/results/pair_default_build.md).  ``pairs="trees"``
    (``--pairs trees``) leaves them out; ``pairs=False`` (``--pairs none``) every body–body pair."""
    import mujoco
    from eomc.compiler.contact.pairs import PairShape, PairSpec, with_pairs
    from eomc.compiler.contact.tree import body_com
    from .collision import body_pairs
    from .treeir import quat_matrix
    found, skipped = body_pairs(m, model.path)
    if model.pairs == "trees":        # asked for: no self-collisions, so no warning
        found = [p for p in found if not p.same_tree or p.explicit]
    if skipped:
        text = "; ".join(f"{n} {kinds} pair(s) (e.g. {example})" for kinds, (n, example) in sorted(skipped.items()))
        warnings.warn(f"{Path(model.path).name}: no contact for {text}: they pass through each other (eomc "
                      f"models pairs of spheres, capsules, boxes and cylinders, and an ellipsoid with anything but a cylinder; "
                      f"no meshes)",
                      EomcWarning, stacklevel=4)
    if not found:
        return built, {}, {}
    tree_body = {owner[0]: i for i, owner in enumerate(built.owners) if owner is not None}
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)

    def shape(g):
        b = int(m.geom_bodyid[g])
        kind = {2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box"}[int(m.geom_type[g])]
        size = tuple(float(x) for x in m.geom_size[g])
        if int(m.body_weldid[b]) == 0:           # static: where it is in the world
            return PairShape(-1, kind, size, tuple(float(x) for x in d.geom_xpos[g]),
                             tuple(tuple(float(x) for x in row) for row in np.array(d.geom_xmat[g]).reshape(3, 3)))
        i = tree_body[b]
        com = body_com(built, built.tree.bodies[i].name, built.owners[i][1])
        offset = tuple((sm.Float(float(p), 17) if p else sm.S.Zero) - c for p, c in zip(m.geom_pos[g], com))
        rot = tuple(tuple(float(x) for x in row) for row in quat_matrix(m.geom_quat[g]))
        return PairShape(i, kind, size, offset, rot)
    specs = [PairSpec(p.name, shape(p.geoms[0]), shape(p.geoms[1]), p.k, p.c, p.mu, margin=p.margin, mut=p.mut,
                      mur=p.mur, rho=p.rho) for p in found]
    built, outputs, events = with_pairs(built, specs, fold=model.fold_parameters)
    built.pair_check = _pair_check(m, d, found, built, tree_body)
    return built, outputs, events


def _pair_check(m, d, found, built, tree_body):
    """NAME.json's ``pair_check`` (runtime/pair_check.py: the run's verdict on two shapes that
    passed into each other, a depth measure independent of the pair's law): per pair its name and,
    per geom, its name, kind, MuJoCo size, and where it sits -- in its MuJoCo body's frame (the
    poses' frame of that name: ``geom_pos``/``geom_quat``), or in the world for a static geom."""
    import mujoco
    from .collision import GEOM_KINDS, _geom_name
    from .treeir import quat_matrix
    out = []
    for p in found:
        shapes = []
        for g in p.geoms:
            b = int(m.geom_bodyid[g])
            static = int(m.body_weldid[b]) == 0
            pos = d.geom_xpos[g] if static else m.geom_pos[g]
            rot = np.array(d.geom_xmat[g]).reshape(3, 3) if static else quat_matrix(m.geom_quat[g])
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            shapes.append({"geom": _geom_name(m, g), "body": body,
                           "frame": None if static else built.tree.bodies[tree_body[b]].name,
                           "kind": GEOM_KINDS.get(int(m.geom_type[g])), "size": [float(x) for x in m.geom_size[g]],
                           "pos": [float(x) for x in pos], "rot": [float(x) for x in np.ravel(rot)]})
        out.append({"name": p.name, "shapes": shapes})
    return {"pairs": out}


def _shapes(built, found):
    """The contact shapes (eomc.compiler.contact.geometry.Shape) of MuJoCo's ground geoms."""
    from eomc.compiler.contact.geometry import Shape
    tree_body = {owner[0]: i for i, owner in enumerate(built.owners) if owner is not None}
    return [Shape(name=g.name, body=tree_body[g.body], kind=g.kind, size=g.size, pos=g.pos, rot=g.rot,
                  normal=g.normal, height=g.height, k=g.k, c=g.c, mu=g.mu, vertices=g.vertices,
                  where=f"geom {g.name}", mut=g.mut, mur=g.mur, rho=g.rho, margin=g.margin) for g in found]


def _xyz_angles(R):
    """Body-XYZ angles (R = Rx Ry Rz, eomc's ball and free joints) of a rotation matrix."""
    return (float(np.arctan2(-R[1, 2], R[2, 2])), float(np.arcsin(np.clip(R[0, 2], -1.0, 1.0))),
            float(np.arctan2(-R[0, 1], R[0, 0])))


def _unit(quat):
    """MuJoCo's quaternion (w, x, y, z) scaled to length 1, as floats."""
    q = np.asarray(quat, dtype=float)
    return [float(v) for v in q / fo.norm(q)]


def reference_state(m, built):
    """{coordinate name: value}: MuJoCo's qpos0 (where mj_resetData starts: hinge/slide ``ref``, a
    free body where the file puts it) in eomc's coordinates, with each joint coupling's joint1
    put on its coupling (qpos0 need not satisfy a polycoef's p0: eomc's constraint is exact,
    so the start must be on it); speeds zero.  Zeros are left out."""
    from .equality import coupled_qpos
    from .treeir import quat_matrix
    out = {}
    qpos0 = coupled_qpos(m)
    for j, kind, iq, _ in built.joints:
        a = int(m.jnt_qposadr[j])
        quaternion = kind in (0, 1) and iq + (3 if kind == 0 else 0) in built.tree.quaternions
        if kind in (2, 3):
            values = [float(qpos0[a])]
        elif kind == 1:
            values = (_unit(m.qpos0[a:a + 4]) if quaternion else
                      list(_xyz_angles(quat_matrix(m.qpos0[a:a + 4]))))
        else:
            values = [float(x) for x in m.qpos0[a:a + 3]] + (
                _unit(m.qpos0[a + 3:a + 7]) if quaternion else list(_xyz_angles(quat_matrix(m.qpos0[a + 3:a + 7]))))
        for k, v in enumerate(values):
            if v != 0.0:
                out[str(built.coordinates[iq + k]).replace("(t)", "")] = v
    return out
