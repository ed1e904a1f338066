"""NAME_energy and NAME_poses of a robot's joint tree as C loops over its bodies.

Why: written straight-line, both functions place every body again (sines and cosines of every
joint, each body's rotation and origin as products of its parent's) and then add one term per
body (a kinetic and potential share) or store one frame per shown link: O(bodies) lines of C
that the default build compiled for outputs no integrator reads (G1: ~0.26 s of gcc and ~0.1 s
of Python on the issue-30 bar, default build <= 1.5x the rhs-only one).  The kernels' inputs
``an[]`` (NAME_dyn_inputs, :mod:`.dynamics_kernel`) and their placement NAME_rd_place
(:func:`.analytic.place_c`: each body's world rotation R, mass centre P, its dofs' axes in the
world Sw) already hold all a body's share or frame needs, so where both are in the file the two
functions call them and loop over per-body tables:

- NAME_energy: v_b = v_parent + Σ Sw_e u_e (world-frame twists, as NAME_dyn's RNEA), then per body
  m/2 |v_c|² + ω_bᵀ I_c ω_b / 2 - m g·P_b, v_c = v_O + ω × P_b the mass centre's velocity and
  ω_b = Rᵀ ω its turn in the body's axes, plus each dof's armature a u²/2; the rest of the energy
  (the joint limits' springs, contacts' elastic energy) stays the program's straight-line code, with
  the loop's sum as its input :data:`.contacts.BODY_ENERGY`.
- NAME_poses: the shown origins placed along the tree from the pose source's steps (a URDF link's
  origin from its parent link's: ``O_b = O_parent + R_parent s_b``), then each shown frame from its
  body's R and origin and its own constant turn D and offset o (a table of the program's values:
  constants, or the floating base's coordinates), then the named points.

The same quantities in another order of operations: equal to the straight-line functions to
rounding (tests/compiler/tree/test_body_loops.py states the bound).  The loops cost more per call
than the straight-line code (they evaluate all of an[]); neither function is on an integrator's
path.  Elsewhere (no NAME_dyn_inputs in the file: small trees, closed trees, a build without the
kernels; Kane's form; a SymPy System's poses) both stay straight-line.
"""
from ..emit.poses import POSE_TABLE
from ..emit.signatures import FUNCTION_ORDER
from .analytic import c_table, place_call
from .contacts import BODY_ENERGY
from .dynamics_kernel import INPUTS_CALL, inputs_users

__all__ = ["BODY_LOOPS", "placed", "energy_loop_body", "energy_loop_ops", "poses_loop_body", "poses_loop_ops"]

# False: NAME_energy and NAME_poses straight-line everywhere (the C before session 26; the tests'
# reference, benchmarks/bench_body_loops.py's "straight" contestant); a generator switch
# (compiler/build/reuse.generator_switches), held in the cache keys when off
BODY_LOOPS = True


def placed(sym, functions):
    """Whether NAME_dyn_inputs and NAME_rd_place are in the file before NAME_energy and NAME_poses:
    a user of the kernels' inputs (:func:`.dynamics_kernel.inputs_users`) emitted before them (the
    inputs are printed just before their first user).  Not beside a batch function (its lanes
    rewrite the printed code of the function they twin, not a call)."""
    if not BODY_LOOPS or getattr(sym, "analytic", None) is None or any(f.endswith("_batch") for f in functions):
        return False
    users = inputs_users(sym, functions)
    return bool(users) and FUNCTION_ORDER.index(users[0]) < FUNCTION_ORDER.index("energy")


def _decls(plan, more=""):
    """The kernels' inputs and NAME_rd_place's arrays, filled."""
    nb, nd = plan.nb, plan.nd
    return [f"    double an[{plan.size}];",
            f"    double R[{9 * nb}], P[{3 * nb}], Sw[{6 * nd}], Y[{10 * nb}]{more};"]


def _place(name):
    return ["    " + INPUTS_CALL.format(name=name), place_call(name)]


