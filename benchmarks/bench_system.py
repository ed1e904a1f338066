"""Derivation through ``System`` + joints: eomc vs SymPy 1.14, same script, same run.

Two models, written the way SymPy 1.14's docs write them and built once with
``eomc.mechanics`` and once with ``sympy.physics.mechanics`` (the module is
the only difference):

* "chain": an n-link planar pendulum, ``System.from_newtonian(ground)`` and n
  ``PinJoint``s (slender rods, uniform gravity);
* "cart": PyDy's n-link pendulum on a cart formed through ``System``: a
  ``PrismaticJoint`` cart, n ``PinJoint`` links, a ``ForceActuator`` input
  ``F`` on the cart.

Timed: thread CPU seconds (``time.thread_time``) of ``system.form_eoms()``
(Kane, the default) with the System built before ("form_eoms"), and of the
whole script incl. SymPy's joint kinematics ("total").  Pinned to one core,
SymPy's cache cleared before each run, eomc and SymPy interleaved per size,
medians of repeats while a run is cheap (< 2 s); once a SymPy run takes longer
than --sympy-budget, larger sizes of that model are not timed with SymPy.  For n <= 10 the two
mass_matrix_full / forcing_full are also compared numerically at a random
state (max relative difference).

    python3 benchmarks/bench_system.py                  # n = 1,2,5,10,20,30,40
    python3 benchmarks/bench_system.py --n 1,5,10 --quick
"""
import os
import pathlib
import statistics
import sys
import time

import numpy as np
import sympy as sm
import sympy.physics.mechanics as sme
from sympy.core.cache import clear_cache

_HERE = pathlib.Path(__file__).resolve().parent
sys.path[:0] = [str(_HERE)]

from common import environment_header, fmt, format_table, parse_args, ratio, write_results  # noqa: E402

import eomc.mechanics as em  # noqa: E402

DEFAULT_N = [1, 2, 5, 10, 20, 30, 40]
CHEAP = 2.0


def chain(n, me):
    """n slender rods hanging from PinJoints, gravity along -y."""
    q, u = me.dynamicsymbols(f"q1:{n + 1}"), me.dynamicsymbols(f"u1:{n + 1}")
    m, l = sm.symbols(f"m1:{n + 1}"), sm.symbols(f"l1:{n + 1}")
    g = sm.Symbol("g")
    ground = me.RigidBody("ground")
    system = me.System.from_newtonian(ground)
    parent, joints = ground, []
    for i in range(n):
        link = me.RigidBody(f"link{i + 1}", mass=m[i])
        link.inertia = me.Inertia.from_inertia_scalars(link.masscenter, link.frame,
                                                       0, 0, m[i] * l[i]**2 / 12)
        joints.append(me.PinJoint(f"J{i + 1}", parent, link, q[i], u[i], joint_axis=parent.z,
                                  parent_point=-l[i - 1] / 2 * parent.y if i else None,
                                  child_point=l[i] / 2 * link.y))
        parent = link
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.y)
    return system


def cart(n, me):
    """PyDy's n-link pendulum on a cart, through System: prismatic cart, n pin links, force F."""
    q, u = me.dynamicsymbols(f"q0:{n + 1}"), me.dynamicsymbols(f"u0:{n + 1}")
    m, l = sm.symbols(f"m0:{n + 1}"), sm.symbols(f"l1:{n + 1}")
    g, F = sm.Symbol("g"), me.dynamicsymbols("F")
    ground = me.RigidBody("ground")
    system = me.System.from_newtonian(ground)
    body = me.RigidBody("cart", mass=m[0])
    joints = [me.PrismaticJoint("slider", ground, body, q[0], u[0], joint_axis=ground.x)]
    system.add_actuators(me.ForceActuator(F, me.LinearPathway(ground.masscenter, body.masscenter)))
    parent = body
    for i in range(1, n + 1):
        bob = me.Particle(f"bob{i}", mass=m[i])
        link = me.RigidBody(f"rod{i}", mass=0)
        link.inertia = me.Inertia.from_inertia_scalars(link.masscenter, link.frame, 0, 0, 0)
        joints.append(me.PinJoint(f"J{i}", parent, link, q[i], u[i], joint_axis=ground.z,
                                  parent_point=-l[i - 2] * parent.y if i > 1 else None))
        bob.masscenter.set_pos(link.masscenter, -l[i - 1] * link.y)
        bob.masscenter.v2pt_theory(link.masscenter, ground.frame, link.frame)
        system.add_bodies(bob)
        parent = link
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.y)
    return system


MODELS = {"chain": chain, "cart": cart}


def _cpu(func):
    clear_cache()
    t0 = time.thread_time()
    out = func()
    return time.thread_time() - t0, out


