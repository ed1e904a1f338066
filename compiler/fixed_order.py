"""Small dense products, dot products and norms computed in one fixed order of operations.

Why: numbers the compiler works out from a model file (welded links' combined inertia, capsule
end points, limit stiffness from carried inertia, principal moments named in warnings) are
printed into the generated C and its messages.  numpy's ``@``, ``dot`` and ``linalg.norm``
hand small arrays to BLAS, and OpenBLAS picks its kernel for the CPU at load time (Haswell,
SkylakeX, Zen...): the kernels sum in different orders and fuse multiply-adds differently, so
the same URDF gave C differing in the last digit of a constant on two machines (panda's hand,
half_cheetah's capsule ends; found when this session's machine lacked the
``OPENBLAS_CORETYPE=Haswell`` of the last one).  Generated C must be byte-identical for
identical input, so these helpers use only elementwise IEEE multiplies and adds, summed in
index order, which give the same bits on every CPU.  The arrays are 3x3 and 6x6: speed is
not the point.
"""
import math

import numpy as np


def matmul(*factors):
    """The product of matrices (and a final vector), left to right, like ``a @ b @ c``."""
    out = np.asarray(factors[0], dtype=float)
    for factor in factors[1:]:
        out = _product(out, np.asarray(factor, dtype=float))
    return out


def _product(a, b):
    if a.ndim == 1 and b.ndim == 1:
        return dot(a, b)
    vector = b.ndim == 1
    if vector:
        b = b[:, None]
    if a.ndim == 1:
        a = a[None, :]
        out = _product(a, b)
        return out[0, 0] if vector else out[0]
    if a.shape[-1] != b.shape[0]:
        raise ValueError(f"shapes {a.shape} and {b.shape} do not match")
    out = a[:, 0, None] * b[None, 0, :]
    for k in range(1, a.shape[-1]):
        out = out + a[:, k, None] * b[None, k, :]
    return out[:, 0] if vector else out


def dot(a, b):
    """The dot product of two vectors, summed in index order (a Python float)."""
    a = np.asarray(a, dtype=float).ravel()
    b = np.asarray(b, dtype=float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"shapes {a.shape} and {b.shape} do not match")
    total = 0.0
    for x, y in zip(a.tolist(), b.tolist()):
        total += x * y
    return total


def norm(v):
    """The Euclidean norm of a vector (a Python float)."""
    return math.sqrt(dot(v, v))


def eigh(sym, sweeps=64):
    """Eigenvalues (ascending) and eigenvectors (columns) of a small symmetric matrix by cyclic
    Jacobi rotations in Python floats: LAPACK's result, like BLAS's, depends on the CPU's kernel
    (a link's principal moments at rounding level, -4.41896e-22 on one machine and -4.42516e-22 on
    another, reached a warning's text)."""
    a = [[float(x) for x in row] for row in np.asarray(sym, dtype=float)]
    n = len(a)
    v = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for _ in range(sweeps):
        off = sum(a[i][j] * a[i][j] for i in range(n) for j in range(n) if i != j)
        if off == 0.0 or not math.isfinite(off):
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                if a[p][q] == 0.0:
                    continue
                theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):                     # columns p, q of a
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):                     # rows p, q of a
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    order = sorted(range(n), key=lambda i: a[i][i])
    values = np.array([a[i][i] for i in order])
    vectors = np.array([[v[k][i] for i in order] for k in range(n)])
    return values, vectors


def eigvalsh(sym):
    """The eigenvalues (ascending) of a small symmetric matrix, as :func:`eigh` computes them."""
    return eigh(sym)[0]
