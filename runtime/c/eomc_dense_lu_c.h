/* Dense complex LU with partial pivoting, shared by Radau (eomc_integrators.c: its complex Newton
 * matrix) and the Radau adjoint (eomc_adjoint.c: the transposed complex eigenblock of the
 * collocation matrix): one copy of the arithmetic.  Static inline, as eomc_dense_lu.h. */
#ifndef EOMC_DENSE_LU_C_H
#define EOMC_DENSE_LU_C_H

#include <complex.h>
#include <math.h>
#include <stddef.h>

typedef double _Complex eomc_cplx;

/* Complex products written out in real arithmetic: C99's '*' and '/' on complex values
 * call __muldc3/__divdc3 (NaN/overflow recovery) and made this LU 5x the real one. */
#define CMUL_RE(a, b) (creal(a) * creal(b) - cimag(a) * cimag(b))
#define CMUL_IM(a, b) (creal(a) * cimag(b) + cimag(a) * creal(b))

static inline eomc_cplx c_recip(eomc_cplx a)
{
    double re = creal(a), im = cimag(a), d = re * re + im * im;
    return re / d - I * (im / d);
}

/* Pivoting on |re| + |im| (as Hairer's decc), not the modulus: no hypot per entry. */
static inline int lu_factor_c(int n, eomc_cplx *A, int *piv)
{
    for (int k = 0; k < n; k++) {
        int pk = k;
        double amax = fabs(creal(A[k * n + k])) + fabs(cimag(A[k * n + k]));
        eomc_cplx inv;
        for (int i = k + 1; i < n; i++) {
            double v = fabs(creal(A[i * n + k])) + fabs(cimag(A[i * n + k]));
            if (v > amax) { amax = v; pk = i; }
        }
        piv[k] = pk;
        if (amax == 0.0 || !isfinite(amax)) return 1;
        if (pk != k)
            for (int j = 0; j < n; j++) {
                eomc_cplx tmp = A[k * n + j]; A[k * n + j] = A[pk * n + j]; A[pk * n + j] = tmp;
            }
        inv = c_recip(A[k * n + k]);
        for (int i = k + 1; i < n; i++) {
            eomc_cplx a = A[i * n + k];
            double lr = CMUL_RE(a, inv), li = CMUL_IM(a, inv);
            A[i * n + k] = lr + I * li;
            if (lr != 0.0 || li != 0.0) {
                double *row = (double *)(A + (size_t)i * n);
                const double *piv_row = (const double *)(A + (size_t)k * n);
                for (int j = k + 1; j < n; j++) {
                    double ur = piv_row[2 * j], ui = piv_row[2 * j + 1];
                    row[2 * j] -= lr * ur - li * ui;
                    row[2 * j + 1] -= lr * ui + li * ur;
                }
            }
        }
    }
    return 0;
}

static inline void lu_solve_c(int n, const eomc_cplx *A, const int *piv, eomc_cplx *b)
{
    for (int k = 0; k < n; k++)          /* all row interchanges first (P b) */
        if (piv[k] != k) { eomc_cplx tmp = b[k]; b[k] = b[piv[k]]; b[piv[k]] = tmp; }
    for (int k = 0; k < n; k++) {
        double br = creal(b[k]), bi = cimag(b[k]);
        for (int i = k + 1; i < n; i++) {
            eomc_cplx a = A[i * n + k];
            b[i] -= (creal(a) * br - cimag(a) * bi) + I * (creal(a) * bi + cimag(a) * br);
        }
    }
    for (int i = n - 1; i >= 0; i--) {
        double sr = creal(b[i]), si = cimag(b[i]);
        eomc_cplx q;
        for (int j = i + 1; j < n; j++) {
            eomc_cplx a = A[i * n + j];
            sr -= CMUL_RE(a, b[j]);
            si -= CMUL_IM(a, b[j]);
        }
        q = c_recip(A[i * n + i]);
        b[i] = (sr * creal(q) - si * cimag(q)) + I * (sr * cimag(q) + si * creal(q));
    }
}

#endif
