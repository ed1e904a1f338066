"""NAME_energy and NAME_poses of a robot's joint tree as C loops over its bodies.

Why: written straight-line, both functions place every body again (each body's rotation and
origin as products of its parent's, its velocity) and then add one term per body (a kinetic and
potential share) or store one frame per shown link: O(bodies) lines of C that the default build
compiled for outputs no integrator step needs (G1: ~0.26 s of gcc and ~0.1 s of Python on issue
30's bar, default build <= 1.5x the rhs-only one).  The kernels' inputs ``an[]`` (NAME_dyn_inputs,
:mod:`.dynamics_kernel`: each body's rotation E and offset r from its parent, its dofs' axes S, mass
and inertia about its mass centre, gravity, armature) hold all a share or a frame needs, so where
NAME_dyn_inputs is in the file the two functions call it and loop over the bodies:

- NAME_energy, in each body's axes (the straight-line code's own recursion): its turn w = E w_l +
  S_w u, its mass centre's velocity v = E (v_l + w_l x r) + S_v u, gravity g_b = E g_l and the
  height term g.p = (g.p)_l + g_l.r (no world rotation is formed), then m/2 |v|² + wᵀ I w / 2 - m g.p
  and each dof's armature a u²/2.  The rest of the energy (the joint limits' springs, contacts'
  elastic energy) stays the program's straight-line code, with the loop's sum as its input
  :data:`.contacts.BODY_ENERGY`.
- NAME_poses: each body's world rotation R = R_l Eᵀ (NAME_rd_place's operations) and its shown
  origin from its parent's by the pose source's step (a URDF link's origin from its parent link's,
  O = O_l + R_l s), then each shown frame from its body's R and origin and its own turn D and offset
  o, then the named points; the steps, D and o are a table of the program's values (constants, the
  floating base's coordinates, parameters).

The same quantities in another order of operations: equal to the straight-line functions to
rounding (tests/compiler/tree/test_body_loops.py; benchmarks/results/body_loops.md measures both
against main's libraries).  Per call the loops cost more than the straight-line code, whose
constants (axes, zeros of the joint rotations) the optimizer folds and which reads no law slopes
(NAME_dyn_inputs computes all of an[]); neither function is on an integrator's step (the fixed
step's energy watch calls NAME_energy once a step).  Elsewhere (no NAME_dyn_inputs in the file:
small or closed trees, a build without the kernels, a batch function beside them; Kane's form; a
SymPy System's poses) both stay straight-line.
"""
from ..emit.poses import POSE_TABLE
from ..emit.signatures import FUNCTION_ORDER
from .analytic import c_table
from .contacts import BODY_ENERGY
from .dynamics_kernel import INPUTS_CALL, inputs_users

__all__ = ["BODY_LOOPS", "placed", "energy_loop_body", "energy_loop_ops", "poses_loop_body", "poses_loop_ops"]

# False: NAME_energy and NAME_poses straight-line everywhere (the C before session 26; the tests'
# reference, benchmarks/bench_body_loops.py's "straight" contestant); a generator switch
# (compiler/build/reuse.generator_switches), held in the cache keys when off
BODY_LOOPS = True


def placed(sym, functions):
    """Whether NAME_dyn_inputs is in the file before NAME_energy and NAME_poses:
    a user of the kernels' inputs (:func:`.dynamics_kernel.inputs_users`) emitted before them (the
    inputs are printed just before their first user).  Not beside a batch function (its lanes
    rewrite the printed code of the function they twin, not a call)."""
    if not BODY_LOOPS or getattr(sym, "analytic", None) is None or any(f.endswith("_batch") for f in functions):
        return False
    users = inputs_users(sym, functions)
    return bool(users) and FUNCTION_ORDER.index(users[0]) < FUNCTION_ORDER.index("energy")


def _inputs(plan, more):
    """The kernels' inputs an[] (NAME_dyn_inputs, emitted before the first of its users) and the
    loop's per-body arrays ``more``."""
    return [f"    double an[{plan.size}], {more};", c_table("par", plan.par)]


