"""The recursive formulation as the C emitter's peer of Kane's (eomc.compiler.emit.formulation).

ABA for u', RNEA for the inverse dynamics and the Jacobians' residuals, CRBA for the mass
matrix, all over the joint tree (:mod:`.lower`); its own C bodies where the articulated
recursion replaces a factorization (:mod:`.emit`, :mod:`.jvp`) and its own operation counts
for them.  Everything else -- outputs, events, constraints, the extra states' rows, poses --
is emit's default, the same code as Kane's.
"""
from collections import Counter

from ..emit.formulation import Formulation
from ..emit.reverse import REVERSE_FUNCTIONS, hess_id_body, hess_id_ops, reverse_body
from ..ir import count_program
from ..tree.analytic import kernel_c
from ..tree.analytic_emit import analytic_body_ops, analytic_jac_id_body, analytic_jac_x_body, has_analytic
from ..tree.constrained import jacobian_symbols
from ..tree.inverse_derivatives import jac_id_body, jac_id_ops
from ..tree.second_order import second_order_body, second_order_c, second_order_ops
from ..tree.emit import tree_jacobian_body, tree_jacobian_ops, tree_implicit_body, tree_matrix_body, tree_rhs_body
from ..tree.dynamics_kernel import (KERNEL_FUNCTIONS, dynamics_body, dynamics_inputs, dynamics_kernel_c,
                                    dynamics_ops, forcing_by_inverse_dynamics, has_dynamics_kernel,
                                    inputs_users)
from ..tree.input_jacobian import input_jacobian_body, input_jacobian_ops, msolve_c
from ..tree.jvp import tree_jvp_body
from ..tree.lower import TREE_FUNCTION_GROUPS, TREE_HELPER_USERS, build_tree_symbolic
from ..tree.regressor import PI_NAMES
from ..contact.tree import contact_outputs
from ..emit.bodies import plain_body
from ..tree.lower import implicit_layout

__all__ = ["Recursive"]

_OWN_COUNTS = ("rhs", "mass_matrix", "forcing", "inverse_dynamics", "jvp", "vjp", "hvp")
_JACOBIANS = ("jac_x", "jac_r", "jac_p")



def speed_parents(body_parent, own):
    """Per speed, its parent speed: the previous speed of its own joint, or the last speed of
    the nearest moving ancestor (-1 at the root).  ``body_parent[i]`` is body i's parent body
    (-1 at the root), ``own[i]`` the speeds of body i's joint in order.  The numbering of M's
    tree-sparse LDLᵀ (runtime/c/eomc_fixedstep.c) and of the LTDL rivals in benchmarks/."""
    parent = [-1] * sum(len(o) for o in own)
    for i in range(len(own)):
        j, last = body_parent[i], -1
        while j >= 0 and not own[j]:
            j = body_parent[j]
        if j >= 0:
            last = own[j][-1]
        for s in own[i]:
            parent[s], last = last, s
    return parent

