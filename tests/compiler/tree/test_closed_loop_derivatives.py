"""Issue 19 item 3: jac_x, jac_r, jac_p, jvp and linearize of a tree closed by constraints.

The recursion differentiates the KKT system's residual (M u' - b - Jᵀλ; J u' + γ) at the
solved u' and λ and solves the tangent KKT system on the rhs's own factors
(compiler/tree/constrained.py: kkt_residual, kkt_solve).  Oracles: eomc's Kane formulation
of the same System (its Jacobians are the derivatives of the same function, since the two
rhs agree at every state) to 1e-11, and central differences of the compiled rhs; linearize
against Kane's at the four-bar's hanging equilibrium.  Both ways the C runs the columns are
checked (unrolled for few states, the tangent loop for many: forced on the four-bar).

Cheap: three small models, each compiled once per formulation (module fixture), and one
generate (no C compiler) of an 8-link chain.
"""
import importlib.util
import runpy
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.driver import generate

ROOT = Path(__file__).resolve().parents[3]
FOUR_BAR = ROOT / "examples" / "four_bar_system.py"
_spec = importlib.util.spec_from_file_location("bench_loops", ROOT / "benchmarks" / "bench_loops.py")
bench_loops = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_loops)

FUNCTIONS = ["rhs", "jac_x", "jac_r", "jac_p", "jvp", "linearize", "constraints", "constraints_jac"]


def _models():
    ns = runpy.run_path(str(FOUR_BAR))
    from eomc.mechanics import dynamicsymbols
    out = {"four_bar": (ns["system"], ns["parameters"], ns["initial_state"], ns["inputs"])}
    sc, p_sc, x_sc = bench_loops.slider_crank()
    out["slider_crank"] = (sc, p_sc, x_sc, [dynamicsymbols("T")])
    fb, p_fb, x_fb = bench_loops.closed_chain(4)
    out["five_bar"] = (fb, p_fb, x_fb, [])
    return out


def _compile(system, params, inputs, formulation, name, cache):
    kw = dict(parameters=params, functions=FUNCTIONS, formulation=formulation,
              cache_dir=str(cache), name=name)
    if inputs:
        kw["inputs"] = inputs
    return eomc.compile(system, **kw)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for label, (system, params, x0, inputs) in _models().items():
        pair = {f: _compile(system, params, inputs, f, f"{label}_d_{f}", cache)
                for f in ("recursive", "kane")}
        out[label] = (pair, x0)
    # the tangent loop (used above 12 states) on the four-bar: forced, its own name and cache
    system, params, _, inputs = _models()["four_bar"]
    import eomc.compiler.tree.lower as tree_lower
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(tree_lower, "TANGENT_MIN_STATES", 0)
        out["tangent"] = _compile(system, params, inputs, "recursive", "four_bar_d_tangent",
                                  tmp_path_factory.mktemp("cache_tangent"))
    return out


def _states(model, x0, count, seed):
    rng = np.random.default_rng(seed)
    names = model.state_names
    by_name = {str(k).replace("(t)", ""): float(v) for k, v in x0.items()}
    start = np.array([by_name[n] for n in names])
    states = []
    for _ in range(10 * count):
        x = start.copy()
        x[:model.nq] += rng.uniform(-0.3, 0.3, model.nq)
        x[model.nq:] = rng.uniform(-1.0, 1.0, len(x) - model.nq)
        try:
            states.append(np.asarray(model.consistent_state(dict(zip(names, x))), dtype=float))
        except eomc.errors.EomcError:
            continue
        if len(states) == count:
            break
    assert len(states) == count
    return states


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))))


