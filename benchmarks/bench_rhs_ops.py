"""Issue 31 item 3: where the floating-base rhs's operations go, and whether a third formulation pays.

For each robot (G1 29-dof, Talos full body, Go2, Solo12; quaternion free joint, ``--limits
off``, rhs only, the recursive formulation) two counts and one timing:

1. **ABA by phase** (eomc's rhs today): the recursion's named temporaries (before the
   optimising passes: these sum a little above the final count), tagged by the phase that
   names them -- ``pre`` (each body's E(q), r(q): sin/cos, the quaternion's rotation, the
   mass centre offsets), ``velocities`` (v_i, c_i), ``backward`` (bias forces v×*Iv, U = IᴬS,
   D, u, Iᴬ - W Uᵀ, Iᴬc, the force transform to the parent), ``inertia to parent``
   (Xᵀ Iᴬ X, :func:`eomc.compiler.tree.spatial.xt_inertia_x`), ``root 6x6`` (the free joint's
   U, D and its LDLᵀ) and ``forward`` (accelerations, u', the root's substitution); per
   moving body beside it.
2. **CRBA + RNEA + tree-sparse LTDL** (Featherstone 2005, "Efficient factorization of the
   joint-space inertia matrix for branched kinematic trees"): M by eomc's CRBA
   (:mod:`eomc.compiler.tree.crba`), the bias -RNEA(u' = 0) (:mod:`eomc.compiler.tree.rnea`),
   M = Lᵀ D L in the speeds' parent-array order (zero fill-in) and the two substitutions;
   :func:`crba_ltdl` below, emitted through the same pipeline by standing in for ABA in the
   lowering (the rhs reads either).  Its final operation count, by phase, its agreement with
   the ABA rhs at 50 random states, and the time of both C libraries in one harness
   (bench_urdf's driver, thread CPU time, pinned to one core, interleaved, medians).

3. **ABA with axis-point origins** (:class:`AxisOrigins`; ``axis+cb``: its bias forces v×*Iv
   computed at the mass centre and shifted, ``com_bias=True``): each revolute body's origin moved
   from its mass centre (eomc's convention) to the nearest point of its joint axis, so S = [a; 0]
   (U a column of Iᴬ, D an entry, c sparser), paid for by a full rigid-body inertia about the new
   origin computed from the runtime mass-centre parameters: Featherstone's joint-frame
   convention, on which his minimal ABA counts rest.  Final count, agreement, time as in 2.

The alternatives live here, not in eomc: they were measured not to pay (see the table), so no
formulation offers them.

    python benchmarks/bench_rhs_ops.py            # all four robots
    python benchmarks/bench_rhs_ops.py go2 solo12
"""
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import sympy as sm

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from bench_urdf import CORE, NSTATES, _run, _timed, _write, eomc_harness  # noqa: E402
from common import environment_header, format_table, write_results  # noqa: E402

ROBOTS = {"g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf", "talos": "talos_data/robots/talos_full_v2.urdf",
          "go2": "go2_description/urdf/go2.urdf", "solo12": "solo12"}
REPEAT = 9
NCALLS = 20000


def speed_parents(bodies):
    """Per speed, its parent speed (-1 at the root): the numbering eomc's implicit metadata uses."""
    from eomc.compiler.formulations.recursive import speed_parents as shared
    own = [[b.speed] if b.S is not None else [s for s, _ in b.multi] if b.multi else [] for b in bodies]
    return shared([b.parent for b in bodies], own)


