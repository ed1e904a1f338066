"""Issue 30: the adjoint gradient of an adaptive (DOP853) trajectory cost with respect to every
parameter, against one simulation and central differences, measured in the same run.

Model: a robot from example-robot-data (default: Unitree G1, floating base, 29 joints, its
inertial parameters -- 10 per body -- and every other parameter), recursive formulation, built
with rhs and vjp.  Trajectory: from a bent pose with joint speeds up to 2 rad/s, falling
under gravity without joint torques, T = 1 s, cost = least squares of every joint coordinate
against a reference run with other inertial parameters, on a 0.05 s grid.

Contestants (thread CPU time, one core, interleaved, medians of --repeat):
- one simulation: ``model.simulate(method="dop853", t_eval=grid)`` at the same tolerance;
- the adjoint: ``eomc.gradient(..., method="dop853")`` -- the forward run (steps ending on the
  grid, accepted steps and their stage derivatives recorded) and the backward run in C with
  vjp (12 calls a step, no rhs), for x0 and all parameters at once;
- central differences of whole adaptive runs, 2 runs per parameter, timed on --fd parameters
  and scaled to all of them (the column says so); their values check the adjoint's.
Goal (issue 30): the gradient with respect to all inertial parameters of G1 <= 5x one simulation.
``--method radau``: the same with Radau IIA (the model then also built with jac_x; the backward
run solves each step's transposed collocation system by iteration preconditioned with one
Jacobian in the method's eigenbasis, its residuals the step's vjp calls; one more contestant:
the same gradient with each step's system solved densely, 3nx unknowns, RADAU_DENSE), written
to adjoint_adaptive_<robot>_radau.md.
"""
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

from common import environment_header, format_table, parse_args, pin_to_one_core, write_results  # noqa: E402

ROBOTS = {"g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
          "ur5": ("ur_description/urdf/ur5_robot.urdf", False)}
INERTIAL = ("m_", "cx_", "cy_", "cz_", "Ixx_", "Iyy_", "Izz_", "Ixy_", "Ixz_", "Iyz_")
T, DT = 1.0, 0.05


