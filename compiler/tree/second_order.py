"""Analytic second-order derivatives of RNEA (hess_id) as C loops over the tree's support sets.

Why: hess_id by forward over reverse on RNEA's straight-line trace (compiler/emit/reverse.py)
is a reverse sweep per row of τ and its tangent per state column: O(n³) work with a large
constant (8 M operations on the 20-link cart), 4-17x slower than Pinocchio's second-order
RNEA derivatives.  The spatial-algebra structure (Singh, Russell & Wensing, "Efficient
Analytical Derivatives of Rigid-Body Dynamics using Spatial Vector Algebra", RA-L 2022, the
algorithm of Pinocchio's ComputeRNEASecondOrderDerivatives) makes every entry of ∂²τ/∂x²
a few 6-vector dot products per triple of joints i ⪰ j ⪰ k on one root-to-leaf path: O(n·d²)
work with small constants, O(1) code, in the style of the first-order kernel (:mod:`.analytic`,
whose plan, inputs ``an[]``, world placement, inertias and their variations it shares).

The kernel (``NAME_rnea_hess``): a forward pass in the world frame per body -- axis S,
ψ̇ = v_λ × S, ψ̈ = a_λ × S + v_λ × ψ̇, φ̇ = v × S, velocity, acceleration (gravity as the
root's), world inertia Y, its variation B = v ×* Y - Y (v ×) + (· ×* Y v) and force
f = Y a + v ×* Y v - load -- then a backward pass that, at each dof i with the composites
Yᶜ, Bᶜ, Fᶜ of its subtree, forms two 6x6 operators (R1 = variation of Yᶜ along S_i, R3 =
along ψ̇_i plus Bᶜ's commutator with S_i) and a few 6-vectors, per support dof j a dozen
6-vectors, and per support dof k of j the entries of the three blocks ∂²τ/∂q², ∂²τ/∂u²,
∂²τ/∂q∂u for the rows i, j, k.  The operators' symmetries (R1, R1's ψ̇ analogue symmetric,
(x ↦ x ×* f) antisymmetric) replace Pinocchio's 6x6 products by vectors.

Output: out[(i nx + j) nx + k] = ∂²τ_i/∂x_j∂x_k (the layout of the reverse path), zero
outside the support paths and the extra states: those entries are left as the caller zeroed
them once (Pinocchio's contract; ``ZERO``), or with ``ZERO`` set zeroed by the kernel.

Where it applies (:func:`second_order_plan`): an analytic plan (:func:`.analytic.analytic_plan`):
revolute and prismatic joints (bodies welded by fixed joints included), joint laws
(URDF/MJCF soft limits, damping, friction): their own curvature is added on their rows'
(q, u) entries after the loops (:func:`with_law_hessians`; why: URDF robots are built with
their limits on by default, and took the reverse path, 10-20x slower); and joints of k
speeds whose axes are fixed in the child (eomc's free joint -- body XYZ Euler angles,
body-frame speeds, Pinocchio's free-flyer speeds --, balls, planar joints).  Those run as
Pinocchio runs them: "j != i" and "k != j" are between joints, every dof of a joint in the
support of every other, which gives the tensor along the joint's tangent ξ (Pinocchio's
Lie-group tangent); hess_id is along the coordinates q (q' = K(q) u), so the kernel then
changes those entries to q with K⁻¹, dK/dq and the first derivatives along ξ
(:func:`_tangent_lines`; why: floating bases -- Go2, G1, Talos -- took the reverse path).
With such a joint at the root (a floating base's free joint) the kernel runs in the root body's own
frame, where the joint's axes are constants, and the pairs (i, j) with j in it take their pair
vectors and dots in a few terms each (:func:`_root_frame`, :func:`_root_pair_lines`,
:func:`_root_dot_lines`: the trunk as one block; Go2 20.3 -> 16.4 us, session 18).
Trees with ground contacts or loops keep the reverse path; the model's metadata ``hess_id``
says which one it got and why.

Checked against central differences of jac_id, the reverse path and Pinocchio
(tests/compiler/tree/test_second_order.py).
"""
from collections import Counter
from dataclasses import replace

import sympy as sm

from ..emit.bodies import IND, store, temps
from ..ir.opcount import count_ops
from .analytic import (AVX2_GUARD, VARIATION_LINES, WORLD_INERTIA_LINES, body_head_lines, c_table, finite_lines, rd_helpers,
                       tree_tables, world_load_lines)

__all__ = ["ANH", "second_order_plan", "with_law_hessians", "with_k_derivatives", "second_order_c", "second_order_body",
           "second_order_ops", "second_order_note"]

ANH = "anh"     # the result group of the kernel's inputs (the analytic plan's values)


def second_order_plan(plan):
    """(plan, None) when the kernel covers the tree, else (None, the reason in the user's terms)."""
    if plan is None:
        return None, ("the tree does not qualify for the analytic derivatives (closed loops, "
                      "state-dependent loads or contacts)")
    if plan.contacts:       # the first-order kernel's ground-contact terms (analytic.py, block G)
        return None, "ground contacts: not covered yet"
    if plan.npair:          # the body-body pairs' wrench tangents (analytic.py, block W)
        return None, "body-body pairs: not covered yet"
    if plan.kcols:          # a quaternion joint's K⁺ (analytic.py): its second derivatives are not written
        return None, "quaternion coordinates: not covered yet"
    return plan, None


def with_law_hessians(plan, values, x, nq):
    """(plan, values) with the joint laws' second derivatives appended to the kernel's inputs
    (block L2: ∂²τ/∂q², ∂²τ/∂q∂u, ∂²τ/∂u² per law dof, in the order of ``plan.laws``).

    Why this is all the laws need: a law is the generalized force e_k·τ_k(q_k, u_k) on its own
    speed (the pair of loads about the joint axis, :mod:`.analytic`), which the kernel carries as
    a constant load in F -- a pair whose generalized force does not move with any joint, so the
    kernel's terms for it are exactly its value's, and the law's own curvature touches only
    row k's (q_k, u_k) entries.  The second derivatives are taken here, from the first ones
    already in block L (``values``: the analytic plan's [((group, i), expr)]; ``x`` the state
    symbols, ``nq`` the number of coordinates), so the first-order kernel's inputs and C stay
    as they were."""
    if not plan.laws:
        return plan, values
    vals = {k[1]: e for k, e in values}
    group = values[0][0][0]
    L, extra = plan.offsets["L"], []
    for j, e in enumerate(plan.laws):
        qs, us = x[plan.qcol[e]], x[nq + plan.row[e]]
        dq, du = sm.sympify(vals[L + 2 * j]), sm.sympify(vals[L + 2 * j + 1])
        extra += [_tidy(sm.diff(dq, qs)), _tidy(sm.diff(dq, us)), _tidy(sm.diff(du, us))]
    n = plan.size
    plan = replace(plan, offsets={**plan.offsets, "L2": n}, size=n + len(extra))
    return plan, list(values) + [((group, n + i), v) for i, v in enumerate(extra)]


def _tidy(e):
    """``e`` with the terms of each limit side (each set of ramp(·) it reads) over one
    denominator and factored.  Why: the plain second derivative of the limit law
    g²(k r + c u g), g = r/(r + e), is a sum of terms of size k·r/(r + e)² that cancel to
    k·6e²r/(r + e)⁴ far past a limit: measured 5.7e-11 relative error 1700 widths past,
    (the old forward-over-reverse path 3e-13), 5e-16 in this form.  (Not expanded first:
    expand-then-factor gives the same form at 5x the build time, ~0.2 s a joint.)"""
    from .joint_laws import ramp
    groups = {}
    for t in sm.Add.make_args(e):
        groups.setdefault(frozenset(t.atoms(ramp)), []).append(t)
    return sm.Add(*[sm.factor(sm.Add(*ts)) if key else sm.Add(*ts) for key, ts in groups.items()])


# The finiteness check without a pass over the output (O(n^3) numbers; 5 of cart20's 48 us), from
# the numbers per dof, not per pair: every stored number is built from the per-dof-i numbers (the
# operators R1, R3, the vectors Y S_i, B^T S_i, g5, g7 and the composite inertia Y, B's entries
# folded in) and the per-dof columns of K (S, psi', psi'', psi' + phi', and with a root k-speed
# joint psi', psi'' along its coordinates, _k_folded_lines), each within BOUND = B:
# a pair vector is a 6x6 product or a force cross product of those, at most 25 B^3 (u4's
# S_i x* (Y s_j) is the cubic one, 20 B^3; the rest within 24 B^2), a dot with a K column at most
# 150 B^4, a store the sum of two (300 B^4), or such minus a joint law's curvature h within
# 1e300: with B = 1e70, every output is within 1e300 + 1e283: finite
# (the k-speed joints' own (q, q) blocks, _tangent_lines, are checked number by number, except a
# folded joint's: with K^-1 within 1, Tq within 9 B^2 and dK^-1/dq checked within B, _folded_block_lines,
# each entry is within 6 (300 B^4 + 9 B^3)).  Else (or
# a NaN anywhere, which fails every <=) the output is checked entry by entry as before, so the
# result (an error exactly when an output is not finite) is the same.  Why per dof: the check of
# the pair's 48 numbers was 7 % of Go2's hess_id (knock-out, 2.5 of 34.7 us; 132 pairs, 18 dofs).
BOUND = "1e70"

# True: the k-speed joints' entries stay along their tangent xi (Pinocchio's Lie-group tangent;
# no change to their coordinates, :func:`_tangent_lines`) -- to compare with Pinocchio's tensors
# and time the change (tests, benchmarks/bench_second_order.py).  Part of the build cache's key
# when set (build/reuse.generator_switches).
TANGENT = False

# Outputs of at least this many numbers (8 bytes each; nu nx nx) are written by halves: the
# triple loop stores the entries whose row's dof is the deeper one, and each row's mirror images
# are copied once the row is complete (:func:`_pair_store`, :func:`_mirror_lines`).  Same-core
# A/B, machine build, bits unchanged: cart80 (2.1 M numbers) 5.40 -> 4.70 ms, cart40 (276 k)
# 406 -> 344 us; smaller outputs, in cache anyway, lose 1-3 % to the copy (cart20 (37 k)
# 51.3 -> 52.3 us, UR10 4.38 -> 4.46, Panda 8.75 -> 9.00).  0: every output (tests); part of the
# build cache's key when not the default (build/reuse.generator_switches).
HALF_FROM_DEFAULT = 1 << 17
HALF_FROM = HALF_FROM_DEFAULT

# False (the default since session 13): the kernel leaves the entries off the support paths (a row
# dof and two column dofs not on one root-to-leaf path: zero for every state) as the caller left
# them, instead of zeroing the whole output first -- Pinocchio's contract (ComputeRNEASecondOrderDerivatives
# writes only those entries of its four nv^3 tensors, zeroed once when its Data is made): a C caller
# zeroes ``out`` once and may pass it again (``model.hess_id`` returns a new zeroed array).  Why: on a
# branched tree most entries are off the paths, and the zeroing wrote the whole output (Talos: 500 k
# numbers, 4 MB) every call; same-core A/B, machine build, bits of the written entries unchanged:
# Talos 198 -> 150 us, G1 99 -> 83, Go2 29.3 -> 27.8.  Chains (every entry written, _covers_all) are
# not zeroed either way.  True: zeroed every call (tests, benchmarks/bench_second_order.py); part
# of the build cache's key when set (build/reuse.generator_switches).
ZERO = False

# True (the default since session 18): with a folded root joint (a floating base's free joint) the kernel
# runs in each root body's own frame and the pairs (i, j) with j in that joint take the root dots
# (:func:`_root_frame`, :func:`_root_dot_lines`); False: the world frame and the lane dots for every j,
# as before (tests, A/B).  Part of the build cache's key when off (build/reuse.generator_switches).
ROOT_DOTS = True


def _half(plan, nx):
    """Whether the kernel writes its output by halves (HALF_FROM): one-speed joints only (the
    k-speed joints' change of coordinates reads both halves of the loop's entries)."""
    return not plan.multi and len(plan.row) * nx * nx >= HALF_FROM


def _covers_all(plan, nq, nx):
    """True when the triple loop writes every entry of the output, so it need not be zeroed
    first: the dofs form one path (each is on the support of, or supported by, every other:
    every (row, column, column) triple of dofs is one the loop visits) and the state is (q, u)
    of those dofs alone.  Checked with a NaN-filled output (tests/compiler/tree/test_second_order.py)."""
    nd = len(plan.lam)
    return nd > 0 and not plan.multi and len(paths(plan)[0]) == 1 and nq == nd and nx == 2 * nd


def second_order_note(plan, reason):
    """The metadata line of hess_id: which algorithm the model got."""
    if plan is not None:
        return "analytic second-order RNEA kernel (compiler/tree/second_order.py)"
    return f"forward over reverse on RNEA (compiler/emit/reverse.py): {reason}"


