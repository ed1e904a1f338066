"""``eomc.gradient``: the gradient of a scalar cost of a simulated trajectory with respect to
the initial state and every parameter, by the adjoint (reverse) method.

Why: identification and trajectory optimization fit many parameters (10 inertial
parameters per body) to a trajectory.  Forward sensitivities or central differences
cost one or two trajectories per parameter; the adjoint costs one forward run and one
backward run whatever the number of parameters.  The cost is any differentiable
function of the states at the grid points, ``J(x_0, ..., x_N)`` -- a terminal cost, a
sum of running costs, a least-squares fit to measurements -- given as
``cost(t, X) -> (J, dJ/dX)``.

Method: fixed-step classic RK4 (the discretization is part of the model being
differentiated, so the gradient is exact for the simulated trajectory, what central
differences of ``simulate(method="rk4", dt=...)`` approach), or ``method="dop853"``:
the adaptive DOP853 run with its steps ending on every grid time, its accepted steps
recorded (start time and state: the checkpoints) and the discrete adjoint taken over
those steps with their sizes held fixed (exact for that step sequence; central
differences of whole adaptive runs approach it as the tolerance tightens).  The forward run stores
every grid state (the checkpoints) and, up to :data:`KEEP_STAGES_MAX` doubles, every step's
stage states (RK4) or stage derivatives (DOP853); the backward run (runtime/c/eomc_adjoint.c) takes them (or recomputes a
step's stages from its checkpoint) and pulls the adjoint through them
with the model's generated ``vjp`` (one reverse sweep of the rhs for all states and
parameters at once).  Both runs are single C calls.  Inputs are constant over the run.
Models need ``vjp`` in their functions (``functions=[..., "vjp"]``).
"""
from dataclasses import dataclass

import numpy as np

from .errors import ModelError, SimulationError
from .header_cdef import header_cdef
from .integrators_api import STATUS_NAMES
from .native import extension_library

__all__ = ["gradient", "GradientResult", "ADJOINT_CDEF"]

ADJOINT_CDEF = header_cdef("eomc_adjoint.h")


@dataclass
class GradientResult:
    """What :func:`gradient` returns.

    value: J; dx0: dJ/dx0 (nx,); dp: dJ/dp (nparam,), in ``param_names`` order;
    t: (N + 1,) grid times; x: (N + 1, nx) the simulated states at them; stats: the
    backward run's counts (method="radau": jac_x calls, factorizations, iterations, steps
    solved densely, vjp calls; else None).
    """
    value: float
    dx0: np.ndarray
    dp: np.ndarray
    t: np.ndarray
    x: np.ndarray
    param_names: tuple
    state_names: tuple
    stats: dict = None

    def dp_named(self):
        """{parameter name: dJ/dp}."""
        return dict(zip(self.param_names, self.dp.tolist()))


def _steps(t_final, dt):
    if not (np.isfinite(t_final) and t_final > 0):
        raise ValueError(f"t_final must be a positive finite time; got {t_final!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite step; got {dt!r}")
    n = int(round(t_final / dt))
    if n < 1 or abs(n * dt - t_final) > 1e-9 * max(1.0, t_final):
        raise ValueError(f"t_final = {t_final:g} is not a whole number of steps dt = {dt:g} "
                         f"(the gradient is of the RK4 trajectory on that grid); choose dt = "
                         f"t_final / n")
    return n


def simulate_grid(model, x0, t_final, *, dt, p=None, r=None, method="rk4", rtol=1e-8, atol=1e-8):
    """(t, X): the trajectory :func:`gradient` differentiates (grid states only)."""
    a = _prepare(model, x0, t_final, dt, p, r)
    if _method(method) != "rk4":
        return a["t"], _forward_adaptive(model, a, rtol, atol, method)[0]
    X, _ = _forward(model, a)
    return a["t"], X


def _method(method):
    if method not in ("rk4", "dop853", "radau"):
        raise ValueError(f"eomc.gradient: method must be 'rk4' (fixed step dt), 'dop853' or "
                         f"'radau' (adaptive, steps ending on the grid); got {method!r}")
    return method


