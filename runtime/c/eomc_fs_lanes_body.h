/* eomc_fs_lanes_body.h -- fs_assemble across FSL_W lanes, included by eomc_fixedstep.c once per
 * vector width (FSL_W doubles, compiled for FSL_TARGET).  Each line below is a line of fs_assemble
 * or fs_tree_lu with the lane's double as a vector: the same operations in the same order, so the
 * same bits in every lane (C99 here: no contraction into fused multiply-adds).  Where the scalar
 * code branches on a lane's value (a joint law off, a contact not touching, a zero multiplier), the
 * vector code computes in every lane and keeps the old value where the scalar code would not have
 * stored (FSL_SEL): a skipped "x -= 0 * y" is not always x to the bit (-0.0).  Not a public header. */

#define FSL_CAT2(a, b) a##b
#define FSL_CAT(a, b) FSL_CAT2(a, b)
#define FSL_V FSL_CAT(fsl_v, FSL_W)
#define FSL_VI FSL_CAT(fsl_vi, FSL_W)
#define FSL_ANY FSL_CAT(fsl_any, FSL_W)
#define FSL_ALL FSL_CAT(fsl_all, FSL_W)
#define FSL_KERNEL FSL_CAT(fs_lanes_kernel, FSL_W)

typedef double FSL_V __attribute__((vector_size(8 * FSL_W)));
typedef long long FSL_VI __attribute__((vector_size(8 * FSL_W)));

/* lanes where m is set take a, the others b */
#define FSL_SEL(m, a, b) ((FSL_V)(((FSL_VI)(a) & (m)) | ((FSL_VI)(b) & ~(m))))
#define FSL_FABS(x) ((FSL_V)((FSL_VI)(x) & ((FSL_VI){0} + 0x7fffffffffffffffLL)))
#define FSL_FINITE(x) ((x) - (x) == (FSL_V){0})

__attribute__((target(FSL_TARGET))) static int FSL_ANY(const FSL_VI *m)
{
    long long r = 0;
    for (int c = 0; c < FSL_W; c++) r |= (*m)[c];
    return r != 0;
}

__attribute__((target(FSL_TARGET))) static int FSL_ALL(const FSL_VI *m)
{
    long long r = -1;
    for (int c = 0; c < FSL_W; c++) r &= (*m)[c];
    return r != 0;
}

/* OUT, Uv: this group's first lane of the batch's columns (stride doubles per row; OUT aligned
 * to the vector), hv, Aout, bout, ok: the group's FSL_W lanes. */
