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
#define FSL_SECANT FSL_CAT(fsl_secant, FSL_W)
#define FSL_SQRT FSL_CAT(fsl_sqrt, FSL_W)
#define FSL_SOLVE FSL_CAT(fsl_solve, FSL_W)
#define FSL_SOLVE2 FSL_CAT(fsl_solve2_, FSL_W)
#define FSL_STEP FSL_CAT(fsl_step, FSL_W)
#define FSL_GATHER FSL_CAT(fsl_gather, FSL_W)
#define FSL_BIAS FSL_CAT(fsl_bias, FSL_W)

typedef double FSL_V __attribute__((vector_size(8 * FSL_W)));
typedef long long FSL_VI __attribute__((vector_size(8 * FSL_W)));

/* lanes where m is set take a, the others b */
#define FSL_SEL(m, a, b) ((FSL_V)(((FSL_VI)(a) & (m)) | ((FSL_VI)(b) & ~(m))))
#define FSL_FABS(x) ((FSL_V)((FSL_VI)(x) & ((FSL_VI){0} + 0x7fffffffffffffffLL)))
#define FSL_FINITE(x) ((x) - (x) == (FSL_V){0})

/* (a mask's lanes are all ones or all zeros: its sign bits say it; one movemask) */
__attribute__((target(FSL_TARGET))) static inline int FSL_ANY(const FSL_VI *m)
{
#if FSL_W == 4
    return _mm256_movemask_pd((__m256d)*m) != 0;
#elif FSL_W == 8
    return _mm512_movepi64_mask((__m512i)*m) != 0;
#else
    long long r = 0;
    for (int c = 0; c < FSL_W; c++) r |= (*m)[c];
    return r != 0;
#endif
}

__attribute__((target(FSL_TARGET))) static inline int FSL_ALL(const FSL_VI *m)
{
#if FSL_W == 4
    return _mm256_movemask_pd((__m256d)*m) == 0xF;
#elif FSL_W == 8
    return _mm512_movepi64_mask((__m512i)*m) == 0xFF;
#else
    long long r = -1;
    for (int c = 0; c < FSL_W; c++) r &= (*m)[c];
    return r != 0;
#endif
}

/* term x of each lane's own row (the lanes rollout's rows: eomc_fs_assemble_lanes) */
__attribute__((target(FSL_TARGET))) static inline FSL_V FSL_GATHER(const double *const *rows, size_t x)
{
    FSL_V v;
    for (int c = 0; c < FSL_W; c++) v[c] = rows[c][x];
    return v;
}

/* sqrt in every lane (IEEE: the scalar sqrt's bits) */
__attribute__((target(FSL_TARGET))) static inline FSL_V FSL_SQRT(FSL_V x)
{
#if FSL_W == 4
    return (FSL_V)_mm256_sqrt_pd((__m256d)x);
#elif FSL_W == 8
    return (FSL_V)_mm512_sqrt_pd((__m512d)x);
#else
    for (int c = 0; c < FSL_W; c++) x[c] = __builtin_sqrt(x[c]);
    return x;
#endif
}

/* fs_secant_friction in every lane: its operations in its order (the same bits), its branches as
 * selects -- the normal's row r and the plane's first axis m picked by masks, a lane with no normal
 * force (r < 0 or not finite) or no finite gf keeping Cs = C.  Measured on G1 (perf, lanes run):
 * the secant lane by lane, with its gathers and scatters, was the kernel's largest scalar part. */
