"""Frame outputs: where named frames are, how fast they move, their Jacobians, the centre of mass.

``eomc.compile(robot, frames=["tool0", "com"])`` / ``--frame tool0`` adds, per named frame,
outputs of the model (the generated ``NAME_outputs``) in the world frame:

    F.p.x  F.p.y  F.p.z              origin position
    F.R[i][j]                        rotation matrix, row-major (columns: the frame's axes)
    F.v.x  F.v.y  F.v.z              velocity of the origin
    F.w.x  F.w.y  F.w.z              angular velocity
    F.J[i][j]                        6 x nu Jacobian: rows v.x, v.y, v.z, w.x, w.y, w.z,
                                     columns the model's speeds, so (v; w) = J u

and for ``com``: ``com.p.x`` ... (the whole robot's mass centre) and ``com.v.x`` ...  This is
Pinocchio's LOCAL_WORLD_ALIGNED convention (``getFrameVelocity`` / ``getFrameJacobian``:
linear velocity of the frame's origin, then angular velocity, world components), entry
for entry.  The runtime reads them back as arrays (eomc.runtime.frames).

Why from the tree and not by differentiating positions: every quantity is built along the
path from the root, one named temporary per entry (the Recorder of the recursive
formulation), so a frame at depth d costs O(d) code and the centre of mass O(n); the
Jacobian's column of speed k of body j is the joint's motion axis carried to the world,
``[R_j S_v + (R_j S_w) x (p_F - p_j); R_j S_w]`` (S = (S_w, S_v): the body's velocity per
unit speed, its origin's linear part), no symbolic differentiation anywhere.  The code is
appended to the program of whichever formulation generates the model (Kane's or the
recursive one), so the optimizer shares sin/cos and products with the dynamics; rhs is
unchanged (outputs are their own C function).

A named frame is a body of the tree plus a constant placement on it (:class:`FrameSpec`).
Where the names come from (:func:`resolve_frames`):

- URDF robots: every link, links welded by fixed joints (tool0, ee_link) included, at its
  own frame -- their fixed offset from the body they were merged into is kept;
- MuJoCo models: every body, at its body frame (MuJoCo's ``xpos``/``xmat``), and every named
  ``<site>`` at its site frame (``site_xpos``/``site_xmat``);
- Systems and KanesMethods: every body of the joint tree, at its mass centre with its frame.
"""
import difflib
import re
from dataclasses import dataclass, field

import sympy as sm

from eomc.runtime.errors import ModelError

from .recorder import Recorder
from .model import NotATree
from .placement import IDENTITY, Placement
from .spatial import cross

__all__ = ["FrameSpec", "FrameSource", "resolve_frames", "with_frames", "frame_output_names",
           "frames_digest", "COM"]

COM = "com"
_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class FrameSpec:
    """A named frame fixed to tree body ``body`` (-1: the ground).

    ``rotation``: 3x3 numbers, the frame's axes in body components; ``offset``: 3
    expressions (mechanics symbols: parameters such as the body's mass-centre coordinates),
    the frame's origin from the body's origin, body components."""
    name: str
    body: int
    rotation: tuple
    offset: tuple


@dataclass(frozen=True)
class FrameSource:
    """What the frame outputs are computed from (before lowering).

    ``columns[k]``: the model speed (index into the model's speeds) of the tree's speed k;
    ``defaults``: values of symbols a placement uses that the model's equations lack (a URDF
    number that only places a link)."""
    tree: object
    frames: tuple
    com: bool
    nu: int
    columns: tuple
    defaults: dict = field(default_factory=dict)

    def names(self):
        return frame_output_names([f.name for f in self.frames], self.com, self.nu)

    def lowered(self, sym, layout, nq):
        """``sym`` (a Symbolic of either formulation) with these frames' outputs appended."""
        return with_frames(sym, self, layout, nq)


