"""Numbers the compiler prints into C come out the same on every CPU (eomc.compiler.fixed_order).

numpy's ``@``/``dot``/``norm`` and LAPACK go through OpenBLAS, whose kernel depends on the CPU
(chosen at load, or by OPENBLAS_CORETYPE): the same URDF gave panda's welded hand a combined
inertia differing in its last digit on two machines, and so different C."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler import fixed_order as fo

def _loops(a, b):
    """The textbook triple loop in Python floats: what fixed_order.matmul must equal bit for bit."""
    return np.array([[sum_in_order(a[i, k] * b[k, j] for k in range(a.shape[1]))
                      for j in range(b.shape[1])] for i in range(a.shape[0])])


def sum_in_order(terms):
    total = None
    for t in terms:
        total = t if total is None else total + t
    return total


@pytest.mark.parametrize("n", [3, 6])
def test_products_are_the_index_order_sums_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for _ in range(50):
        a, b, c = rng.normal(size=(3, n, n))
        assert np.array_equal(fo.matmul(a, b), _loops(a, b))
        assert np.array_equal(fo.matmul(a, b, c), _loops(_loops(a, b), c))
        v = rng.normal(size=n)
        assert np.array_equal(fo.matmul(a, v), _loops(a, v[:, None])[:, 0])
        assert fo.dot(v, v) == sum_in_order(float(x) * float(x) for x in v)
        np.testing.assert_allclose(fo.matmul(a, b), a @ b, rtol=1e-13, atol=1e-13)


def test_eigh_matches_lapack_to_rounding_and_reconstructs():
    rng = np.random.default_rng(1)
    for n in (3, 6):
        for _ in range(100):
            a = rng.normal(size=(n, n))
            s = a + a.T
            w, v = fo.eigh(s)
            np.testing.assert_allclose(w, np.linalg.eigvalsh(s), atol=1e-12 * np.abs(s).max())
            np.testing.assert_allclose(v @ np.diag(w) @ v.T, s, atol=1e-12 * np.abs(s).max())
            np.testing.assert_allclose(v.T @ v, np.eye(n), atol=1e-13)


def _panda():
    for root in map(Path, sys.path):
        path = root / "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"
        if path.is_file():
            return path
    pytest.fail("example-robot-data's panda.urdf not found (a test dependency)")


SCRIPT = """
import json, sys
from eomc.compiler.urdf.reader import read_urdf
from eomc.compiler.urdf.tree import build_tree
tree = build_tree(read_urdf(sys.argv[1]))
print(json.dumps({name: [repr(float(x)) for x in list(body.com) + list(body.inertia.ravel())]
                  for name, body in tree.bodies.items()}))
"""


def test_a_urdf_tree_is_the_same_whichever_blas_kernel_runs():
    """panda's welded hand and fingers combined under two OpenBLAS kernels (Haswell: AVX2 with
    fused multiply-adds; Prescott: SSE3), each in a fresh process: the same bits."""
    out = []
    for kernel in ("Haswell", "Prescott"):
        env = dict(os.environ, OPENBLAS_CORETYPE=kernel)
        run = subprocess.run([sys.executable, "-c", SCRIPT, str(_panda())], env=env,
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        out.append(json.loads(run.stdout.strip().splitlines()[-1]))
    assert out[0] == out[1]
    assert any(len(set(v[3:])) > 2 for v in out[0].values())   # real tensors, not all zeros
