"""Closed loops on the tree (issue 19 item 3): build time and rhs time, recursive vs Kane.

Models (SymPy 1.14 ``System``s of joints whose loops are closed by holonomic constraints):

* ``four_bar``      examples/four_bar_system.py (3 pins, 2 constraints, 1 dof);
* ``slider_crank``  crank and rod pinned in series, a slider on the ground, the rod's end
                    pinned to the slider by 2 constraints (1 dof);
* ``rssr``          a spatial four-bar: pin, ball joint, pin; 3 constraints (2 dof);
* ``chain_n``       n rods pinned in series from the ground, the last one's end pinned to
                    the ground at (d, 0) by 2 constraints (n - 2 dof; n = 4 is a five-bar).

For each model and formulation: a cold build of rhs and the constraints (process CPU time of
model file + generate + compile + load, no cache), the rhs's operation count, and the rhs
call time (thread CPU ns per call, median of interleaved batches, at a consistent state),
plus the largest relative difference of the two rhs at random consistent states.

Run:  python benchmarks/bench_loops.py [--n 4,6,8,12] [--out benchmarks/results/loops.md]
"""
import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import sympy as sm

ROOT = Path(__file__).resolve().parents[1]
# rhs, and the constraints (the same generic code in both formulations) for consistent states
FUNCTIONS = ["rhs", "constraints", "constraints_jac"]
FOUR_BAR = ROOT / "examples" / "four_bar_system.py"


def slider_crank(mech=None):
    """(system, parameters, initial state) of a slider-crank with gravity and a crank torque."""
    me = mech or __import__("eomc.mechanics", fromlist=["System"])
    q1, q2, q3 = me.dynamicsymbols("q1:4")
    u1, u2, u3 = me.dynamicsymbols("u1:4")
    T = me.dynamicsymbols("T")
    r, l, mc, mr, ms, g = sm.symbols("r l m_c m_r m_s g", positive=True)
    ground = me.RigidBody("ground")
    crank = me.RigidBody("crank", mass=mc)
    rod = me.RigidBody("rod", mass=mr)
    slider = me.RigidBody("slider", mass=ms)
    for body, length in ((crank, r), (rod, l)):
        body.inertia = me.Inertia.from_inertia_scalars(body.masscenter, body.frame, 0, 0,
                                                       body.mass * length**2 / 12)
    slider.inertia = me.Inertia.from_inertia_scalars(slider.masscenter, slider.frame, 0, 0, ms / 10)
    joints = [
        me.PinJoint("crank_pin", ground, crank, q1, u1, child_point=-r / 2 * crank.x,
                    joint_axis=ground.z),
        me.PinJoint("wrist_pin", crank, rod, q2, u2, parent_point=r / 2 * crank.x,
                    child_point=-l / 2 * rod.x, joint_axis=crank.z),
        me.PrismaticJoint("slide", ground, slider, q3, u3, joint_axis=ground.x),
    ]
    system = me.System.from_newtonian(ground)
    system.add_joints(*joints)
    gap = rod.masscenter.pos_from(slider.masscenter) + l / 2 * rod.x
    system.add_holonomic_constraints(gap.dot(ground.x), gap.dot(ground.y))
    system.q_ind, system.q_dep = [q1], [q2, q3]
    system.u_ind, system.u_dep = [u1], [u2, u3]
    system.add_actuators(me.TorqueActuator(T, ground.z, crank, ground))
    system.apply_uniform_gravity(-g * ground.y)
    system.validate_system()
    params = {r: 0.3, l: 1.0, mc: 1.0, mr: 2.0, ms: 0.5, g: 9.81}
    th = -np.arcsin(0.3 * np.sin(0.7) / 1.0)
    x0 = {q1: 0.7, q2: th - 0.7, q3: 0.3 * np.cos(0.7) + np.cos(th), u1: 0.0, u2: 0.0, u3: 0.0}
    return system, params, x0