def energy_loop_body(ctx, prog, sym, guards=()):
    """NAME_energy's body: the bodies' shares summed over the tree into ``eb`` (see the module
    doc), then the program's straight-line rest reading it (``guards``: the contact depths' broad
    phase, compiler/emit/generate.energy_guards)."""
    from ..emit.bodies import store, temps
    from ..emit.guards import guarded_temps
    plan, o, nq, nb = sym.analytic, sym.analytic.offsets, ctx.nq, sym.analytic.nb
    pr = ctx.printer(prog)
    pr._names[BODY_ENERGY] = "eb"
    lines = _inputs(plan, f"W[{3 * nb}], V[{3 * nb}], G[{3 * nb}], H[{nb}]")
    lines += [c_table("d0", plan.first), c_table("nd", plan.count), c_table("row", plan.row),
              "    double eb = 0.0;",
              "    int b, i, e, l;",
              "    " + INPUTS_CALL.format(name=ctx.name),
              f"    for (b = 0; b < {nb}; b++) {{   /* each body's kinetic energy and gravity potential */",
              f"        const double *E = an + 9 * b, *r = an + {o['r']} + 3 * b, *In = an + {o['I']} + 10 * b;",
              "        double *w = W + 3 * b, *v = V + 3 * b, *g = G + 3 * b, t[3], Iw[3];",
              "        l = par[b];",
              "        if (l >= 0) {   /* from the parent: turn, mass centre's velocity, gravity, in the body's axes */",
              "            const double *wl = W + 3 * l, *vl = V + 3 * l, *gl = G + 3 * l;",
              "            t[0] = vl[0] + wl[1] * r[2] - wl[2] * r[1];",
              "            t[1] = vl[1] + wl[2] * r[0] - wl[0] * r[2];",
              "            t[2] = vl[2] + wl[0] * r[1] - wl[1] * r[0];",
              "            for (i = 0; i < 3; i++) {",
              "                w[i] = E[3 * i] * wl[0] + E[3 * i + 1] * wl[1] + E[3 * i + 2] * wl[2];",
              "                v[i] = E[3 * i] * t[0] + E[3 * i + 1] * t[1] + E[3 * i + 2] * t[2];",
              "                g[i] = E[3 * i] * gl[0] + E[3 * i + 1] * gl[1] + E[3 * i + 2] * gl[2];",
              "            }",
              "            H[b] = H[l] + gl[0] * r[0] + gl[1] * r[1] + gl[2] * r[2];   /* g . p */",
              "        } else {",
              f"            const double *gw = an + {o['g']};",
              "            for (i = 0; i < 3; i++) {",
              "                w[i] = v[i] = 0.0;",
              "                g[i] = E[3 * i] * gw[0] + E[3 * i + 1] * gw[1] + E[3 * i + 2] * gw[2];",
              "            }",
              "            H[b] = gw[0] * r[0] + gw[1] * r[1] + gw[2] * r[2];",
              "        }",
              "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* v += S u, and the armature's a u^2 / 2 */",
              f"            const double *S = an + {o['S']} + 6 * e;",
              f"            const double ue = x[{nq} + row[e]];",
              "            for (i = 0; i < 3; i++) {",
              "                w[i] += S[i] * ue;",
              "                v[i] += S[3 + i] * ue;",
              "            }",
              f"            eb += 0.5 * an[{o['arm']} + e] * ue * ue;",
              "        }",
              "        for (i = 0; i < 3; i++) Iw[i] = In[1 + 3 * i] * w[0] + In[2 + 3 * i] * w[1] + In[3 + 3 * i] * w[2];",
              "        eb += 0.5 * (In[0] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + w[0] * Iw[0] + w[1] * Iw[1]"
              " + w[2] * Iw[2])",
              "              - In[0] * H[b];",
              "    }"]
    if guards:
        rest, pr = guarded_temps(prog, pr, guards)
    else:
        rest = temps(prog, pr)
    lines += rest
    lines.append(store("out[0]", prog.result_exprs("en").get(("en", 0), 0.0), pr))
    lines.append(f"    return {ctx.name}_finite(out, 1);")
    return lines


def energy_loop_ops(plan):
    """Operations of NAME_energy's loop (counted from the C above; NAME_dyn_inputs is the program's)."""
    return {"adds": 40 * plan.nb + 7 * plan.nd, "muls": 56 * plan.nb + 10 * plan.nd, "divs": 0, "calls": 0}


def poses_loop_ops(plan, shape):
    """Operations of NAME_poses' loops (counted from the C below)."""
    turned = sum(1 for _, d, _ in shape["frames"] if d >= 0)
    moved = sum(1 for _, _, m in shape["frames"] if m >= 0)
    return {"adds": 27 * plan.nb + 18 * turned + 9 * moved, "muls": 36 * plan.nb + 27 * turned + 9 * moved,
            "divs": 0, "calls": 0}


