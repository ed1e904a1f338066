"""runtime/limit_energy.stored: the energy a limit's spring holds at a depth past its limit,
against scipy's adaptive quadrature of the same law (eomc.compiler.tree.joint_laws.joint_torque
at u = 0), over the shapes the readers give (MJCF's unilateral held limits; a plain spring)."""
import numpy as np
import pytest
from scipy.integrate import quad

from eomc.runtime.limit_energy import stored


def _force(d, K, E, push, hold):
    G, w = hold if hold else (1.0, E)
    f = K * (d + (G - 1.0) * w * np.tanh(d / w))
    if push:
        s = K * E * push
        f = (f + np.sqrt(f * f + s * s)) / 2
    return (d / (d + E)) ** 2 * f


@pytest.mark.parametrize("r,K,E,push,hold", [
    (0.5, 693.0, 3e-4, 0.1, (19.0, 1e-3)),       # the test_switching arm, 0.5 rad past
    (1e-4, 693.0, 3e-4, 0.1, (19.0, 1e-3)),      # inside one width
    (0.52, 5e3, 3e-4, 0.1, (5.3, 1e-3)),         # an ant ankle's start
    (2.0, 10.0, 1e-2, 0.0, None),                # a plain two-sided spring
    (3e-3, 1.0, 3e-4, 0.1, None),
])
def test_stored_is_the_integral_of_the_law_at_rest(r, K, E, push, hold):
    G, w = hold if hold else (1.0, E)
    ref = quad(_force, 0.0, r, args=(K, E, push, hold), limit=500, epsabs=0.0, epsrel=1e-13,
               points=[p for p in (E, w, 10 * E, 10 * w) if p < r] or None)[0]
    assert stored(r, K, E, push, hold) == pytest.approx(ref, rel=1e-11)


def test_no_energy_inside_the_range_or_without_a_spring():
    assert stored(0.0, 100.0, 3e-4, 0.1, (19.0, 1e-3)) == 0.0
    assert stored(-0.2, 100.0, 3e-4, 0.1, None) == 0.0
    assert stored(0.2, 0.0, 3e-4, 0.1, None) == 0.0


def test_stored_along_is_stored_at_each_depth():
    """The verdict's vectorised spring energy (stored_along: every recorded point of a run) gives
    stored()'s numbers, depths inside the range (<= 0) and NaN 0, the hold and the push included."""
    from eomc.runtime.limit_energy import stored, stored_along
    r = np.array([-0.2, 0.0, 1e-7, 2e-5, 1e-3, 0.05, 0.52, np.nan])
    for shape in ((0.0, None), (0.3, None), (0.0, (5.0, 0.02)), (0.2, (5.0, 0.02))):
        got = stored_along(r, 693.0, 3e-4, *shape)
        want = [stored(d, 693.0, 3e-4, *shape) if np.isfinite(d) else 0.0 for d in r]
        assert np.allclose(got, want, rtol=1e-12, atol=0.0), (shape, got, want)
        assert got[-1] == 0.0 and np.all(got[:2] == 0.0) and np.all(got[2:-1] > 0.0)
        # past the cached table's reach (SPRING_REACH), the run's own graded quadrature: the same numbers
        far = np.array([0.5, 20.0])
        assert np.allclose(stored_along(far, 693.0, 3e-4, *shape), [stored(d, 693.0, 3e-4, *shape) for d in far],
                           rtol=1e-12, atol=0.0)
    # one cached table per shape serves every stiffness: the energy is linear in K
    assert np.allclose(stored_along(r, 2.5, 3e-4, 0.3, None)[2:-1] / 2.5,
                       stored_along(r, 1.0, 3e-4, 0.3, None)[2:-1], rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("E,push,hold", [(3e-4, 0.1, (19.0, 1e-3)), (3e-4, 0.1, (1.03, 1e-3)),
                                         (1e-2, 0.1, (5.3, 1e-3)), (3e-4, 0.0, None), (1e-2, 0.0, None)])
def test_the_watchs_spring_table_is_stored_within_its_interpolation(E, push, hold):
    """The C energy watch's table (eomc_spring: cubic Hermite of stored() between knots 1/16 of an
    octave apart, spring_table) against stored() over depths from 1e-7 to 10 (and its slope against
    the law at rest): within 3e-7 of stored() past one width, 1e-10 (K = 1) absolutely anywhere;
    0 inside the range; NaN past its reach.  Measured: 1.9e-7 and 4.6e-11 at worst."""
    from eomc.runtime.limit_energy import SPRING_BITS, SPRING_REACH, spring_energy, spring_table
    base, S, f = spring_table(E, push, hold)
    rng = np.random.default_rng(7)
    d = np.exp(rng.uniform(np.log(1e-7), np.log(10.0), 2000))
    ref = np.array([stored(x, 1.0, E, push, hold) for x in d])
    got = spring_energy(d, 1.0, E, base, S, f)
    assert np.all(np.abs(got - ref) <= 1e-10)
    past = d > E
    assert np.all(np.abs(got[past] - ref[past]) <= 3e-7 * ref[past])
    knots = spring_energy(np.array([0.0, -1.0]), 1.0, E, base, S, f)
    assert np.array_equal(knots, [0.0, 0.0])
    assert np.isnan(spring_energy(np.array([2 * SPRING_REACH]), 1.0, E, base, S, f)[0])
    # K scales it (the law at rest is linear in K, its push smoothing included)
    assert np.allclose(spring_energy(d[:50], 693.0, E, base, S, f), 693.0 * got[:50], rtol=1e-15, atol=0)
    assert np.allclose(spring_energy(d[:50], 693.0, E, base, S, f),
                       [stored(x, 693.0, E, push, hold) for x in d[:50]], rtol=3e-7, atol=1e-7)
    # the slope at the knots is the law's force at rest (_force, this file's own)
    knot_d = ((np.uint64(base) + np.arange(len(S), dtype=np.uint64)) << np.uint64(52 - SPRING_BITS)).view(np.float64)
    assert np.allclose(f, _force(knot_d, 1.0, E, push, hold), rtol=1e-14, atol=0)