def closed_chain(n, mech=None):
    """(system, parameters, initial state) of n rods pinned in series from the ground, the last
    rod's end pinned to the ground at (d, 0): 2 holonomic constraints, n - 2 dof (n = 4: a
    five-bar linkage), gravity along -y.  The initial state is that arch at rest (consistent)."""
    me = mech or __import__("eomc.mechanics", fromlist=["System"])
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    d, g = sm.symbols("d g", positive=True)
    L = sm.symbols(f"l1:{n + 1}", positive=True)
    m = sm.symbols(f"m1:{n + 1}", positive=True)
    ground = me.RigidBody("ground")
    links = [me.RigidBody(f"link{k + 1}", mass=m[k]) for k in range(n)]
    for body, length in zip(links, L):
        body.inertia = me.Inertia.from_inertia_scalars(body.masscenter, body.frame, 0, 0,
                                                       body.mass * length**2 / 12)
    joints = []
    parent, ppoint = ground, 0 * ground.x
    for k, body in enumerate(links):
        joints.append(me.PinJoint(f"J{k + 1}", parent, body, q[k], u[k], parent_point=ppoint,
                                  child_point=-L[k] / 2 * body.x, joint_axis=parent.frame.z))
        parent, ppoint = body, L[k] / 2 * body.x
    system = me.System.from_newtonian(ground)
    system.add_joints(*joints)
    gap = links[-1].masscenter.pos_from(ground.masscenter) + L[-1] / 2 * links[-1].x - d * ground.x
    system.add_holonomic_constraints(gap.dot(ground.x), gap.dot(ground.y))
    system.q_ind, system.q_dep = list(q[:n - 2]), list(q[n - 2:])
    system.u_ind, system.u_dep = list(u[:n - 2]), list(u[n - 2:])
    system.apply_uniform_gravity(-g * ground.y)
    system.validate_system()
    # an arch: link k's absolute angle pi/2 - (k + 1/2)·pi/n (up, over, down), unit rods, so
    # the heights cancel and the ground gap d is the arch's span
    ang = [np.pi / 2 - (k + 0.5) * np.pi / n for k in range(n)]
    span = float(sum(np.cos(a) for a in ang))
    params = {d: span, g: 9.81, **{x: 1.0 for x in L}, **{x: 1.0 + 0.1 * k for k, x in enumerate(m)}}
    rel = [ang[0]] + [ang[k] - ang[k - 1] for k in range(1, n)]
    x0 = {**{qk: v for qk, v in zip(q, rel)}, **{uk: 0.0 for uk in u}}
    return system, params, x0