def poses_loop_body(ctx, prog, sym, shape):
    """NAME_poses' body (see the module doc): ``shape`` (compiler/tree/poses.TreePoseSource.table):
    per frame its body (-1: the world), where its turn D and offset o are in the table (-1: none),
    per point its frame (-1: the world's origin); the table's values are the program's results."""
    from ..emit.bodies import temps
    plan, nb = sym.analytic, sym.analytic.nb
    pr = ctx.printer(prog)
    vals = prog.result_exprs(POSE_TABLE)
    size = shape["size"]
    entries = [vals.get((POSE_TABLE, k), 0) for k in range(size)]
    fixed = [pr.doprint(e) if getattr(e, "is_number", True) else "0.0" for e in entries]
    frames, points = shape["frames"], shape["points"]
    nf, npt = len(frames), len(points)
    lines = _inputs(plan, f"R[{9 * nb}], O[{3 * nb}]")
    lines += [f"    static const double tc[{size}] = {{{', '.join(fixed)}}};",
              f"    double tb[{size}];",
              c_table("fb", [b for b, _, _ in frames]), c_table("fd", [d for _, d, _ in frames]),
              c_table("fo", [m for _, _, m in frames])]
    if npt:
        lines.append(c_table("pf", points))
    lines += ["    static const double I3[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, Z3[3] = {0.0, 0.0, 0.0};",
              "    int b, i, j, k, l;"]
    lines += temps(prog, pr)
    lines.append(f"    for (k = 0; k < {size}; k++) tb[k] = tc[k];   /* the table: its constants, then the rest */")
    lines += [f"    tb[{k}] = {pr.doprint(e)};" for k, e in enumerate(entries) if not getattr(e, "is_number", True)]
    lines += ["    " + INPUTS_CALL.format(name=ctx.name),
        f"    for (b = 0; b < {nb}; b++) {{   /* each body's rotation (as NAME_rd_place's) and shown origin (its step) */",
        "        const double *E = an + 9 * b, *s = tb + 3 * b;",
        "        double *Rb = R + 9 * b, *ob = O + 3 * b;",
        "        l = par[b];",
        "        if (l >= 0) {",
        "            const double *Rl = R + 9 * l, *ol = O + 3 * l;",
        "            for (i = 0; i < 3; i++) {",
        "                for (j = 0; j < 3; j++)",
        "                    Rb[3 * i + j] = Rl[3 * i] * E[3 * j] + Rl[3 * i + 1] * E[3 * j + 1] + Rl[3 * i + 2] * E[3 * j + 2];",
        "                ob[i] = ol[i] + Rl[3 * i] * s[0] + Rl[3 * i + 1] * s[1] + Rl[3 * i + 2] * s[2];",
        "            }",
        "        } else {",
        "            for (i = 0; i < 3; i++) {",
        "                for (j = 0; j < 3; j++) Rb[3 * i + j] = E[3 * j + i];",
        "                ob[i] = s[i];",
        "            }",
        "        }",
        "    }",
        f"    for (k = 0; k < {nf}; k++) {{   /* each frame: position (3), rotation (9, rows) */",
        "        const double *Rb = fb[k] >= 0 ? R + 9 * fb[k] : I3, *ob = fb[k] >= 0 ? O + 3 * fb[k] : Z3;",
        "        double *f = out + 12 * k;",
        "        for (i = 0; i < 3; i++) {",
        "            f[i] = ob[i];",
        "            if (fo[k] >= 0) {",
        "                const double *m = tb + fo[k];",
        "                f[i] += Rb[3 * i] * m[0] + Rb[3 * i + 1] * m[1] + Rb[3 * i + 2] * m[2];",
        "            }",
        "            if (fd[k] >= 0) {",
        "                const double *D = tb + fd[k];",
        "                for (j = 0; j < 3; j++)",
        "                    f[3 + 3 * i + j] = Rb[3 * i] * D[j] + Rb[3 * i + 1] * D[3 + j] + Rb[3 * i + 2] * D[6 + j];",
        "            } else {",
        "                for (j = 0; j < 3; j++) f[3 + 3 * i + j] = Rb[3 * i + j];",
        "            }",
        "        }",
        "    }",
    ]
    if npt:
        lines += [f"    for (k = 0; k < {npt}; k++)   /* each point: its frame's origin (-1: the world's) */",
                  "        for (i = 0; i < 3; i++)",
                  f"            out[{12 * nf} + 3 * k + i] = pf[k] >= 0 ? out[12 * pf[k] + i] : 0.0;"]
    lines.append(f"    return {ctx.name}_finite(out, {12 * nf + 3 * npt});")
    return lines
