"""Which geoms of an MJCF model touch the ground, and with which contact law: MuJoCo's own rules.

One job: from the compiled ``MjModel``, the list of :class:`GroundGeom` -- a geom on a
moving body that MuJoCo would collide with a plane fixed in the world -- with the
parameters of eomc's smooth law (:mod:`eomc.compiler.contact.law`) chosen so that the
contact behaves as MuJoCo's does.  The geometry (which points of the geom can touch)
is :mod:`eomc.compiler.contact.geometry`'s job.

MuJoCo's filters (``mj_collision``), applied as MuJoCo applies them:

- dynamic pairs (unless ``<flag contact="disable"/>``): the plane's and the geom's bodies
  are not welded to one body; not parent and child of each other (both welds not the
  world, unless ``<flag filterparent="disable"/>``); the pair not named in
  ``<contact><exclude>``; ``(contype1 & conaffinity2) || (contype2 & conaffinity1)``;
- explicit ``<contact><pair>``: always, with the pair's own parameters (a dynamic pair of
  the same two geoms is replaced by it).

The parameters of two geoms are mixed as ``mj_contactParam`` mixes them: the higher
``priority`` wins, else friction and ``condim`` are the larger, ``solref``/``solimp`` the
``solmix``-weighted mean (a direct, negative ``solref``: the smaller); ``margin`` is the sum of
the two geoms' (MuJoCo's ``mjContact.includemargin``).

The mapping to eomc's law, per geom (the *documented rule*; the README quotes it):

- δ_ref, MuJoCo's resting penetration of a contact: at rest its soft constraint holds
  d·k·r = (1 - d)·g (acceleration space: the same for any mass) with MuJoCo's
  k = d(r)/(dmax·tc·z)² (``solref`` = (tc, z), tc at least 2 time steps unless
  ``refsafe`` is disabled; a negative ``solref`` gives k = -solref[0]/dmax² directly) and
  d(r) the ``solimp`` impedance at penetration r: the fixed point of
  r = (1 - d(r))·g/(d(r)·k(r)), g = |gravity| (9.81 without gravity).
- stiffness k = W/δ_ref^1.5 with W = g·(mass of the geom's kinematic tree: what rests on it
  when it alone carries the robot), so that geom rests at MuJoCo's depth.
- damping c = 2·z·ω/(1.5·g), ω = sqrt(1.5·g/δ_ref): the linearised law at rest has the
  damping ratio z of ``solref`` (z = b/(2·sqrt(k)) for a direct ``solref``).
- friction coefficient mu = the sliding friction (``friction[0]``); 0 when ``condim`` = 1.
- condim 4 and 6 against a plane: torsional (``friction[1]``) and, for 6, rolling
  (``friction[2]``) friction, moments bounded by coefficient x normal force as MuJoCo bounds them
  (:func:`~eomc.compiler.contact.mujoco_law.spin_parameters`, law.spin_moment), regularised at
  ω_s = v_s/ρ, ρ the geom's bounding radius (``geom_rbound``; a body-body pair's: the smaller of
  the two geoms').
- ``margin``: MuJoCo's constraint acts at distance < ``margin`` with its reference there
  (``aref = -b·v - k·imp·(dist - includemargin)``, ``includemargin`` = the margin), so the plane
  is raised by ``margin`` for that geom.  ``gap``: MuJoCo (4.0, as installed) detects contacts
  out to ``margin + gap`` but leaves those at distance >= ``margin`` out of the constraint
  (``mjContact.exclude``: recorded for the user, no force); no force depends on it, so there is
  nothing to map (test_collision.test_gap_changes_no_force holds MuJoCo to this: a MuJoCo
  whose ``includemargin`` were ``margin - gap`` would fail it).
- vs (the friction's regularisation speed): eomc's default, 0.01 m/s: MuJoCo's friction is
  a soft constraint with no such speed.
"""
import warnings
from dataclasses import dataclass

import numpy as np

from eomc.runtime.errors import EomcWarning

from ..contact.mujoco_law import MINVAL, law_parameters, resting_depth, spin_parameters  # noqa: F401 -- this module's rule, public here
from eomc.compiler import fixed_order as fo

__all__ = ["GroundGeom", "ground_geoms", "law_parameters", "resting_depth", "GEOM_KINDS"]

GEOM_KINDS = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box",
              7: "mesh", 8: "sdf"}
TOUCHING = ("sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh")


