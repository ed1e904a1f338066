/* Dense LU with partial pivoting, shared by the Radau/DOPRI file (eomc_integrators.c) and BDF
 * (eomc_bdf.c): one copy of the arithmetic, so both methods factor their Newton matrices bit for
 * bit alike (BDF solves with them by rows, lu_solve_rows below: the same solution summed in
 * another order). Static inline functions in a header: each translation unit keeps its own
 * private copy, nothing is exported from the runtime library, and a unit that uses only some of
 * them is not warned about the others. (The fixed-step runner keeps its own variant: it
 * multiplies by the pivot's reciprocal, and its results are recorded bit for bit in tests.) */
#ifndef EOMC_DENSE_LU_H
#define EOMC_DENSE_LU_H

#include <math.h>

/* Row ri -= l * row rk over columns lo..n-1 (two distinct rows: restrict).  Four entries
 * at a time, so that the compiler packs them into vector instructions (SLP vectorisation,
 * on at -O2 since GCC 12; the plain loop stayed scalar, the compiler could not tell the rows
 * apart).  Each entry gets the same multiply and subtract as before: the factors are bit for
 * bit the same.  lu_factor at n = 28 / 37 / 60 (the ant, Solo12, a humanoid): 4.2 / 9.9 /
 * 41 -> 2.0 / 4.2 / 17 us (gcc 12 -O2, core 0). */
static inline void lu_row_update(double *restrict ri, const double *restrict rk, double l,
                                 int lo, int n)
{
    int j = lo;
    for (; j + 3 < n; j += 4) {
        double a0 = ri[j] - l * rk[j], a1 = ri[j + 1] - l * rk[j + 1];
        double a2 = ri[j + 2] - l * rk[j + 2], a3 = ri[j + 3] - l * rk[j + 3];
        ri[j] = a0; ri[j + 1] = a1; ri[j + 2] = a2; ri[j + 3] = a3;
    }
    for (; j < n; j++) ri[j] -= l * rk[j];
}

/* In-place LU with partial pivoting of the n x n row-major A. 1 if singular (or not finite). */
static inline int lu_factor(int n, double *A, int *piv)
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
            if (l != 0.0) lu_row_update(A + (size_t)i * n, A + (size_t)k * n, l, k + 1, n);
        }
    }
    return 0;
}

/* Solve A x = b in place with the factors of lu_factor. */
static inline void lu_solve(int n, const double *A, const int *piv, double *b)
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

/* Row i of L or U (row-major, entries lo..hi-1) times b: the dot product with four
 * independent partial sums, so the multiply-adds of one row overlap instead of waiting on
 * one another.  A triangular solve is a chain of such rows (b[i] needs every earlier b), and
 * with one running sum each row was a chain of dependent adds: the back-substitution alone
 * was a quarter of eomc_bdf_trial's time on gymnasium's ant (perf; ant and Solo12 runs 3-4 %
 * faster with this, benchmarks/results/contact_wp.md, s8 notes). */
static inline double row_dot(const double *a, const double *b, int lo, int hi)
{
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int j = lo;
    for (; j + 3 < hi; j += 4) {
        s0 += a[j] * b[j];
        s1 += a[j + 1] * b[j + 1];
        s2 += a[j + 2] * b[j + 2];
        s3 += a[j + 3] * b[j + 3];
    }
    for (; j < hi; j++) s0 += a[j] * b[j];
    return (s0 + s1) + (s2 + s3);
}

/* Solve A x = b in place with the factors of lu_factor, by rows: lu_solve's solution summed in
 * another order.  BDF's Newton uses it (one solve per iteration); Radau keeps lu_solve. */
static inline void lu_solve_rows(int n, const double *A, const int *piv, double *b)
{
    for (int k = 0; k < n; k++)
        if (piv[k] != k) { double tmp = b[k]; b[k] = b[piv[k]]; b[piv[k]] = tmp; }
    for (int i = 1; i < n; i++) b[i] -= row_dot(A + (size_t)i * n, b, 0, i);
    for (int i = n - 1; i >= 0; i--)
        b[i] = (b[i] - row_dot(A + (size_t)i * n, b, i + 1, n)) / A[(size_t)i * n + i];
}

#endif
