"""The energy a joint limit's spring holds at a depth past its limit, for the limits whose
spring has no closed-form potential (MJCF's: unilateral, smoothed, held; NAME.json
``limit_laws``, eomc.compiler.tree.joint_laws.law_shape).

One job: the energy verdict of a run that starts outside a joint's range
(runtime/switching.verdict).  The generated ``energy`` output leaves these springs out, so the
spring energy a start holds comes out as a gain; with the start's spring energy added, a gain
beyond it is still the integrator's (kinetic + gravity + the springs' potential can only fall
in a passive model: the damping, clip included, only takes energy out).  Numbers only: no
SymPy here (a built model loads without it)."""

from functools import lru_cache

import numpy as np

__all__ = ["stored", "stored_along", "spring_table", "force_at_rest", "SPRING_BITS"]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(8)
_PANELS = 40


def stored(r, K, E, push=0.0, hold=None):
    """∫₀^r g(d)² F(d) dd: the work the limit's force at rest (u = 0) does from depth ``r`` back
    to its limit (joint_laws.joint_torque: g = d/(d + E), F = K·held(d) smoothed by ``push``
    (max(F, 0) over K·E·push), held(d) = d + (G - 1)·w·tanh(d/w) for ``hold`` = (G, w)).

    Gauss-Legendre on panels graded geometrically from a hundredth of the law's smallest width
    (where g and tanh turn over) to r: 8 nodes on 40 panels, each at most (100 r/E)^(1/40) times
    the last, integrate these smooth functions to about 1e-12 relative.  Kept per argument
    values (the verdict of every run from one start asks again: gymnasium's ant, four ankles
    outside their ranges: a run's Python side 0.84 -> 0.33 ms, of 5-6 ms at rtol 1e-2)."""
    r, K, E = float(r), float(K), float(E)
    if not r > 0 or not K > 0 or not E > 0:
        return 0.0
    return _stored(r, K, E, float(push), (float(hold[0]), float(hold[1])) if hold else None)


@lru_cache(maxsize=256)
def _stored(r, K, E, push, hold):
    """stored() for floats and hold = (G, w) or None (hashable: cached)."""
    G, w = hold if hold else (1.0, E)
    start = min(E, w) / 100.0
    edges = np.concatenate(([0.0], np.geomspace(start, r, _PANELS))) if r > start else np.array([0.0, r])
    a, b = edges[:-1, None], edges[1:, None]
    d = (a + b) / 2 + (b - a) / 2 * _NODES
    force = K * (d + (G - 1.0) * w * np.tanh(d / w)) if hold else K * d
    if push:
        s = K * E * push
        force = (force + np.sqrt(force * force + s * s)) / 2
    g = d / (d + E)
    return float(np.sum((b - a) / 2 * _WEIGHTS * g * g * force))


def stored_along(r, K, E, push=0.0, hold=None):
    """stored() for an array of depths ``r`` (one limit's depth past its bound at every recorded
    point of a run; <= 0 or NaN where inside its range: 0): the energy verdict's total energy
    along a run (runtime/switching._energy_rise).

    The law's work at K = 1 is kept per shape (E, push, hold) at the edges of fixed panels graded
    geometrically (1/16 of an octave each, finer than stored()'s 40) from a hundredth of the law's
    smallest width to SPRING_REACH (:func:`_work_at_edges`: one quadrature per shape, cached); a
    depth's energy is K times the work up to the edge below it plus 8 Gauss-Legendre nodes on the
    piece from that edge (inside one panel: as accurate as stored()).  The force is linear in K
    (the push's smoothing scales with it), so one table serves every stiffness.  Why: the verdict
    runs after every simulate, and a quadrature per run (a graded grid up to the run's deepest
    point, cut at every depth) cost gymnasium's hopper 0.44 ms of its 1.7 ms at rtol 1e-2, more
    than the integration (benchmarks/results/contact_wp.md, session 36).  Depths past SPRING_REACH
    (not met by a run that stays a model) take that quadrature."""
    r = np.asarray(r, dtype=float)
    out = np.zeros(r.shape)
    K, E = float(K), float(E)
    past = np.flatnonzero(np.isfinite(r) & (r > 0))
    if not past.size or not K > 0 or not E > 0:
        return out
    push = float(push)
    hold = (float(hold[0]), float(hold[1])) if hold else None
    d = r[past]
    if float(d.max()) >= SPRING_REACH:
        out[past] = _stored_graded(d, K, E, push, hold)
        return out
    edges, work = _work_at_edges(E, push, hold)
    k = np.searchsorted(edges, d, side="right") - 1
    a = edges[k]
    out[past] = K * (work[k] + _pieces(a, d, E, push, hold))
    return out


def _pieces(a, b, E, push, hold):
    """∫_a^b of the law at K = 1 per element (a, b arrays): 8 Gauss-Legendre nodes each."""
    a, b = a[:, None], b[:, None]
    nodes = (a + b) / 2 + (b - a) / 2 * _NODES
    return np.sum((b - a) / 2 * _WEIGHTS * force_at_rest(nodes, E, push, hold), axis=1)


