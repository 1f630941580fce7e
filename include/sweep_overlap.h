/*
 * sweep_overlap.h: the ABI of overlap plugins for `sweep` (ABI version 1).
 *
 * A plugin is a shared library (`cc -O2 -shared -fPIC -o libmine.so mine.c`) named in a plan:
 *
 *     [[overlap]]
 *     plugins = ["plugins/libmine.so"]   # relative to the plan file's folder
 *
 * It is timed beside the built-in kernels exactly as they are (same configuration sets, same
 * blocks, visits and noise checks), called through a function pointer once per configuration,
 * after its verdicts were checked against Eq. 2 of Tonti & Patti decided exactly: a verdict that
 * differs where rounding cannot explain it fails the point, naming the configuration.
 *
 * Every configuration is given in the lab frame, as Algorithms 2-5 of the OCSI paper take it:
 *
 *   r_sc    the sphere centre relative to the cuboid centre, r_SC = r_S - r_C;
 *   axes    the cuboid's unit axes: axes[0] = e_T, axes[1] = e_L, axes[2] = e_W, each a row of
 *           three lab-frame components (r_SC . e_i is the projection on axis i);
 *   half    the cuboid's half extents along e_T, e_L, e_W: c_T, c_L, c_W (the cuboid is the set
 *           of points r_C + sum_i x_i e_i with |x_i| <= c_i);
 *   radius  the sphere's radius R.
 *
 * Return 1 when sphere and cuboid overlap or touch (d_min <= R, Eq. 2), 0 otherwise. The
 * pointers point into sweep's arrays (r_sc and axes are 12 consecutive values); read them, never
 * write them or keep them. A function must not keep state between calls.
 *
 * Export the name (it heads the plugin's column in Tables 1-2 and its panels in Figs. 2-3: 1 to
 * 40 letters, digits or '_', not the name of a built-in algorithm) and at least one precision. A
 * plan that asks a precision the plugin does not export is refused, naming the missing symbol.
 * sweep_overlap_abi is optional; when exported it must return SWEEP_OVERLAP_ABI.
 */
#ifndef SWEEP_OVERLAP_H
#define SWEEP_OVERLAP_H

#define SWEEP_OVERLAP_ABI 1

#ifdef __cplusplus
extern "C" {
#endif

const char *sweep_overlap_name(void);
int sweep_overlap_abi(void);
int sweep_overlap_f32(const float r_sc[3], const float axes[3][3], const float half[3], float radius);
int sweep_overlap_f64(const double r_sc[3], const double axes[3][3], const double half[3], double radius);

#ifdef __cplusplus
}
#endif

#endif