def build(case, cache, method="dop853"):
    import eomc
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import robot_path
    rel, floating = ROBOTS[case]
    system = from_urdf(robot_path(rel), floating_base=floating, limits=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        functions = ["rhs", "jac_x", "vjp"] if method == "radau" else ["rhs", "vjp"]
        return eomc.compile(system, case + ("_jx" if method == "radau" else ""), functions=functions,
                            formulation="recursive",
                            cache_dir=cache, progress=False)


def main(argv=None):
    args = parse_args(__doc__.splitlines()[0], [0], default_repeat=3, argv=argv,
                      extra=lambda p: (p.add_argument("--robot", default="g1"),
                                       p.add_argument("--tol", type=float, default=1e-8),
                                       p.add_argument("--fd", type=int, default=6),
                                       p.add_argument("--cache", default=None),
                                       p.add_argument("--method", default="dop853",
                                                      choices=["dop853", "radau"])))
    import eomc
    from eomc.runtime.adjoint import simulate_grid
    pin_to_one_core()
    model = build(args.robot, args.cache, args.method)
    rng = np.random.default_rng(0)
    nq, nu = model.nq, model.nu
    x0 = np.zeros(model.nx)
    x0[:nq] = rng.uniform(-0.3, 0.3, nq)
    x0[nq:nq + nu] = rng.uniform(-2.0, 2.0, nu)
    # no joint torques: constant torques of a few N m spin G1's wrists (inertia ~5e-4 kg m^2)
    # hundreds of radians in 0.5 s, a chaotic run whose differences mean nothing
    r = np.zeros(model.ninput) if model.ninput else None
    p = np.array(model.param_defaults, dtype=float)
    inertial = [i for i, n in enumerate(model.param_names) if n.startswith(INERTIAL)]
    p_ref = p.copy()
    p_ref[inertial] *= rng.uniform(0.9, 1.1, len(inertial))
    kw = dict(dt=DT, r=r, method=args.method, rtol=args.tol, atol=args.tol)
    t, X_ref = simulate_grid(model, x0, T, p=p_ref, **kw)
    joints = slice(6 if ROBOTS[args.robot][1] else 0, nq)

    def cost(t, X):
        d = X[:, joints] - X_ref[:, joints]
        G = np.zeros_like(X)
        G[:, joints] = d / len(t)
        return 0.5 * float(np.sum(d * d)) / len(t), G

    fd_cols = [inertial[k] for k in np.linspace(0, len(inertial) - 1, args.fd).astype(int)]

    def plain():
        return model.simulate(x0, (0.0, T), p=p, r=r, method=args.method, rtol=args.tol, atol=args.tol,
                              t_eval=t)

    def adjoint():
        return eomc.gradient(model, x0, T, cost=cost, p=p, **kw)

    def central():
        out = []
        for i in fd_cols:
            h = 1e-6 * max(abs(p[i]), 1e-3)
            pp, pm = p.copy(), p.copy()
            pp[i] += h
            pm[i] -= h
            out.append((cost(*simulate_grid(model, x0, T, p=pp, **kw))[0]
                        - cost(*simulate_grid(model, x0, T, p=pm, **kw))[0]) / (2 * h))
        return np.array(out)

    def dense():
        from eomc.runtime import adjoint as adjoint_module
        adjoint_module.RADAU_DENSE = True
        try:
            return eomc.gradient(model, x0, T, cost=cost, p=p, **kw)
        finally:
            adjoint_module.RADAU_DENSE = False

    contestants = {"plain": plain, "adjoint": adjoint, "fd": central}
    if args.method == "radau":
        contestants["dense"] = dense
    cpu = {k: [] for k in contestants}
    val = {}
    for _ in range(args.repeat):
        for k, f in contestants.items():
            t0 = time.thread_time()
            val[k] = f()
            cpu[k].append(time.thread_time() - t0)
    base = float(np.median(cpu["plain"]))
    adj = float(np.median(cpu["adjoint"]))
    fd = float(np.median(cpu["fd"])) * len(inertial) / len(fd_cols)
    g = val["adjoint"].dp[fd_cols]
    agree = float(np.max(np.abs(g - val["fd"])) / np.max(np.abs(val["fd"])))
    steps = val["plain"].stats["steps"]
    rows = [[f"one simulation ({args.method}, t_eval = grid)", f"{base * 1e3:.2f}", "1.00", steps, ""],
            [f"adjoint gradient: x0 + all {model.nparam} parameters ({len(inertial)} inertial)",
             f"{adj * 1e3:.2f}", f"{adj / base:.2f}", "", f"{agree:.1e}"],
            *([[f"adjoint gradient, each step's system by dense 3nx LU (RADAU_DENSE)",
                f"{np.median(cpu['dense']) * 1e3:.2f}", f"{np.median(cpu['dense']) / base:.2f}", "",
                f"{np.max(np.abs(val['dense'].dp[fd_cols] - val['fd'])) / np.max(np.abs(val['fd'])):.1e}"]]
              if "dense" in cpu else []),
            [f"central differences, {len(inertial)} inertial parameters (timed on {len(fd_cols)}, scaled)",
             f"{fd * 1e3:.1f}", f"{fd / base:.1f}", "", "(reference)"]]
    headers = ["contestant", "CPU ms (median)", "x one simulation", "steps",
               f"max |adjoint - differences| / max |differences| ({len(fd_cols)} parameters)"]
    table = format_table(headers, rows)
    print(table)
    if not args.no_write:
        text = environment_header(f"Adjoint gradient of a {args.method} trajectory, {args.robot}, "
                                  f"T = {T} s, grid {DT} s, tol {args.tol:g}", args,
                                  notes=["one process pinned to one core; contestants interleaved; "
                                         "thread CPU time, medians",
                                         f"model: nx = {model.nx}, {model.nparam} parameters; "
                                         "goal (issue 30): <= 5x one simulation for all inertial "
                                         "parameters of G1"]) + "\n" + table + "\n"
        suffix = "_radau" if args.method == "radau" else ""
        write_results(f"adjoint_adaptive_{args.robot}{suffix}", text,
                      [[args.robot, args.tol, base, adj, fd, agree, steps]],
                      ["robot", "tol", "plain_s", "adjoint_s", "differences_s", "agreement", "steps"],
                      keep_notes=True)


if __name__ == "__main__":
    main()