def rssr(mech=None):
    """(system, parameters, initial state) of a spatial RSSR four-bar: a crank pinned about the
    ground's z axis, a coupler on a ball joint at the crank's tip (SymPy's SphericalJoint), a
    rocker pinned about the ground's x axis at (1, 0, 0.5); 3 holonomic constraints put the
    coupler's far end at the rocker's tip (5 coordinates, 2 dof: the crank and the coupler's
    spin about its own axis).  Gravity along -z.  The initial state solves the constraints
    at q1 = q2 = 0 (Newton, SymPy's nsolve)."""
    me = mech or __import__("eomc.mechanics", fromlist=["System"])
    q = me.dynamicsymbols("q1:6")
    u = me.dynamicsymbols("u1:6")
    a, L, b, g = sm.symbols("a L b g", positive=True)
    m = sm.symbols("m1:4", positive=True)
    ground = me.RigidBody("ground")
    crank, coupler, rocker = (me.RigidBody(n, mass=mk) for n, mk in
                              (("crank", m[0]), ("coupler", m[1]), ("rocker", m[2])))
    crank.inertia = me.Inertia.from_inertia_scalars(crank.masscenter, crank.frame, m[0] / 100,
                                                    m[0] * a**2 / 12, m[0] * a**2 / 12)
    coupler.inertia = me.Inertia.from_inertia_scalars(coupler.masscenter, coupler.frame, m[1] / 50,
                                                      m[1] * L**2 / 12, m[1] * L**2 / 12)
    rocker.inertia = me.Inertia.from_inertia_scalars(rocker.masscenter, rocker.frame,
                                                     m[2] * b**2 / 12, m[2] / 100, m[2] * b**2 / 12)
    joints = [
        me.PinJoint("crank_pin", ground, crank, q[0], u[0], child_point=-a / 2 * crank.x,
                    joint_axis=ground.z),
        me.SphericalJoint("ball", crank, coupler, [q[1], q[2], q[3]], [u[1], u[2], u[3]],
                          parent_point=a / 2 * crank.x, child_point=-L / 2 * coupler.x),
        me.PinJoint("rocker_pin", ground, rocker, q[4], u[4],
                    parent_point=ground.x + ground.z / 2, child_point=-b / 2 * rocker.y,
                    joint_axis=ground.x),
    ]
    system = me.System.from_newtonian(ground)
    system.add_joints(*joints)
    gap = coupler.masscenter.pos_from(rocker.masscenter) + L / 2 * coupler.x - b / 2 * rocker.y
    system.add_holonomic_constraints(*(gap.dot(v) for v in (ground.x, ground.y, ground.z)))
    system.q_ind, system.q_dep = list(q[:2]), list(q[2:])
    system.u_ind, system.u_dep = list(u[:2]), list(u[2:])
    system.apply_uniform_gravity(-g * ground.z)
    system.validate_system()
    params = {a: 0.3, L: 1.0, b: 0.5, g: 9.81, m[0]: 1.0, m[1]: 1.5, m[2]: 0.8}
    hol = sm.Matrix(list(system.holonomic_constraints)).xreplace(params).xreplace({q[0]: 0, q[1]: 0})
    x = sm.symbols("x3:6")
    sol = sm.nsolve(hol.xreplace(dict(zip(q[2:], x))), x, (-0.5, 0.5, 0.1))
    x0 = {q[0]: 0.0, q[1]: 0.0, **{qk: float(v) for qk, v in zip(q[2:], sol)},
          **{uk: 0.0 for uk in u}}
    return system, params, x0


def models(ns):
    """(label, model) pairs, each model built when its turn comes."""
    yield "four_bar", (str(FOUR_BAR), None, None)
    yield "slider_crank", slider_crank()
    yield "rssr", rssr()
    for n in ns:
        yield f"chain_{n}", closed_chain(n)


def _cpu(fn):
    t = time.process_time()
    value = fn()
    return value, time.process_time() - t


def _build(label, model, formulation, cache):
    import eomc
    src, params, _ = model
    fresh = tempfile.mkdtemp(dir=cache)         # cold: an empty cache per build

    def go():
        if isinstance(src, str):
            return eomc.compile(src, formulation=formulation, functions=FUNCTIONS, cache_dir=fresh)
        return eomc.compile(src, formulation=formulation, functions=FUNCTIONS, parameters=params,
                            cache_dir=fresh)
    return _cpu(go)


def _state(built, model):
    _, _, x0 = model
    if x0 is None:
        return np.asarray(built.consistent_state(None), dtype=float)
    names = built.state_names
    start = {str(k).replace("(t)", ""): v for k, v in x0.items()}
    return np.asarray(built.consistent_state({k: start[k] for k in names}), dtype=float)


def _drift(built, x):
    """Largest constraint residual (position and velocity rows) of a 5 s DOP853 run,
    rtol = atol = 1e-9, no projection, started at ``x`` with the first speed set to 1
    (completed onto the constraints)."""
    x = np.array(x, dtype=float)
    x[built.nq] = 1.0
    x = np.asarray(built.consistent_state(dict(zip(built.state_names, x))), dtype=float)
    res = built.simulate(x, (0.0, 5.0), method="dop853", rtol=1e-9, atol=1e-9, n_points=101)
    return float(np.max(res.constraint_residual)) if res.status == 0 else float("nan")