def frame_output_names(frames, com, nu):
    """The output names, in order, of frames named ``frames`` (and the centre of mass)."""
    out = []
    for f in frames:
        out += [f"{f}.p.{a}" for a in _AXES]
        out += [f"{f}.R[{i}][{j}]" for i in range(3) for j in range(3)]
        out += [f"{f}.v.{a}" for a in _AXES] + [f"{f}.w.{a}" for a in _AXES]
        out += [f"{f}.J[{i}][{j}]" for i in range(6) for j in range(nu)]
    if com:
        out += [f"{COM}.p.{a}" for a in _AXES] + [f"{COM}.v.{a}" for a in _AXES]
    return out


# ---------------------------------------------------------------- which frames there are


def _requested(names):
    """(unique frame names in order, com wanted) of ``frames=`` (a name or a list of names)."""
    if names is None:
        return [], False
    if isinstance(names, str):
        names = [names]
    if isinstance(names, (set, frozenset, dict)):     # no order: the outputs' order would vary by run
        raise ModelError(f"frames= takes a list of frame names (its order is the outputs' order), "
                         f"not a {type(names).__name__}")
    try:
        names = list(names)
    except TypeError:
        raise ModelError(f"frames= takes a list of frame names (e.g. ['tool0', 'com']), "
                         f"not {names!r}") from None
    out, com = [], False
    for n in names:
        if not isinstance(n, str) or not n.strip():
            raise ModelError(f"frames=: each frame is named by a non-empty string, not {n!r}")
        n = n.strip()
        if n == COM:
            com = True
        elif n not in out:
            out.append(n)
    return out, com


_PLURAL = {"body": "bodies", "body or site": "bodies and sites"}


def _unknown(name, known, where, what):
    close = difflib.get_close_matches(name, known, n=5, cutoff=0.4)
    hint = (f"nearest: {', '.join(close)}" if close else
            f"{_PLURAL.get(what, what + 's')}: {', '.join(known[:12])}{', ...' if len(known) > 12 else ''}")
    return ModelError(f"{where}: no {what} named {name!r} to output as a frame ({hint}; "
                      f"'{COM}' is the centre of mass)")


def _columns(tree, speeds, where):
    """Tree speed k -> its index among the model's speeds (the same symbols)."""
    index = {s: j for j, s in enumerate(speeds)}
    out = []
    for s in tree.speeds:
        if s not in index:
            raise ModelError(f"{where}: frame outputs: the joint tree's speed {s} is not a speed of "
                             f"the model (a constrained or reduced system?); frames are not available")
        out.append(index[s])
    return tuple(out)


def resolve_frames(spec, names):
    """The :class:`FrameSource` of the frames ``names`` asks for in the model ``spec``
    (a :class:`~eomc.compiler.model.spec.ModelSpec`), or None when none is asked for.
    An unknown name is a ModelError listing the nearest names the model has."""
    wanted, com = _requested(names)
    if not wanted and not com:
        return None
    where = str(spec.path) if spec.path is not None else f"model {spec.name}"
    formed = spec.formed
    reading = getattr(spec.system, "reading", None)
    if reading is not None:   # a robot reader's System passed in (from_urdf): its links, under
        # every formulation (not the bodies of the tree recognized from the System: a link's frame is
        # at its joint, a System body's at its mass centre, and welded links are no bodies)
        tree, specs, defaults = _reading_frames(reading, wanted, where)
    elif spec.model is not None:
        tree, specs = spec.model.tree, _model_frames(spec.model, wanted, where)
        defaults = (dict(spec.model.defaults) if spec.model.source.format != "system"
                    else dict(spec.parameters or {}))
    else:
        tree = _system_tree(spec, where)
        specs, defaults = _body_frames(tree, wanted, where), dict(spec.parameters or {})
    seen = {}
    for f, asked in zip(specs, wanted):
        if f.name in seen or f.name == COM:
            raise ModelError(f"{where}: frames {seen.get(f.name, COM)!r} and {asked!r} would both be "
                             f"output as {f.name!r}.*; ask for one of them")
        seen[f.name] = asked
    return FrameSource(tree=tree, frames=tuple(specs), com=com, nu=formed.nu,
                       columns=_columns(tree, formed.speeds, where), defaults=defaults)


