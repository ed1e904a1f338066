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