def gradient(model, x0, t_final, *, dt, cost, p=None, r=None, method="rk4", rtol=1e-8, atol=1e-8):
    """The cost of an RK4 trajectory and its gradient w.r.t. x0 and all parameters.

    ``x0``: initial state (array or {state name: value}); ``t_final``: a whole number of
    steps ``dt`` from t = 0; ``cost(t, X)``: t the (N + 1,) grid times, X the (N + 1, nx)
    states; returns (J, dJ/dX) with dJ/dX shaped as X.  ``p``, ``r``: parameters and
    constant inputs as for ``simulate``.  ``method``: "rk4" (steps dt), "dop853" or "radau"
    (adaptive at rtol/atol, every grid time a step end; dt is then the cost's grid only;
    "radau" also needs jac_x).  Returns a :class:`GradientResult`.
    """
    if "vjp" not in model.functions:
        raise ModelError(f"{model.name}: eomc.gradient needs the model built with 'vjp' "
                         f"(functions=[..., 'vjp'] or eomc build --outputs ...,vjp)")
    if _method(method) == "radau" and "jac_x" not in model.functions:
        raise ModelError(f"{model.name}: eomc.gradient(method='radau') needs the model built with "
                         f"'jac_x' too (functions=[..., 'jac_x', 'vjp'])")
    a = _prepare(model, x0, t_final, dt, p, r)
    if method != "rk4":
        return _gradient_adaptive(model, a, cost, rtol, atol, method)
    X, (ffi, lib) = _forward(model, a, keep_stages=True)
    value, G = _evaluate_cost(model, cost, a["t"], X)
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    lam0, gp = np.empty(model.nx), np.empty(max(model.nparam, 1))
    vjp = getattr(model.model_lib, f"{model.name}_vjp")
    status = lib.eomc_adjoint_rk4_backward(model.c_model, vjp, 0.0, a["h"], a["n"], buf(a["p"]),
                                           a["rptr"], buf(X), a["S"], buf(G), buf(lam0), buf(gp),
                                           buf(a["work"]))
    if status:
        raise SimulationError(f"{model.name}: the adjoint (backward) run failed: "
                              f"{STATUS_NAMES.get(status, status)}")
    return GradientResult(float(value), lam0, gp[:model.nparam].copy(), a["t"], X,
                          tuple(model.param_names), tuple(model.state_names))


def _prepare(model, x0, t_final, dt, p, r):
    n = _steps(float(t_final), float(dt))
    ffi, lib = extension_library(model.ffi, ADJOINT_CDEF)
    if isinstance(x0, dict):
        x0 = model._named(x0, model.state_names, np.zeros(model.nx), "state")
    x0 = model._array(x0, (model.nx,), "x0 (initial state)", model.state_names)
    if p is None:
        p = np.array(model.param_defaults, dtype=np.float64)
    elif isinstance(p, dict):
        p = model._named(p, model.param_names, model.param_defaults, "parameter")
    else:
        p = model._array(p, (model.nparam,), "p (parameters)", model.param_names)
    p = np.ascontiguousarray(p, dtype=np.float64)
    if model.ninput:
        if r is None:
            r = np.zeros(model.ninput)
        elif isinstance(r, dict):
            r = model._named(r, model.input_names, np.zeros(model.ninput), "input")
        else:
            r = model._array(r, (model.ninput,), "r (constant inputs)", model.input_names)
        r = np.ascontiguousarray(r, dtype=np.float64)
        rptr = ffi.from_buffer("double[]", r)
    else:
        if r is not None and np.size(r):
            raise ValueError(f"{model.name}: this model has no inputs, but r was given")
        rptr = ffi.NULL
    if not np.all(np.isfinite(x0)):
        raise ValueError(f"{model.name}: x0 must be finite")
    h = float(t_final) / n
    work = np.empty(int(lib.eomc_adjoint_work_size(model.nx, model.nparam)) + max(model.work_size, 1))
    return {"n": n, "h": h, "t": np.arange(n + 1) * h, "x0": x0, "p": p if p.size else np.zeros(1),
            "r": r, "rptr": rptr, "work": work, "ffi": ffi, "lib": lib}


# method="radau": solve each step's transposed collocation system densely (3nx LU with the
# three stage Jacobians) instead of by the preconditioned iteration -- the reference the
# iteration is tested against, and 2-3x slower on G1 (benchmarks/results/adjoint_adaptive_g1_radau.md)
RADAU_DENSE = False

# stage states kept for the backward run up to this many doubles (80 MB); beyond, recomputed
KEEP_STAGES_MAX = 10_000_000


def _forward(model, a, keep_stages=False):
    ffi, lib = a["ffi"], a["lib"]
    X = np.empty((a["n"] + 1, model.nx))
    a["S"], a["stages"] = ffi.NULL, None
    if keep_stages and 3 * a["n"] * model.nx <= KEEP_STAGES_MAX:
        a["stages"] = np.empty(3 * a["n"] * model.nx)
        a["S"] = ffi.from_buffer("double[]", a["stages"])
    X[0] = a["x0"]
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    failed = ffi.new("int *")
    status = lib.eomc_adjoint_rk4_forward(model.c_model, 0.0, a["h"], a["n"], buf(a["p"]), a["rptr"],
                                          buf(X), a["S"], buf(a["work"]), failed)
    if status:
        k = int(failed[0])
        raise SimulationError(f"{model.name}: the RK4 run failed at step {k} (t = {k * a['h']:g}): "
                              f"{STATUS_NAMES.get(status, status)}")
    return X, (ffi, lib)