def crba_ltdl(bodies, rec, speeds, gravity, v, c, keep=None):
    """[(speed, u', pivot margin)] as eomc.compiler.tree.aba.aba returns, by M u' = -RNEA(u' = 0)
    with M = Lᵀ D L factored in place over the parent array (Featherstone 2005: for k from the
    last speed down, for each ancestor i of k: a = M_ki / M_kk, M_ij -= a M_kj for j = i and
    its ancestors, M_ki = a); then x = L⁻¹ D⁻¹ L⁻ᵀ b.  The pivots D_kk stand where ABA's D_i
    do in the singular test (each above PIVOT_TOL times their sum)."""
    from eomc.compiler.emit.linsolve import PIVOT_TOL
    from eomc.compiler.tree.construct import _add, _mul
    from eomc.compiler.tree.crba import crba
    from eomc.compiler.tree.rnea import rnea
    nu = len(speeds)
    H = crba(bodies, rec)
    tau0 = rnea(bodies, rec, [0] * nu, gravity, v, c)
    lam = speed_parents(bodies)
    assert all(p < k for k, p in enumerate(lam)), "speeds not numbered parents first"
    chain = {}
    for k in range(nu):
        chain[k], i = [], lam[k]
        while i >= 0:
            chain[k].append(i)
            i = lam[i]
    F = {(k, i): H.get((k, i), 0) for k in range(nu) for i in [k] + chain[k]}
    dinv = {}
    for k in reversed(range(nu)):
        F[(k, k)] = rec.let(F[(k, k)])
        dinv[k] = rec.let(1 / F[(k, k)])
        row = {i: F[(k, i)] for i in chain[k]}
        for i in chain[k]:
            a = rec.let(_mul(row[i], dinv[k]))
            for j in [i] + chain[i]:
                F[(i, j)] = rec.let(_add((F[(i, j)], -_mul(a, row[j]))))
            F[(k, i)] = a
    x = {k: -tau0[k] for k in range(nu)}
    for k in reversed(range(nu)):             # L⁻ᵀ
        xk = x[k] = rec.let(x[k])
        for j in chain[k]:
            x[j] = _add((x[j], -_mul(F[(k, j)], xk)))
    for k in range(nu):                        # D⁻¹, then L⁻¹
        x[k] = rec.let(_add([_mul(x[k], dinv[k])] + [-_mul(F[(k, j)], x[j]) for j in chain[k]]))
    threshold = rec.let(PIVOT_TOL * _add([F[(k, k)] for k in range(nu)]))
    return [(k, x[k], rec.let(F[(k, k)] - threshold)) for k in range(nu)]


def cross(a, b):
    return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]


class _Bias(list):
    """I v of a body moved off its mass centre, with what its bias force needs (see AxisOrigins)."""


