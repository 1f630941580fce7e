/*
 * Arvo's test (Algorithm 1 of Tonti & Patti) as an overlap plugin of sweep, written from the
 * paper, for a randomly oriented cuboid: the sphere centre is first moved into the cuboid frame
 * (r_S,i = r_SC . e_i, the cuboid centred at the origin, so B_i = [-c_i, c_i]), then the
 * axis-aligned test runs as Algorithm 1 writes it, branches included.
 *
 *     cc -O2 -ffinite-math-only -fno-signed-zeros -shared -fPIC -I include \\
 *        -o libc_arvo.so plugins/example/arvo.c
 *
 * (the flags of the OCSI example, for a like-for-like comparison)
 */
#include "sweep_overlap.h"

const char *sweep_overlap_name(void) { return "c_arvo"; }

int sweep_overlap_abi(void) { return SWEEP_OVERLAP_ABI; }

int sweep_overlap_f32(const float r_sc[3], const float axes[3][3], const float half[3], float radius)
{
    float d = 0.0f;
    for (int i = 0; i < 3; i++) {
        float r_s = r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2];
        float inf = -half[i], sup = half[i];
        if (r_s < inf) {
            d += (inf - r_s) * (inf - r_s);
        } else if (r_s > sup) {
            d += (r_s - sup) * (r_s - sup);
        }
    }
    return d <= radius * radius;
}

int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius)
{
    double d = 0.0;
    for (int i = 0; i < 3; i++) {
        double r_s = r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2];
        double inf = -half[i], sup = half[i];
        if (r_s < inf) {
            d += (inf - r_s) * (inf - r_s);
        } else if (r_s > sup) {
            d += (r_s - sup) * (r_s - sup);
        }
    }
    return d <= radius * radius;
}