def _forward_adaptive(model, a, rtol, atol, method="dop853"):
    """(grid states, rec_t, rec_x, rec_k, nrec, boundary index of each grid time): the DOP853
    run with its steps ending on the grid, every accepted step's start recorded, and its 12
    stage derivatives too while they fit in :data:`KEEP_STAGES_MAX` doubles (rec_k, else
    None: the backward run then recomputes them, 12 rhs a step).  method="radau": the Radau
    run, rec_k its converged stage increments Z (3 x nx a step, always kept: the backward run
    needs them)."""
    from .integrators_api import METHOD_IDS
    from .simulate import PI_BETA
    ffi, lib = a["ffi"], a["lib"]
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"{model.name}: rtol and atol must be positive; got {rtol!r}, {atol!r}")
    radau = method == "radau"
    method = METHOD_IDS[method]
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    t = a["t"]
    tstop = np.ascontiguousarray(t[1:])
    opt = ffi.new("eomc_options *")
    opt.method, opt.rtol, opt.atol, opt.max_steps = method, float(rtol), float(atol), 1_000_000
    opt.stiff_check, opt.pi_beta = 1, PI_BETA
    work = np.empty(int(model.integrators.eomc_integrate_work_size(model.c_model, method)))
    x0 = np.ascontiguousarray(a["x0"], dtype=np.float64)
    cap = 16 * a["n"] + 1024
    while True:
        rec_t, rec_x = np.empty(cap + 1), np.empty((cap, model.nx))
        rec_k = (np.empty((cap, 3, model.nx)) if radau
                 else np.empty((cap, 12, model.nx)) if 12 * cap * model.nx <= KEEP_STAGES_MAX else None)
        nrec, x_last = ffi.new("long *"), np.empty(model.nx)
        stats = ffi.new("eomc_stats *")
        status = lib.eomc_adjoint_erk_forward(model.c_model, opt, 0.0, float(t[-1]), buf(x0),
                                              buf(a["p"]), a["rptr"], tstop.size, buf(tstop), cap,
                                              buf(rec_t), buf(rec_x),
                                              ffi.NULL if rec_k is None else buf(rec_k), nrec,
                                              buf(x_last), stats, buf(work), work.size)
        if status:
            name = "Radau" if radau else "DOP853"
            raise SimulationError(f"{model.name}: the {name} run failed at t = {stats.t:g}: "
                                  f"{STATUS_NAMES.get(status, status)}")
        if nrec[0] <= cap:
            break
        cap = int(nrec[0]) + 16
    n = int(nrec[0])
    rec_t = rec_t[:n + 1]
    idx = np.searchsorted(rec_t, t)
    if np.any(idx > n) or not np.array_equal(rec_t[idx], t):
        raise SimulationError(f"{model.name}: the adaptive run did not step onto every grid time")
    X = np.vstack([rec_x[:n], x_last[None, :]])[idx]
    return X, rec_t, rec_x[:n], None if rec_k is None else rec_k[:n], n, idx



def _evaluate_cost(model, cost, t, X):
    """The user's cost on the grid, checked once for both methods: (J, dJ/dX) shaped as X, finite."""
    value, G = cost(t, X.copy())
    G = np.ascontiguousarray(G, dtype=np.float64)
    if G.shape != X.shape:
        raise ValueError(f"{model.name}: cost must return (J, dJ/dX) with dJ/dX shaped as X "
                         f"{X.shape} (grid points x states); got shape {G.shape}")
    if not np.all(np.isfinite(G)) or not np.isfinite(value):
        raise ValueError(f"{model.name}: cost returned a non-finite value or gradient")
    return value, G


def _gradient_adaptive(model, a, cost, rtol, atol, method="dop853"):
    ffi, lib = a["ffi"], a["lib"]
    X, rec_t, rec_x, rec_k, n, idx = _forward_adaptive(model, a, rtol, atol, method)
    value, G = _evaluate_cost(model, cost, a["t"], X)
    Gb = np.zeros((n + 1, model.nx))
    Gb[idx] = G
    buf = lambda arr: ffi.from_buffer("double[]", arr)  # noqa: E731
    size = lib.eomc_adjoint_radau_work_size if method == "radau" else lib.eomc_adjoint_erk_work_size
    work = np.empty(int(size(model.nx, model.nparam)) + max(model.work_size, 1))
    lam0, gp = np.empty(model.nx), np.empty(max(model.nparam, 1))
    rec_x = np.ascontiguousarray(rec_x)
    vjp = getattr(model.model_lib, f"{model.name}_vjp")
    args = (model.c_model, vjp, n, buf(rec_t), buf(rec_x) if n else ffi.NULL,
            buf(rec_k) if n and rec_k is not None else ffi.NULL, buf(a["p"]), a["rptr"], buf(Gb),
            buf(lam0), buf(gp), buf(work))
    stats = None
    if method == "radau":
        counts = ffi.new("long[5]")
        status = lib.eomc_adjoint_radau_backward(*args, int(RADAU_DENSE), counts)
        stats = dict(zip(("jac_x", "factorizations", "iterations", "dense_steps", "vjp"), list(counts)))
    else:
        status = lib.eomc_adjoint_erk_backward(*args)
    if status:
        raise SimulationError(f"{model.name}: the adjoint (backward) run failed: "
                              f"{STATUS_NAMES.get(status, status)}")
    return GradientResult(float(value), lam0, gp[:model.nparam].copy(), a["t"], X,
                          tuple(model.param_names), tuple(model.state_names), stats)
