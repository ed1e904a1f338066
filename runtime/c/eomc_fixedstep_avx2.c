/*
 * eomc_fixedstep_avx2.c -- eomc_fixedstep.c's scalar step compiled for CPUs with AVX2, as
 * eomc_fs_run_avx2; eomc_fs_run hands a run to it where the CPU has AVX2 (why, and why the bits
 * are the same: the note at EOMC_FS_AVX2 in eomc_fixedstep.c).  Only the step: the lanes' exports
 * and the work sizes stay in eomc_fixedstep.c's own build, so the copy's lanes helpers are unused.
 */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(EOMC_NO_FS_AVX2)
#define EOMC_FS_AVX2_COPY 1
#pragma GCC target("avx2")
#pragma GCC diagnostic ignored "-Wunused-function"
#include "eomc_fixedstep.c"
#else
typedef int eomc_fixedstep_avx2_unused;   /* ISO C: a translation unit declares something */
#endif