def _time_calls(built, X):
    """Thread CPU ns per rhs evaluation: ``rhs_many`` over the rows of X (one C loop, so the
    Python call costs nothing per evaluation)."""
    t = time.thread_time_ns()
    built.rhs_many(0.0, X)
    return (time.thread_time_ns() - t) / len(X)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="4,6,8,12", help="closed-chain sizes")
    ap.add_argument("--out", default=None, help="write the markdown table here")
    ap.add_argument("--batches", type=int, default=11)
    ap.add_argument("--calls", type=int, default=20000, help="states per rhs_many batch")
    args = ap.parse_args(argv)
    ns = [int(s) for s in args.n.split(",") if s]
    from eomc.errors import EomcError
    rows = []
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as cache:
        for label, model in models(ns):
            built, build_s, ops = {}, {}, {}
            for f in ("recursive", "kane"):        # interleaved per model
                built[f], build_s[f] = _build(label, model, f, cache)
                ops[f] = sum(built[f].metadata["op_counts"]["rhs"].values())
            x = _state(built["kane"], model)
            rng = np.random.default_rng(7)
            diff = 0.0
            for _ in range(5):      # random consistent states near the start
                xs = x.copy()
                xs[:len(xs)] += rng.uniform(-0.2, 0.2, len(xs))
                try:
                    xs = np.asarray(built["kane"].consistent_state(
                        dict(zip(built["kane"].state_names, xs))), dtype=float)
                except EomcError:
                    continue
                a, b = built["kane"].rhs(0.0, xs), built["recursive"].rhs(0.0, xs)
                diff = max(diff, float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(a)))))
            times = {"recursive": [], "kane": []}
            X = np.tile(x, (args.calls, 1))
            for _ in range(args.batches):
                for f in ("recursive", "kane"):
                    times[f].append(_time_calls(built[f], X))
            nu = built["kane"].nu
            drift = {f: _drift(built[f], x) for f in ("recursive", "kane")}
            rows.append((label, nu, nu - built["kane"].nvel, build_s["recursive"], build_s["kane"],
                         ops["recursive"], ops["kane"], statistics.median(times["recursive"]),
                         statistics.median(times["kane"]), diff, drift["recursive"], drift["kane"]))
            print(f"{label}: {rows[-1]}", flush=True)
    load_after = os.getloadavg()
    head = ("| model | speeds | dof | build CPU s: recursive | Kane | rhs ops: recursive | Kane "
            "| rhs ns/eval: recursive | Kane | max rel. diff | drift: recursive | Kane |\n"
            "|--|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    lines = [head] + [f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.2f} | {r[4]:.2f} | {r[5]} | {r[6]} | "
                      f"{r[7]:.0f} | {r[8]:.0f} | {r[9]:.1e} | {r[10]:.1e} | {r[11]:.1e} |" for r in rows]
    table = "\n".join(lines)
    print(table)
    if args.out:
        import sympy
        meta = (f"Run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node()} "
                f"({os.cpu_count()} cores), Python {platform.python_version()}, SymPy "
                f"{sympy.__version__}, NumPy {np.__version__}, load average before/after "
                f"{load_before[0]:.2f}/{load_after[0]:.2f}.")
        Path(args.out).write_text(_REPORT.format(meta=meta, table=table, argv=" ".join(sys.argv[1:])))
    return 0


_REPORT = """# Closed loops on the tree: recursive vs Kane (issue 19 item 3)

`python benchmarks/bench_loops.py {argv}`

{meta}

Build: a cold `eomc.compile(..., functions=["rhs", "constraints", "constraints_jac"])`
(the constraint functions are the same code in both formulations; they give the consistent
states) into an empty cache, process CPU time
(model construction excluded for the in-Python models; the four-bar's model file run
included), generate + gcc + load.  rhs ns/eval: `model.rhs_many` over 20000 copies of a
consistent state (one C loop), thread CPU time per evaluation, median of interleaved batches.
drift: the largest constraint residual (positions and velocities) along a 5 s DOP853 run
(rtol = atol = 1e-9, no projection), the first speed started at 1.  max rel. diff: the two rhs at 5 random consistent states.

{table}
"""


if __name__ == "__main__":
    sys.exit(main())
