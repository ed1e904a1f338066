/* Dense LU with partial pivoting, shared by the Radau/DOPRI file (eomc_integrators.c) and BDF
 * (eomc_bdf.c): one copy of the arithmetic, so both methods factor their Newton matrices bit for
 * bit alike. Static functions in a header: each translation unit keeps its own private copy and
 * nothing is exported from the runtime library. (The fixed-step runner keeps its own variant: it
 * multiplies by the pivot's reciprocal, and its results are recorded bit for bit in tests.) */
#ifndef EOMC_DENSE_LU_H
#define EOMC_DENSE_LU_H

#include <math.h>

/* In-place LU with partial pivoting of the n x n row-major A. 1 if singular (or not finite). */
static int lu_factor(int n, double *A, int *piv)
{
    for (int k = 0; k < n; k++) {
        int pk = k;
        double amax = fabs(A[k * n + k]);
        for (int i = k + 1; i < n; i++)
            if (fabs(A[i * n + k]) > amax) { amax = fabs(A[i * n + k]); pk = i; }
        piv[k] = pk;
        if (!(amax > 0.0) || !isfinite(amax)) return 1;
        if (pk != k)
            for (int j = 0; j < n; j++) {
                double tmp = A[k * n + j]; A[k * n + j] = A[pk * n + j]; A[pk * n + j] = tmp;
            }
        for (int i = k + 1; i < n; i++) {
            double l = A[i * n + k] /= A[k * n + k];
            if (l != 0.0)
                for (int j = k + 1; j < n; j++) A[i * n + j] -= l * A[k * n + j];
        }
    }
    return 0;
}

/* Solve A x = b in place with the factors of lu_factor. */
static void lu_solve(int n, const double *A, const int *piv, double *b)
{
    for (int k = 0; k < n; k++)          /* all row interchanges first (P b): they moved whole rows */
        if (piv[k] != k) { double tmp = b[k]; b[k] = b[piv[k]]; b[piv[k]] = tmp; }
    for (int k = 0; k < n; k++)
        for (int i = k + 1; i < n; i++) b[i] -= A[i * n + k] * b[k];
    for (int i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (int j = i + 1; j < n; j++) s -= A[i * n + j] * b[j];
        b[i] = s / A[i * n + i];
    }
}

#endif