@dataclass(frozen=True)
class GroundGeom:
    """A geom that touches a ground plane: what :mod:`eomc.compiler.contact.geometry` needs."""
    geom: int                  # MuJoCo geom id
    body: int                  # MuJoCo body id (a moving one)
    name: str                  # the geom's name (or <body>_geom<id>): names parameters and outputs
    kind: str                  # one of TOUCHING
    size: tuple                # MuJoCo's geom_size
    pos: tuple                 # geom frame in the body frame: origin ...
    rot: tuple                 # ... and rotation (3x3, rows), geom -> body components
    vertices: tuple            # a mesh's vertices (geom frame), else ()
    normal: tuple              # the plane's unit normal (world)
    height: float              # n·x of the plane, raised by the margin
    k: float
    c: float
    mu: float
    plane: str                 # the plane geom's name
    mut: float = None          # torsional friction (condim 4, 6), m; None: none
    mur: float = None          # rolling friction (condim 6), m; None: none
    rho: float = None          # their regularisation length (the geom's bounding radius), m
    margin: float = 0.0        # the pair's margin, in height: the animation draws the plane below it


def _mix(m, g1, g2):
    """(condim, friction, solref, solimp) of a dynamic pair, as mj_contactParam mixes them."""
    p1, p2 = int(m.geom_priority[g1]), int(m.geom_priority[g2])
    if p1 != p2:
        top = g1 if p1 > p2 else g2
        return (int(m.geom_condim[top]), np.array(m.geom_friction[top]), np.array(m.geom_solref[top]),
                np.array(m.geom_solimp[top]))
    s1, s2 = float(m.geom_solmix[g1]), float(m.geom_solmix[g2])
    if s1 >= MINVAL and s2 >= MINVAL:
        mix = s1 / (s1 + s2)
    elif s1 < MINVAL and s2 < MINVAL:
        mix = 0.5
    else:
        mix = 0.0 if s1 < MINVAL else 1.0
    r1, r2 = np.array(m.geom_solref[g1]), np.array(m.geom_solref[g2])
    solref = mix * r1 + (1 - mix) * r2 if r1[0] > 0 and r2[0] > 0 else np.minimum(r1, r2)
    solimp = mix * np.array(m.geom_solimp[g1]) + (1 - mix) * np.array(m.geom_solimp[g2])
    friction = np.maximum(m.geom_friction[g1], m.geom_friction[g2])
    return max(int(m.geom_condim[g1]), int(m.geom_condim[g2])), friction, solref, solimp


def _excluded(m):
    return {int(s) for s in m.exclude_signature[:m.nexclude]}


def _filtered(m, g1, g2, excluded, filterparent):
    """True when MuJoCo's dynamic collision leaves the pair (g1, g2) out."""
    b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
    w1, w2 = int(m.body_weldid[b1]), int(m.body_weldid[b2])
    if w1 == w2:
        return True
    wp1, wp2 = int(m.body_weldid[m.body_parentid[w1]]), int(m.body_weldid[m.body_parentid[w2]])
    if filterparent and w1 != 0 and w2 != 0 and (w1 == wp2 or w2 == wp1):
        return True
    lo, hi = min(b1, b2), max(b1, b2)
    if ((lo << 16) + hi) in excluded:
        return True
    return not ((int(m.geom_contype[g1]) & int(m.geom_conaffinity[g2]))
                or (int(m.geom_contype[g2]) & int(m.geom_conaffinity[g1])))


def _geom_name(m, g):
    import mujoco
    from eomc.compiler.multibody.joints import identifier
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
    if name:
        return identifier(name)
    body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) or f"body{int(m.geom_bodyid[g])}"
    return f"{identifier(body)}_geom{g}"


def _rows(R):
    return tuple(tuple(float(x) for x in row) for row in np.asarray(R).reshape(3, 3))