class Recursive(Formulation):
    """The recursive formulation of the joint tree ``tree`` (eomc.compiler.tree.model.Tree)."""
    name = "recursive"
    groups = TREE_FUNCTION_GROUPS
    helper_users = TREE_HELPER_USERS
    solves = False            # rhs, jac_x and jac_r solve by ABA (no factorization)

    def __init__(self, tree):
        self.tree = tree

    def refusal(self, functions):
        return None

    def builds_implicit(self, requested):
        from ..contact.tree import contact_outputs
        if contact_outputs(self.tree) and self.tree.loops is None:
            return True
        return super().builds_implicit(requested)

    def symbolic(self, formed, layout, functions, outputs=None, events=None):
        return build_tree_symbolic(self.tree, formed, layout, functions, outputs, events)

    def body(self, fn, ctx, prog, sym, layout, nx):
        if fn == "rhs":
            return tree_rhs_body(ctx, prog, sym.guards)
        if fn in KERNEL_FUNCTIONS and has_dynamics_kernel(prog, sym, fn):
            return dynamics_body(ctx, prog, sym, fn)
        if fn == "forcing" and sym.forcing_calls == "inverse_dynamics":
            return forcing_by_inverse_dynamics(ctx)
        if fn in ("mass_matrix", "forcing", "inverse_dynamics"):
            return tree_matrix_body(ctx, prog, fn)
        shared = fn in inputs_users(sym, ctx.functions)
        if fn == "jac_id" and has_analytic(prog, sym):
            return analytic_jac_id_body(ctx, prog, sym, shared)
        if fn == "jac_x" and has_analytic(prog, sym):
            return analytic_jac_x_body(ctx, prog, sym, *jacobian_symbols(prog, sym.W, ctx.nu), shared=shared)
        if fn == "jac_id":
            return jac_id_body(ctx, prog, sym.seeds)
        if fn == "jac_r" and sym.input_solve:
            return input_jacobian_body(ctx, prog, sym, len(layout.r), shared)
        if fn == "hess_id" and sym.second_order is not None:
            return second_order_body(ctx, prog, sym)
        if fn == "hess_id":
            return hess_id_body(ctx, prog, sym, nx)
        if fn in REVERSE_FUNCTIONS:
            return reverse_body(fn, ctx, prog, sym, nx, len(layout.p), jacobian_symbols(prog, sym.W, ctx.nu)[1])
        if fn == "implicit":
            size = implicit_layout(ctx.nq, ctx.nu, len(contact_outputs(self.tree)))["size"]
            return tree_implicit_body(ctx, prog, sym.implicit_guards, size)
        if fn == "jvp":
            return tree_jvp_body(ctx, prog, *jacobian_symbols(prog, sym.W, ctx.nu), sym.seeds, nx, len(layout.p))
        if fn in _JACOBIANS:
            return tree_jacobian_body(ctx, prog, *jacobian_symbols(prog, sym.W, ctx.nu), sym.seeds, fn,
                                      len(layout.p) if fn == "jac_p" else len(layout.r))
        return None

    def ops(self, fn, prog, sym, nx, nr, npar, nq, nu, solve_in):
        if fn == "hess_id" and sym.second_order is not None:
            return second_order_ops(prog, *sym.second_order)
        if fn == "hess_id":      # the sweep once per row, its tangent once per row and column
            return hess_id_ops(prog, sym, nx, nu)
        if fn in KERNEL_FUNCTIONS and prog is not None and has_dynamics_kernel(prog, sym, fn):
            c = count_program(prog) + Counter(dynamics_ops(sym.analytic, fn))
            return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
        if fn in _OWN_COUNTS and fn not in solve_in:
            c = count_program(prog) if prog is not None else Counter()
            return {k: int(c.get(k, 0)) for k in ("adds", "muls", "divs", "calls")}
        if fn in ("jac_id", "jac_x") and has_analytic(prog, sym):
            nq_ = nx - nu if nq is None else nq
            return analytic_body_ops(fn, prog, sym, *jacobian_symbols(prog, sym.W, nu), nq_, nu, nx)
        if fn == "jac_id":
            return jac_id_ops(prog, sym.seeds, nx - nu if nq is None else nq, nu, nx)
        if fn == "jac_r" and sym.input_solve:
            return input_jacobian_ops(prog, sym, nx - nu if nq is None else nq, nu, nr)
        if fn in _JACOBIANS:
            return tree_jacobian_ops(prog, *jacobian_symbols(prog, sym.W, nu), sym.seeds, fn,
                                     nx - nu if nq is None else nq, nx, npar if fn == "jac_p" else nr)
        return None

    def shared_code(self, fn, ctx, prog, sym, functions):
        """NAME_dyn_inputs: the kernels' inputs an[], once for mass_matrix, forcing,
        inverse_dynamics, jac_x and jac_id (:func:`~.dynamics_kernel.inputs_users`), before
        the first of them."""
        users = inputs_users(sym, functions)
        if not users or fn != users[0] or prog is None or not has_analytic(prog, sym):
            return None
        return dynamics_inputs(ctx, prog, sym, own=fn in KERNEL_FUNCTIONS)

    def restrict_scratch(self, fn):
        """rhs: its sub-functions take their scratch array ``restrict`` (same bits, G1 and Talos
        10 % faster, UR10 6 %: :func:`~eomc.compiler.emit.split.split_body`).  The other
        functions keep their C (the derivatives' owners measure them on their own)."""
        return fn == "rhs"

    def c_helpers(self, name, sym, functions, nq):
        """NAME_rnea_derivs (:mod:`.analytic`) when jac_x or jac_id use it, NAME_dyn
        (:mod:`.dynamics_kernel`) when mass_matrix, forcing or inverse_dynamics do, NAME_msolve
        (:mod:`.input_jacobian`) when jac_r does."""
        out = []
        first = sym.analytic is not None and bool({"jac_x", "jac_id"} & set(functions))
        if first:
            out.append(kernel_c(name, sym.analytic, nq, solve="jac_x" in functions))
        if sym.analytic is not None and set(sym.dynamics_kernel) & set(functions):
            out.append(dynamics_kernel_c(name, sym.analytic))
        if "jac_r" in functions and sym.input_solve:     # NAME_msolve (.input_jacobian)
            out.append(msolve_c(name, sym.analytic, sym.input_solve))
        if "hess_id" in functions and sym.second_order is not None:   # NAME_rnea_hess (.second_order)
            out.append(second_order_c(name, *sym.second_order[:1], nq, sym.second_order[1], helpers=not first))
        return "\n\n".join(out)

    def metadata(self, sym, functions):
        out = {}
        if "implicit" in functions:
            out["implicit"] = self.implicit_metadata()
        if getattr(self.tree, "quaternions", ()):
            # x indices of each quaternion's w (x, y, z follow): the runtime keeps them unit
            out["quaternions"] = [int(k) for k in self.tree.quaternions]
        if "hess_id" in functions and sym.second_order_note:
            out["hess_id"] = sym.second_order_note
        if "regressor" not in functions:
            return out
        return {**out, "regressor_bodies": list(sym.regressor_bodies),
                "regressor_reference": list(sym.regressor_reference),
                "regressor_parameters": list(PI_NAMES)}

    def implicit_metadata(self):
        """What runtime/c/eomc_fixedstep.c needs besides NAME_implicit's numbers: per contact
        the speeds that move its body (its chain to the root), and per speed its parent in
        the tree (the previous speed of its joint or of the nearest moving ancestor; -1 at
        the root), for M's tree-sparse LDLᵀ."""
        bodies = self.tree.bodies
        own = [[s for s, _ in b.dofs] for b in bodies]

        def chain(i):
            out = []
            while i >= 0:
                out = own[i] + out
                i = bodies[i].parent
            return out
        parent = speed_parents([b.parent for b in bodies], own)
        nq, nu = len(self.tree.coordinates), len(self.tree.speeds)
        contacts = contact_outputs(self.tree)
        return {"contacts": [{"name": c.name, "speeds": chain(c.body)} for c in contacts],
                "parents": parent, "layout": implicit_layout(nq, nu, len(contacts))}