def second_order_c(name, plan, nq, nx, helpers):
    """The C text of ``NAME_rnea_hess(an, u, ud, out)`` (see the module doc); ``helpers``:
    write the NAME_rd_* helpers and NAME_rd_finite (False when the first-order kernel wrote them:
    one finiteness check for both kernels, :func:`.analytic.finite_lines`)."""
    nb, nd, o = plan.nb, plan.nd, plan.offsets
    fn = f"{name}_rnea_hess"
    rd = f"{name}_rd"
    nn = nx * nx
    nm = sum(k for _, k, _ in plan.multi)
    oj = "oj" if nm else "j != i"     # j in another joint than i (one-speed joints: another dof)
    cfg = _lanes_cfg(plan)
    half = _half(plan, nx)
    lines = (rd_helpers(name) + finite_lines(name) if helpers else []) + [
        *_lanes_macro(name),
        *(_prefetch_macro(name) if _scratch(plan, nq, nx, half) else []),
        f"static inline void {name}_h2_mv(const double *m, const double *x, double *out)",
        "{   /* out = M x, M 6x6 row-major, column by column (six sums side by side) */",
        "    double o0 = 0.0, o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;",
        "    int c;",
        "    for (c = 0; c < 6; c++) {",
        "        const double xc = x[c];",
        "        o0 += m[c] * xc; o1 += m[6 + c] * xc; o2 += m[12 + c] * xc;",
        "        o3 += m[18 + c] * xc; o4 += m[24 + c] * xc; o5 += m[30 + c] * xc;",
        "    }",
        "    out[0] = o0; out[1] = o1; out[2] = o2; out[3] = o3; out[4] = o4; out[5] = o5;",
        "}",
        "",
        f"static inline void {name}_h2_mtv(const double *m, const double *x, double *out)",
        "{   /* out = M^T x, row by row */",
        "    double o0 = 0.0, o1 = 0.0, o2 = 0.0, o3 = 0.0, o4 = 0.0, o5 = 0.0;",
        "    int r;",
        "    for (r = 0; r < 6; r++) {",
        "        const double xr = x[r], *mr = m + 6 * r;",
        "        o0 += mr[0] * xr; o1 += mr[1] * xr; o2 += mr[2] * xr;",
        "        o3 += mr[3] * xr; o4 += mr[4] * xr; o5 += mr[5] * xr;",
        "    }",
        "    out[0] = o0; out[1] = o1; out[2] = o2; out[3] = o3; out[4] = o4; out[5] = o5;",
        "}",
        "",
        *(_transpose_helper(name, plan, nq, nx) if half else []),
        f"/* d2 tau / dx2 of RNEA by the spatial-algebra second-order algorithm (compiler/tree/second_order.py):",
        f"   out[(i * {nx} + j) * {nx} + k] = d2 tau_i / dx_j dx_k at velocities u and accelerations ud (per dof).",
        *([] if ZERO or _covers_all(plan, nq, nx) else [
            "   Entries off the support paths are not written (second_order.ZERO off): the caller zeroes out once."]),
        f"   Returns 0 when every number the outputs are made of is within {BOUND} (the outputs are then finite), else 1. */",
        f"static int {fn}(const double *an, const double *u, const double *ud, double *out)",
        "{",
        *tree_tables(plan),
        c_table("qc", plan.qcol),
        c_table("uc", [nq + s for s in plan.row]),
        c_table("lam", plan.lam or (-1,)),
        *(_joint_tables(plan) if nm else []),
        f"    double R[{9 * nb}], P[{3 * nb}], V[{6 * nb}], A[{6 * nb}], Y[{10 * nb}], dY[{12 * nb}], F[{6 * nb}];",
        f"    double Sw[{6 * nd}], PS[{6 * nd}], PS2[{6 * nd}], PP[{6 * nd}];",
        f"#if {name.upper()}_H2_LANES == 4",
        f"    double XA[{24 * nd}], XB[{24 * nd}], M3[144], FF[24];   /* the pair products' lanes (_pair_vector_lines) */",
        "#endif",
        *([f"    double Tq[{nd * nm}];   /* d tau / d xi of the k-speed joints' dofs (their columns), per dof's row */"]
          if nm and not TANGENT else []),
        *cfg[0],
        f"    double K[{cfg[1]}], D[{(15 if _rooted(plan) else 14) * cfg[2]}];   /* per path, component-major: S, psi', psi'', psi' + phi' of its dofs; the dots */",
        "    double Ym[36], Bm[36], Ma[36], Mb[36], Mc[36], R1[36], R3[36];",
        "    int b, i, j, k, e, c, l, big = 0;",
        *_kinv_lines(plan),
    ] + ([] if _covers_all(plan, nq, nx) or not ZERO else [
        f"    for (k = 0; k < {nd * nn}; k++) out[k] = 0.0;"]) + (
        [f"    for (k = 0; k < {nd * nm}; k++) Tq[k] = 0.0;"] if nm and not TANGENT else []) + [
        f"    for (b = 0; b < {nb}; b++) {{   /* forward: placements, axes and their rates, v, a, Y, B, f */",
        *_root_frame(body_head_lines(o, "al[i];"), o, plan),
        "        for (e = d0[b]; e < d0[b] + nd[b]; e++) {   /* psi' = v_l x S, psi'' = a_l x S + v_l x psi', phi' = v x S */",
        "            const double *s = Sw + 6 * e;",
        "            double *ps = PS + 6 * e, *ps2 = PS2 + 6 * e;",
        f"            {rd}_cross(vl, s, ps);",
        f"            {rd}_cross(al, s, ps2);",
        f"            {rd}_cross(vl, ps, t);",
        "            for (i = 0; i < 6; i++) ps2[i] += t[i];",
        f"            {rd}_cross(vb, s, t);",
        "            for (i = 0; i < 6; i++) {",
        "                ab[i] += s[i] * ud[e] + t[i] * u[e];",
        "                PP[6 * e + i] = ps[i] + t[i];   /* psi' + phi' */",
        "            }",
        f"#if {name.upper()}_H2_LANES == 4",
        *_lane_fill_lines(),
        "#endif",
        "        }",
        *WORLD_INERTIA_LINES,
        "        IO[1] = IO[3] = Yb[7]; IO[2] = IO[6] = Yb[8]; IO[5] = IO[7] = Yb[9];",
        "        /* momentum h, force f = Y a + v x* h - load */",
        f"        {rd}_ymul(Yb, vb, hm);",
        f"        {rd}_ymul(Yb, ab, fb);",
        f"        {rd}_crossf(vb, hm, t);",
        "        for (i = 0; i < 6; i++) fb[i] += t[i];",
    ] + (world_load_lines(o) if plan.loads else []) + [
        *VARIATION_LINES,
        "    }",
        f"    for (i = 0; i < {cfg[3]}; i++) {{   /* K: each path's dof vectors, component-major (zeros past its end) */",
        "        double *G = K + pG[i];",
        "        const int L = pL[i];",
        "        for (j = 0; j < L; j++) {",
        "            const int d = j < pn[i] ? pd[p0[i] + j] : -1;",
        "            for (c = 0; c < 6; c++) {",
        "                G[c * L + j] = d >= 0 ? Sw[6 * d + c] : 0.0;",
        "                G[(6 + c) * L + j] = d >= 0 ? PS[6 * d + c] : 0.0;",
        "                G[(12 + c) * L + j] = d >= 0 ? PS2[6 * d + c] : 0.0;",
        "                G[(18 + c) * L + j] = d >= 0 ? PP[6 * d + c] : 0.0;",
        "            }",
        "        }",
        "    }",
        *_k_folded_lines(plan, cfg[3]),
        f"    for (k = 0; k < {cfg[1]}; k++) big |= !(fabs(K[k]) <= {BOUND});",
        f"    for (b = {nb - 1}; b >= 0; b--) {{   /* backward: per dof i of the body, its subtree's composites */",
        "        const double *Yb = Y + 10 * b, *dYb = dY + 12 * b, *fb = F + 6 * b;",
        "        for (i = d0[b]; i < d0[b] + nd[b]; i++) {",
        "            const double *S = Sw + 6 * i, *ps = PS + 6 * i;",
        f"            double *Oi = out + (size_t)row[i] * {nn};",
        "            const int qi = qc[i], ui = uc[i];",
        "            double ys[6], yp[6], bs[6], g5[6], g7[6], t[6]" + (", x[6];" if nm else ";"),
        "            /* the composite inertia Ym and variation Bm as 6x6 matrices (angular rows first) */",
        "            Ym[0] = Yb[4]; Ym[7] = Yb[5]; Ym[14] = Yb[6];",
        "            Ym[1] = Ym[6] = Yb[7]; Ym[2] = Ym[12] = Yb[8]; Ym[8] = Ym[13] = Yb[9];",
        "            Ym[3] = Ym[18] = 0.0; Ym[4] = Ym[24] = -Yb[3]; Ym[5] = Ym[30] = Yb[2];",
        "            Ym[9] = Ym[19] = Yb[3]; Ym[10] = Ym[25] = 0.0; Ym[11] = Ym[31] = -Yb[1];",
        "            Ym[15] = Ym[20] = -Yb[2]; Ym[16] = Ym[26] = Yb[1]; Ym[17] = Ym[32] = 0.0;",
        "            Ym[21] = Ym[28] = Ym[35] = Yb[0];",
        "            Ym[22] = Ym[23] = Ym[27] = Ym[29] = Ym[33] = Ym[34] = 0.0;",
        "            for (k = 0; k < 36; k++) Bm[k] = 0.0;   /* Bm = [[T, 0], [-2 [h]x, 0]] (the 12 numbers of dY) */",
        "            for (k = 0; k < 3; k++)",
        "                for (c = 0; c < 3; c++) Bm[6 * k + c] = dYb[3 * k + c];",
        "            Bm[19] = 2.0 * dYb[11]; Bm[20] = -2.0 * dYb[10]; Bm[24] = -2.0 * dYb[11];",
        "            Bm[26] = 2.0 * dYb[9]; Bm[30] = 2.0 * dYb[10]; Bm[31] = -2.0 * dYb[9];",
        "            /* Ma = S x* Ym, Mb = psi' x* Ym, Mc = S x* Bm, stored transposed (row k: column k; Ym is",
        "               symmetric, so its column k is its row k) */",
        "            for (k = 0; k < 6; k++) {",
        f"                {rd}_crossf(S, Ym + 6 * k, Ma + 6 * k);",
        f"                {rd}_crossf(ps, Ym + 6 * k, Mb + 6 * k);",
        "                if (k < 3) {   /* Bm's last three columns are zero, and so are Mc's */",
        "                    double y[6];",
        "                    for (c = 0; c < 6; c++) y[c] = Bm[6 * c + k];",
        f"                    {rd}_crossf(S, y, Mc + 6 * k);",
        "                } else {",
        "                    for (c = 0; c < 6; c++) Mc[6 * k + c] = 0.0;",
        "                }",
        "            }",
        f"            {rd}_ymul(Yb, S, ys);",
        f"            {rd}_ymul(Yb, ps, yp);",
        f"            {rd}_dmult(dYb, S, bs);",
        "            /* R1 = variation of Ym along S (symmetric), R3 = along psi' + (. x* Ym psi') + S x* Bm - Bm (S x) */",
        "            for (k = 0; k < 6; k++) {",
        "                double z[6];",
        f"                {rd}_crossf(S, Bm + 6 * k, z);   /* row k of Bm -> column k of S x* Bm^T: row k of -Bm (S x) */",
        "                for (c = 0; c < 6; c++) {",
        "                    R1[6 * k + c] = Ma[6 * c + k] + Ma[6 * k + c];",
        "                    R3[6 * k + c] = Mb[6 * c + k] + Mb[6 * k + c] + Mc[6 * c + k] + z[c];",
        "                }",
        "            }",
        "            /* R3 += (. x* yp): its 18 nonzero entries (column k is e_k x* yp) */",
        *_yp_lines(),
        f"#if {name.upper()}_H2_LANES == 4",
        "            for (k = 0; k < 6; k++)   /* M3: R3 on lanes 0, 1, R3^T on lane 2 (_pair_product_lines) */",
        "                for (c = 0; c < 6; c++) {",
        "                    M3[24 * k + 4 * c] = M3[24 * k + 4 * c + 1] = R3[6 * k + c];",
        "                    M3[24 * k + 4 * c + 2] = R3[6 * c + k];",
        "                    M3[24 * k + 4 * c + 3] = 0.0;",
        "                }",
        "#endif",
        "            /* g5 = Bm psi' + S x* F + Ym psi'', g7 = Bm S + Ym (psi' + phi') */",
        f"            {rd}_dmul(dYb, ps, g5);",
        f"            {rd}_crossf(S, fb, t);",
        "            for (c = 0; c < 6; c++) g5[c] += t[c];",
        f"            {rd}_ymul(Yb, PS2 + 6 * i, t);",
        "            for (c = 0; c < 6; c++) g5[c] += t[c];",
        f"            {rd}_dmul(dYb, S, g7);",
        f"            {rd}_ymul(Yb, PP + 6 * i, t);",
        "            for (c = 0; c < 6; c++) g7[c] += t[c];",
        f"            for (c = 0; c < 36; c++) big |= !(fabs(R1[c]) <= {BOUND}) | !(fabs(R3[c]) <= {BOUND});   /* BOUND */",
        "            for (c = 0; c < 6; c++)",
        f"                big |= !(fabs(ys[c]) <= {BOUND}) | !(fabs(bs[c]) <= {BOUND}) | !(fabs(g5[c]) <= {BOUND}) | !(fabs(g7[c]) <= {BOUND});",
        f"            for (c = 0; c < 10; c++) big |= !(fabs(Yb[c]) <= {BOUND});",
        f"#if {name.upper()}_H2_LANES == 4",
        "            for (c = 0; c < 6; c++) {   /* FF: the cross products' lanes (_pair_cross_lines) */",
        "                FF[4 * c] = ys[c]; FF[4 * c + 1] = bs[c]; FF[4 * c + 2] = g5[c]; FF[4 * c + 3] = g7[c];",
        "            }",
        "#endif",
        *(_tq_folded_lines(plan, nm) if nm and not TANGENT else []),
        *(["            for (j = jl[i]; j >= 0; j = lam[j]) {   /* i's joint (every dof of it) and its support */",
           "                const double *s = Sw + 6 * j, *p = PS + 6 * j;",
           "                const int oj = db[j] != b;   /* j in another joint than i */"] if nm else [
          "            for (j = i; j >= 0; j = lam[j]) {   /* the support of i */",
          "                const double *s = Sw + 6 * j, *p = PS + 6 * j;"]),
        f"                double *Oj = out + (size_t)row[j] * {nn};",
        "                const int qj = qc[j], uj = uc[j];",
        *_prefetch_lines(name, _scratch(plan, nq, nx, half), nx, nq, plan),
        "                double U[60], r1p[6], r0p[6];   /* the pair's vectors */",
        "                double *u1 = U, *u2 = U + 6, *u3 = U + 12, *u6 = U + 18, *u7 = U + 24, *u9 = U + 30, *w = U + 36;",
        "                double *u4 = U + 42, *u10 = U + 48, *u11 = U + 54;",
        *_pair_vector_lines(name, rd, nm, oj, plan),
    ] + (_first_order_lines(rd, nm, plan) if nm and not TANGENT else []) + _triple_lines(name, rd, nx, cfg, nm, plan, half, _scratch(plan, nq, nx, half)) + [
        "            }",
        *(_mirror_lines(name, plan, nq, nx) if half else []),
        "        }",
        "        l = par[b];",
        "        if (l >= 0) {   /* composite inertia, its variation and force */",
        "            for (i = 0; i < 10; i++) Y[10 * l + i] += Yb[i];",
        "            for (i = 0; i < 12; i++) dY[12 * l + i] += dYb[i];",
        "            for (i = 0; i < 6; i++) F[6 * l + i] += fb[i];",
        "        }",
        "    }",
    ] + (_law_lines(plan, nx) if plan.laws else []) + (_tangent_lines(plan, nx, nm) if nm and not TANGENT else []) + [
        "    return big;",
        "}",
    ]
    start = next(n for n, x in enumerate(lines) if x.startswith(f"#if {name.upper()}_H2_LANES == 4 && defined(__GNUC__)")
                 or x.startswith("/* d2 tau / dx2 of RNEA"))
    return "\n".join(lines + [""] + _avx2_twin(name, lines[start:]))


