/* A wrong plugin for the tests: it says every pair overlaps. */
#include "sweep_overlap.h"

const char *sweep_overlap_name(void) { return "always_overlap"; }

int sweep_overlap_f32(const float r_sc[3], const float axes[3][3], const float half[3], float radius)
{
    (void)r_sc; (void)axes; (void)half; (void)radius;
    return 1;
}

int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius)
{
    (void)r_sc; (void)axes; (void)half; (void)radius;
    return 1;
}