__attribute__((target(FSL_TARGET))) static void FSL_KERNEL(eomc_fs_lanes *w, const double *OUT,
                                                          const double *Uv, size_t stride, const double *hv,
                                                          double *const *Aout, double *const *bout, int *ok)
{
    const eomc_implicit *imp = w->imp;
    const fs_layout *L = &w->L;
    const int nu = w->nu;
    const FSL_V zero = {0}, one = zero + 1.0;
    FSL_V *A = (FSL_V *)w->A, *b = (FSL_V *)w->b, *J = (FSL_V *)w->J, *GJ = (FSL_V *)w->GJ;
    FSL_V h, hh, scale = zero, lim;
    FSL_VI fail = {0};
    const int *up = w->upd;
    memcpy(&h, hv, sizeof h);
    hh = h * h;
#define FSL_T(e) (*(const FSL_V *)(OUT + (size_t)(e) * stride))    /* term e in the group's lanes */
    for (int s = 0; s < w->nslot; s++) A[s] = FSL_T(L->M + (size_t)w->slot_ij[s]);
    for (int i = 0; i < nu; i++) b[i] = FSL_T(L->f + (size_t)i);
    for (int s = 0; s < nu; s++) {                   /* joint laws: diagonal */
        FSL_V d = FSL_T(L->joint + 2 * (size_t)s), k = FSL_T(L->joint + 2 * (size_t)s + 1), u;
        FSL_VI m;
        memcpy(&u, Uv + (size_t)s * stride, sizeof u);
        d = FSL_SEL(d > zero, d, zero);
        k = FSL_SEL(k > zero, k, zero);
        m = (d != zero) | (k != zero);
        if (FSL_ANY(&m)) {
            FSL_V *a = A + w->diag[s];
            *a = FSL_SEL(m, *a + (h * d + hh * k), *a);
            b[s] = FSL_SEL(m, b[s] - h * k * u, b[s]);
        }
    }
    for (int c = 0; c < imp->ncontact; c++) {
        const size_t ce = L->contact + 25 * (size_t)c;
        const int *cols = imp->chain + imp->chain_start[c], *cs = w->cslot + w->cslot_start[c];
        int m = imp->chain_start[c + 1] - imp->chain_start[c];
        FSL_V e[25], G[9], Cs[9], Kv[3];
        const FSL_V *p = e + 1, *vp = e + 4, *K = e + 7, *C = e + 16;
        FSL_VI on = FSL_T(ce) > zero, any = {0};
        if (!FSL_ANY(&on)) continue;                 /* not touching: no force, no slope */
        for (int a = 0; a < 25; a++) e[a] = FSL_T(ce + (size_t)a);
        for (int l = 0; l < FSL_W; l++) {             /* the secant, lane by lane (scalar code) */
            double k9[9], c9[9], s9[9];
            for (int a = 0; a < 9; a++) { k9[a] = K[a][l]; c9[a] = C[a][l]; s9[a] = 0.0; }
            if (on[l]) fs_secant_friction(k9, c9, s9);
            for (int a = 0; a < 9; a++) Cs[a][l] = s9[a];
        }
        for (int a = 0; a < 9; a++) {
            G[a] = h * Cs[a] + hh * K[a];
            any |= G[a] != zero;
        }
        on &= any;
        if (!FSL_ANY(&on)) continue;
        for (int a = 0; a < 3; a++)
            Kv[a] = K[3 * a] * vp[0] + K[3 * a + 1] * vp[1] + K[3 * a + 2] * vp[2];
        for (int k = 0; k < m; k++) {                 /* J[:, k] = ±(w x p + v0) of speed cols[k] */
            const size_t sw = L->screw + 6 * (size_t)fs_speed(cols[k]);
            const FSL_V wv[3] = {FSL_T(sw), FSL_T(sw + 1), FSL_T(sw + 2)};
            const FSL_V v0[3] = {FSL_T(sw + 3), FSL_T(sw + 4), FSL_T(sw + 5)};
            FSL_V *j = J + 3 * k, *bk = b + fs_speed(cols[k]);
            j[0] = v0[0] + wv[1] * p[2] - wv[2] * p[1];
            j[1] = v0[1] + wv[2] * p[0] - wv[0] * p[2];
            j[2] = v0[2] + wv[0] * p[1] - wv[1] * p[0];
            if (cols[k] < 0) {                        /* a pair's first body: v_rel = v_B - v_A */
                j[0] = -j[0];
                j[1] = -j[1];
                j[2] = -j[2];
            }
            for (int a = 0; a < 3; a++)
                GJ[3 * k + a] = G[3 * a] * j[0] + G[3 * a + 1] * j[1] + G[3 * a + 2] * j[2];
            *bk = FSL_SEL(on, *bk - h * (j[0] * Kv[0] + j[1] * Kv[1] + j[2] * Kv[2]), *bk);
        }
        for (int a = 0; a < m; a++) {
            const FSL_V *ja = J + 3 * a;
            for (int k = 0; k < m; k++) {
                const FSL_V *g = GJ + 3 * k;
                FSL_V *r = A + cs[a * m + k];
                *r = FSL_SEL(on, *r + (ja[0] * g[0] + ja[1] * g[1] + ja[2] * g[2]), *r);
            }
        }
    }
#undef FSL_T
    /* fs_tree_lu; a lane that fails its test is marked (the others go on) */
    for (int k = 0; k < nu; k++) {
        FSL_V a = FSL_FABS(A[w->diag[k]]);
        scale = FSL_SEL(a > scale, a, scale);
    }
    fail |= ~FSL_FINITE(scale);
    lim = 64 * DBL_EPSILON * scale;
    for (int k = nu - 1; k >= 0; k--) {
        int na = w->start[k + 1] - w->start[k];
        FSL_V dk = A[w->diag[k]], inv;
        const int *rk = up;                          /* the slots (k, a[y]) */
        fail |= ~(FSL_FABS(dk) > lim) | ~FSL_FINITE(dk);
        inv = one / dk;
        up += na;
        for (int x = 0; x < na; x++) {
            const int *ri = up + 1;                  /* (a[x], k), then (a[x], a[y]) */
            FSL_V u = A[up[0]] * inv;
            FSL_VI nz = u != zero;
            if (FSL_ALL(&nz)) {                      /* every lane updates (the common case) */
                for (int y = 0; y < na; y++) A[ri[y]] -= u * A[rk[y]];
            } else if (FSL_ANY(&nz)) {
                for (int y = 0; y < na; y++) {
                    FSL_V a = A[ri[y]], d = a - u * A[rk[y]];
                    A[ri[y]] = FSL_SEL(nz, d, a);
                }
            }
            A[up[0]] = u;
            up += 1 + na;
        }
        for (int y = 0; y < na; y++) A[rk[y]] *= inv;
    }
    {
        double *Ao[FSL_W], *bo[FSL_W];               /* the lanes written out (others: scratch) */
        for (int l = 0; l < FSL_W; l++) {
            ok[l] = !fail[l] && !((w->test_fail >> l) & 1u);
            Ao[l] = ok[l] && Aout[l] ? Aout[l] : w->sink;
            bo[l] = ok[l] && Aout[l] ? bout[l] : w->sink;
        }
        for (int s = 0; s < w->nslot; s++) {       /* slot by slot: one pass over the vectors */
            const FSL_V a = A[s];
            const int at = w->slot_ij[s];
            for (int l = 0; l < FSL_W; l++) Ao[l][at] = a[l];
        }
        for (int i = 0; i < nu; i++) {
            const FSL_V v = b[i];
            for (int l = 0; l < FSL_W; l++) bo[l][i] = v[l];
        }
    }
}

#undef FSL_KERNEL
#undef FSL_ANY
#undef FSL_ALL
#undef FSL_VI
#undef FSL_V
#undef FSL_SEL
#undef FSL_FABS
#undef FSL_FINITE
#undef FSL_CAT
#undef FSL_CAT2