def energy_loop_body(ctx, prog, sym, guards=()):
    """NAME_energy's body: the bodies' shares summed over the tree into ``eb`` (see the module
    doc), then the program's straight-line rest reading it (``guards``: the contact depths' broad
    phase, compiler/emit/generate.energy_guards)."""
    from ..emit.bodies import store, temps
    from ..emit.guards import guarded_temps
    plan, o, nq = sym.analytic, sym.analytic.offsets, ctx.nq
    pr = ctx.printer(prog)
    pr._names[BODY_ENERGY] = "eb"
    lines = _decls(plan, f", V[{6 * plan.nb}]")
    lines += [c_table("par", plan.par), c_table("d0", plan.first), c_table("nd", plan.count),
              c_table("row", plan.row),
              "    double eb = 0.0;",
              "    int b, i, e, l;"]
    lines += _place(ctx.name)
    lines += [
        f"    for (b = 0; b < {plan.nb}; b++) {{   /* each body's kinetic energy and gravity potential */",
        f"        const double *Rb = R + 9 * b, *pb = P + 3 * b, *In = an + {o['I']} + 10 * b;",
        "        double *vb = V + 6 * b, w[3], vc[3];",
        "        l = par[b];",
        "        for (i = 0; i < 6; i++) vb[i] = l >= 0 ? V[6 * l + i] : 0.0;",
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* v += S u, and the armature's a u^2 / 2 */",
        "            const double *s = Sw + 6 * e;",
        f"            const double ue = x[{nq} + row[e]];",
        "            for (i = 0; i < 6; i++) vb[i] += s[i] * ue;",
        f"            eb += 0.5 * an[{o['arm']} + e] * ue * ue;",
        "        }",
        "        /* the mass centre's velocity v_O + w x p, the turn in the body's axes R^T w */",
        "        vc[0] = vb[3] + vb[1] * pb[2] - vb[2] * pb[1];",
        "        vc[1] = vb[4] + vb[2] * pb[0] - vb[0] * pb[2];",
        "        vc[2] = vb[5] + vb[0] * pb[1] - vb[1] * pb[0];",
        "        for (i = 0; i < 3; i++) w[i] = Rb[i] * vb[0] + Rb[3 + i] * vb[1] + Rb[6 + i] * vb[2];",
        "        eb += 0.5 * (In[0] * (vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2])",
        "                     + w[0] * (In[1] * w[0] + In[2] * w[1] + In[3] * w[2])",
        "                     + w[1] * (In[4] * w[0] + In[5] * w[1] + In[6] * w[2])",
        "                     + w[2] * (In[7] * w[0] + In[8] * w[1] + In[9] * w[2]))",
        f"              - In[0] * (an[{o['g']}] * pb[0] + an[{o['g']} + 1] * pb[1] + an[{o['g']} + 2] * pb[2]);",
        "    }",
    ]
    if guards:
        rest, pr = guarded_temps(prog, pr, guards)
    else:
        rest = temps(prog, pr)
    lines += rest
    lines.append(store("out[0]", prog.result_exprs("en").get(("en", 0), 0.0), pr))
    lines.append(f"    return {ctx.name}_finite(out, 1);")
    return lines


def _place_ops(plan):
    """NAME_dyn_inputs is the program's; NAME_rd_place's ~110 per body and ~25 per dof
    (.dynamics_kernel.dynamics_ops' count of the same code)."""
    return {"adds": 100 * plan.nb + 22 * plan.nd, "muls": 110 * plan.nb + 25 * plan.nd}


def energy_loop_ops(plan):
    """Operations of NAME_energy's loop (counted from the C above) and of the placement it calls."""
    c = _place_ops(plan)
    return {"adds": c["adds"] + 26 * plan.nb + 7 * plan.nd, "muls": c["muls"] + 31 * plan.nb + 10 * plan.nd,
            "divs": 0, "calls": 0}


def poses_loop_ops(plan, shape):
    """Operations of NAME_poses' loops and of the placement it calls."""
    c = _place_ops(plan)
    turned = sum(1 for _, d, _ in shape["frames"] if d >= 0)
    moved = sum(1 for _, _, m in shape["frames"] if m >= 0)
    return {"adds": c["adds"] + 9 * plan.nb + 18 * turned + 9 * moved,
            "muls": c["muls"] + 9 * plan.nb + 27 * turned + 9 * moved, "divs": 0, "calls": 0}


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
    lines = _decls(plan, f", O[{3 * nb}]")
    lines += [f"    static const double tc[{size}] = {{{', '.join(fixed)}}};",
              f"    double tb[{size}];",
              c_table("par", plan.par),
              c_table("fb", [b for b, _, _ in frames]), c_table("fd", [d for _, d, _ in frames]),
              c_table("fo", [m for _, _, m in frames])]
    if npt:
        lines.append(c_table("pf", points))
    lines += ["    static const double I3[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, Z3[3] = {0.0, 0.0, 0.0};",
              "    int b, i, j, k, l;"]
    lines += temps(prog, pr)
    lines.append(f"    for (k = 0; k < {size}; k++) tb[k] = tc[k];   /* the table: its constants, then the rest */")
    lines += [f"    tb[{k}] = {pr.doprint(e)};" for k, e in enumerate(entries) if not getattr(e, "is_number", True)]
    lines += _place(ctx.name)
    lines += [
        f"    for (b = 0; b < {nb}; b++) {{   /* each body's shown origin, from its parent's by its step */",
        "        const double *s = tb + 3 * b;",
        "        double *ob = O + 3 * b;",
        "        l = par[b];",
        "        if (l >= 0) {",
        "            const double *Rl = R + 9 * l, *ol = O + 3 * l;",
        "            for (i = 0; i < 3; i++) ob[i] = ol[i] + Rl[3 * i] * s[0] + Rl[3 * i + 1] * s[1] + Rl[3 * i + 2] * s[2];",
        "        } else {",
        "            for (i = 0; i < 3; i++) ob[i] = s[i];",
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
