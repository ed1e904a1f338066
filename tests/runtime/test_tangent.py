"""eomc.runtime.tangent: linearization with quaternions in their 3-angle tangent chart.

Oracles: central differences of the exact dynamics in the chart (q = q0 (x) Exp(theta), whose
rates are J_r(theta)^-1 w) at a state with every speed non-zero; and the Euler build of the same
file (the same physics in body-XYZ angles), whose A is the chart's up to a change of coordinates
at rest: their eigenvalues must agree.  The full A over the 4 coordinates has the quaternions'
length as extra zero eigenvalues; the chart's does not.
"""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.mjcf.compare import from_mujoco, prepared, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.runtime.errors import EomcWarning  # noqa: E402
from eomc.runtime.tangent import _left, linearize_tangent, tangent_chart  # noqa: E402

from ..compiler.mjcf.test_mjcf import SMALL  # noqa: E402


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    root = tmp_path_factory.mktemp("tangent")
    path = root / "small.xml"
    path.write_text(SMALL)
    built = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        for orientation in ("quaternion", "euler"):
            built[orientation] = eomc.compile(MjcfModel(path, limits=False, pairs=False, orientation=orientation),
                                              name=f"tan_{orientation}", cache_dir=root / "cache",
                                              progress=False, functions=["rhs", "jac_x", "linearize"])
    return path, built


def _exp(v):
    a = np.linalg.norm(v)
    return np.r_[np.cos(a / 2), np.sin(a / 2) * v / a] if a > 0 else np.r_[1.0, 0.0, 0.0, 0.0]


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _chart_rhs(model, chart, xi):
    """The dynamics in the chart at xi: the full rhs at q0 (x) Exp(theta), each quaternion's rows
    turned into theta' = J_r(theta)^-1 w (w = 2 vec(q* (x) q'); J_r^-1 to second order)."""
    starts, y, i, j = set(model.quaternions), np.empty(model.nx), 0, 0
    while i < model.nx:
        if i in starts:
            y[i:i + 4] = _left(chart.x[i:i + 4]) @ _exp(xi[j:j + 3])
            i, j = i + 4, j + 3
        else:
            y[i] = chart.x[i] + xi[j]
            i, j = i + 1, j + 1
    f, out, i, j = model.rhs(0.0, y), np.empty(len(xi)), 0, 0
    while i < model.nx:
        if i in starts:
            w = 2.0 * (_left(y[i:i + 4] * np.array([1.0, -1.0, -1.0, -1.0])) @ f[i:i + 4])[1:]
            th = xi[j:j + 3]
            out[j:j + 3] = (np.eye(3) + 0.5 * _skew(th) + _skew(th) @ _skew(th) / 12.0) @ w
            i, j = i + 4, j + 3
        else:
            out[j] = f[i]
            i, j = i + 1, j + 1
    return out


def test_the_chart_linearization_is_the_central_differences_of_the_chart_dynamics(small):
    """At a moving state (every speed non-zero, quaternions 0.7 and 1.3 long: made unit), not only at rest."""
    model = small[1]["quaternion"]
    assert len(model.quaternions) == 2
    rng = np.random.default_rng(1)
    x = np.array(model.initial_state, dtype=float)
    x[model.nq:] = rng.uniform(-2.0, 2.0, model.nu)
    for k, i in enumerate(model.quaternions):
        x[i:i + 4] = rng.normal(size=4)
        x[i:i + 4] *= (0.7, 1.3)[k] / np.linalg.norm(x[i:i + 4])
    lin = linearize_tangent(model, 0.0, x)
    chart = tangent_chart(model, x)
    assert lin.A.shape == (model.nx - 2, model.nx - 2) and lin.B.shape == (model.nx - 2, model.ninput)
    assert "q_free_rotx" in lin.states and "q_ball_rotz" in lin.states and "q_free_qw" not in lin.states
    assert np.allclose(chart.S @ chart.T, np.eye(model.nx - 2), atol=1e-15, rtol=0)
    h = 1e-6
    fd = np.column_stack([(_chart_rhs(model, chart, h * e) - _chart_rhs(model, chart, -h * e)) / (2 * h)
                          for e in np.eye(model.nx - 2)])
    assert np.abs(lin.A - fd).max() < 1e-7 * max(1.0, np.abs(fd).max())
    # the full A over 4 coordinates a quaternion: the length adds zero eigenvalues the chart has not
    zeros = lambda M: int(np.sum(np.abs(np.linalg.eigvals(M)) < 1e-6))  # noqa: E731
    x_rest = chart.x.copy()
    x_rest[model.nq:] = 0.0
    full, _ = model.linearize(0.0, x_rest)
    assert zeros(full) == zeros(linearize_tangent(model, 0.0, x_rest).A) + 2


def test_the_chart_has_the_euler_builds_eigenvalues_at_rest(small):
    """The same file built with body-XYZ angles at the matched state (zero speeds: no term from
    the charts' change along the motion): the same spectrum, to the round-off of the zero
    eigenvalues' Jordan blocks (the free body's position and the unsprung slider)."""
    path, built = small
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        motors = check_model(m, path, ())
    rng = np.random.default_rng(4)
    for _ in range(3):
        qpos = np.array(m.qpos0)
        for j in range(m.njnt):
            a, kind = int(m.jnt_qposadr[j]), int(m.jnt_type[j])
            if kind in (2, 3):
                qpos[a] = rng.uniform(-0.8, 0.8)
            else:
                off = 3 if kind == 0 else 0
                q = rng.normal(size=4)
                qpos[a + off:a + off + 4] = q / np.linalg.norm(q)
        spectra = []
        for model in (built["quaternion"], built["euler"]):
            tree = tree_of(m, model, actuators=motors)
            q, u = from_mujoco(m, tree, qpos, np.zeros(m.nv))
            A = linearize_tangent(model, 0.0, np.concatenate([q, u])).A
            assert A.shape == (2 * m.nv, 2 * m.nv)
            spectra.append(np.sort_complex(np.linalg.eigvals(A)))
        big = np.abs(spectra[1]) > 1e-3
        assert big.sum() >= 10
        assert np.abs(spectra[0][big] - spectra[1][big]).max() < 1e-8 * np.abs(spectra[1]).max()
        assert np.abs(spectra[0][~big]).max() < 1e-4 and np.abs(spectra[1][~big]).max() < 1e-4


def test_a_zero_quaternion_is_refused(small):
    model = small[1]["quaternion"]
    x = np.array(model.initial_state, dtype=float)
    x[model.quaternions[0]:model.quaternions[0] + 4] = 0.0
    with pytest.raises(ValueError, match=r"quaternion \(q_ball_qw.*is zero: it is no orientation"):
        linearize_tangent(model, 0.0, x)