def _central(f, x, h=1e-6):
    cols = []
    for i in range(len(x)):
        e = np.zeros(len(x))
        e[i] = h
        cols.append((f(x + e) - f(x - e)) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize("label", ["four_bar", "slider_crank", "five_bar"])
def test_jacobians_agree_with_kane_and_central_differences(built, label):
    (pair, x0) = built[label]
    rec, kane = pair["recursive"], pair["kane"]
    assert rec.metadata["formulation"] == "recursive" and kane.metadata["formulation"] == "kane"
    rng = np.random.default_rng(1)
    assert list(rec.param_names) == list(kane.param_names) and rec.state_names == kane.state_names
    p = np.asarray(rec.param_defaults, float) * rng.uniform(0.9, 1.1, rec.nparam)
    for x in _states(rec, x0, 3, seed=2):
        r = rng.uniform(-1.0, 1.0, rec.ninput)
        A = rec.jacobian(0.0, x, p, r)
        assert _rel(A, kane.jacobian(0.0, x, p, r)) < 1e-11
        assert _rel(A, _central(lambda y: rec.rhs(0.0, y, p, r), x)) < 1e-6
        # off the constraints too: both are the derivative of the same function everywhere
        xo = x + rng.uniform(-0.05, 0.05, len(x))
        assert _rel(rec.jacobian(0.0, xo, p, r), kane.jacobian(0.0, xo, p, r)) < 1e-11
        P = rec.jac_p(0.0, x, r=r, p=p)
        assert _rel(P, kane.jac_p(0.0, x, r=r, p=p)) < 1e-11
        assert _rel(P, _central(lambda q: rec.rhs(0.0, x, q, r), p)) < 1e-6
        if rec.ninput:
            B = rec.input_jacobian(0.0, x, p, r)
            assert _rel(B, kane.input_jacobian(0.0, x, p, r)) < 1e-11
            assert _rel(B, _central(lambda s: rec.rhs(0.0, x, p, s), r)) < 1e-6


def test_the_tangent_loop_agrees_with_the_unrolled_columns(built):
    (pair, x0), tangent = built["four_bar"], built["tangent"]
    rec, kane = pair["recursive"], pair["kane"]
    src = Path(tangent.source_path).read_text()
    assert "dx[k] = 1.0;" in src          # the columns really run the tangent program
    assert "dx[k] = 1.0;" not in Path(rec.source_path).read_text()
    for x in _states(rec, x0, 3, seed=3):
        r = np.array([0.7])
        assert _rel(tangent.jacobian(0.0, x, r=r), kane.jacobian(0.0, x, r=r)) < 1e-11


def test_linearize_at_the_hanging_equilibrium_is_kanes(built):
    """The parallelogram four-bar hangs at q1 = -pi/2 (coupler level, crank and rocker down)."""
    pair, _ = built["four_bar"]
    rec, kane = pair["recursive"], pair["kane"]
    q1 = -np.pi / 2
    x = np.array([q1, np.pi - q1, q1, 0.0, 0.0, 0.0])
    r = np.zeros(1)
    assert np.max(np.abs(rec.rhs(0.0, x, r=r))) < 1e-12       # it is an equilibrium
    A, B = rec.linearize(0.0, x, r=r)
    Ak, Bk = kane.linearize(0.0, x, r=r)
    assert _rel(A, Ak) < 1e-11 and _rel(B, Bk) < 1e-11
    assert np.max(np.abs(B)) > 0.1 and np.max(np.abs(A[3:, :3])) > 1.0    # not trivially zero
    # the reduced linearization (independent states) oscillates: a pendulum's eigenvalues
    Ar, *_ = rec.linearize_reduced(0.0, x, r=r)
    Akr, *_ = kane.linearize_reduced(0.0, x, r=r)
    assert _rel(Ar, Akr) < 1e-10
    ev = np.linalg.eigvals(Ar)
    assert np.all(np.abs(ev.real) < 1e-8) and np.all(np.abs(ev.imag) > 0.1)


def test_jvp_is_kanes_along_state_and_parameter_directions(built):
    pair, x0 = built["five_bar"]
    rec, kane = pair["recursive"], pair["kane"]
    rng = np.random.default_rng(4)
    D = rng.uniform(-1.0, 1.0, (3, rec.nx + rec.nparam))
    D[0, rec.nx:] = 0.0                      # one direction without a parameter part
    for x in _states(rec, x0, 2, seed=5):
        xd, JD = rec.jvp(0.0, x, D)
        xk, JK = kane.jvp(0.0, x, D)
        assert _rel(xd, xk) < 1e-11 and _rel(JD, JK) < 1e-11
        full = np.hstack([rec.jacobian(0.0, x), rec.jac_p(0.0, x)])
        assert _rel(JD, D @ full.T) < 1e-11


def test_auto_keeps_the_tree_with_the_default_functions_on_a_long_chain(monkeypatch):
    """The default function set (jac_x, jac_r, linearize among them) no longer sends a closed
    tree to Kane: above 6 speeds auto lowers the recursion without forming Kane's equations."""
    from eomc.compiler.mechanics import unformed

    def forbidden(system):
        raise AssertionError("Kane's equations were formed")

    monkeypatch.setattr(unformed, "form_system", forbidden)
    system, params, _ = bench_loops.closed_chain(8)
    _, gm = generate(system, "chain8", formulation="auto", functions=None, parameters=params,
                     use_cache=False, progress=False)
    assert gm.metadata["formulation"] == "recursive"
    assert "formulation_note" not in gm.metadata
    assert {"rhs", "jac_x", "linearize"} <= set(gm.metadata["functions"])