__attribute__((target(FSL_TARGET))) static void FSL_SECANT(const FSL_V *K, const FSL_V *C, FSL_V *Cs)
{
    const FSL_V zero = {0}, one = zero + 1.0, half_ = zero + 0.5;
    FSL_V big = zero, n[3], e[2][3], B[2][2], l, gf, nm, kr[3] = {zero, zero, zero};
    FSL_VI found = {0}, keep, m0, m1, m2;
    for (int a = 0; a < 3; a++) {
        FSL_V s2 = K[3 * a] * K[3 * a] + K[3 * a + 1] * K[3 * a + 1] + K[3 * a + 2] * K[3 * a + 2];
        FSL_VI gt = s2 > big;
        big = FSL_SEL(gt, s2, big);
        for (int c = 0; c < 3; c++) kr[c] = FSL_SEL(gt, K[3 * a + c], kr[c]);
        found |= gt;
    }
    keep = ~found | ~FSL_FINITE(big);
    l = one / FSL_SQRT(big);
    for (int a = 0; a < 3; a++) n[a] = kr[a] * l;
    {
        FSL_V a0 = FSL_FABS(n[0]), a1 = FSL_FABS(n[1]), a2 = FSL_FABS(n[2]);
        FSL_VI le01 = a0 <= a1;
        m0 = le01 & (a0 <= a2);
        m1 = ~le01 & (a1 <= a2);
        m2 = ~m0 & ~m1;
        nm = FSL_SEL(m0, n[0], FSL_SEL(m1, n[1], n[2]));
    }
    e[0][0] = FSL_SEL(m0, one, zero) - nm * n[0];
    e[0][1] = FSL_SEL(m1, one, zero) - nm * n[1];
    e[0][2] = FSL_SEL(m2, one, zero) - nm * n[2];
    l = one / FSL_SQRT(e[0][0] * e[0][0] + e[0][1] * e[0][1] + e[0][2] * e[0][2]);
    for (int a = 0; a < 3; a++) e[0][a] *= l;
    e[1][0] = n[1] * e[0][2] - n[2] * e[0][1];
    e[1][1] = n[2] * e[0][0] - n[0] * e[0][2];
    e[1][2] = n[0] * e[0][1] - n[1] * e[0][0];
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            FSL_V t = zero;
            for (int a = 0; a < 3; a++)
                t += e[i][a] * (C[3 * a] * e[j][0] + C[3 * a + 1] * e[j][1] + C[3 * a + 2] * e[j][2]);
            B[i][j] = t;
        }
    {
        FSL_V mean = half_ * (B[0][0] + B[1][1]), hf = half_ * (B[0][0] - B[1][1]), off = half_ * (B[0][1] + B[1][0]);
        gf = mean + FSL_SQRT(hf * hf + off * off);
    }
    keep |= ~FSL_FINITE(gf);
    for (int a = 0; a < 9; a++) Cs[a] = C[a];
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            FSL_V d = (i == j ? gf : zero) - B[i][j];
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) Cs[3 * a + b] += e[i][a] * d * e[j][b];
        }
    for (int a = 0; a < 9; a++) Cs[a] = FSL_SEL(keep, C[a], Cs[a]);
}

/* fs_tree_solve in every lane: B := A^-1 B with the kernel's factored A (its slots, pattern P) */
__attribute__((target(FSL_TARGET))) static void FSL_SOLVE(const eomc_fs_lanes *w, const fsl_pattern *P,
                                                         const FSL_V *A, FSL_V *B)
{
    const int n = w->nu, *start = P->start, *anc = P->anc, *lo = P->lo, *up = P->up;
    for (int k = n - 1; k >= 0; k--) {
        const FSL_V bk = B[k];
        for (int x = start[k]; x < start[k + 1]; x++) B[anc[x]] -= A[lo[x]] * bk;
    }
    for (int k = 0; k < n; k++) B[k] /= A[w->diag[k]];
    for (int k = 0; k < n; k++) {
        FSL_V s = B[k];
        for (int x = start[k]; x < start[k + 1]; x++) s -= A[up[x]] * B[anc[x]];
        B[k] = s;
    }
}

/* FSL_SOLVE on two right sides B and C at once, A's entries and the lists read once for both (each
 * side the same operations in the same order: the same bits) */
