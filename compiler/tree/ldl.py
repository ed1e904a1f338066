"""D = L diag(d) Lᵀ of a k-speed joint's articulated inertia, unrolled on symbols (ABA, loops)."""
import sympy as sm


class _LDL:
    """D = L diag(d) Lᵀ of a symmetric kxk (k ≤ 6), unrolled and named; ``solve`` applies D⁻¹
    by forward and back substitution (cheaper than forming D⁻¹: a root's D is solved once).

    A pivot that is zero as an expression means nothing resists some motion of the
    joint: refused here naming the body, as the one-speed D = 0."""

    def __init__(self, Dm, rec, b):
        k = self.k = len(Dm)
        self.rec = rec
        L = self.L = [[sm.S.Zero] * k for _ in range(k)]
        d, dinv = self.d, self.dinv = [None] * k, [None] * k
        for j in range(k):
            d[j] = rec.let(Dm[j][j] - sum((L[j][m] ** 2 * d[m] for m in range(j) if L[j][m] != 0),
                                          sm.S.Zero))
            if d[j] == 0:
                from .model import NotATree
                raise NotATree(f"body {b.name} (joint {b.joint}) has no inertia against one of its "
                               f"joint's motions, even with everything beyond it: its acceleration "
                               f"is undefined")
            dinv[j] = rec.let(1 / d[j])
            L[j][j] = sm.S.One
            for i in range(j + 1, k):
                L[i][j] = rec.let((Dm[i][j] - sum((L[i][m] * L[j][m] * d[m] for m in range(j)
                                                   if L[i][m] != 0 and L[j][m] != 0), sm.S.Zero)) * dinv[j])

    def solve(self, rhs):
        """D⁻¹ rhs (a k-list), each step named."""
        k, L, rec = self.k, self.L, self.rec
        y = [None] * k
        for j in range(k):
            y[j] = rec.let(rhs[j] - sum((L[j][m] * y[m] for m in range(j) if L[j][m] != 0), sm.S.Zero))
        x = [None] * k
        for j in reversed(range(k)):
            x[j] = rec.let(y[j] * self.dinv[j] - sum((L[m][j] * x[m] for m in range(j + 1, k)
                                                      if L[m][j] != 0), sm.S.Zero))
        return x