def _model_frames(model, wanted, where):
    """The FrameSpecs of the frames ``wanted`` among the Model's named frames."""
    out = []
    for name in wanted:
        frame = model.frame(name)
        if frame is None:
            raise _unknown(name, [f.name for f in model.frames], where, model.frame_noun)
        out.append(FrameSpec(_safe(name), frame.body, frame.rotation, frame.offset))
    return out


def _system_tree(spec, where):
    from .recognize import tree_of
    if spec.system is None:
        raise ModelError(f"{where}: frame outputs need the model's joint tree; only formed "
                         f"equations were given (pass the System or KanesMethod itself)")
    try:
        return tree_of(spec.system, spec.formed)
    except NotATree as exc:
        raise ModelError(f"{where}: frame outputs are computed along the joint tree, and this "
                         f"system is not one the tree reader takes ({exc})") from None


_IDENTITY = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def _body_frames(tree, wanted, where):
    """Bodies of a System's tree by name: the mass centre, the body's frame."""
    index = {b.name: i for i, b in enumerate(tree.bodies)}
    out = []
    for name in wanted:
        if name not in index:
            raise _unknown(name, list(index), where, "body")
        out.append(FrameSpec(_safe(name), index[name], _IDENTITY, (0, 0, 0)))
    return out


def _safe(name):
    """A frame name as an output prefix: a '.' or ',' would break the names (and CSV headers)."""
    return re.sub(r"[.,\s\[\]]", "_", name)


def _reading_frames(reading, wanted, where):
    """(Tree, FrameSpecs, defaults) of the links of a robot reader's System (from_urdf), passed
    in as an object: the Model of the reading the reader made (its ``model()``), as a robot
    file's."""
    model = reading.model()
    return model.tree, _model_frames(model, wanted, where), dict(model.defaults)


# ---------------------------------------------------------------- lowering


def frames_digest(source):
    """Everything of ``source`` that shapes the generated code, for the generation cache key
    (the tree itself is in the key already, through the formed system or its digest)."""
    if source is None:
        return []
    out = ["frames", str(source.com), str(source.columns)]
    for f in source.frames:
        out += [f.name, str(f.body), str(f.rotation), str(f.offset)]
    out += [f"{s}={v!r}" for s, v in sorted(source.defaults.items(), key=lambda kv: str(kv[0]))]
    if source.frames or source.com:
        from .model import tree_exprs
        out += [str(len(source.tree.bodies))] + [str(b.parent) for b in source.tree.bodies]
        out += [str(e) for e in tree_exprs(source.tree)]
    return out


def _dot3(M, v):
    return [sum((M[i][k] * v[k] for k in range(3)), sm.S.Zero) for i in range(3)]


class _World:
    """Per tree body, built once on demand and from the root down (no recursion: depth is
    free): R (body axes in world components) and p (its origin), placed along the tree
    (:class:`.placement.Placement`), w (angular velocity), v (its origin's velocity), and
    its joint's axes in the world [(model speed, axis_w, origin_v)]."""

    def __init__(self, tree, rec, ren, speeds, columns):
        self.tree, self.rec, self.ren, self.speeds, self.columns = tree, rec, ren, speeds, columns
        self.done = {}

        def E(i):
            b = tree.bodies[i]
            return [[ren(b.rotation[r, c], f"body {b.name} (joint {b.joint})") for c in range(3)] for r in range(3)]

        def r(i):
            b = tree.bodies[i]
            return [ren(b.position[k], f"body {b.name} (joint {b.joint})") for k in range(3)]
        self.placement = Placement([b.parent for b in tree.bodies], E, r, rec.let)

    def ground(self):
        return IDENTITY, [sm.S.Zero] * 3, [sm.S.Zero] * 3, [sm.S.Zero] * 3, []

    def __call__(self, i):
        if i < 0:
            return self.ground()
        chain = []
        while i >= 0 and i not in self.done:
            chain.append(i)
            i = self.tree.bodies[i].parent
        for j in reversed(chain):
            self.done[j] = self._place(j)
        return self.done[chain[0]] if chain else self.done[i]

    def _place(self, i):
        b, let = self.tree.bodies[i], self.rec.let
        what = f"body {b.name} (joint {b.joint})"
        _, _, wp, vp, _ = self(b.parent) if b.parent >= 0 else self.ground()
        R, p = self.placement.rotation(i), self.placement.origin(i)
        Rr = self.placement.arm(i)
        axes = []
        w, v = list(wp), [vp[k] + x for k, x in enumerate(cross(wp, [let(x) for x in Rr]))]
        for k, S in b.dofs:
            S = [self.ren(s, what) for s in S]
            aw = [let(x) for x in _dot3(R, S[:3])]
            av = [let(x) for x in _dot3(R, S[3:])]
            u = self.speeds[self.columns[k]]
            axes.append((self.columns[k], aw, av))
            w = [w[m] + aw[m] * u for m in range(3)]
            v = [v[m] + av[m] * u for m in range(3)]
        return R, p, [let(x) for x in w], [let(x) for x in v], axes

    def path(self, i):
        """Bodies from ``i`` up to the root."""
        out = []
        while i >= 0:
            out.append(i)
            i = self.tree.bodies[i].parent
        return out