__attribute__((target(FSL_TARGET))) static void FSL_SOLVE2(const eomc_fs_lanes *w, const fsl_pattern *P,
                                                          const FSL_V *A, FSL_V *B, FSL_V *C)
{
    const int n = w->nu, *start = P->start, *anc = P->anc, *lo = P->lo, *up = P->up;
    for (int k = n - 1; k >= 0; k--) {
        const FSL_V bk = B[k], ck = C[k];
        for (int x = start[k]; x < start[k + 1]; x++) {
            const FSL_V a = A[lo[x]];
            B[anc[x]] -= a * bk;
            C[anc[x]] -= a * ck;
        }
    }
    for (int k = 0; k < n; k++) {
        const FSL_V d = A[w->diag[k]];
        B[k] /= d;
        C[k] /= d;
    }
    for (int k = 0; k < n; k++) {
        FSL_V s = B[k], t = C[k];
        for (int x = start[k]; x < start[k + 1]; x++) {
            const FSL_V a = A[up[x]];
            s -= a * B[anc[x]];
            t -= a * C[anc[x]];
        }
        B[k] = s;
        C[k] = t;
    }
}

/* fs_fast_try's lines after its model call, in every lane, with the group's A (factored) and b:
 * the residual ratio of the try whose velocity change is du[l] (NULL: none asked), and the next
 * try's du1 = A^-1 (h b) and rate v1 = qd + N du1 (from the same terms: a step of h from here), in
 * the order of the scalar lines, so each lane's bits.  Why here: per row and scalar, the two tree
 * solves and the products with M and N (1260 terms on G1) were a quarter of the lanes rollout's C
 * time (perf). */
__attribute__((target(FSL_TARGET))) static void FSL_STEP(eomc_fs_lanes *w, const fsl_pattern *P, const double *OUT,
                                                        size_t stride, FSL_V h, const FSL_V *A, const FSL_V *b,
                                                        const double *const *du, FSL_V *ratio)
{
    const fs_layout *L = &w->L;
    const int nu = w->nu, nq = w->nq;
    const FSL_V zero = {0};
    FSL_V *D = (FSL_V *)w->D, *R = (FSL_V *)w->R, *V = (FSL_V *)w->V;
    int any = 0;
#define FSL_T(e) (*(const FSL_V *)(OUT + (size_t)(e) * stride))
    for (int l = 0; l < FSL_W; l++) any |= du[l] != NULL;
    if (any) {                                       /* r = M1 du - h f1 over M's columns, A^-1 r */
        FSL_V rn = zero, dn = zero;
        for (int k = 0; k < nu; k++) {
            FSL_V d;
            for (int l = 0; l < FSL_W; l++) d[l] = du[l] ? du[l][k] : 0.0;
            D[k] = d;
        }
        for (int i = 0; i < nu; i++) {
            FSL_V r = -h * FSL_T(L->f + (size_t)i);
            for (int x = w->mstart[i]; x < w->mstart[i + 1]; x++) {
                const int k = w->mcols[x];
                r += FSL_T(L->M + (size_t)i * nu + (size_t)k) * D[k];
            }
            R[i] = r;
        }
        for (int i = 0; i < nu; i++) dn += D[i] * D[i];
        /* the residual's solve and the next try's (du1 = A^-1 h b) in one pass over the factor
         * (measured, one process switched call by call, 40 and 10 calls a side, core 0, load 13-14:
         * ant 0.987-0.991, humanoid 0.995 of the rollout's time) */
        for (int i = 0; i < nu; i++) D[i] = h * b[i];
        FSL_SOLVE2(w, P, A, R, D);
        for (int i = 0; i < nu; i++) rn += R[i] * R[i];
        *ratio = FSL_SQRT(rn) / (FSL_SQRT(dn) + h * RESID_ACCEL);
    } else {
        for (int i = 0; i < nu; i++) D[i] = h * b[i];
        FSL_SOLVE(w, P, A, D);
    }
    for (int i = 0; i < nq; i++) {   /* v = qd + N du over N's columns that are not a constant 0 (w->ncol:
                                        fs_fast_try's sum, its terms in its order; the humanoid's 35 of 552) */
        FSL_V v = FSL_T(L->qd + (size_t)i);
        const size_t ni = L->N + (size_t)i * nu;
        for (int x = w->nstart[i]; x < w->nstart[i + 1]; x++) v += FSL_T(ni + (size_t)w->ncol[x]) * D[w->ncol[x]];
        V[i] = v;
    }
#undef FSL_T
}