def _rooted(plan):
    """The root k-speed joints (indices into ``plan.multi``: a floating base's free joint, a root ball)
    whose pairs (i, j), j one of their dofs, take the root dots (:func:`_root_dot_lines`): all of them
    when their axes' pattern is known (``plan.spat``, :func:`with_k_derivatives`) and ROOT_DOTS is on."""
    if not (plan.spat and ROOT_DOTS):
        return []
    return [n for n, (e0, _, _) in enumerate(plan.multi) if plan.lam[e0] < 0]


def _root_frame(lines, o, plan):
    """``lines`` (:func:`.analytic.body_head_lines`) with, when the tree has a root joint taking the root
    dots (:func:`_rooted`), each root body placed at the origin of the kernel's frame, unrotated
    (R = 1, p = 0), and gravity as its acceleration expressed in its frame (E g, E = R^T): the kernel
    then runs in each root body's own frame (each root's subtree is separate: no composite, pair or dot
    couples two roots' dofs).  Every output is a dot product of a motion and a force of one subtree, the
    same in any frame (to rounding).  Why: in that frame a root joint's axes are its body-frame axes,
    constants with zeros and ones (a free joint's: unit vectors, and the angular ones' offsets), so
    the dots of the pairs (i, j) with j in that joint are picks (:func:`_root_dot_lines`)."""
    if not _rooted(plan):
        return lines
    g = o["g"]
    old = ["                for (j = 0; j < 3; j++) Rb[3 * i + j] = E[3 * j + i];",
           "                pb[i] = r[i];",
           f"                al[i + 3] = -an[{g} + i];"]
    new = ["                for (j = 0; j < 3; j++) Rb[3 * i + j] = i == j ? 1.0 : 0.0;   /* the root's own frame (_root_frame) */",
           "                pb[i] = 0.0;",
           f"                al[i + 3] = -(E[3 * i] * an[{g}] + E[3 * i + 1] * an[{g + 1}] + E[3 * i + 2] * an[{g + 2}]);"]
    out = list(lines)
    for a, b in zip(old, new):
        assert out.count(a) == 1, a
        out[out.index(a)] = b
    return out


def _avx2_twin(name, lines):
    """C: the kernel (``lines``: NAME_rnea_hess and, written by halves, its transposes NAME_h2_trt /
    NAME_h2_trs) a second time as NAME_rnea_hess_avx2 (and NAME_h2_trt_avx2 / NAME_h2_trs_avx2),
    built for AVX2 (``target("avx2")``) with the AVX2 forms chosen (NAME_H2_LANES 4: the triple
    loop's dots 4 k a step, the pair products on four lanes, the tiles' transposes on vector
    registers), under ``EOMC_RD_AVX2`` (:func:`.analytic.avx2_guard_lines`: gcc, optimizing, x86,
    flags without AVX); NAME_hess_id takes it when ``__builtin_cpu_supports("avx2")``
    (:func:`second_order_body`).  The machine build (-mavx2) compiles the plain kernel in these
    forms and preprocesses the twin out.  Same bits: the lane and scalar forms sum every term in the
    same order (see _pair_vector_lines, LANES), and AVX2 without FMA neither contracts nor
    reassociates.  The inline helpers (NAME_rd_*, NAME_h2_mv) are inlined into it and built for
    AVX2 there.  Why: a portable -O2 build runs the kernel on SSE2, two doubles an instruction
    (session 16: Go2 34 vs 26 us machine, cart40 392 vs 253 us).  The block holds no other
    preprocessor conditional (compiler/emit/target.without_cpu_dispatch cuts it at its first
    ``#endif``: the c99-f32 target keeps the portable kernel only)."""
    from .analytic import AVX2_GUARD, avx2_guard_lines
    up = name.upper()
    attr = '__attribute__((target("avx2"))) '
    out, keep, mode, depth = [], True, None, 0
    for x in lines:
        if mode == "drop":      # the machine build's vector types (nested conditionals): the twin's own below
            depth += x.startswith("#if")
            depth -= x.startswith("#endif")
            mode, keep = (None, True) if depth == 0 else (mode, keep)
            continue
        if x.startswith(f"#if {up}_H2_LANES == 4 && defined(__GNUC__)"):
            mode, keep, depth = "drop", False, 1
            continue
        if x in (f"#if {up}_H2_LANES == 4", f"#ifdef {up}_H2_VT"):
            mode, keep = "if", True
            continue
        if x == "#else" and mode == "if":
            keep = False
            continue
        if x == "#endif" and mode is not None:
            mode, keep = None, True
            continue
        if x.startswith("#"):
            if mode == "drop":
                continue
            raise AssertionError(f"a preprocessor line the AVX2 twin does not know: {x}")
        if not keep:
            continue
        for f in ("rnea_hess", "h2_trt", "h2_trs"):
            x = x.replace(f"{name}_{f}(", f"{name}_{f}_avx2(")
        x = (x.replace(f"{up}_H2_LANES", "4").replace(f"{name}_h2_v4", f"{name}_h2_v4x")
             .replace(f"{up}_H2_SHUF(", f"{up}_H2_SHUFX("))
        if x.startswith("static "):
            x = attr + x
        out.append(x)
    return avx2_guard_lines("AVX2 twins, chosen per call by the CPU") + [
        f"#if {AVX2_GUARD}",
        "/* the kernel for AVX2 (_avx2_twin), taken by NAME_hess_id when the CPU has it */",
        f"typedef double {name}_h2_v4x __attribute__((vector_size(32), aligned(8)));",
        f"typedef long long {name}_h2_m4x __attribute__((vector_size(32)));",
        f"#define {up}_H2_SHUFX(a, b, i, j, k, l) __builtin_shuffle(a, b, ({name}_h2_m4x){{i, j, k, l}})",
    ] + out + ["#endif"]


LANES = 4      # K's paths are padded to a multiple of this: the most k a step of the triple loop's dots
# The k per step in the C (NAME_H2_LANES): 4 doubles (one register) when built with AVX2, else 2
# (one SSE2 register).  Why not 4 everywhere: with SSE2's 16 registers, 4 lanes spill (measured,
# gcc 12 -O2: UR10 4.4 -> 4.7 us, Panda 8.8 -> 9.9 us).  The bits are the same either way.
# The G rows each dot reads (0: S, 1: psi', 2: psi'', 3: psi' + phi'; see _triple_lines), j = i / j != i
GROUPS_A = (1, 2, 1, 0, 0, 0, 3, 0, 0)
GROUPS_B = (1, 2, 1, 0, 0, 0, 3, 0, 1, 2, 0, 3, 0, 0)


def paths(plan):
    """The tree's dofs packed into root-to-leaf paths: (paths as lists of dofs, path of each dof,
    its position there).  Each dof's support (itself and the dofs before it) is the start of its
    path, so the triple loop reads its k's data contiguously (a chain is one path)."""
    nd = len(plan.lam)
    kids = [0] * nd
    for e in plan.lam:
        if e >= 0:
            kids[e] += 1
    out, jp, jt = [], [-1] * nd, [0] * nd
    for leaf in range(nd):
        if kids[leaf]:
            continue
        path, e = [], leaf
        while e >= 0:
            path.append(e)
            e = plan.lam[e]
        path.reverse()
        for t, e in enumerate(path):
            if jp[e] < 0:
                jp[e], jt[e] = len(out), t
        out.append(path)
    return out, jp, jt