def ground_geoms(m, path=None):
    """[GroundGeom]: every (geom, ground plane) pair MuJoCo would collide (module docstring).

    Height fields and SDF geoms on moving bodies have no contact here: left out with a
    warning naming them (MuJoCo allows planes on static bodies only).  A height field in the
    world that a moving geom can touch is a plane at its top when its elevation data are all
    equal (dm_control's quadruped's terrain before a task fills it; its finite extent is not
    kept: MuJoCo's planes are infinite too, its hfield is not); with varying elevation it is
    refused (ModelFileError at the geom's line)."""
    import mujoco
    from .treeir import quat_matrix
    where = f"{path}: " if path else ""
    if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT):
        return []
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)          # static planes' world frames
    weld = m.body_weldid
    planes = [g for g in range(m.ngeom) if GEOM_KINDS.get(int(m.geom_type[g])) == "plane"]  # static: MuJoCo's rule
    excluded = _excluded(m)
    filterparent = not (m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    surface = {}          # a flat height field: the height of its top in its own frame
    for g in range(m.ngeom):
        if GEOM_KINDS.get(int(m.geom_type[g])) != "hfield" or int(weld[int(m.geom_bodyid[g])]) != 0:
            continue
        touching = [o for o in range(m.ngeom) if o != g and int(weld[int(m.geom_bodyid[o])]) != 0
                    and not _filtered(m, g, o, excluded, filterparent)]
        touching += [int(m.pair_geom2[q]) if int(m.pair_geom1[q]) == g else int(m.pair_geom1[q])
                     for q in range(m.npair) if g in (int(m.pair_geom1[q]), int(m.pair_geom2[q]))]
        if not touching:
            continue
        h = int(m.geom_dataid[g])
        adr, count = int(m.hfield_adr[h]), int(m.hfield_nrow[h]) * int(m.hfield_ncol[h])
        data = np.asarray(m.hfield_data[adr:adr + count], dtype=float)
        if count and np.ptp(data) == 0.0:      # flat: its top is a plane (MuJoCo's elevation = size[2]·data)
            surface[g] = float(m.hfield_size[h][2]) * float(data[0])
            planes.append(g)
            continue
        from eomc.runtime.errors import ModelFileError
        from .files import locate
        raw = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
        raise ModelFileError(f"<geom>: geom {raw or f'#{g}'}: a height field (hfield) with varying elevation, "
                             f"which geom {_geom_name(m, touching[0])} can touch: eomc has no contact with a height "
                             f"field's terrain (a flat one is a plane; contype=\"0\" conaffinity=\"0\" on it leaves it "
                             f"out)", *(locate(path, "geom", raw) if path else (None, None)))
    g_mag = fo.norm(m.opt.gravity) or 9.81
    timestep = None if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE) else float(m.opt.timestep)
    pairs = {}
    for q in range(m.npair):                # explicit pairs first: they replace dynamic ones
        g1, g2 = int(m.pair_geom1[q]), int(m.pair_geom2[q])
        plane, other = (g1, g2) if g1 in planes else (g2, g1) if g2 in planes else (None, None)
        if plane is None:
            continue
        five = np.array(m.pair_friction[q])        # slide, slide, torsion, roll, roll -> slide, torsion, roll
        pairs[(plane, other)] = (int(m.pair_dim[q]), five[[0, 2, 3]], np.array(m.pair_solref[q]),
                                 np.array(m.pair_solimp[q]), float(m.pair_margin[q]))
    for plane in planes:
        for g in range(m.ngeom):
            if g == plane or (plane, g) in pairs or _filtered(m, plane, g, excluded, filterparent):
                continue
            condim, friction, solref, solimp = _mix(m, plane, g)
            pairs[(plane, g)] = (condim, friction, solref, solimp,
                                 float(m.geom_margin[plane]) + float(m.geom_margin[g]))
    out, skipped = [], set()
    for (plane, g), (condim, friction, solref, solimp, margin) in sorted(pairs.items(), key=lambda x: x[0][::-1]):
        kind = GEOM_KINDS.get(int(m.geom_type[g]), str(int(m.geom_type[g])))
        b = int(m.geom_bodyid[g])
        if int(weld[b]) == 0:
            continue                         # welded to the world: it never moves
        if kind not in TOUCHING:
            if g not in skipped:
                skipped.add(g)
                warnings.warn(f"{where}geom {_geom_name(m, g)} ({kind}) on a moving body: eomc has no contact "
                              f"for a {kind} against a plane; it passes through the ground", EomcWarning,
                              stacklevel=3)
            continue
        n = np.array(d.geom_xmat[plane]).reshape(3, 3)[:, 2]
        height = fo.dot(n, d.geom_xpos[plane]) + surface.get(plane, 0.0) + margin
        weight = g_mag * float(m.body_subtreemass[int(m.body_rootid[b])])
        k, c, mu = law_parameters(solref, solimp, friction, condim, g_mag, weight, timestep)
        mut, mur = spin_parameters(friction, condim)
        verts = ()
        if kind == "mesh":
            mesh = int(m.geom_dataid[g])
            a, nv = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            verts = tuple(tuple(float(x) for x in v) for v in m.mesh_vert[a:a + nv])
        name = _geom_name(m, g)
        if len(planes) > 1:
            name = f"{name}_{_geom_name(m, plane)}"
        out.append(GroundGeom(geom=g, body=b, name=name, kind=kind, size=tuple(float(x) for x in m.geom_size[g]),
                              pos=tuple(float(x) for x in m.geom_pos[g]), rot=_rows(quat_matrix(m.geom_quat[g])),
                              vertices=verts, normal=tuple(float(x) for x in n), height=height, k=k, c=c, mu=mu,
                              plane=_geom_name(m, plane), mut=mut, mur=mur,
                              rho=float(m.geom_rbound[g]) if mut is not None else None, margin=margin))
    return out