def _timed(build, n, me, repeat):
    """Median (build + form_eoms, form_eoms) CPU seconds, and the last formed System.

    One run times both: the System is built (timed), then formed (timed).
    Repeats only while a run is cheap.
    """
    totals, forms, system = [], [], None
    for _ in range(repeat):
        t_build, system = _cpu(lambda: build(n, me))
        t_form, _ = _cpu(system.form_eoms)
        totals.append(t_build + t_form)
        forms.append(t_form)
        if t_build + t_form > CHEAP:
            break
    return statistics.median(totals), statistics.median(forms), system


def _agreement(ours, theirs):
    """Max relative difference of M_full and f_full at one random state (parameters random too)."""
    rng = np.random.default_rng(1)
    syms = set()
    for X in (theirs.mass_matrix_full, theirs.forcing_full):
        syms |= X.free_symbols | set(sme.find_dynamicsymbols(X))
    syms.discard(sme.dynamicsymbols._t)
    vals = {s: rng.uniform(0.5, 1.5) for s in syms}
    worst = 0.0
    for a, b in ((ours.mass_matrix_full, theirs.mass_matrix_full),
                 (ours.forcing_full, theirs.forcing_full)):
        A = np.array(sme.msubs(a, vals).evalf(), float)
        B = np.array(sme.msubs(b, vals).evalf(), float)
        worst = max(worst, float(np.abs(A - B).max() / max(1.0, np.abs(B).max())))
    return worst


def measure(model, n, repeat, sympy_max, sympy_skip):
    build = MODELS[model]
    row = {"model": model, "n": n}
    row["eomc_total"], row["eomc_form"], ours = _timed(build, n, em, repeat)
    if n <= sympy_max and not sympy_skip:
        row["sympy_total"], row["sympy_form"], theirs = _timed(build, n, sme, repeat)
        if n <= 10:
            row["diff"] = _agreement(ours, theirs)
    return row


HEADERS = ["model", "n", "eomc form_eoms s", "SymPy form_eoms s", "ratio",
           "eomc total s", "SymPy total s", "ratio", "max rel diff"]


def table_row(r):
    g = r.get
    return [r["model"], r["n"], g("eomc_form"), g("sympy_form"), ratio(g("sympy_form"), g("eomc_form")),
            g("eomc_total"), g("sympy_total"), ratio(g("sympy_total"), g("eomc_total")),
            fmt(g("diff"), 2) if g("diff") is not None else "n/a"]


def main(argv=None):
    def extra(p):
        p.add_argument("--sympy-max", type=int, default=40, help="largest n timed with SymPy")
        p.add_argument("--note", action="append", default=[], help="a line for the results file")
        p.add_argument("--sympy-budget", type=float, default=150.0,
                       help="seconds: after a SymPy run this long, larger n of that model skip SymPy")
        p.add_argument("--models", default="chain,cart", help="comma-separated: chain,cart")
    args = parse_args("System derivation, eomc vs SymPy", DEFAULT_N, default_repeat=3,
                      argv=argv, extra=extra)
    try:
        os.sched_setaffinity(0, {1})
    except (AttributeError, OSError):
        pass
    rows = []
    for model in args.models.split(","):
        skip = False
        for n in args.n:
            r = measure(model, n, args.repeat, args.sympy_max, skip)
            skip = skip or (r.get("sympy_total") or 0) > args.sympy_budget
            rows.append(table_row(r))
            print(" | ".join(fmt(c) for c in rows[-1]), flush=True)
    table = format_table(HEADERS, rows)
    print(table)
    if args.no_write:
        return
    notes = ["times are thread CPU seconds (time.thread_time), pinned to CPU 1, SymPy's cache cleared "
             "before each run; eomc and SymPy interleaved per size; medians of up to --repeat runs "
             "while a run takes < 2 s",
             "'form_eoms' = System.form_eoms() alone (Kane, the default), the System built first; "
             "'total' = building the System (SymPy's joint kinematics, the same code for both) + form_eoms",
             f"n/a for SymPy: skipped after one of its runs of that model took > {args.sympy_budget:g} s "
             "(--sympy-budget)",
             "max rel diff = |M_full, f_full (eomc) - (SymPy)| / max(1, |SymPy's|) at one random "
             "state and parameter set (n <= 10)"]
    notes += args.note
    text = environment_header("Derivation through System + joints: eomc vs SymPy 1.14", args, notes)
    text += "\n" + table + "\n"
    text += ("\n## Reading the table\n\n"
             "- The same script runs with `eomc.mechanics` and with `sympy.physics.mechanics`; eomc's "
             "System is SymPy's (subclassed), so the joints' kinematics cost the same and only the "
             "equation forming differs (eomc's KanesMethod).\n")
    csv_rows = [[c for c in r] for r in rows]
    for path in write_results("system", text, csv_rows, HEADERS):
        print("wrote", path)


if __name__ == "__main__":
    main()