class AxisOrigins:
    """ABA with each one-speed body whose axis is a unit rotation (a revolute joint) moved from its
    mass centre to the nearest point of its joint axis: S = [a; 0], r(q) = r - Eᵀd + d_parent,
    I about the new origin (Ic - m d×d×, m d×; -m d×, m 1), body loads' moments shifted by d × f.
    Featherstone's joint-frame convention, which his minimal ABA counts assume; the free joint's
    root stays at its mass centre.  Patches the lowering for the length of a ``with``.

    ``com_bias``: ABA's bias force v×*(I v) of a moved body computed at its mass centre and
    shifted to the new origin (v_c = v + ω×d; [ω×Ic ω; m ω×v_c]; n += d×f), instead of with the
    full rigid-body inertia about the new origin."""
    def __init__(self, com_bias=False):
        self.com_bias = com_bias

    def __enter__(self):
        import eomc.compiler.tree.lower as L
        self.L = L
        self.LB, self.lb = L.LoweredBody, L._lowered_bodies
        shift = self.shift = []
        LB = self.LB
        def make(body, rec, E, r, S, mass, inertia, fext, multi=None, armature=None):
            d = [sm.S.Zero] * 3
            if S is not None and all(sm.sympify(x).is_number for x in S[:3]) and any(x != 0 for x in S[:3]):
                a = [sm.sympify(x) for x in S[:3]]
                if sum(x * x for x in a) == 1:
                    d = [sm.expand(x) for x in cross(S[3:], a)]
            dp = shift[body.parent] if body.parent >= 0 else [sm.S.Zero] * 3
            shift.append(d)
            if any(x != 0 for x in d) or any(x != 0 for x in dp):
                Ed = [sum((E[k, j] * d[k] for k in range(3)), sm.S.Zero) for j in range(3)]
                r = sm.Matrix([sm.expand(r[j] - Ed[j] + dp[j]) for j in range(3)])
            if S is not None and any(x != 0 for x in d):
                ad = cross(S[:3], d)
                S = list(S[:3]) + [sm.expand(S[3 + j] - ad[j]) for j in range(3)]
            b = LB(body, rec, E, r, S, mass, inertia, fext, multi, armature)
            if any(x != 0 for x in d):
                m = b.I[3][3]
                hx = [[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]]
                hh = [[sum(hx[i][k] * hx[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
                for i in range(3):
                    for j in range(3):
                        b.I[i][j] = rec.let(sm.expand(inertia[i, j] - m * hh[i][j]))
                        b.I[i][j + 3] = rec.let(sm.expand(m * hx[i][j]))
                        b.I[j + 3][i] = b.I[i][j + 3]
                self.bias[id(b.I)] = (d, m, [[inertia[i, j] for j in range(3)] for i in range(3)])
            return b
        L.LoweredBody = make
        self.bias = {}
        if self.com_bias:
            import eomc.compiler.tree.aba as A
            from eomc.compiler.tree.construct import _add, _mul
            from eomc.compiler.tree.spatial import _cross
            self.A, self.times, self.cross_force = A, A._times, A.cross_force
            times, cross_force = A._times, A.cross_force

            def times_(I, v):
                out = times(I, v)
                if id(I) in self.bias:
                    out = _Bias(out)
                    out.com = self.bias[id(I)]
                return out

            def cross_force_(v, f):
                if not isinstance(f, _Bias):
                    return cross_force(v, f)
                d, m, Ic = f.com
                w = v[:3]
                vc = [_add((v[3 + k], x)) for k, x in enumerate(_cross(w, d))]
                n = _cross(w, [_add([_mul(Ic[i][k], w[k]) for k in range(3)]) for i in range(3)])
                fl = [_mul(m, x) for x in _cross(w, vc)]
                return [_add((n[k], x)) for k, x in enumerate(_cross(d, fl))] + fl
            A._times, A.cross_force = times_, cross_force_
        def lowered(tree, layout, rec):
            shift.clear()
            bodies, g = self.lb(tree, layout, rec)
            for b, d in zip(bodies, shift):
                if b.fext is not None and any(x != 0 for x in d):
                    n, f = b.fext[:3], b.fext[3:]
                    df = cross(d, f)   # moment about the new origin (at COM - d): n + (COM - O) x f = n + d x f
                    b.fext = [n[k] + df[k] for k in range(3)] + list(f)
            return bodies, g
        L._lowered_bodies = lowered
        return self
    def __exit__(self, *e):
        self.L.LoweredBody, self.L._lowered_bodies = self.LB, self.lb
        if self.com_bias:
            self.A._times, self.A.cross_force = self.times, self.cross_force


class Phases:
    """Tags every temporary the recursions name with the phase that named it (see the module
    docstring), by wrapping the lowering's entry points for the length of a ``with``."""

    def __init__(self, kind):
        self.kind, self.tags, self.phase, self.undo = kind, [], "pre", []

    def _wrap(self, mod, name, phase, after=None):
        f = getattr(mod, name)

        def g(*a, **k):
            before, self.phase = self.phase, phase
            try:
                return f(*a, **k)
            finally:
                self.phase = before if after is None else after
        setattr(mod, name, g)
        self.undo.append((mod, name, f))

    def __enter__(self):
        import eomc.compiler.tree.aba as A
        import eomc.compiler.tree.crba as CR
        import eomc.compiler.tree.lower as L
        import eomc.compiler.tree.recorder as R
        let = R.Recorder.let

        def tagged(rec, e):
            n = len(rec.assignments)
            out = let(rec, e)
            if len(rec.assignments) > n:
                self.tags.append((self.phase, rec.assignments[-1][1]))
            return out
        R.Recorder.let = tagged
        self.undo.append((R.Recorder, "let", let))
        if self.kind == "ltdl":
            L_aba = L.aba
            self.undo.append((L, "aba", L_aba))
            L.aba = crba_ltdl
            self._wrap(L, "aba", "LTDL factor and solve", after="after")
            import eomc.compiler.tree.crba as crba_mod
            import eomc.compiler.tree.rnea as rnea_mod
            self._wrap(crba_mod, "crba", "CRBA columns")
            self._wrap(rnea_mod, "rnea", "RNEA bias")
            self._wrap(CR, "xt_inertia_x", "inertia to parent")
        else:
            self._wrap(L, "aba", "backward", after="after")
            self._wrap(A, "_root_acceleration", "forward", after="forward")
            self._wrap(A, "xt_inertia_x", "inertia to parent")
            self._wrap(A, "_multi_articulate", "root 6x6")
        self._wrap(L, "velocities", "velocities", after="pre")
        return self

    def __exit__(self, *exc):
        for mod, name, f in reversed(self.undo):
            setattr(mod, name, f)

    def counts(self):
        from eomc.compiler.ir.opcount import count_ops
        c = Counter()
        for phase, e in self.tags:
            c[phase] += sum(count_ops(e).values())
        return c


def build(name, kind, tmp):
    """(model, phase counts) of one robot's rhs: ABA, CRBA+LTDL or ABA with axis-point origins."""
    import contextlib
    import eomc
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.robots import robot_path
    with Phases("ltdl" if kind == "ltdl" else "aba") as ph, (
            AxisOrigins(com_bias=kind == "axis2") if kind in ("axis", "axis2") else contextlib.nullcontext()):
        m = eomc.compile(UrdfModel(robot_path(ROBOTS[name]), floating_base="quaternion", limits=False),
                         f"{name}_{kind}", functions=["rhs"], cache_dir=tmp / f"cache_{kind}",
                         output_dir=tmp / f"out_{name}_{kind}", progress=False, formulation="recursive")
    return m, ph.counts()


def _states(m, rng):
    xs = []
    for _ in range(NSTATES):
        x = rng.normal(size=m.nx)
        x[3:7] /= np.linalg.norm(x[3:7])
        xs.append(x)
    return xs


ABA_PHASES = ("pre", "velocities", "backward", "inertia to parent", "root 6x6", "forward")
LTDL_PHASES = ("pre", "velocities", "inertia to parent", "CRBA columns", "RNEA bias", "LTDL factor and solve")


KINDS = ("aba", "ltdl", "axis", "axis2")


def main(names):
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(31)
    rows, phase_rows, cmds, info = [], [], {}, {}
    with tempfile.TemporaryDirectory(prefix="bench_rhs_ops_") as tmpname:
        tmp = Path(tmpname)
        for name in names:
            built = {k: build(name, k, tmp) for k in KINDS}
            ma = built["aba"][0]
            xs = _states(ma, rng)
            err = {k: max(float(np.max(np.abs(ma.rhs(0.0, x) - built[k][0].rhs(0.0, x))) / np.max(np.abs(ma.rhs(0.0, x))))
                          for x in xs[:50]) for k in KINDS[1:]}
            for kind in KINDS:
                m = built[kind][0]
                f = tmp / f"{name}_{kind}.bin"
                _write(f, xs, head=[float(v) for v in m.param_defaults])
                cmds[name, kind] = [str(eomc_harness(m, m.directory, tmp)), str(f), str(NSTATES), str(NCALLS)]
            info[name] = (built, err)
            print(f"{name}: built", flush=True)
        samples = {k: [] for k in cmds}
        for rep in range(REPEAT):
            for name in names:
                for kind in KINDS[rep % len(KINDS):] + KINDS[:rep % len(KINDS)]:
                    samples[name, kind].append(_timed(cmds[name, kind])[0])
            print(f"repeat {rep + 1}/{REPEAT}", flush=True)
    for name in names:
        built, err = info[name]
        ma = built["aba"][0]
        ops = {k: sum(int(v) for v in built[k][0].metadata["op_counts"]["rhs"].values()) for k in KINDS}
        med = {k: float(np.median(samples[name, k])) for k in KINDS}
        ratio = {k: float(np.median(np.array(samples[name, k]) / np.array(samples[name, "aba"]))) for k in KINDS[1:]}
        rows.append([name, ma.nu, ops["aba"]] + [ops[k] for k in KINDS[1:]]
                    + [f"{ops[k] / ops['aba']:.3f}" for k in KINDS[1:]] + [round(med[k]) for k in KINDS]
                    + [f"{ratio[k]:.3f}" for k in KINDS[1:]] + [f"{med['aba'] / ops['aba']:.3f}",
                                                               " / ".join(f"{err[k]:.1e}" for k in KINDS[1:])])
        nb = ma.nu - 5          # moving bodies: the free joint's root and one per one-speed joint
        for kind, label, phases in (("aba", "ABA", ABA_PHASES), ("ltdl", "CRBA+LTDL", LTDL_PHASES),
                                    ("axis", "ABA, axis-point origins", ABA_PHASES),
                                    ("axis2", "ABA, axis-point, bias at mass centre", ABA_PHASES)):
            c = built[kind][1]
            phase_rows.append([name, label] + [f"{c.get(p, 0)} ({c.get(p, 0) / nb:.0f})" for p in phases]
                              + [f"{sum(c.values())} ({sum(c.values()) / nb:.0f})"])
    headers = ["robot", "nu", "rhs ops ABA", "ops LTDL", "ops axis", "ops axis+cb", "ops LTDL / ABA",
               "ops axis / ABA", "ops axis+cb / ABA", "ABA [ns]", "LTDL [ns]", "axis [ns]", "axis+cb [ns]",
               "time LTDL / ABA", "time axis / ABA", "time axis+cb / ABA", "ABA ns per op",
               "max rel. diff of xdot from ABA (50 states): LTDL / axis / axis+cb"]
    table = format_table(headers, rows)
    pheads = ["robot", "form", "phase 1: pre", "2: velocities", "3: backward / inertia to parent",
              "4: inertia to parent / CRBA columns", "5: root 6x6 / RNEA bias", "6: forward / LTDL", "sum"]
    ptable = format_table(pheads, phase_rows)
    print(table)
    print(ptable)
    uptime = _run(["uptime"]).stdout.strip()
    header = environment_header(
        "Floating-base rhs: operations by phase; CRBA + RNEA + tree-sparse LTDL and ABA with axis-point "
        "origins against ABA (issue 31 item 3)",
        None, notes=[f"`python3 benchmarks/bench_rhs_ops.py {' '.join(names)}`; uptime at the end: {uptime}",
                     f"pinned to core {CORE}; medians of {REPEAT} interleaved repeats (order rotated) of {NCALLS} "
                     f"calls over {NSTATES} random states (quaternion normalised); ratios: median of per-repeat "
                     "ratios",
                     "all libraries built by eomc (rhs only, quaternion free joint, --limits off, recursive "
                     "formulation, eomc's default flags for this machine); the two alternatives stand in for "
                     "eomc's lowering (crba_ltdl and AxisOrigins in this script)",
                     "rhs ops: adds + multiplies + divides + calls of NAME_rhs as eomc counts them (final, after "
                     "the optimising passes)"])
    doc = ("\nLTDL: CRBA + RNEA + tree-sparse LTDL; axis: ABA with axis-point origins; axis+cb: the same "
           "with each moved body's bias force computed at its mass centre and shifted (AxisOrigins(com_bias=True)).\n"
           "\nPhase counts: the recursion's named temporaries before the optimising passes (they sum a "
           "little above the final count), by the phase that named them; in parentheses per moving body "
           "(nu - 5: the free joint's root and one body per one-speed joint).  Columns 3-6 name the ABA "
           "phase first, then the CRBA+LTDL one.  ABA: pre = E(q), r(q), sin/cos, quaternion rotation, "
           "(axis-point: the bodies' inertias about their new origins); backward = bias forces, U, D, u, "
           "Iᴬ - W Uᵀ, Iᴬc, force to parent; inertia to parent = Xᵀ Iᴬ X; forward = accelerations and u'.  "
           "CRBA+LTDL: inertia to parent = the composite inertias' Xᵀ Iᶜ X; CRBA columns = F = Iᶜ S "
           "carried up to the root and M's entries; LTDL = the factorisation and the substitutions.\n")
    write_results("rhs_ops", header + "\n" + table + "\n" + doc + "\n" + ptable + "\n", keep_notes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or list(ROBOTS)))