@dataclass(frozen=True)
class BodyPair:
    """Two geoms MuJoCo would collide that are not a plane (see :func:`body_pairs`)."""
    geoms: tuple               # (g1, g2) MuJoCo geom ids; g1 may be static (a world geom)
    name: str
    kinds: tuple
    k: float
    c: float
    mu: float
    margin: float
    explicit: bool = False     # a <contact><pair> of the file
    same_tree: bool = False    # both geoms in one kinematic tree (a self-collision)
    mut: float = None          # torsional friction (condim 4, 6), m; None: none (GroundGeom's)
    mur: float = None          # rolling friction (condim 6), m
    rho: float = None          # their regularisation length: the smaller geom's bounding radius


def body_pairs(m, path=None):
    """([BodyPair] of every pair of non-plane geoms MuJoCo would collide, at least one of them on a
    moving body, whose kinds eomc models (eomc.compiler.contact.pairs.PAIR_KINDS); the pairs left
    out for their kinds as {"kind-kind": (count, example name)}).

    The filters and parameter mixing are :func:`ground_geoms`' (MuJoCo's); k, c, mu by the same
    rule with the weight of the lighter of the two geoms' kinematic trees (what one rests on the
    other with); a static geom's tree weighs nothing, so there the moving one's; two geoms of one
    tree (a self-collision): the lighter of the two branches below their common ancestor
    (:func:`branch_masses`)."""
    import mujoco
    from eomc.compiler.contact.pairs import pair_supported
    if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT):
        return [], {}
    weld = m.body_weldid
    excluded = _excluded(m)
    filterparent = not (m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    g_mag = fo.norm(m.opt.gravity) or 9.81
    timestep = None if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE) else float(m.opt.timestep)
    flat = ("plane", "hfield")

    def kind(g):
        return GEOM_KINDS.get(int(m.geom_type[g]), str(int(m.geom_type[g])))

    def moving(g):
        return int(weld[int(m.geom_bodyid[g])]) != 0
    found = {}
    for q in range(m.npair):
        g1, g2 = sorted((int(m.pair_geom1[q]), int(m.pair_geom2[q])))
        if kind(g1) in flat or kind(g2) in flat or not (moving(g1) or moving(g2)):
            continue
        five = np.array(m.pair_friction[q])        # slide, slide, torsion, roll, roll -> slide, torsion, roll
        found[(g1, g2)] = (int(m.pair_dim[q]), five[[0, 2, 3]], np.array(m.pair_solref[q]),
                           np.array(m.pair_solimp[q]), float(m.pair_margin[q]))
    explicit = set(found)
    for g1 in range(m.ngeom):
        if kind(g1) in flat:
            continue
        for g2 in range(g1 + 1, m.ngeom):
            if (g1, g2) in found or kind(g2) in flat or not (moving(g1) or moving(g2)) \
                    or _filtered(m, g1, g2, excluded, filterparent):
                continue
            condim, friction, solref, solimp = _mix(m, g1, g2)
            found[(g1, g2)] = (condim, friction, solref, solimp, float(m.geom_margin[g1]) + float(m.geom_margin[g2]))
    reach = _reach(m)
    found = {pair: v for pair, v in found.items() if not _apart(m, reach, *pair, v[4])}
    out, skipped = [], {}
    for (g1, g2), (condim, friction, solref, solimp, margin) in sorted(found.items()):
        k1, k2 = kind(g1), kind(g2)
        name = f"{_geom_name(m, g1)}__{_geom_name(m, g2)}"
        if not pair_supported(k1, k2):
            key = "-".join(sorted((k1, k2)))
            count, example = skipped.get(key, (0, name))
            skipped[key] = (count + 1, example)
            continue
        roots = {int(m.body_rootid[int(m.geom_bodyid[g])]) for g in (g1, g2)}
        if len(roots) == 1 and moving(g1) and moving(g2):
            masses = branch_masses(m, int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2]))
        else:
            masses = [float(m.body_subtreemass[int(m.body_rootid[int(m.geom_bodyid[g])])]) for g in (g1, g2) if moving(g)]
        k, c, mu = law_parameters(solref, solimp, friction, condim, g_mag, g_mag * min(masses), timestep)
        mut, mur = spin_parameters(friction, condim)
        rho = min(float(m.geom_rbound[g1]), float(m.geom_rbound[g2])) if mut is not None else None
        out.append(BodyPair((g1, g2), name, (k1, k2), k, c, mu, margin, (g1, g2) in explicit,
                            len(roots) == 1 and moving(g1) and moving(g2), mut, mur, rho))
    return out, skipped


