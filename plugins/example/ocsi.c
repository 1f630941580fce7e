/*
 * OCSI (Algorithm 5 of Tonti & Patti) as an overlap plugin of sweep, written from the paper:
 * l_i = max(|r_SC . e_i| - c_i, 0)^2 for i in {T, L, W}, overlap iff l_T + l_L + l_W <= R^2.
 * The loop has no branch, so the compiler may vectorise the three axes (the paper's `omp simd`).
 *
 *     cc -O2 -shared -fPIC -I include -o libc_ocsi.so plugins/example/ocsi.c
 */
#include "sweep_overlap.h"

const char *sweep_overlap_name(void) { return "c_ocsi"; }

int sweep_overlap_abi(void) { return SWEEP_OVERLAP_ABI; }

int sweep_overlap_f32(const float r_sc[3], const float axes[3][3], const float half[3], float radius)
{
    float l[3];
    for (int i = 0; i < 3; i++) {
        float a = r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2];
        float s = (a < 0.0f ? -a : a) - half[i];
        s = s > 0.0f ? s : 0.0f;
        l[i] = s * s;
    }
    return l[0] + l[1] + l[2] <= radius * radius;
}

int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius)
{
    double l[3];
    for (int i = 0; i < 3; i++) {
        double a = r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2];
        double s = (a < 0.0 ? -a : a) - half[i];
        s = s > 0.0 ? s : 0.0;
        l[i] = s * s;
    }
    return l[0] + l[1] + l[2] <= radius * radius;
}
