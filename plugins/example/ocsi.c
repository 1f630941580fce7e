/*
 * OCSI (Algorithm 5 of Tonti & Patti) as an overlap plugin of sweep, written from the paper:
 * l_i = max(|r_SC . e_i| - c_i, 0)^2 for i in {T, L, W}, overlap iff l_T + l_L + l_W <= R^2.
 * The loop has no branch, so the compiler may vectorise the three axes (the paper's `omp simd`).
 *
 *     cc -O2 -ffinite-math-only -fno-signed-zeros -shared -fPIC -I include \
 *        -o libc_ocsi.so plugins/example/ocsi.c
 *
 * The two flags let GCC turn max(x, 0) into one maxsd/maxss instead of a branch (whose
 * mispredictions on random signs would cost more than the test); neither changes a verdict for
 * finite inputs (the only ones sweep passes).
 */
#include <math.h>

#include "sweep_overlap.h"

const char *sweep_overlap_name(void) { return "c_ocsi"; }

int sweep_overlap_abi(void) { return SWEEP_OVERLAP_ABI; }

int sweep_overlap_f32(const float r_sc[3], const float axes[3][3], const float half[3], float radius)
{
    float l[3];
    for (int i = 0; i < 3; i++) {
        float s = fabsf(r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2]) - half[i];
        s = s > 0.0f ? s : 0.0f;
        l[i] = s * s;
    }
    return l[0] + l[1] + l[2] <= radius * radius;
}

int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius)
{
    double l[3];
    for (int i = 0; i < 3; i++) {
        double s = fabs(r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2]) - half[i];
        s = s > 0.0 ? s : 0.0;
        l[i] = s * s;
    }
    return l[0] + l[1] + l[2] <= radius * radius;
}