def branch_masses(m, b1, b2):
    """(m1, m2): the masses on either side of a self-collision between bodies ``b1`` and ``b2`` of
    one kinematic tree -- each body's branch below the two bodies' lowest common ancestor (the
    subtree of that ancestor's child on the body's path); a body that is the ancestor itself has
    the rest of the tree on its side.  What one side can rest on the other with: a hand on a thigh
    carries its arm, not the robot.

    Why (the stiffness rule k = W/δ_ref^1.5 rests the pair at MuJoCo's depth under the weight W,
    docs/contact.md): with W the whole tree's weight, gymnasium's humanoid's 109 self-pairs were
    as stiff as if each carried the robot (k 5.9e7 N/m^1.5 between a 1.2 kg forearm and a thigh);
    its resting self-contacts sat 4-10x shallower than MuJoCo's (4-8e-5 m against 1.3-5.5e-4 m)
    and the light limbs between them made a stiff creeping system on which BDF held 2-6e-4 s
    steps for the whole rest (24167 steps for the 10 s fall, 14126 with this rule;
    benchmarks/results/passive.md, 2026-11-30)."""
    def path(b):
        out = [b]
        while b != 0:
            b = int(m.body_parentid[b])
            out.append(b)
        return out[::-1]
    p1, p2 = path(int(b1)), path(int(b2))
    k = 0
    while k < min(len(p1), len(p2)) and p1[k] == p2[k]:
        k += 1
    tree = float(m.body_subtreemass[int(m.body_rootid[int(b1)])])
    m1 = float(m.body_subtreemass[p1[k]]) if k < len(p1) else None
    m2 = float(m.body_subtreemass[p2[k]]) if k < len(p2) else None
    return (tree - m2 if m1 is None else m1), (tree - m1 if m2 is None else m2)


def _reach(m):
    """{geom: (centre, radius)}: a ball in the world that holds the geom in every pose, for geoms
    whose bodies turn about points fixed in the world only (each moving body of the chain with hinge
    or ball joints sharing one anchor): the first anchor, and the chain's anchor-to-anchor lengths
    plus the geom's own bounding radius (``geom_rbound``; rotations keep each length).  Geoms on
    slide or free joints, or bodies with joints at different anchors, are not bounded (absent)."""
    import mujoco
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    out = {}
    for g in range(m.ngeom):
        body = int(m.geom_bodyid[g])
        if int(m.body_weldid[body]) == 0:
            continue
        point, length, ok = np.array(d.geom_xpos[g]), float(m.geom_rbound[g]), True
        while body != 0 and ok:
            count, adr = int(m.body_jntnum[body]), int(m.body_jntadr[body])
            if count:
                kinds = {int(m.jnt_type[j]) for j in range(adr, adr + count)}
                anchors = np.array([d.xanchor[j] for j in range(adr, adr + count)])
                if kinds - {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_BALL)} \
                        or np.ptp(anchors, axis=0).max() > 0:
                    ok = False
                    break
                length += fo.norm(point - anchors[0])
                point = anchors[0]
            body = int(m.body_parentid[body])
        if ok:
            out[g] = (point, length)
    return out


def _apart(m, reach, g1, g2, margin):
    """True when the two geoms' reach balls (:func:`_reach`; a static geom's own bounding ball) never
    meet: such a pair can never touch, so it is not emitted (dm_control's finger: its spinner's
    and its finger's hinge-axis cylinders, 0.4 m apart)."""
    balls = []
    for g in (g1, g2):
        if int(m.body_weldid[int(m.geom_bodyid[g])]) == 0:
            return False                    # a static geom: left to the pair (cheap, usually near)
        if g not in reach:
            return False
        balls.append(reach[g])
    (c1, r1), (c2, r2) = balls
    return fo.norm(c1 - c2) > r1 + r2 + max(margin, 0.0) + 1e-9