@lru_cache(maxsize=64)
def _work_at_edges(E, push, hold):
    """(edges, work): 0, then 1/16-octave steps from a hundredth of the law's smallest width past
    SPRING_REACH, and the law's work at K = 1 from 0 to each (read-only arrays: cached)."""
    w = hold[1] if hold else E
    start = min(E, w) / 100.0
    n = int(np.ceil(16.0 * np.log2(SPRING_REACH / start))) + 1
    edges = np.concatenate(([0.0], start * 2.0 ** (np.arange(n + 1) / 16.0)))
    work = np.concatenate(([0.0], np.cumsum(_pieces(edges[:-1], edges[1:], E, push, hold))))
    edges.flags.writeable = False
    work.flags.writeable = False
    return edges, work


def _stored_graded(r, K, E, push, hold):
    """stored() at each depth of ``r`` (> 0, finite): the graded panels up to the largest depth,
    cut at every depth, 8 Gauss-Legendre nodes on each piece, summed in order."""
    G, w = hold if hold else (1.0, E)
    start = min(E, w) / 100.0
    depths, back = np.unique(r, return_inverse=True)
    grid = np.geomspace(start, depths[-1], _PANELS) if depths[-1] > start else np.empty(0)
    edges = np.unique(np.concatenate(([0.0], grid, depths)))
    work = np.concatenate(([0.0], np.cumsum(K * _pieces(edges[:-1], edges[1:], E, push, hold))))
    return work[np.searchsorted(edges, depths)][back]


SPRING_BITS = 4         # eomc_spring.bits: 16 knots an octave (relative spacing <= 1/16)
SPRING_REACH = 16.0     # rad or m past the limit: the table's last knot (past it: not known)


def force_at_rest(d, E, push=0.0, hold=None):
    """The slope of stored() at depths ``d`` (> 0) for K = 1: g(d)² F(d) of stored()'s law."""
    d = np.asarray(d, dtype=float)
    if hold:
        G, w = float(hold[0]), float(hold[1])
        force = d + (G - 1.0) * w * np.tanh(d / w)
    else:
        force = d.copy()
    if push:
        s = E * float(push)
        force = (force + np.sqrt(force * force + s * s)) / 2
    g = d / (d + E)
    return g * g * force


def spring_table(E, push=0.0, hold=None, bits=SPRING_BITS):
    """(base, S, f): the knots of the C energy watch's table of stored() at K = 1 for a limit of
    width ``E`` and shape (push, hold) -- runtime/c/eomc_integrators.h eomc_spring: knot k is the
    double whose bits are (base + k) << (52 - bits), from a hundredth of the law's smallest width
    to SPRING_REACH; S the stored energy there (stored_along), f its slope (force_at_rest).

    Why a table: the watch runs at every step of every rollout row, and stored() is a quadrature
    (320 law evaluations); a cubic Hermite between knots 1/16 of an octave apart costs a few
    flops and is within about 1e-8 of stored() (tests/runtime/test_limit_energy.py measures it)."""
    E = float(E)
    w = float(hold[1]) if hold else E
    shift = 52 - int(bits)
    lo = np.array([min(E, w) / 100.0]).view(np.uint64)[0] >> np.uint64(shift)
    hi = np.array([SPRING_REACH]).view(np.uint64)[0] >> np.uint64(shift)
    n = int(hi - lo) + 2
    knots = ((lo + np.arange(n, dtype=np.uint64)) << np.uint64(shift)).view(np.float64)
    S = stored_along(knots, 1.0, E, push, hold)
    f = force_at_rest(knots, E, push, hold)
    return int(lo), np.ascontiguousarray(S), np.ascontiguousarray(f)


def spring_energy(d, K, E, base, S, f, bits=SPRING_BITS):
    """The C watch's value (eomc_integrators.c spring_energy) in numpy, for tests: K times the
    table's cubic Hermite at depths d (0 where d <= 0; NaN past the table)."""
    d = np.atleast_1d(np.asarray(d, dtype=float))
    out = np.zeros(d.shape)
    shift = 52 - int(bits)
    past = d > 0
    k = (d[past].view(np.uint64) >> np.uint64(shift)).astype(np.int64) - base
    knot = lambda j: ((np.int64(base) + j).astype(np.uint64) << np.uint64(shift)).view(np.float64)  # noqa: E731
    below = k < 0
    kk = np.maximum(k, 0)
    inside = kk < len(S) - 1
    kk = np.minimum(kk, len(S) - 2)
    d0 = np.where(below, 0.0, knot(kk))
    d1 = np.where(below, knot(np.zeros_like(kk)), knot(kk + 1))
    S0, f0 = np.where(below, 0.0, S[kk]), np.where(below, 0.0, f[kk])
    S1, f1 = np.where(below, S[0], S[kk + 1]), np.where(below, f[0], f[kk + 1])
    h = d1 - d0
    u = (d[past] - d0) / h
    v = 1.0 - u
    val = K * (v * v * ((1.0 + 2.0 * u) * S0 + u * h * f0) + u * u * ((3.0 - 2.0 * u) * S1 - v * h * f1))
    out[past] = np.where(inside, val, np.nan)
    return out