def with_frames(sym, source, layout, nq):
    """``sym`` (a :class:`~eomc.compiler.emit.symbolic.Symbolic`) with the frame outputs of
    ``source`` appended to its ``outputs`` group (after the model's own outputs)."""
    from dataclasses import replace
    program = sym.program
    rec = Recorder(program.ntemp)
    memo = {}
    defaults = {s: sm.Float(v) for s, v in source.defaults.items()
                if isinstance(s, sm.Symbol) and s not in layout.subs}

    def ren(e, what):
        e = sm.sympify(e)
        if defaults:
            e = e.xreplace(defaults)
        return layout.apply(e, f"frame outputs: {what}", memo)

    speeds = layout.x[nq:nq + source.nu]
    world = _World(source.tree, rec, ren, speeds, source.columns)
    values = []
    for f in source.frames:
        R, p, w, v, _ = world(f.body)
        C = [[sm.sympify(x) for x in row] for row in f.rotation]
        o = [ren(x, f"the placement of frame {f.name}") for x in f.offset]
        Ro = [rec.let(x) for x in _dot3(R, o)]
        pf = [rec.let(p[k] + Ro[k]) for k in range(3)]
        Rf = [[rec.let(sum((R[a][k] * C[k][c] for k in range(3)), sm.S.Zero)) for c in range(3)]
              for a in range(3)]
        vf = [rec.let(v[k] + x) for k, x in enumerate(cross(w, Ro))]
        J = [[sm.S.Zero] * source.nu for _ in range(6)]
        for j in world.path(f.body):
            pj = world(j)[1]
            arm = [rec.let(pf[k] - pj[k]) for k in range(3)]
            for col, aw, av in world(j)[4]:
                lin = cross(aw, arm)
                for k in range(3):
                    J[k][col] = rec.let(av[k] + lin[k])
                    J[3 + k][col] = aw[k]
        values += pf + [Rf[a][c] for a in range(3) for c in range(3)] + vf + list(w)
        values += [J[i][j] for i in range(6) for j in range(source.nu)]
    if source.com:
        total, mp, mv = sm.S.Zero, [sm.S.Zero] * 3, [sm.S.Zero] * 3
        for i, b in enumerate(source.tree.bodies):
            m = ren(b.mass, f"the mass of body {b.name}")
            if m == 0:
                continue
            _, p, _, v, _ = world(i)
            total += m
            mp = [mp[k] + m * p[k] for k in range(3)]
            mv = [mv[k] + m * v[k] for k in range(3)]
        if total == 0:
            raise ModelError("frame outputs: the centre of mass of a model without mass")
        inv = rec.let(1 / rec.let(total))
        values += [rec.let(x * inv) for x in mp] + [rec.let(x * inv) for x in mv]
    first = len(sym.output_names)
    results = tuple((("out", first + k), e) for k, e in enumerate(values))
    program = program.with_(assignments=program.assignments + tuple(rec.assignments),
                            results=program.results + results, ntemp=rec.count)
    return replace(sym, program=program, output_names=tuple(sym.output_names) + tuple(source.names()))