/* fs_point_bias of contact c in every lane: the same operations in the same order (OUT, Uv, stride:
 * the kernel's); a body-body pair's (fs_pair_bias) likewise.  The chain's order by speed, its case
 * and each speed's flags are made once (eomc_fs_lanes_new: w->border, bflag, bpair), no longer
 * sorted and looked up per contact and call (the free-joint test alone was a tenth of this
 * function's samples on the ant, perf) */
__attribute__((target(FSL_TARGET))) static int FSL_BIAS(const eomc_fs_lanes *w, int c, const double *OUT,
                                                       const double *Uv, size_t stride, const FSL_V *p,
                                                       const FSL_V *vp, FSL_V *a)
{
    const eomc_implicit *imp = w->imp;
    const fs_layout *L = &w->L;
    const FSL_V zero = {0};
    const int c0 = imp->chain_start[c], m = imp->chain_start[c + 1] - c0, *order = w->border + c0;
    const unsigned char *fl = w->bflag + c0;
    FSL_V V[6] = {zero, zero, zero, zero, zero, zero}, B[6] = {zero, zero, zero, zero, zero, zero};
    FSL_V Vg[6] = {zero, zero, zero, zero, zero, zero};
#define FSL_SCREW(k, x) (*(const FSL_V *)(OUT + (L->screw + 6 * (size_t)(k) + (size_t)(x)) * stride))
    if (w->bpair[c] < 0) return 0;
    if (w->bpair[c]) {                                /* fs_pair_bias */
        FSL_V V0[6] = {zero, zero, zero, zero, zero, zero}, VB[6], VA[6], pa[3], dw[3];
        for (int k = imp->parent[fs_speed(order[0])]; k >= 0; k = imp->parent[k]) {
            FSL_V uk;
            memcpy(&uk, Uv + (size_t)k * stride, sizeof uk);
            for (int x = 0; x < 6; x++) V0[x] += FSL_SCREW(k, x) * uk;
        }
        memcpy(VB, V0, sizeof VB);
        memcpy(VA, V0, sizeof VA);
        for (int i = 0; i < m; i++) {
            int k = fs_speed(order[i]);
            FSL_V S[6], X[6], uk, *Vs = order[i] >= 0 ? VB : VA;
            const FSL_V *Vk = Vs;
            memcpy(&uk, Uv + (size_t)k * stride, sizeof uk);
            for (int x = 0; x < 6; x++) S[x] = FSL_SCREW(k, x) * uk;
            if (imp->joint) {                         /* that side's V before k's joint */
                if (fl[i] & 2) memcpy(Vg, Vs, sizeof Vg);
                Vk = Vg;
            }
            if (!(fl[i] & 1)) {
                X[0] = Vk[1] * S[2] - Vk[2] * S[1];
                X[1] = Vk[2] * S[0] - Vk[0] * S[2];
                X[2] = Vk[0] * S[1] - Vk[1] * S[0];
                X[3] = (Vk[1] * S[5] - Vk[2] * S[4]) + (Vk[4] * S[2] - Vk[5] * S[1]);
                X[4] = (Vk[2] * S[3] - Vk[0] * S[5]) + (Vk[5] * S[0] - Vk[3] * S[2]);
                X[5] = (Vk[0] * S[4] - Vk[1] * S[3]) + (Vk[3] * S[1] - Vk[4] * S[0]);
                if (order[i] >= 0)
                    for (int x = 0; x < 6; x++) B[x] += X[x];
                else
                    for (int x = 0; x < 6; x++) B[x] -= X[x];
            }
            for (int x = 0; x < 6; x++) Vs[x] += S[x];
        }
        pa[0] = VA[3] + (VA[1] * p[2] - VA[2] * p[1]);
        pa[1] = VA[4] + (VA[2] * p[0] - VA[0] * p[2]);
        pa[2] = VA[5] + (VA[0] * p[1] - VA[1] * p[0]);
        for (int x = 0; x < 3; x++) dw[x] = VB[x] - VA[x];
        a[0] = (B[1] * p[2] - B[2] * p[1]) + B[3] + (VB[1] * vp[2] - VB[2] * vp[1]) + (dw[1] * pa[2] - dw[2] * pa[1]);
        a[1] = (B[2] * p[0] - B[0] * p[2]) + B[4] + (VB[2] * vp[0] - VB[0] * vp[2]) + (dw[2] * pa[0] - dw[0] * pa[2]);
        a[2] = (B[0] * p[1] - B[1] * p[0]) + B[5] + (VB[0] * vp[1] - VB[1] * vp[0]) + (dw[0] * pa[1] - dw[1] * pa[0]);
        return 1;
    }
    for (int i = 0; i < m; i++) {
        int k = order[i];
        FSL_V S[6], uk;
        const FSL_V *Vk = V;
        memcpy(&uk, Uv + (size_t)k * stride, sizeof uk);
        for (int x = 0; x < 6; x++) S[x] = FSL_SCREW(k, x) * uk;
        if (imp->joint) {                             /* V before k's joint */
            if (fl[i] & 2) memcpy(Vg, V, sizeof Vg);
            Vk = Vg;
        }
        if (!(fl[i] & 1)) {
            B[0] += Vk[1] * S[2] - Vk[2] * S[1];
            B[1] += Vk[2] * S[0] - Vk[0] * S[2];
            B[2] += Vk[0] * S[1] - Vk[1] * S[0];
            B[3] += (Vk[1] * S[5] - Vk[2] * S[4]) + (Vk[4] * S[2] - Vk[5] * S[1]);
            B[4] += (Vk[2] * S[3] - Vk[0] * S[5]) + (Vk[5] * S[0] - Vk[3] * S[2]);
            B[5] += (Vk[0] * S[4] - Vk[1] * S[3]) + (Vk[3] * S[1] - Vk[4] * S[0]);
        }
        for (int x = 0; x < 6; x++) V[x] += S[x];
    }
#undef FSL_SCREW
    a[0] = (B[1] * p[2] - B[2] * p[1]) + B[3] + (V[1] * vp[2] - V[2] * vp[1]);
    a[1] = (B[2] * p[0] - B[0] * p[2]) + B[4] + (V[2] * vp[0] - V[0] * vp[2]);
    a[2] = (B[0] * p[1] - B[1] * p[0]) + B[5] + (V[0] * vp[1] - V[1] * vp[0]);
    return 1;
}

