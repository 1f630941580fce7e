/* A plugin for the tests with one precision only: OCSI in f64, no sweep_overlap_f32. */
#include "sweep_overlap.h"

const char *sweep_overlap_name(void) { return "f64_only"; }

int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius)
{
    double d = 0.0;
    for (int i = 0; i < 3; i++) {
        double a = r_sc[0] * axes[i][0] + r_sc[1] * axes[i][1] + r_sc[2] * axes[i][2];
        double s = (a < 0.0 ? -a : a) - half[i];
        s = s > 0.0 ? s : 0.0;
        d += s * s;
    }
    return d <= radius * radius;
}