def _lanes_cfg(plan):
    """C: the path tables (:func:`paths`) and their sizes: (table lines, K size, MAXL, paths);
    K holds 6 numbers per row group of :func:`_k_rows` per path position."""
    ps, jp, jt = paths(plan)
    lens = [-(-len(p) // LANES) * LANES for p in ps]
    base, b = [], 0
    for n in lens:
        base.append(b)
        b += 6 * _k_rows(plan) * n
    starts, s = [], 0
    for p in ps:
        starts.append(s)
        s += len(p)
    tables = [c_table("jp", jp or (0,)), c_table("jt", jt or (0,)), c_table("pL", lens or (0,)),
              c_table("pG", base or (0,)), c_table("pn", [len(p) for p in ps] or (0,)),
              c_table("p0", starts or (0,)), c_table("pd", [e for p in ps for e in p] or (0,))]
    return tables, max(b, 1), max(lens or [LANES]), len(ps)


def _k_rows(plan):
    """K's row groups: 4 (S, psi', psi'', psi' + phi'), plus 2 with a folded joint
    (:func:`_folded`): psi' and psi'' with that joint's columns along its coordinates (4: psi' K^-1,
    5: psi'' K^-1; the other dofs' columns as in 1 and 2), which the dots the stores read along
    q_k take (:data:`QDOTS_B`)."""
    return 6 if _folded(plan) else 4


def _k_folded_lines(plan, npaths):
    """C (after K is filled): K's row groups 4 and 5 (:func:`_k_rows`): psi', psi'' with each
    folded joint's columns (at the start of the paths it is on) combined by its K^-1's
    diagonal blocks, psi'_a K^-1 = sum_d psi'_d K^-1[d, a] -- every entry the dots make of
    those columns is linear in them (psi' = v x S_k, psi'' too), so a dot with such a column is
    the entry along the coordinate q_a.  Why: the same combination of the dots per pair (i, j),
    the fold, was 11 % of Go2's hess_id (perf); here it is once per path."""
    fold = _folded(plan)
    if not fold:
        return []
    out = [f"    for (i = 0; i < {npaths}; i++) {{   /* K's groups 4, 5: psi', psi'' along the folded joints' coordinates */",
           "        double *G = K + pG[i];",
           "        const int L = pL[i];",
           "        for (k = 0; k < 12 * L; k++) G[24 * L + k] = G[6 * L + k];"]
    for n in fold:
        e0 = plan.multi[n][0]
        out.append(f"        if (pd[p0[i]] == {e0}) {{   /* joint {n}: S K^-1 by K^-1's diagonal blocks */")
        for bl, (r, c) in enumerate(plan.kblocks[n]):
            b = len(r)
            out += [f"            for (k = 0; k < 12; k++) {{",
                    "                const double *g = G + (6 + k) * L;",
                    "                double *h = G + (24 + k) * L;"]
            for jj in range(b):
                out.append(f"                h[{r[jj]}] = " + " + ".join(
                    f"g[{c[i]}] * Kv{n}_{bl}[{b * i + jj}]" for i in range(b)) + ";")
            out.append("            }")
        out.append("        }")
    return out + ["    }"]


def _pair_vector_lines(name, rd, nm, oj, plan=None):
    """C, per pair (i, j): the pair's vectors u1 .. u11, w.  With AVX2 (NAME_H2_LANES 4) the
    seven 6x6 matrix-vector products and four force cross products run on four lanes
    (:func:`_pair_product_lines`, :func:`_pair_cross_lines`); without, one by one (with SSE2's
    two lanes the lane form was slower: cart4 4.05 -> 4.45 us, UR10 5.5 -> 5.7, portable -O2).
    Both sum every term in the same order: the same bits."""
    lanes = f"{name.upper()}_H2_LANES"
    root = _root_pair_lines(plan, oj) if plan is not None else []
    return root + (["                {"] if root else []) + [
        f"#if {lanes} == 4",
        "                {",
        "                    double oa[24], ob[24], oc[24];",
        *_pair_product_lines(),
        *_pair_cross_lines(),
        "                    for (c = 0; c < 6; c++) {",
        "                        u2[c] = oa[4 * c];",
        "                        r1p[c] = oa[4 * c + 1];",
        "                        u9[c] = oc[4 * c];",
        "                        w[c] = oc[4 * c + 1];",
        "                        u6[c] = oc[4 * c + 3];",
        "                        u3[c] = ob[4 * c + 1] + oa[4 * c + 2];   /* R3 psi' + R1 psi'' + S_j x* g5 */",
        "                        u3[c] += oc[4 * c + 2];",
        "                        u1[c] = ob[4 * c + 2];   /* R3^T S_j, R3 S_j + R1 psi'_j + R1 phi'_j (read when j, i in two joints) */",
        "                        u7[c] = ob[4 * c] + (r1p[c] + oa[4 * c + 3]);",
        "                    }",
        "                }",
        "#else",
        f"                {name}_h2_mv(R1, s, u2);",
        f"                {name}_h2_mv(R1, p, r1p);",
        f"                {rd}_crossf(s, ys, u9);",
        f"                {rd}_crossf(s, bs, w);",
        f"                {name}_h2_mv(R3, p, u3);",
        f"                {name}_h2_mv(R1, PS2 + 6 * j, t);",
        "                for (c = 0; c < 6; c++) u3[c] += t[c];",
        f"                {rd}_crossf(s, g5, t);",
        "                for (c = 0; c < 6; c++) u3[c] += t[c];",
        f"                {rd}_crossf(s, g7, u6);",
        f"                if ({oj}) {{",
        "                    double ph[6];",
        f"                    {name}_h2_mtv(R3, s, u1);",
        f"                    {name}_h2_mv(R3, s, u7);",
        "                    for (c = 0; c < 6; c++) ph[c] = PP[6 * j + c] - p[c];   /* phi'_j */",
        f"                    {name}_h2_mv(R1, ph, t);",
        "                    for (c = 0; c < 6; c++) u7[c] += r1p[c] + t[c];",
        "                }",
        "#endif",
        f"                {rd}_crossf(p, ys, r0p);",
        *(["                }"] if root else []),
        "                for (c = 0; c < 6; c++) {",
        "                    u10[c] = u2[c] + u9[c];",
        "                    u11[c] = u2[c] - u9[c];",
        "                    w[c] += r0p[c] - r1p[c];",
        "                    u4[c] = 2.0 * u9[c];",
        "                    u6[c] += r1p[c] + r0p[c];",
        "                }",
        *([
            "                if (!oj && j != i) {   /* two dofs of one joint: u4 = s_j x* (Y S_i) + S_i x* (Y s_j) */",
            f"                    {rd}_ymul(Yb, s, t);",
            f"                    {rd}_crossf(S, t, x);",
            "                    for (c = 0; c < 6; c++) u4[c] = u9[c] + x[c];",
            "                }"] if nm else []),
        f"                if (!({oj}))",
        "                    for (c = 0; c < 6; c++) u1[c] = u7[c] = 0.0;   /* unread (j == i), set for the compiler */",
    ]


_CROSSF = (((1, 2, 1), (2, 1, -1), (4, 5, 1), (5, 4, -1)), ((2, 0, 1), (0, 2, -1), (5, 3, 1), (3, 5, -1)),
           ((0, 1, 1), (1, 0, -1), (3, 4, 1), (4, 3, -1)), ((1, 5, 1), (2, 4, -1)), ((2, 3, 1), (0, 5, -1)),
           ((0, 4, 1), (1, 3, -1)))     # rd_crossf's terms: out[r] = sum sign v[a] f[b]


def _terms(ts):
    """C: a sum of (sign, factor text) terms, "0.0" when there are none."""
    if not ts:
        return "0.0"
    out = ("-" if ts[0][0] < 0 else "") + ts[0][1]
    for sg, t in ts[1:]:
        out += (" - " if sg < 0 else " + ") + t
    return out


def _root_pair_lines(plan, oj):
    """C, per pair (i, j): ``if (j is a dof of a root joint) { its pair vectors } else`` (the generic
    forms follow), for each joint of :func:`_rooted`, one ``case`` per dof d of the joint.  In the
    root's own frame (:func:`_root_frame`) S_j is constant with zeros and ones (``plan.spat``),
    psi'_j = 0 and psi''_j has no angular part (see :func:`_root_dot_lines`), so R1 S_j, R3 S_j,
    R3^T S_j are a column or a few, S_j x* f a few terms, R1 psi'_j = psi'_j x* Y S_i = 0 (r1p, r0p),
    and R1 psi''_j three columns; R1 phi'_j stays a full product.  The same values as the generic forms
    to rounding.  Why: after the root dots, the pair vectors were the largest part of Go2's hess_id
    (24 %, perf), 108 of its 132 pairs with j in the free joint."""
    rooted = _rooted(plan)
    out = []
    for n in rooted:
        e0, k, _ = plan.multi[n]
        pat = plan.spat[n]
        out += [f"                if (j >= {e0} && j < {e0 + k}) {{   /* j in root joint {n}: its pair vectors in the root's frame (_root_pair_lines) */",
                f"                    const double *Sr = Sw + {6 * e0};",
                f"                    switch (j - {e0}) {{"]
        for d in range(k):
            nz = [c for c in range(6) if pat[d][c]]

            def s(c):
                return None if pat[d][c] == 1 else f"Sr[{6 * d + c}]"

            def prod(a, c):
                return a if s(c) is None else f"{a} * {s(c)}"

            def crossf(f, r):
                return [(sg, prod(f"{f}[{b}]", a)) for a, b, sg in _CROSSF[r] if pat[d][a]]
            acc = any(pat[d][c] for c in range(3))
            body = []
            for r in range(6):
                body.append(f"u2[{r}] = {_terms([(1, prod(f'R1[{6 * r + c}]', c)) for c in nz])};")
                body.append(f"u9[{r}] = {_terms(crossf('ys', r))};")
                body.append(f"w[{r}] = {_terms(crossf('bs', r))};")
                body.append(f"u6[{r}] = {_terms(crossf('g7', r))};")
                pp = [(1, f"R1[{6 * r + c}] * PS2[{6 * (e0 + d) + c}]") for c in range(3, 6)] if acc else []
                body.append(f"u3[{r}] = {_terms(pp + crossf('g5', r))};")
                body.append(f"r1p[{r}] = r0p[{r}] = 0.0;")
            body.append(f"if ({oj}) {{")
            for r in range(6):
                body.append(f"    u1[{r}] = {_terms([(1, prod(f'R3[{6 * c + r}]', c)) for c in nz])};")
                ph = " + ".join(f"R1[{6 * r + c}] * PP[{6 * (e0 + d) + c}]" for c in range(6))
                body.append(f"    u7[{r}] = {_terms([(1, prod(f'R3[{6 * r + c}]', c)) for c in nz])} + ({ph});")
            body.append("}")
            out += [f"                    case {d}:"] + ["                        " + x for x in body] + [
                "                        break;"]
        out += ["                    }", "                } else"]
    return out


def _lane_fill_lines():
    """C, in the forward pass per dof e: its vectors as the lanes of the pair products
    (:func:`_pair_product_lines`), component-major: XA = (S, psi', psi'', phi'), XB = (S, psi', S, 0)."""
    return [
        "            for (i = 0; i < 6; i++) {   /* the pair products' lanes */",
        "                double *xa = XA + 24 * e + 4 * i, *xb = XB + 24 * e + 4 * i;",
        "                xa[0] = xb[0] = xb[2] = s[i];",
        "                xa[1] = xb[1] = ps[i];",
        "                xa[2] = ps2[i];",
        "                xa[3] = PP[6 * e + i] - ps[i];",
        "                xb[3] = 0.0;",
        "            }",
    ]


def _pair_product_lines():
    """C, per pair (i, j): the seven 6x6 matrix-vector products of the pair's vectors as two
    products of a 6x6 by four lanes, oa = R1 (S_j, psi'_j, psi''_j, phi'_j) and ob = (R3 S_j,
    R3 psi'_j, R3^T S_j, 0) (M3: R3 on lanes 0, 1 and R3^T on lane 2, set per dof i), a lane
    loop gcc vectorizes (4 lanes a step with AVX2, 2 with SSE2).  Each sum runs over the
    columns in order from 0.0, as the scalar products did, so the bits are theirs.  Why:
    these products were ~a third of hess_id on Go2 (perf), one scalar multiply-add each."""
    def row(m, x, r):
        return "0.0 + " + " + ".join(f"{m(r, c)} * {x}[{4 * c} + l]" for c in range(6))
    return [
        "                {",
        "                    const double *xa = XA + 24 * j, *xb = XB + 24 * j;",
        "                    int l;",
        *[f"                    for (l = 0; l < 4; l++) oa[{4 * r} + l] = " + row(lambda r, c: f"R1[{6 * r + c}]", "xa", r) + ";"
          for r in range(6)],
        *[f"                    for (l = 0; l < 4; l++) ob[{4 * r} + l] = " + row(lambda r, c: f"M3[{24 * r + 4 * c} + l]", "xb", r) + ";"
          for r in range(6)],
        "                }",
    ]


def _pair_cross_lines():
    """C, per pair (i, j): S_j x* f for the four force vectors of dof i, FF's lanes (Y S_i,
    B^T S_i, g5, g7) -> oc (u9, w's first term, u3's last, u6's first), the force cross
    product's terms in rd_crossf's order (the bits are its) over a lane loop gcc vectorizes."""
    terms = ["+1 2 -2 1 +4 5 -5 4", "+2 0 -0 2 +5 3 -3 5", "+0 1 -1 0 +3 4 -4 3", "+1 5 -2 4", "+2 3 -0 5", "+0 4 -1 3"]
    out = ["                {", "                    int l;"]
    for r, t in enumerate(terms):
        ts = t.split()
        e = ""
        for n in range(0, len(ts), 2):
            sg, a, b = ts[n][0], ts[n][1:], ts[n + 1]
            e += ("" if n == 0 else f" {sg} ") + f"s[{a}] * FF[{4 * int(b)} + l]"
        out.append(f"                    for (l = 0; l < 4; l++) oc[{4 * r} + l] = {e};")
    return out + ["                }"]


def _yp_lines():
    """C: R3 += the matrix of x -> x x* yp, entry by entry (rd_crossf(e_k, yp)'s nonzero terms:
    the scalar loop over unit vectors spent its time on products by 0 and 1)."""
    terms = [(0, 1, "+", 2), (0, 2, "-", 1), (0, 4, "+", 5), (0, 5, "-", 4), (1, 0, "-", 2), (1, 2, "+", 0),
             (1, 3, "-", 5), (1, 5, "+", 3), (2, 0, "+", 1), (2, 1, "-", 0), (2, 3, "+", 4), (2, 4, "-", 3),
             (3, 1, "+", 5), (3, 2, "-", 4), (4, 0, "-", 5), (4, 2, "+", 3), (5, 0, "+", 4), (5, 1, "-", 3)]
    return [f"            R3[{6 * r + k}] {sg}= yp[{f}];" for r, k, sg, f in terms]


def _lanes_macro(name):
    """C (file scope): NAME_H2_LANES, the k per step of the triple loop's dots (see LANES)."""
    return ["#ifdef __AVX2__", f"#define {name.upper()}_H2_LANES 4", "#else",
            f"#define {name.upper()}_H2_LANES 2", "#endif", ""]


def _dot_lanes(groups, vecs, maxl, lanes):
    """C: the dots D[m] = vecs[m] . (row groups[m] of K) for LANES k a step, K's rows read once a
    step; each dot summed in rd_dot's order.  (A last step of 2 k when at most 2 are left, 6
    lanes for T = 6 instead of 8: same bits, Go2 10 % slower, same-core A/B, session 13.)"""
    ind = "                                "
    out = [f"                        for (tk = 0; tk < T; tk += {lanes})",
           f"                            for (ln = 0; ln < {lanes}; ln++) {{",
           "                                const int o = tk + ln;"]
    for g in sorted(set(groups)):
        out += [f"{ind}const double g{g}_{c} = G[{6 * g + c} * L + o];" for c in range(6)]
    for m, (g, v) in enumerate(zip(groups, vecs)):
        out.append(f"{ind}D[{m * maxl} + o] = " + " + ".join(f"{v}[{c}] * g{g}_{c}" for c in range(6)) + ";")
    return out + ["                            }"]


def _folded(plan):
    """The k-speed joints whose change to their coordinates runs inside the triple loop (indices
    into ``plan.multi``): those at the root of the dof tree (a floating base's free joint, a root
    ball).  Why only those: every dof in the support of such a joint's dof is in the joint, so
    the only entries read along its coordinates as "j" (not "k") are its own (q, q) block, which
    :func:`_tangent_lines` finishes per row; a joint deeper in the tree keeps the pass over its
    rows and columns."""
    if TANGENT or not plan.multi:
        return []
    return [n for n, (e0, _, _) in enumerate(plan.multi) if plan.lam[e0] < 0]


def _kinv_lines(plan):
    """C (the kernel's head): K^-1 of each folded joint (:func:`_folded`) by its diagonal blocks,
    as ``Kv<joint>_<block>[speed * b + coordinate]`` (the block's local indices), and ``big``
    set unless every entry is within 1 (then the folded dots stay within the kernel's bound;
    a free joint's K^-1 is a rotation's transpose and the Euler angles' rate matrix, both within 1)."""
    from .analytic import _ginv_lines
    fold = _folded(plan)
    if not fold:
        return []
    o = plan.offsets
    lines = []
    for n in fold:
        for m, (r, c) in enumerate(plan.kblocks[n]):
            lines.append(f"    double Kv{n}_{m}[{len(r) ** 2}];")
    lines += ["    {   /* K^-1 of the root k-speed joints, by their diagonal blocks (_kinv_lines) */",
              "        double Km[36], piv, tmp;",
              "        int p;"]
    for n in fold:
        e0, k, koff = plan.multi[n]
        for m, (r, c) in enumerate(plan.kblocks[n]):
            b = len(r)
            lines += [f"        {{   /* joint {n}, block {m}: coordinates {list(r)}, speeds {list(c)} */",
                      c_table("kr", r).replace("    ", "            ", 1),
                      c_table("kc", c).replace("    ", "            ", 1),
                      f"            for (i = 0; i < {b}; i++)",
                      f"                for (j = 0; j < {b}; j++) Km[{b} * i + j] = an[{o['K'] + koff} + {k} * kr[i] + kc[j]];"]
            lines += ["    " + x for x in _ginv_lines(b, f"Kv{n}_{m}")]
            lines += [f"            for (i = 0; i < {b * b}; i++) big |= !(fabs(Kv{n}_{m}[i]) <= 1.0);",
                      "        }"]
    return lines + ["    }"]


# The dots whose k enters along its coordinate (stored at a column q_k), grouped as the sums the
# stores read: D0 -> p1, D1 + D2 -> p2, D8 + D9 -> a (the j != i group only); see _triple_lines'
# stores.  With a root k-speed joint they read K's columns along its coordinates (_qgroups).
QDOTS_A = ((0,), (1, 2))
QDOTS_B = ((0,), (1, 2), (8, 9))


def _qgroups(plan, groups, qdots):
    """The K row groups the dots read: with a folded joint (:func:`_folded`) the dots the stores
    read along q_k (``qdots``) take psi', psi'' along the coordinates (groups 4, 5,
    :func:`_k_folded_lines`) instead of 1, 2."""
    if not _folded(plan):
        return groups
    q = {m for ms in qdots for m in ms}
    assert all(groups[m] in (1, 2) for m in q), "a q-dot reads a group K does not have along q"
    return tuple(g + 3 if m in q else g for m, g in enumerate(groups))


def _pair_store(half, first, second, val, low, keep_up="", indent=0):
    """C: ``first = second = val;`` -- an entry and its mirror image -- or with ``half`` the one
    whose row's dof is the deeper (``low``: 0 first, 1 second) alone, plus the other when
    ``keep_up`` holds (then both are one dof's: its (q, u) and (u, q) entries, which
    :func:`_mirror_lines` does not copy)."""
    ind = " " * (24 + indent)
    if not half:
        return [f"{ind}{first} = {second} = {val};"]
    lo, up = (first, second) if low == 0 else (second, first)
    return [f"{ind}{lo} = {val};"] + ([f"{ind}if ({keep_up}) {up} = {val};"] if keep_up else [])


def _triple_lines(name, rd, nx, cfg, nm=0, plan=None, half=False, scratch=None):
    """C: the triple loop for one (i, j): the dots of (i, j)'s vectors with every k on j's path,
    LANES k a step from the component-major copy K (gcc's vectorizer pairs the lanes; each dot
    is summed in rd_dot's order, so the bits are the scalar loop's), then the stores, k = j first
    and up the support of j (the stores' order of the scalar loop)."""
    nn, maxl, lanes = nx * nx, cfg[2], f"{name.upper()}_H2_LANES"
    # with k-speed joints, "j != i" and "k != j" are between joints (db: a dof's body), and the
    # k run over every dof of j's joint (jl: its last dof); else the one-speed forms
    oj, ok = ("oj", "ok") if nm else ("j != i", "k != j")
    T, kd = ("jt[jl[j]] + 1, bj = db[j]", ", ok = db[k] != bj") if nm else ("jt[j] + 1", "")
    def d(m):
        return f"D[{m * maxl} + tk]" if m else "D[tk]"
    lines = [
        "                {   /* the dots of (i, j) with every k on j's path, H2_LANES k a step */",
        f"                    const int pa = jp[j], L = pL[pa], T = {T};",
        "                    const double *G = K + pG[pa];",
        "                    int tk, ln;",
        *_root_dot_lines(plan, rd, oj, maxl),
        f"                    if ({oj}) {{",
        *_dot_lanes(_qgroups(plan, GROUPS_B, QDOTS_B), VECS_B, maxl, lanes),
        "                    } else {",
        *_dot_lanes(_qgroups(plan, GROUPS_A, QDOTS_A), VECS_A, maxl, lanes),
        "                    }",
        "                    for (tk = T - 1; tk >= 0; tk--) {   /* k = j" + (" and j's joint" if nm else "") + ", then up the support of j */",
        f"                        const int k = pd[p0[pa] + tk], qk = qc[k], uk = uc[k]{kd};",
        f"                        double *Ok = out + (size_t)row[k] * {nn};",
        f"                        const double p1 = {d(0)}, p2 = {d(1)} + {d(2)};",
        f"                        const double v = {oj} || {ok} ? {d(3)} : 0.0;",
        f"                        Oi[qj * {nx} + qk] = p2;",
        *_pair_store(half, f"Oi[qk * {nx} + uj]", f"Oi[uj * {nx} + qk]", "-p1", 1, f"!({ok})"),
        f"                        if ({oj}) {{",
        f"                            const double a = {d(8)} + {d(9)};",
        f"                            const double d = {d(10)} + {d(11)};",
        *_pair_store(half, f"Oj[qk * {nx} + qi]", f"Oj[qi * {nx} + qk]", "a", 1, indent=4),
        *_pair_store(half, f"Oj[qk * {nx} + ui]", f"Oj[ui * {nx} + qk]", "p1", 1, indent=4),
        *_pair_store(half, f"Oj[qi * {nx} + uk]", f"Oj[uk * {nx} + qi]", "d", 0, indent=4),
        *_pair_store(half, f"Oj[uk * {nx} + ui]", f"Oj[ui * {nx} + uk]", "v", 1, indent=4),
        "                        }",
        f"                        if ({ok}) {{",
        f"                            const double p3 = -v, e3 = {d(4)};",
        f"                            const double f = {d(5)} + {d(6)}, g = {d(7)};",
        *([] if half else [f"                            Oi[qk * {nx} + qj] = p2;"]),
        f"                            Ok[qi * {nx} + qj] = e3;",
        *_pair_store(half, f"Oi[uj * {nx} + uk]", f"Oi[uk * {nx} + uj]", "p3", 0, indent=4),
        *_pair_store(half, f"Oi[qj * {nx} + uk]", f"Oi[uk * {nx} + qj]", "f", 0, indent=4),
        *_pair_store(half, f"Ok[qj * {nx} + ui]", f"Ok[ui * {nx} + qj]", "g", 1, f"!({oj})", indent=4),
        f"                            if ({oj}) {{",
        f"                                const double p6 = {d(12)}, mm = {d(13)};",
        *([] if half else [f"                                Ok[qj * {nx} + qi] = e3;"]),
        *_pair_store(half, f"Ok[ui * {nx} + uj]", f"Ok[uj * {nx} + ui]", "p6", 0, indent=8),
        *_pair_store(half, f"Ok[qi * {nx} + uj]", f"Ok[uj * {nx} + qi]", "mm", 0, indent=8),
        "                            } else {",
        f"                                Ok[uj * {nx} + ui] = {d(8)};",
        "                            }",
        "                        } else {",
        f"                            Oi[uj * {nx} + uk] = -{_same_joint_dot(plan, rd, maxl)};",
        "                        }",
        "                    }",
    ]
    k0 = next(n for n, x in enumerate(lines) if "for (tk = T - 1;" in x)
    loop = _unswitched(lines[k0:], oj)
    if scratch is not None:     # the other rows' stores of the j != i copy into row i's scratch (_scratch)
        nd, quads = scratch
        lines.insert(lines.index("                    int tk, ln;") + 1,
                     f"                    double *const Hj = Oi + ({nd - 1} - j) * {nx} + {nd} - j;   /* row i's scratch (_scratch) */")
        k0 += 1
        cut = loop.index("                    } else {")
        for (rw, cl, val), q in zip(_SCRATCH_STORES, quads):
            old = f"Ok[{rw} * {nx} + {cl}] = {val};"
            hits = [n for n in range(cut) if loop[n].strip() == old]
            assert len(hits) == 1, old
            loop[hits[0]] = loop[hits[0]].replace(old, f"Hj[{q} + k] = {val};")
    return lines[:k0] + loop + ["                }"]


VECS_A = ("u11", "u9", "w", "u11", "u3", "w", "u9", "u6", "u4")      # the pair vectors the dots read (_triple_lines)
VECS_B = ("u11", "u9", "w", "u11", "u3", "w", "u9", "u6", "u1", "u2", "u1", "u2", "u10", "u7")


def _root_dot_lines(plan, rd, oj, maxl):
    """C, opening the dots of a pair (i, j): ``if (j is a dof of a root joint) { its dots } else``, for
    each joint of :func:`_rooted` (the generic lane dots follow as the ``else``).  Its k are that
    joint's dofs (T of them at the start of its paths), and in the root's own frame
    (:func:`_root_frame`) their vectors have a known form, so each dot is a few terms instead of a
    lane dot over K's 24 numbers per k (the padding lanes included):
      * S_k: the body-frame axis, constants (``plan.spat``): the terms of its entries not identically
        0, an entry identically 1 taken without a product;
      * psi'_k = v_l x S_k = 0 (the root's parent is the ground, v_l = 0), and so psi' K^-1: the dot is 0;
      * psi''_k = a_l x S_k, a_l = (0, -g) (no angular part): its angular part is 0, so the dot is over
        the linear part alone, 0 for a k whose axis has no angular part (psi'' K^-1: whose K^-1 block
        has none);
      * psi'_k + phi'_k = v x S_k (v the root body's velocity): x . (v x S_k) = -S_k . (v x* x), one
        force cross product per vector, then S_k's terms as above.
    The same values as the lane dots to rounding (checked against them, the reverse path, differences of
    jac_id and Pinocchio: tests/compiler/tree/test_second_order.py).  Why: on Go2 the lane dots of the
    pairs with j in the free joint were 4.5 of hess_id's 21 us (a knock-out, session 18; 108 of its
    132 pairs)."""
    rooted = _rooted(plan)
    if not rooted:
        return []
    db = [b for b in range(plan.nb) for _ in plan.dofs(b)]
    ps = paths(plan)[0]
    out = []
    for n in rooted:
        e0, k, _ = plan.multi[n]
        assert all(p[:k] == list(range(e0, e0 + k)) for p in ps if e0 in p), "a root joint's dofs start its paths"
        pat = plan.spat[n]
        acc = [any(pat[d][c] for c in range(3)) for d in range(k)]     # psi''_d not identically 0
        acc_q = [False] * k         # psi'' K^-1's column (coordinate) a: some speed of its block has one
        for r, c in plan.kblocks[n]:
            for a in r:
                acc_q[a] = any(acc[d] for d in c)

        def sdot(x, d, neg=False):
            t = [f"{x}[{c}]" if pat[d][c] == 1 else f"{x}[{c}] * Sr[{6 * d + c}]" for c in range(6) if pat[d][c]]
            e = " + ".join(t) if t else "0.0"
            return f"-({e})" if neg and t else e

        def form(groups, vecs):
            lines, crossed = [], {}
            for g, v in zip(groups, vecs):
                if g == 3 and v not in crossed:
                    crossed[v] = f"y{len(crossed)}"
            if crossed:
                lines.append("                        double " + ", ".join(f"{y}[6]" for y in crossed.values()) + ";")
                lines += [f"                        {rd}_crossf(vr, {v}, {y});   /* v x* {v} */" for v, y in crossed.items()]
            for m, (g, v) in enumerate(zip(groups, vecs)):
                for d in range(k):
                    if g in (1, 4):
                        e = "0.0"
                    elif g == 0:
                        e = sdot(v, d)
                    elif g == 3:
                        e = sdot(crossed[v], d, neg=True)
                    else:
                        assert g in (2, 5), f"group {g} in a root dot"
                        e = (" + ".join(f"{v}[{c}] * G[{6 * g + c} * L + {d}]" for c in range(3, 6))
                             if (acc_q if g == 5 else acc)[d] else "0.0")
                    lines.append(f"                        D[{m * maxl + d}] = {e};")
            lines += [f"                        D[{14 * maxl + d}] = {sdot('u2', d)};   /* u2 . S_k (_same_joint_dot) */"
                      for d in range(k)]
            return lines
        out += [f"                    if (j >= {e0} && j < {e0 + k}) {{   /* j in root joint {n}: its dots in the root's frame (_root_dot_lines) */",
                f"                        const double *Sr = Sw + {6 * e0}, *vr = V + {6 * db[e0]};",
                f"                        if ({oj}) {{",
                *["    " + x for x in form(_qgroups(plan, GROUPS_B, QDOTS_B), VECS_B)],
                "                        } else {",
                *["    " + x for x in form(_qgroups(plan, GROUPS_A, QDOTS_A), VECS_A)],
                "                        }",
                "                    } else"]
    return out


def _same_joint_dot(plan, rd, maxl):
    """C: u2 . S_k for k in j's joint (the (u_j, u_k) entry of row i): for j in a root joint of
    :func:`_rooted`, the root dots' 15th row (:func:`_root_dot_lines`, S_k's terms), else rd_dot."""
    conds = [f"(j >= {e0} && j < {e0 + k})" for e0, k, _ in (plan.multi[n] for n in _rooted(plan))]
    if not conds:
        return f"{rd}_dot(u2, Sw + 6 * k)"
    return f"({' || '.join(conds)} ? D[{14 * maxl} + tk] : {rd}_dot(u2, Sw + 6 * k))"


def _unswitched(loop, oj):
    """C: ``loop`` (the stores of one (i, j)) twice, under ``if (oj)`` with oj read as 1 and
    under its ``else`` as 0 (``oj``: the C of "j in another joint than i", constant over the
    loop), so no store tests it per k.  The stores and their order are the same: the same bits.
    Why: gcc -O2 does not unswitch it; measured, same core, Go2 30.7 -> 30.1 us, cart20 50.8 -> 49.4."""
    import re
    pat = re.compile(r"\boj\b" if oj == "oj" else re.escape(oj))
    return ([f"                    if ({oj}) {{"] + ["    " + pat.sub("1", x) for x in loop]
            + ["                    } else {"] + ["    " + pat.sub("0", x) for x in loop] + ["                    }"])


def _joint_tables(plan):
    """C: per dof the body (= joint) it belongs to, the last dof of that joint, and (with
    k-speed joints) its place among those joints' dofs (-1 for a one-speed joint's)."""
    db = [b for b in range(plan.nb) for _ in plan.dofs(b)]
    jl = [plan.first[b] + plan.count[b] - 1 for b in db]
    out = [c_table("db", db or (0,)), c_table("jl", jl or (0,))]
    if plan.multi:
        mi, m = [-1] * plan.nd, 0
        for e0, k, _ in plan.multi:
            for c in range(k):
                mi[e0 + c], m = m, m + 1
        out.append(c_table("mi", mi))
        fold = _folded(plan)
        if fold and len(fold) < len(plan.multi):    # mi without the folded joints' dofs (_first_order_lines)
            for n in fold:
                e0, k, _ = plan.multi[n]
                mi[e0:e0 + k] = [-1] * k
            out.append(c_table("mp", mi))
    return out


def _first_order_lines(rd, nm, plan):
    """C, in the pair loop (i, j): the first derivatives d tau / d xi along the k-speed joints'
    dofs, which the change to their coordinates needs (:func:`_tangent_lines`): row i along a
    dof j of i's joint or support (Carpentier-Mansard: (Y S_i).psi''_j + (B^T S_i).psi'_j, i's
    composites), row j along a dof i of a joint below j (S_j.g5_i, g5 = B psi'_i + S_i x* f + Y psi''_i).
    The folded joints' columns of row i are not taken here but per dof i (:func:`_tq_folded_lines`):
    ``mp`` is ``mi`` without their dofs, and the first line is left out when every k-speed joint
    is folded."""
    fold = _folded(plan)
    first = [] if len(fold) == len(plan.multi) else [
        f"                if ({'mp' if fold else 'mi'}[j] >= 0) Tq[i * {nm} + mi[j]] = {rd}_dot(ys, PS2 + 6 * j) + {rd}_dot3(bs, p);"]
    return first + [f"                if (mi[i] >= 0 && oj) Tq[j * {nm} + mi[i]] = {rd}_dot(s, g5);"]


def _tq_folded_lines(plan, nm):
    """C, per dof i before its pair loop: row i's first derivatives along each folded joint's
    dofs d (:func:`_folded`; every dof below such a root joint has all of them in its support),
    Tq[i, d] = (Y S_i).psi''_d + (B^T S_i).psi'_d (:func:`_first_order_lines`), for the joint's k
    dofs side by side from K's row groups 2 and 1 (they sit at the start of i's path, component-
    major): a loop gcc vectorizes instead of k branches and 9-term dots in the pair loop.  Each
    sum in rd_dot's then rd_dot3's order: the bits of the pair loop's form.  Why: that form was
    1.5 % of Go2's hess_id (knock-out, 0.4 of 27.1 us)."""
    out = []
    for n in _folded(plan):
        e0, k, _ = plan.multi[n]
        m0 = sum(kj for _, kj, _ in plan.multi[:n])
        ys = " + ".join(f"ys[{c}] * G[{12 + c} * L + l]" for c in range(6))
        bs = " + ".join(f"bs[{c}] * G[{6 + c} * L + l]" for c in range(3))
        out += [f"            if (pd[p0[jp[i]]] == {e0}) {{   /* Tq along joint {n}'s dofs: the start of i's path (_tq_folded_lines) */",
                "                const double *G = K + pG[jp[i]];",
                "                const int L = pL[jp[i]];",
                f"                for (l = 0; l < {k}; l++) Tq[i * {nm} + {m0} + l] = ({ys}) + ({bs});",
                "            }"]
    return out


def with_k_derivatives(plan, values, x):
    """(plan, values) with dK/dq of each k-speed joint appended (block K2: per joint, per
    coordinate b of it, the k x k matrix dK/dq_b, K's layout), for :func:`_tangent_lines`.
    ``values`` the analytic plan's [((group, i), expr)], ``x`` the state symbols."""
    if not plan.multi:
        return plan, values
    vals = {k[1]: e for k, e in values}
    spat = tuple(tuple(tuple(_entry_kind(vals[plan.offsets["S"] + 6 * (e0 + d) + c]) for c in range(6)) for d in range(k))
                 for e0, k, _ in plan.multi)
    if TANGENT:
        return replace(plan, spat=spat), values
    group = values[0][0][0]
    K0, extra, nz = plan.offsets["K"], [], []
    for e0, k, koff in plan.multi:
        nzj = []
        for b in range(k):
            qb = x[plan.qcol[e0 + b]]
            d = [sm.diff(sm.sympify(vals[K0 + koff + i]), qb) for i in range(k * k)]
            extra += d
            if any(e != 0 for e in d):
                nzj.append(b)
        nz.append(tuple(nzj))
    n = plan.size
    plan = replace(plan, offsets={**plan.offsets, "K2": n}, size=n + len(extra), k2nz=tuple(nz), spat=spat)
    return plan, list(values) + [((group, n + i), v) for i, v in enumerate(extra)]


def _entry_kind(e):
    """0 or 1 when the expression ``e`` is identically that number, else 2 (:data:`.analytic.AnalyticPlan.spat`)."""
    e = sm.sympify(e)
    return 0 if e == 0 else 1 if e == 1 else 2


def _tangent_lines(plan, nx, nm):
    """C: the kernel's tensor is along each k-speed joint's tangent xi (the body-frame
    perturbation its speeds move it by, Pinocchio's Lie-group tangent: G[i, d, e] = d/dxi_e of
    d tau_i / dxi_d); hess_id is along its coordinates q, q' = K(q) u, so dxi = K^-1 dq and

        d2 tau_i / dq_a dq_b = sum_de K^-1[d, a] G[i, d, e] K^-1[e, b] + sum_d T_i[d] dK^-1[d, a]/dq_b,

    dK^-1/dq_b = -K^-1 (dK/dq_b) K^-1 (block K2), T_i[d] = d tau_i / dxi_d (Tq).  Per row i:
    the joint's rows q_a first, (K^-T G)[a, .] over every column (K^-1 by K's diagonal blocks
    as the first-order kernel does, :func:`.analytic._blocks`: a free joint's translation and
    angle blocks, half the work of the full 6x6; a loop over the columns gcc vectorizes); the
    columns q_b of the other rows are then copies of those rows (the result is a Hessian,
    symmetric, and ξ and a one-speed coordinate or a speed commute: the Lie bracket enters only
    the (q_a, q_b) block), which is K^-T G K^-1 + T dK^-1/dq from the saved (q_a, ξ_e) entries.
    Measured on Go2 (bench_second_order.py): the change cost 12 µs of 43 with the columns
    transformed like the rows.  Each new number is summed into a v * 0 check (the kernel's
    bound does not cover K^-1)."""
    from .analytic import _ginv_lines
    o, nn = plan.offsets, nx * nx
    whole = len(_folded(plan)) < len(plan.multi)     # some joint takes the pass over its rows and columns
    lines = ["    {   /* the k-speed joints: from their tangent xi to their coordinates q */",
             "        double chk = 0.0" + (", tmp, piv;" if whole else ";")] + (["        int p;"] if whole else [])
    m0, fold = 0, _folded(plan)
    for jn, ((e0, k, koff), blocks) in enumerate(zip(plan.multi, plan.kblocks)):
        kb = [len(r) for r, _ in blocks]
        kk = k * k
        if jn in fold:
            lines += _folded_block_lines(plan, nx, nm, jn, m0)
            m0 += k
            continue
        lines += [
            "        {",
            f"            double Km[{max(kb) ** 2}], Kf[{kk}], W[{k * kk}], Z[{kk}], Rw[{k * nx}];",
            f"            static const int jq[{k}] = {{{', '.join(str(plan.qcol[e0 + c]) for c in range(k))}}};",
        ] + [f"            double Ki{n}[{kb[n] ** 2}];" for n in range(len(blocks))] + [
            c_table(f"kr{n}", r).replace("    ", "            ", 1) for n, (r, _) in enumerate(blocks)] + [
            c_table(f"kc{n}", c).replace("    ", "            ", 1) for n, (_, c) in enumerate(blocks)] + [
            f"            for (i = 0; i < {kk}; i++) Kf[i] = 0.0;   /* K^-1 whole: rows speeds, columns coordinates */"]
        for n, b in enumerate(kb):
            lines += [
                f"            for (i = 0; i < {b}; i++)",
                f"                for (j = 0; j < {b}; j++) Km[{b} * i + j] = an[{o['K'] + koff} + {k} * kr{n}[i] + kc{n}[j]];",
            ] + ["    " + x for x in _ginv_lines(b, f"Ki{n}")] + [
                f"            for (i = 0; i < {b}; i++)",
                f"                for (j = 0; j < {b}; j++) Kf[{k} * kc{n}[i] + kr{n}[j]] = Ki{n}[{b} * i + j];",
            ]
        k2 = o["K2"] + sum(kj ** 3 for _, kj, _ in plan.multi[:jn])     # K2: k blocks of k x k per joint
        lines += _w_lines(k, k2) + [
            f"            for (e = 0; e < {plan.nd}; e++) {{",
            f"                double *O = out + (size_t)row[e] * {nn};",
            f"                const double *Te = Tq + e * {nm} + {m0};",
            f"                for (i = 0; i < {k}; i++)   /* the joint's rows G[d, .] */",
            f"                    for (c = 0; c < {nx}; c++) Rw[{nx} * i + c] = O[jq[i] * {nx} + c];",
        ]
        for n, b in enumerate(kb):
            lines += [
                f"                for (j = 0; j < {b}; j++) {{   /* rows q_a: sum_d K^-1[d, a] G[d, .], every column */",
                f"                    double *o = O + jq[kr{n}[j]] * {nx};",
                f"                    for (c = 0; c < {nx}; c++) {{",
                f"                        tmp = Rw[{nx} * kc{n}[0] + c] * Ki{n}[j];",
                f"                        for (i = 1; i < {b}; i++) tmp += Rw[{nx} * kc{n}[i] + c] * Ki{n}[{b} * i + j];",
                "                        o[c] = tmp;",
                "                        chk += tmp * 0.0;",
                "                    }",
                "                }",
            ]
        lines += [
            f"                for (j = 0; j < {k}; j++)   /* their (q_a, xi_e) entries, before the copy below */",
            f"                    for (i = 0; i < {k}; i++) Z[{k} * j + i] = O[jq[j] * {nx} + jq[i]];",
            f"                for (j = 0; j < {k}; j++) {{   /* columns q_b of the other rows: the result is symmetric */",
            f"                    const double *o = O + jq[j] * {nx};",
            f"                    for (c = 0; c < {nx}; c++) O[c * {nx} + jq[j]] = o[c];",
            "                }",
            f"                for (j = 0; j < {k}; j++)   /* (q_a, q_b): sum_e (K^-T G)[a, e] K^-1[e, b] + sum_d T[d] dK^-1[d, a]/dq_b */",
            f"                    for (b = 0; b < {k}; b++) {{",
            "                        tmp = 0.0;",
            f"                        for (i = 0; i < {k}; i++) tmp += Z[{k} * j + i] * Kf[{k} * i + b] + Te[i] * W[{kk} * b + {k} * i + j];",
            f"                        O[jq[j] * {nx} + jq[b]] = tmp;",
            "                        chk += tmp * 0.0;",
            "                    }",
            "            }",
            "        }",
        ]
        m0 += k
    return lines + ["        big |= !(chk == 0.0);", "    }"]


def _w_lines(k, k2):
    """C: W_b = dK^-1/dq_b = -K^-1 (dK/dq_b) K^-1 for each coordinate b of a k-speed joint
    (K^-1 whole in Kf, rows speeds; dK/dq_b from an[k2 + k*k*b])."""
    kk = k * k
    loop = f"for (b = 0; b < {k}; b++) {{"
    return [
        f"            {loop}   /* W_b = dK^-1/dq_b = -K^-1 dK/dq_b K^-1 */",
        f"                const double *dK = an + {k2} + {kk} * b;",
        f"                for (i = 0; i < {k}; i++)",
        f"                    for (j = 0; j < {k}; j++) {{",
        "                        tmp = 0.0;",
        f"                        for (c = 0; c < {k}; c++) tmp += Kf[{k} * i + c] * dK[{k} * c + j];",
        f"                        Z[{k} * i + j] = tmp;",
        "                    }",
        f"                for (i = 0; i < {k}; i++)",
        f"                    for (j = 0; j < {k}; j++) {{",
        "                        tmp = 0.0;",
        f"                        for (c = 0; c < {k}; c++) tmp += Z[{k} * i + c] * Kf[{k} * c + j];",
        f"                        W[{kk} * b + {k} * i + j] = -tmp;",
        "                    }",
        "            }",
    ]


def _folded_block_lines(plan, nx, nm, jn, m0):
    """C: a folded joint's (:func:`_folded`) own (q, q) block in every row i, the only entries the
    triple loop leaves along its tangent on the "j" side: the loop wrote Z = G K^-1 (columns
    along q), so the block is K^-T Z + sum_d T_i[d] dK^-1[d, .]/dq_b (the k-speed joint's
    Hessian along its coordinates, see :func:`_tangent_lines`); per row instead of the pass over
    the joint's rows and columns (19-26 % of hess_id on Go2, G1, Talos).

    How: row a of the block is sum_d K^-1[d, a] Z[d, .] + T_i[d] Wt[a, d, .] over the speeds d of
    a's diagonal block of K^-1, with Wt[a, d, b] = dK^-1[d, a]/dq_b (:func:`_wt_lines`, once per
    call; 0 for the b whose dK/dq_b is identically 0, ``plan.k2nz``): a loop over the row's k
    columns that gcc vectorizes (the entry-by-entry form, unrolled, was 5 % of Go2's hess_id).
    Each entry sums its terms in the entry-by-entry form's order, and a term T_i[d] * 0.0 added
    to a finite sum leaves its bits (x + 0 = x; the sum starts at +0.0, which -0.0 leaves +0.0),
    so the bits are that form's.  The entries stay finite by the kernel's bound (BOUND) with
    Wt's entries checked against it (K^-1 within 1, T_i within 9 B^2): no per-entry check."""
    e0, k, _ = plan.multi[jn]
    kk, nn = k * k, nx * nx
    jq = [plan.qcol[e0 + c] for c in range(k)]
    lines = [
        "        {",
        f"            double Kf[{kk}], Wt[{k * kk}], Z[{kk}];",
        f"            static const int jq[{k}] = {{{', '.join(map(str, jq))}}};",
        "            int l;",
        f"            for (i = 0; i < {kk}; i++) Kf[i] = 0.0;   /* K^-1 whole from its blocks: rows speeds, columns coordinates */",
    ]
    speeds = {}     # coordinate a -> the speeds of its block (ascending: the full loop's order)
    for bl, (r, c) in enumerate(plan.kblocks[jn]):
        b = len(r)
        lines += [f"            Kf[{k * c[i] + r[jj]}] = Kv{jn}_{bl}[{b * i + jj}];" for i in range(b) for jj in range(b)]
        for a in r:
            speeds[a] = sorted(c)
    # the row's columns: contiguous (a root joint's coordinates are) -> a loop gcc vectorizes
    col = (f"{jq[0]} + l" if jq == list(range(jq[0], jq[0] + k)) else "jq[l]")
    lines += _wt_lines(plan, jn) + [
        f"            for (i = 0; i < {k * kk}; i++) big |= !(fabs(Wt[i]) <= {BOUND});",
        f"            for (e = 0; e < {plan.nd}; e++) {{",
        f"                double *O = out + (size_t)row[e] * {nn};",
        f"                const double *Te = Tq + e * {nm} + {m0};",
        f"                for (j = 0; j < {k}; j++)   /* Z[d, b]: the loop's (xi_d, q_b) entries */",
        f"                    for (l = 0; l < {k}; l++) Z[{k} * j + l] = O[jq[j] * {nx} + {col}];",
        "                /* (q_a, q_b): sum_d K^-1[d, a] Z[d, b] + T[d] dK^-1[d, a]/dq_b, d over a's block */",
    ]
    for a in range(k):
        terms = [f"(Kf[{k * d + a}] * Z[{k * d} + l] + Te[{d}] * Wt[{(a * k + d) * k} + l])" for d in speeds[a]]
        lines.append(f"                for (l = 0; l < {k}; l++) O[{jq[a] * nx} + {col}] = 0.0 + " + " + ".join(terms) + ";")
    return lines + ["            }", "        }"]


def _wt_lines(plan, jn):
    """C: Wt[(a k + d) k + b] = dK^-1[d, a]/dq_b = -(K^-1 (dK/dq_b) K^-1)[d, a] of folded joint
    ``jn`` (K^-1 whole in Kf: rows speeds, columns coordinates; dK/dq_b from the block K2), for
    the b in ``plan.k2nz`` (the others stay 0), d and a in one diagonal block of K (the others
    are 0: K^-1 and dK/dq_b have K's blocks).  The sums run over that block alone, in the full
    product's order (the terms left out are products by Kf's exact zeros)."""
    e0, k, _ = plan.multi[jn]
    kk = k * k
    k2 = plan.offsets["K2"] + sum(kj * kj * kj for _, kj, _ in plan.multi[:jn])
    nz = plan.k2nz[jn] if plan.k2nz else tuple(range(k))
    if not nz:
        return [f"            for (i = 0; i < {k * kk}; i++) Wt[i] = 0.0;"]
    lines = [f"            for (i = 0; i < {k * kk}; i++) Wt[i] = 0.0;",
             f"            for (l = 0; l < {len(nz)}; l++) {{   /* W_b = dK^-1/dq_b = -K^-1 dK/dq_b K^-1, block by block */",
             f"                static const int bz[{len(nz)}] = {{{', '.join(map(str, nz))}}};",
             "                const double *dK;",
             "                double Y[" + str(kk) + "];",
             "                b = bz[l];",
             f"                dK = an + {k2} + {kk} * b;"]
    for r, c in plan.kblocks[jn]:
        rs, cs = sorted(r), sorted(c)
        for i in cs:            # Y = K^-1 dK/dq_b: rows speeds, columns speeds
            for j in cs:
                lines.append(f"                Y[{k * i + j}] = 0.0 + " + " + ".join(f"Kf[{k * i + m}] * dK[{k * m + j}]" for m in rs) + ";")
        for i in cs:            # W = -Y K^-1: rows speeds d, columns coordinates a
            for j in rs:
                lines.append(f"                Wt[({j * k + i}) * {k} + b] = -(0.0 + " + " + ".join(
                    f"Y[{k * i + m}] * Kf[{k * m + j}]" for m in cs) + ");")
    return lines + ["            }"]


# The stores of row k (k < j < i) the triple loop makes per (i, j) in a chain written by halves, as
# (row, column, value): each is in another output block (one per k), and with _scratch they go to
# row i's scratch instead, in this order of its quadrants (q, q), (q, u), (u, q), (u, u).
_SCRATCH_STORES = (("qi", "qj", "e3"), ("qi", "uj", "mm"), ("ui", "qj", "g"), ("ui", "uj", "p6"))


def _scratch(plan, nq, nx, half):
    """(nd, the offsets of row i's four quadrants) when the triple loop of a chain written by halves
    (:func:`_chain_columns`) puts the stores of the rows k < j (:data:`_SCRATCH_STORES`, per (i, j) in j != i)
    into row i's own output block, in the strict upper triangles of its quadrants, which the
    loop leaves for the mirror images (:func:`_mirror_lines`) and are free until then: the values of
    (j, k) (k < j < i) at quadrant row nd - 1 - j, columns nd - j + k, contiguous in k; each
    quadrant's scratch is copied to rows q_i, u_i of the blocks k < i before the mirror images
    (:func:`_transpose_helper`'s NAME_h2_trs, d[k nn + j] = s[j ss + k]).  Else None.

    Why: those stores go to a new output block for every k (cart80: 80 blocks 210 kB apart, four
    cache lines each per (i, j)), which L1 does not hold from one j to the next; in the scratch
    they are contiguous in k, and the copy writes rows of each block.  Copies only: the same bits.
    Same-core A/B of the generated C (hess_id alone, core 0, load ~15, session 16): machine build
    cart80 3.98 -> 3.67 ms (bits checked over 32 states); -O2 (16 scalar copies a tile) 4.88 -> 4.87;
    cart40 (2.2 MB of output, mostly in cache) 274 -> 278 us, -O2 395 -> 385: unchanged."""
    chain = _chain_columns(plan, nq) if half else None
    if chain is None:
        return None
    q0, u0 = chain
    return len(plan.lam), tuple(r * nx + c for r, c in ((q0, q0), (q0, u0), (u0, q0), (u0, u0)))


def _prefetch_macro(name):
    """C (file scope): ``NAME_H2_PF(p)``, a prefetch for writing (GCC's and clang's builtin; else nothing).
    A definition given before it (-D) is kept: the tests check its addresses with one."""
    pf = f"{name.upper()}_H2_PF"
    return [f"#ifndef {pf}", "#if defined(__GNUC__)", f"#define {pf}(p) __builtin_prefetch((p), 1)", "#else",
            f"#define {pf}(p) ((void)(p))", "#endif", "#endif", ""]


def _prefetch_lines(name, scratch, nx, nq, plan):
    """C, at the top of (i, j)'s pair (with :func:`_scratch`: a chain written by halves): prefetches for
    writing of the output lines the next pair (i, jn), jn = lam[j], stores to first -- rows q_i, u_i of
    block jn (columns q_k, u_k, k <= jn), rows q_jn, u_jn of block i, and jn's scratch in block i
    (:func:`_scratch`, its four quadrants, k < jn) -- a line every 8 numbers and each segment's last
    (every address one of the entries the pair writes).  Why: each pair's stores go to lines no pair
    wrote before in this call, 210 kB apart on cart80 (a block per j), which the hardware prefetchers do
    not guess, so each waited for its line.  Same-core A/B of the generated C (hess_id alone, core 1,
    load ~20, session 17, bits equal over 8 states): cart80 -O2 2.79 -> 2.05 ms (rows of block jn alone
    2.63; the pair after next 2.36).  No effect on the values: the same bits."""
    if scratch is None:
        return []
    nd, quads = scratch
    q0, u0 = _chain_columns(plan, nq)
    pf = f"{name.upper()}_H2_PF"
    return [
        "                {   /* prefetch the next pair's first stores (_prefetch_lines) */",
        "                    const int jn = lam[j];",
        "                    int z;",
        "                    if (jn >= 0)",
        "                        for (z = 0; z < jn + 8; z += 8) {",
        f"                            const int y = z < jn ? z : jn, y1 = z < jn - 1 ? z : jn - 1;",
        f"                            double *const On = out + (size_t)row[jn] * {nx * nx};",
        *[f"                            {pf}({b} + {r} * {nx} + {c} + y);"
          for b, r, c in (("On", "qi", q0), ("On", "qi", u0), ("On", "ui", q0), ("On", "ui", u0),
                          ("Oi", "qc[jn]", q0), ("Oi", "qc[jn]", u0), ("Oi", "uc[jn]", q0), ("Oi", "uc[jn]", u0))],
        "                            if (jn > 0) {",
        *[f"                                {pf}(Oi + ({nd - 1} - jn) * {nx} + {nd} - jn + {q} + y1);" for q in quads],
        "                            }",
        "                        }",
        "                }",
    ]


def _chain_columns(plan, nq):
    """(q0, u0) when the dofs form one path in their own order (dof a's parent dof is a - 1) with
    their coordinates and speeds contiguous (x[q0 + a], x[u0 + a]), as on a cart or an arm: then
    row i's mirror images are four strictly triangular transposes (:func:`_transpose_helper`);
    else None."""
    nd = len(plan.lam)
    if plan.multi or list(plan.lam) != list(range(-1, nd - 1)):
        return None
    q0, u0 = plan.qcol[0], nq + plan.row[0]
    if list(plan.qcol) != list(range(q0, q0 + nd)) or [nq + s for s in plan.row] != list(range(u0, u0 + nd)):
        return None
    return q0, u0


def _transpose_helper(name, plan, nq, nx):
    """C (file scope, with :func:`_chain_columns`): ``NAME_h2_trt(s, d)``, d[m nx + a] = s[a nx + m]
    for 0 <= m < a < nd: a strictly lower triangle copied to the upper one, in 4 x 4 tiles (with
    AVX2 and GCC's vector extensions, or clang's, a tile is four loads, eight shuffles and four
    stores; else sixteen scalar copies), the diagonal tiles and the last rows entry by entry.
    Copies only: the bits are the entry-by-entry loop's.  Why: that loop (four copies per pair of
    dofs, one a column: 27 instructions per four copies) was 28 % of cart40's hess_id (knock-out,
    91 of 324 us); same-core A/B, machine build: cart40 331 -> 270 us (scalar tiles 291)."""
    if _chain_columns(plan, nq) is None:
        return []
    nd, X, up = len(plan.lam), nx, name.upper()
    vec = [
        f"        const {name}_h2_v4 r0 = *(const {name}_h2_v4 *)t, r1 = *(const {name}_h2_v4 *)(t + {X});",
        f"        const {name}_h2_v4 r2 = *(const {name}_h2_v4 *)(t + {2 * X}), r3 = *(const {name}_h2_v4 *)(t + {3 * X});",
        f"        const {name}_h2_v4 t0 = {up}_H2_SHUF(r0, r1, 0, 4, 2, 6), t1 = {up}_H2_SHUF(r0, r1, 1, 5, 3, 7);",
        f"        const {name}_h2_v4 t2 = {up}_H2_SHUF(r2, r3, 0, 4, 2, 6), t3 = {up}_H2_SHUF(r2, r3, 1, 5, 3, 7);",
        f"        *({name}_h2_v4 *)o = {up}_H2_SHUF(t0, t2, 0, 1, 4, 5);",
        f"        *({name}_h2_v4 *)(o + {X}) = {up}_H2_SHUF(t1, t3, 0, 1, 4, 5);",
        f"        *({name}_h2_v4 *)(o + {2 * X}) = {up}_H2_SHUF(t0, t2, 2, 3, 6, 7);",
        f"        *({name}_h2_v4 *)(o + {3 * X}) = {up}_H2_SHUF(t1, t3, 2, 3, 6, 7);",
    ]
    scalar = [f"        o[{r * X + c}] = t[{c * X + r}];" for r in range(4) for c in range(4)]
    vs = [x.replace(f"(t + {X})", "(t + ss)").replace(f"(t + {2 * X})", "(t + 2 * ss)").replace(f"(t + {3 * X})", "(t + 3 * ss)")
          .replace(f"(o + {X})", "(o + ds)").replace(f"(o + {2 * X})", "(o + 2 * ds)").replace(f"(o + {3 * X})", "(o + 3 * ds)")
          for x in vec]
    ss = [f"        o[{r} * ds + {c}] = t[{c} * ss + {r}];" for r in range(4) for c in range(4)]
    return [
        f"#if {up}_H2_LANES == 4 && defined(__GNUC__)   /* a 4 x 4 tile's transpose on vector registers */",
        f"#define {up}_H2_VT 1",
        f"typedef double {name}_h2_v4 __attribute__((vector_size(32), aligned(8)));",
        "#ifdef __clang__",
        f"#define {up}_H2_SHUF(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)",
        "#else",
        f"typedef long long {name}_h2_m4 __attribute__((vector_size(32)));",
        f"#define {up}_H2_SHUF(a, b, i, j, k, l) __builtin_shuffle(a, b, ({name}_h2_m4){{i, j, k, l}})",
        "#endif",
        "#endif",
        f"static void {name}_h2_trt(const double *s, double *d)",
        f"{{   /* d[m * {X} + a] = s[a * {X} + m] for 0 <= m < a < {nd}, in 4 x 4 tiles (_transpose_helper) */",
        "    int a, m, a0, m0;",
        f"    for (a0 = 0; a0 + 4 <= {nd}; a0 += 4) {{",
        "        for (m0 = 0; m0 < a0; m0 += 4) {",
        f"            const double *t = s + a0 * {X} + m0;",
        f"            double *o = d + m0 * {X} + a0;",
        f"#ifdef {up}_H2_VT",
        *["    " + x for x in vec],
        "#else",
        *["    " + x for x in scalar],
        "#endif",
        "        }",
        "        for (a = a0 + 1; a < a0 + 4; a++)",
        f"            for (m = a0; m < a; m++) d[m * {X} + a] = s[a * {X} + m];",
        "    }",
        f"    for (a = a0; a < {nd}; a++)",
        f"        for (m = 0; m < a; m++) d[m * {X} + a] = s[a * {X} + m];",
        "}",
        "",
        f"static void {name}_h2_trs(const double *s, long ss, double *d, long ds, int n)",
        "{   /* d[m * ds + a] = s[a * ss + m] for 0 <= m < a < n, in 4 x 4 tiles along d's rows (_scratch) */",
        "    int a, m, a0 = 0, m0;",
        "    for (m0 = 0; m0 + 4 <= n; m0 += 4) {",
        "        for (m = m0; m < m0 + 3; m++)   /* the diagonal tile */",
        "            for (a = m + 1; a < m0 + 4; a++) d[m * ds + a] = s[a * ss + m];",
        "        for (a0 = m0 + 4; a0 + 4 <= n; a0 += 4) {",
        "            const double *t = s + a0 * ss + m0;",
        "            double *o = d + m0 * ds + a0;",
        f"#ifdef {up}_H2_VT",
        *["    " + x for x in vs],
        "#else",
        *["    " + x for x in ss],
        "#endif",
        "        }",
        "        for (m = m0; m < m0 + 4; m++)   /* the last columns */",
        "            for (a = a0; a < n; a++) d[m * ds + a] = s[a * ss + m];",
        "    }",
        "    for (m = m0; m < n; m++)",
        "        for (a = m + 1; a < n; a++) d[m * ds + a] = s[a * ss + m];",
        "}",
        "",
    ]


def _mirror_lines(name, plan, nq, nx):
    """C, at the end of row i's pair loop (with ``half``, :func:`_pair_store`): row i's entries
    whose row dof m is on the support of the column dof a, (x_m, x_a) = (x_a, x_m), the four of
    each pair of dofs (the result is a Hessian, symmetric).  Row i is complete then: the rows
    after it (dofs nearer the root) write no entry of it, and its written half is still in
    cache.  Why: the triple loop's mirror stores (along a column: one cache line per k, and in
    row j's and row k's blocks) were most of cart80's time (perf).  A chain in order
    (:func:`_chain_columns`) takes four triangular transposes in tiles (:func:`_transpose_helper`), after
    copying out row i's scratch (:func:`_scratch`), which the transposes then overwrite."""
    chain = _chain_columns(plan, nq)
    if chain is not None:
        q0, u0 = chain
        sc, nn = _scratch(plan, nq, nx, True), nx * nx
        drain = [] if sc is None else [
            "            /* rows q_i, u_i of the blocks k < i from row i's scratch, before it takes the mirror images (_scratch) */"] + [
            f"            {name}_h2_trs(Oi + {q + (sc[0] - 1) * nx + sc[0]}, {-(nx + 1)}, out + (size_t)row[0] * {nn} + {rw} * {nx} + "
            f"{q0 if cl == 'qj' else u0}, {nn}, i);" for (rw, cl, _), q in zip(_SCRATCH_STORES, sc[1] if sc else ())]
        return drain + ["            /* row i's mirror images, left out by the triple loop: (q, q), (q, u), (u, q), (u, u) (_mirror_lines) */"] + [
            f"            {name}_h2_trt(Oi + {r * nx + c}, Oi + {c * nx + r});" for r, c in ((q0, q0), (u0, q0), (q0, u0), (u0, u0))]
    return [
        "            {   /* row i's mirror images, left out by the triple loop (_mirror_lines) */",
        "                int a, t;",
        f"                for (a = 0; a < {plan.nd}; a++) {{   /* m over a's support: the start of its path (paths) */",
        f"                    const double *rq = Oi + qc[a] * {nx}, *ru = Oi + uc[a] * {nx};",
        "                    const int qa = qc[a], ua = uc[a], *sa = pd + p0[jp[a]], ta = jt[a];",
        "                    for (t = 0; t < ta; t++) {",
        "                        const int qm = qc[sa[t]], um = uc[sa[t]];",
        f"                        Oi[qm * {nx} + qa] = rq[qm]; Oi[qm * {nx} + ua] = ru[qm];",
        f"                        Oi[um * {nx} + qa] = rq[um]; Oi[um * {nx} + ua] = ru[um];",
        "                    }",
        "                }",
        "            }",
    ]


def _law_lines(plan, nx):
    """The joint laws' own curvature (block L2, :func:`with_law_hessians`): τ = RNEA - law, so
    each law's second derivatives leave its row's (q_k, u_k) entries."""
    o, nn = plan.offsets["L2"], nx * nx
    return [
        "    {   /* the joint laws: their value is in F (a constant load above), their own curvature here */",
        "    " + c_table("jd", plan.laws),
        f"        for (j = 0; j < {len(plan.laws)}; j++) {{",
        f"            double *O = out + (size_t)row[jd[j]] * {nn};",
        "            const int qj = qc[jd[j]], uj = uc[jd[j]];",
        f"            const double *h = an + {o} + 3 * j;",
        "            big |= !(fabs(h[0]) <= 1e300) | !(fabs(h[1]) <= 1e300) | !(fabs(h[2]) <= 1e300);",
        f"            O[qj * {nx} + qj] -= h[0];",
        f"            O[qj * {nx} + uj] -= h[1];",
        f"            O[uj * {nx} + qj] -= h[1];",
        f"            O[uj * {nx} + uj] -= h[2];",
        "        }",
        "    }",
    ]


def second_order_body(ctx, program, sym):
    """C body of NAME_hess_id on the kernel: its inputs an[] (straight-line), u and u' per
    dof, one call."""
    plan = sym.second_order[0]
    pr = ctx.printer(program)
    vals = program.result_exprs(ANH)
    rows = ", ".join(str(s) for s in plan.row)
    lines = [f"{IND}double an[{plan.size}];"]
    lines += temps(program, pr)
    lines += [store(f"an[{k[1]}]", e, pr) for k, e in sorted(vals.items(), key=lambda kv: kv[0][1])]
    lines += [f"{IND}{{",
              f"{IND}    static const int sp[{plan.nd}] = {{{rows}}};",
              f"{IND}    double u[{plan.nd}], ud[{plan.nd}];",
              f"{IND}    int e, big;",
              f"{IND}    for (e = 0; e < {plan.nd}; e++) {{",
              f"{IND}        u[e] = x[{ctx.nq} + sp[e]];",
              f"{IND}        ud[e] = udot[sp[e]];",
              f"{IND}    }}",
              *([f"{IND}    /* the entries off the tree's support paths are left as the caller zeroed them (NAME_rnea_hess) */"]
                if not ZERO and not _covers_all(plan, ctx.nq, ctx.nx) else []),
              f"#if {AVX2_GUARD}",
              f'{IND}    if (__builtin_cpu_supports("avx2"))   /* the same bits, on AVX2 (_avx2_twin) */',
              f"{IND}        big = {ctx.name}_rnea_hess_avx2(an, u, ud, out);",
              f"{IND}    else",
              "#endif",
              f"{IND}    big = {ctx.name}_rnea_hess(an, u, ud, out);",
              f"{IND}    if (!big) return EOMC_OK;   /* finite by its bound (BOUND) */",
              f"{IND}}}",
              f"{IND}return {ctx.name}_rd_finite(out, {ctx.nu * ctx.nx * ctx.nx});   /* analytic.finite_lines */"]
    return lines


def second_order_ops(program, plan, nx):
    """Floating-point operations of NAME_hess_id on the kernel (multiply-adds as one mul and
    one add), counted from the C above: per body ~1,200 (placement, v, a, Y, B, f), per dof
    ~2,300 (the 6x6 operators), per (dof, support dof) pair ~600, per triple ~90 muls."""
    c = Counter()
    for _, e in program.assignments:
        count_ops(e, c)
    for e in program.result_exprs(ANH).values():
        count_ops(e, c)
    pairs = sum(d + 1 for d in plan.dep)
    triples = sum((d + 1) * (d + 2) // 2 for d in plan.dep)
    c["adds"] += 4 * len(plan.laws)     # the laws' curvature (_law_lines)
    if plan.multi and not TANGENT:      # the change to the k-speed joints' coordinates (_tangent_lines)
        fold = _folded(plan)
        for n, ((_, k, _), blocks) in enumerate(zip(plan.multi, plan.kblocks)):
            if n in fold:       # per path K's columns along q (_k_folded_lines), per row the (q, q) block
                per_path = 12 * sum(len(r) ** 2 for r, _ in blocks)     # (_folded_block_lines), W (_wt_lines)
                npaths = len(paths(plan)[0])
                per_row = 2 * k * sum(len(r) ** 2 for r, _ in blocks)
                w = 2 * len(plan.k2nz[n] if plan.k2nz else range(k)) * sum(len(r) ** 3 for r, _ in blocks)
                c["muls"] += npaths * per_path + plan.nd * per_row + w
                c["adds"] += npaths * per_path + plan.nd * per_row + w
                continue
            per_row = 2 * sum(len(r) ** 2 for r, _ in blocks) * nx + k ** 3
            c["muls"] += plan.nd * per_row + 2 * k ** 4
            c["adds"] += plan.nd * per_row + 2 * k ** 4
    c["muls"] += 620 * plan.nb + 1150 * plan.nd + 300 * pairs + 84 * triples
    c["adds"] += 600 * plan.nb + 1150 * plan.nd + 300 * pairs + 84 * triples
    return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