/* OUT, Uv: this group's first lane of the batch's columns (stride doubles per row; OUT aligned
 * to the vector), req, ahead: the group's FSL_W lanes (eomc_fs_assemble_lanes); rows (NULL: none):
 * the group's lanes' rows, which hold the terms rlo .. rhi - 1 instead of OUT. */
__attribute__((target(FSL_TARGET))) static void FSL_KERNEL(eomc_fs_lanes *w, const double *OUT,
                                                          const double *Uv, size_t stride,
                                                          eomc_fs_request *const *req, double *const *ahead,
                                                          const double *const *rows, size_t rlo, size_t rhi)
{
    const eomc_implicit *imp = w->imp;
    const fs_layout *L = &w->L;
    const int nu = w->nu;
    const FSL_V zero = {0}, one = zero + 1.0;
    FSL_V *A = (FSL_V *)w->A, *b = (FSL_V *)w->b, *J = (FSL_V *)w->J, *GJ = (FSL_V *)w->GJ;
    FSL_V h, hh, scale = zero, lim;
    FSL_VI fail = {0}, act;                          /* act: the lanes asked (req), all ones */
    const fsl_pattern *P = w->dyn ? &w->base : &w->full;
    int nt = 0;
    const int *up;
    const double *du[FSL_W];
    h = zero;
    int *tl[FSL_W], ntl[FSL_W];                      /* the lanes' contacts in touch (req->touch) */
    for (int l = 0; l < FSL_W; l++) {
        h[l] = req[l] ? req[l]->h : 0.0;
        du[l] = req[l] ? req[l]->du : NULL;
        act[l] = req[l] ? -1 : 0;
        tl[l] = req[l] ? req[l]->touch : NULL;
        ntl[l] = 0;
    }
    hh = h * h;
#define FSL_T(e) (*(const FSL_V *)(OUT + (size_t)(e) * stride))    /* term e in the group's lanes */
#define FSL_E(x) (rows && (x) >= rlo && (x) < rhi ? FSL_GATHER(rows, (x)) : FSL_T(x))   /* term x: the rows' or OUT's */
    {   /* the contacts in touch in an asked lane (depth > 0), and of them the pairs across two
           branches: their fill (one scan of the depths: the contacts' loop below takes the list).
           A lane not asked is read by no store: its contacts neither add work nor grow the pattern
           (an assembly pass's other columns, lanes_pass in eomc_rollout.c, are other rows') */
        int nx = 0;
        for (int c = 0; c < imp->ncontact; c++) {
            const FSL_VI on = (FSL_E(L->contact + 25 * (size_t)c) > zero) & act;
            if (!FSL_ANY(&on)) continue;
            w->touch[nt++] = c;
            if (w->cross[c]) w->xon[nx++] = c;
            for (int l = 0; l < FSL_W; l++)          /* each asked lane's own list (req->touch) */
                if (on[l] && tl[l]) {
                    if (ntl[l] >= 0 && ntl[l] < FS_TOUCH) tl[l][ntl[l]++] = c;
                    else ntl[l] = -1;
                }
        }
        if (nx > 0) P = fsl_grow(w, w->xon, nx);
    }
    up = P->upd;
    for (int x = 0; x < P->nslots; x++) A[P->slots[x]] = FSL_T(L->M + (size_t)w->slot_ij[P->slots[x]]);
    for (int i = 0; i < nu; i++) b[i] = FSL_T(L->f + (size_t)i);
    for (int r = 0; r < imp->nfree; r++) {           /* fs_transport, on row s's slots */
        const int s = imp->free[r];
        const FSL_V g = 0.5 * h;
        FSL_V wv[3];
        for (int a = 0; a < 3; a++) memcpy(&wv[a], Uv + (size_t)(s + 3 + a) * stride, sizeof wv[a]);
        for (int x = w->mstart[s]; x < w->mstart[s + 1]; x++) {
            const int k = w->mcols[x];
            const FSL_V p0 = FSL_T(L->M + (size_t)s * nu + k), p1 = FSL_T(L->M + (size_t)(s + 1) * nu + k),
                        p2 = FSL_T(L->M + (size_t)(s + 2) * nu + k);
            const FSL_VI on = (p0 != zero) | (p1 != zero) | (p2 != zero);
            FSL_V *a0 = A + w->slot[s * nu + k], *a1 = A + w->slot[(s + 1) * nu + k],
                  *a2 = A + w->slot[(s + 2) * nu + k];
            *a0 = FSL_SEL(on, *a0 + g * (wv[1] * p2 - wv[2] * p1), *a0);
            *a1 = FSL_SEL(on, *a1 + g * (wv[2] * p0 - wv[0] * p2), *a1);
            *a2 = FSL_SEL(on, *a2 + g * (wv[0] * p1 - wv[1] * p0), *a2);
        }
    }
    for (int s = 0; s < nu; s++) {                   /* joint laws: diagonal */
        FSL_V d = FSL_T(L->joint + 2 * (size_t)s), k = FSL_T(L->joint + 2 * (size_t)s + 1), u;
        FSL_VI m;
        memcpy(&u, Uv + (size_t)s * stride, sizeof u);
        d = FSL_SEL(d > zero, d, zero);
        k = FSL_SEL(k > zero, k, zero);
        m = ((d != zero) | (k != zero)) & act;
        if (FSL_ANY(&m)) {
            FSL_V *a = A + w->diag[s];
            *a = FSL_SEL(m, *a + (h * d + hh * k), *a);
            b[s] = FSL_SEL(m, b[s] - h * k * u, b[s]);
        }
    }
    for (int t = 0; t < nt; t++) {
        const int c = w->touch[t];
        const size_t ce = L->contact + 25 * (size_t)c;
        const int *cols = imp->chain + imp->chain_start[c], *cs = w->cslot + w->cslot_start[c];
        int m = imp->chain_start[c + 1] - imp->chain_start[c];
        FSL_V e[25], G[9], Cs[9], Kv[3];
        const FSL_V *p = e + 1, *vp = e + 4, *K = e + 7, *C = e + 16;
        FSL_VI on, any = {0};
        on = (FSL_E(ce) > zero) & act;
        if (!FSL_ANY(&on)) continue;                 /* not touching: no force, no slope */
        for (int a = 0; a < 25; a++) e[a] = FSL_E(ce + (size_t)a);
        FSL_SECANT(K, C, Cs);                         /* the lanes off: read by no store */
        for (int a = 0; a < 9; a++) {
            G[a] = h * Cs[a] + hh * K[a];
            any |= G[a] != zero;
        }
        on &= any;
        if (!FSL_ANY(&on)) continue;
        {                                             /* Kv = K v + C a: fs_point_bias */
            FSL_V ab[3] = {zero, zero, zero};
            int bias = FSL_BIAS(w, c, OUT, Uv, stride, p, vp, ab);
            for (int a = 0; a < 3; a++) {
                Kv[a] = K[3 * a] * vp[0] + K[3 * a + 1] * vp[1] + K[3 * a + 2] * vp[2];
                if (bias) Kv[a] += Cs[3 * a] * ab[0] + Cs[3 * a + 1] * ab[1] + Cs[3 * a + 2] * ab[2];
            }
        }
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
        if (FSL_ALL(&on)) {                          /* every lane's contact pressed: no select */
            for (int a = 0; a < m; a++) {
                const FSL_V *ja = J + 3 * a;
                for (int k = 0; k < m; k++) {
                    const FSL_V *g = GJ + 3 * k;
                    A[cs[a * m + k]] += ja[0] * g[0] + ja[1] * g[1] + ja[2] * g[2];
                }
            }
            continue;
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
#undef FSL_E
#undef FSL_T
    /* fs_tree_lu over P; a lane that fails its test is marked (the others go on) */
    for (int k = 0; k < nu; k++) {
        FSL_V a = FSL_FABS(A[w->diag[k]]);
        scale = FSL_SEL(a > scale, a, scale);
    }
    fail |= ~FSL_FINITE(scale);
    lim = 64 * DBL_EPSILON * scale;
    for (int k = nu - 1; k >= 0; k--) {
        int na = P->start[k + 1] - P->start[k];
        FSL_V dk = A[w->diag[k]], inv, *row = (FSL_V *)w->R;
        const int *rk = up;                          /* the slots (k, a[y]) */
        int done2 = 0;
        fail |= ~(FSL_FABS(dk) > lim) | ~FSL_FINITE(dk);
        inv = one / dk;
        up += na;
        /* row k, unchanged by its own updates (they write rows a[x] < k), copied out once: the
         * updates then read it in order instead of through its slots (FSL_STEP overwrites R) */
        for (int y = 0; y < na; y++) row[y] = A[rk[y]];
        /* two rows a[x], a[x + 1] at once while every lane of both updates: row[y] loaded once for
         * both, one loop (rows' entries distinct, each the same operation: the same bits).
         * Measured with the N du lists and FSL_BIAS's lists (one process, switched call by call,
         * 64 rows, core 1, load 10-11): ant 0.980-0.983, humanoid 0.971 of the rollout's time;
         * four rows at once measured no better than two */
        for (int x = 0; x + 2 <= na; x += 2) {
            const int *u0 = up, *u1 = up + 1 + na;
            FSL_V v0 = A[u0[0]] * inv, v1 = A[u1[0]] * inv;
            FSL_VI nz = (v0 != zero) & (v1 != zero);
            if (!FSL_ALL(&nz)) break;
            for (int y = 0; y < na; y++) {
                const FSL_V r = row[y];
                A[u0[1 + y]] -= v0 * r;
                A[u1[1 + y]] -= v1 * r;
            }
            A[u0[0]] = v0;
            A[u1[0]] = v1;
            up += 2 * (1 + na);
            done2 = x + 2;
        }
        for (int x = done2; x < na; x++) {           /* the rest, one row at a time */
            const int *ri = up + 1;                  /* (a[x], k), then (a[x], a[y]) */
            FSL_V u = A[up[0]] * inv;
            FSL_VI nz = u != zero;
            if (FSL_ALL(&nz)) {                      /* every lane updates (the common case) */
                for (int y = 0; y < na; y++) A[ri[y]] -= u * row[y];
            } else if (FSL_ANY(&nz)) {
                for (int y = 0; y < na; y++) {
                    FSL_V a = A[ri[y]], d = a - u * row[y];
                    A[ri[y]] = FSL_SEL(nz, d, a);
                }
            }
            A[up[0]] = u;
            up += 1 + na;
        }
        for (int y = 0; y < na; y++) A[rk[y]] = row[y] * inv;
    }
    {   /* the lanes' answers; A and b stay here (the row's next try at h takes du1 and v1, a try at
           another h assembles its own: measured on G1, writing them out was a tenth of this kernel) */
        const FSL_V *D = (const FSL_V *)w->D, *V = (const FSL_V *)w->V;
        FSL_V ratio = zero;
        FSL_STEP(w, P, OUT, stride, h, A, b, du, &ratio);
        for (int l = 0; l < FSL_W; l++) {
            eomc_fs_request *q = req[l];
            int ok = !fail[l] && !((w->test_fail >> l) & 1u);
            if (q == NULL) continue;
            q->done = q->ahead = ok;
            if (!ok) continue;
            q->ntouch = ntl[l];
            q->ratio = isfinite(ratio[l]) ? ratio[l] : INFINITY;
            for (int i = 0; i < nu; i++) ahead[l][i] = D[i][l];
            for (int i = 0; i < w->nq; i++) ahead[l][nu + i] = V[i][l];
            q->du1 = ahead[l];
            q->v1 = ahead[l] + nu;
        }
    }
}

#undef FSL_KERNEL
#undef FSL_STEP
#undef FSL_GATHER
#undef FSL_BIAS
#undef FSL_SOLVE
#undef FSL_SOLVE2
#undef FSL_SECANT
#undef FSL_SQRT
#undef FSL_ANY
#undef FSL_ALL
#undef FSL_VI
#undef FSL_V
#undef FSL_SEL
#undef FSL_FABS
#undef FSL_FINITE
#undef FSL_CAT
#undef FSL_CAT2
