"""The one mechanism every benchmark times: PyDy's n-link pendulum on a cart.

Each tool gets the same model with the same numbers.  The symbolic model comes
from tests/zoo.py (so benchmarks and tests share one definition); the
Pinocchio model is built here from joints and inertias and checked against the
symbolic one (`check_pinocchio`) before anything is timed, because a benchmark
that compares different models is worthless.

Conventions of the zoo model: q0 is the cart's x position, q_i (i >= 1) the
ABSOLUTE angle of link i about I.z (link i points along +B_i.y, so q = 0 is
upright), u = q', point masses m_i at the link ends, gravity -g along I.y,
one input F(t) pushing the cart along I.x.  Pinocchio's revolute joints use
RELATIVE angles, so its states are converted (outside the timed call).
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

_TESTS = Path(__file__).resolve().parent.parent / "tests"
if str(_TESTS) not in sys.path:       # the tests' helpers package (tests/helpers/zoo.py)
    sys.path.insert(0, str(_TESTS))

from helpers.zoo import n_link_pendulum_on_cart  # noqa: E402

__all__ = [
    "n_link_pendulum_on_cart", "sympy_kane", "eomc_kane", "parameter_values",
    "parameter_vector", "initial_state", "random_states", "pydy_ode_function",
    "sympy_lambdified_rhs", "symengine_lambdified_rhs", "pinocchio_model",
    "pinocchio_rhs", "eomc_compile", "eomc_status", "check_against",
]

G = 9.81


def sympy_kane(n):
    """(KanesMethod, specified) formed by sympy.physics.mechanics."""
    import sympy.physics.mechanics as me
    return n_link_pendulum_on_cart(n, me)


def eomc_kane(n):
    """(KanesMethod, specified) formed by eomc.mechanics (SymPy's if eomc has none yet)."""
    try:
        import eomc.mechanics as em
        if hasattr(em, "KanesMethod"):
            return n_link_pendulum_on_cart(n, em)
    except Exception:  # noqa: BLE001 - eomc may be half-written while benchmarks run
        pass
    return sympy_kane(n)


def parameter_values(n):
    """name -> value: masses and lengths vary a little so no symmetry hides a bug."""
    values = {"g": G, "m0": 1.0}
    for i in range(n):
        values[f"l{i}"] = (1.0 + 0.05 * i) / n
        values[f"m{i + 1}"] = 0.5 + 0.03 * i
    return values


def parameter_vector(symbols, n):
    """The values of `symbols` (SymPy symbols or names) in that order."""
    values = parameter_values(n)
    return np.array([values[str(s)] for s in symbols], dtype=float)


def initial_state(n, amplitude=0.3):
    """Links displaced by `amplitude` rad from hanging (q_i = pi - amplitude), at rest.

    Not PyDy's example start (links horizontal): from there the chain is
    chaotic within 10 s and two rtol=1e-13 solutions end O(10) apart, so no
    final-state error could be resolved.  From 0.3 rad they agree to ~1e-12.
    """
    return np.concatenate([[0.0], np.full(n, np.pi - amplitude), np.zeros(n + 1)])


def random_states(n, count, seed=0):
    """`count` varied states (rows), bounded so nothing is near a singularity."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(count, n + 1))
    u = rng.uniform(-2.0, 2.0, size=(count, n + 1))
    return np.ascontiguousarray(np.hstack([q, u]))


_CONSTANTS = {}


def _constants(kane):
    """The system's constants, sorted by name; remembered per system so the harness's own
    walk over the expressions is not timed as part of a warm eomc.compile."""
    key = id(kane)
    if key not in _CONSTANTS or _CONSTANTS[key][0] is not kane:
        syms = kane.mass_matrix_full.free_symbols | kane.forcing_full.free_symbols
        _CONSTANTS[key] = (kane, sorted((s for s in syms if str(s) != "t"), key=str))
    return _CONSTANTS[key][1]


def pydy_ode_function(n, kane=None, specified=None, generator="cython", tmp_dir=None):
    """PyDy 0.9.4's generated rhs f(x, t, r, p) and its parameter vector p.

    Uses the full mass matrix and forcing (as pydy.system.System does) with
    numpy's linear solver.  Only generate_ode_function is inside the returned
    time; derivation is the caller's business.
    """
    from pydy.codegen.ode_function_generators import generate_ode_function
    if kane is None:
        kane, specified = sympy_kane(n)
    constants = _constants(kane)
    kwargs = {"generator": generator}
    if generator == "cython":
        kwargs["tmp_dir"] = tmp_dir or tempfile.mkdtemp(prefix="pydy_bench_")
    f = generate_ode_function(kane.forcing_full, kane.q, kane.u, constants,
                              mass_matrix=kane.mass_matrix_full, specifieds=specified,
                              **kwargs)
    return f, parameter_vector(constants, n)


def _mass_forcing_exprs(kane, specified=()):
    """(states, M, F, inputs) with the dynamic symbols replaced by plain symbols.

    symengine cannot take q(t) as an argument, and plain symbols cost SymPy's
    lambdify nothing, so both lambdify paths get the same substituted input.
    """
    import sympy as sm
    dyn = list(kane.q) + list(kane.u) + list(specified)
    plain = [sm.Symbol(f"x{i}_") for i in range(len(dyn))]
    sub = dict(zip(dyn, plain))
    nx = len(kane.q) + len(kane.u)
    return (plain[:nx], kane.mass_matrix_full.xreplace(sub),
            kane.forcing_full.xreplace(sub), plain[nx:])


def sympy_lambdified_rhs(n, kane=None, specified=None):
    """rhs(x) by sympy.lambdify (numpy, cse) of M(x) and F(x) plus numpy.linalg.solve."""
    import sympy as sm
    if kane is None:
        kane, specified = sympy_kane(n)
    states, M, F, inputs = _mass_forcing_exprs(kane, specified)
    constants = _constants(kane)
    args = states + inputs + constants
    fm = sm.lambdify(args, M, modules="numpy", cse=True)
    ff = sm.lambdify(args, F, modules="numpy", cse=True)
    p = list(parameter_vector(constants, n))
    nx = len(states)
    solve = np.linalg.solve

    def rhs(x, r):
        a = (*x, *r, *p)
        return solve(fm(*a), ff(*a).reshape(nx))
    return rhs


def symengine_lambdified_rhs(n, kane=None, specified=None):
    """(rhs(x, r), backend) by symengine.Lambdify of [M, F] (LLVM if built with it)."""
    import symengine as se
    if kane is None:
        kane, specified = sympy_kane(n)
    states, M, F, inputs = _mass_forcing_exprs(kane, specified)
    constants = _constants(kane)
    args = states + inputs + constants
    nx = len(states)
    exprs = list(M) + list(F)
    try:
        f = se.Lambdify(args, exprs, backend="llvm", cse=True)
        backend = "llvm"
    except (RuntimeError, ValueError, TypeError):
        f = se.Lambdify(args, exprs, backend="lambda", cse=True)
        backend = "lambda"
    p = parameter_vector(constants, n)
    buf = np.empty(len(args))
    k = nx * nx
    nr = len(specified)
    solve = np.linalg.solve

    def rhs(x, r):
        buf[:nx] = x
        buf[nx:nx + nr] = r
        buf[nx + nr:] = p
        out = f(buf)
        return solve(out[:k].reshape(nx, nx), out[k:])
    return rhs, backend


def pinocchio_model(n):
    """(model, data): prismatic-X cart + n revolute-Z joints, point masses, gravity -g y."""
    import pinocchio as pin
    values = parameter_values(n)
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0.0, -G, 0.0]), np.zeros(3))
    parent = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "cart")
    model.appendBodyToJoint(parent, pin.Inertia(values["m0"], np.zeros(3), np.zeros((3, 3))),
                            pin.SE3.Identity())
    offset = np.zeros(3)  # joint i+1 sits at the end of link i
    for i in range(n):
        placement = pin.SE3(np.eye(3), offset)
        parent = model.addJoint(parent, pin.JointModelRZ(), placement, f"link{i}")
        lever = np.array([0.0, values[f"l{i}"], 0.0])
        model.appendBodyToJoint(parent, pin.Inertia(values[f"m{i + 1}"], lever, np.zeros((3, 3))),
                                pin.SE3.Identity())
        offset = lever
    return model, model.createData()


def to_pinocchio(x, n):
    """Our (absolute-angle) state -> Pinocchio's (q, v) with relative joint angles."""
    q, u = x[:n + 1], x[n + 1:]
    return (np.concatenate([[q[0]], np.diff(q[1:], prepend=0.0)]),
            np.concatenate([[u[0]], np.diff(u[1:], prepend=0.0)]))


def pinocchio_rhs(n):
    """rhs(x, r) through pin.aba, converted back to absolute angles (for checking only)."""
    import pinocchio as pin
    model, data = pinocchio_model(n)

    def rhs(x, r):
        q, v = to_pinocchio(x, n)
        tau = np.zeros(n + 1)
        tau[0] = r[0]
        a = np.array(pin.aba(model, data, q, v, tau))
        udot = np.concatenate([[a[0]], np.cumsum(a[1:])])
        return np.concatenate([x[n + 1:], udot])
    return rhs


def check_against(reference, candidate, n, label, count=5, tol=1e-10, seed=7):
    """Max relative difference of two rhs(x, r) at random states; raise if above `tol`."""
    worst = 0.0
    for x in random_states(n, count, seed=seed):
        r = np.array([0.3])
        a, b = np.asarray(reference(x, r)), np.asarray(candidate(x, r))
        worst = max(worst, float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(a)))))
    if not worst <= tol:
        raise AssertionError(f"{label}: rhs differs from the reference by {worst:.3g} (n={n})")
    return worst


def eomc_status():
    """(True, '') if eomc.compile can be imported, else (False, reason)."""
    try:
        import eomc
        eomc.compile  # noqa: B018 - resolves the lazy attribute
        return True, ""
    except Exception as exc:  # noqa: BLE001
        return False, f"{type(exc).__name__}: {exc}"


def eomc_compile(n, cache_dir, kane=None, name=None, **kwargs):
    """Model for the n-link cart with our parameter values as defaults."""
    import eomc
    if kane is None:
        kane, _ = eomc_kane(n)
    constants = _constants(kane)
    params = dict(zip(constants, parameter_vector(constants, n)))
    return eomc.compile(kane, name=name or f"nlink{n}", parameters=params,
                        cache_dir=str(cache_dir), **kwargs)


def eomc_p(model, n):
    """Our parameter vector in the model's own parameter order."""
    return parameter_vector(model.param_names, n)


__all__ += ["to_pinocchio", "eomc_p", "G"]
