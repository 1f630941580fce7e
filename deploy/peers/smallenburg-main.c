/* A main() for Smallenburg's hard-sphere EDMD ("Single" variant) as a `sweep` program job.
 *
 * Built by build-smallenburg.sh, which copies the peer's sources (never part of this repository)
 * into a build folder, renames their main() and makes init()'s seed ours, then compiles this
 * file, which #includes the patched mdSingle.c.
 *
 * usage: md-single N PHI COLLISIONS SEED
 *   N           4 x a cube (FCC start): 256, 2048, 16384, 131072 ...
 *   PHI         packing fraction
 *   COLLISIONS  about this many collisions: the run lasts COLLISIONS / (N 2 rho g(sigma) sqrt(pi))
 *               time units (kT = m = sigma = 1, g(sigma) = (Z - 1) / (4 phi) from Kolafa's Z)
 *   SEED        the Mersenne Twister's seed
 *
 * Prints, as its last line, what smallenburg-run.h says, the initial state (FCC, random
 * velocities, lists) excluded from tau_c and reported as init_s.
 */
#include "smallenburg-clock.h"
#include "mdSingle.c"
#include "smallenburg-run.h"

int main(int argc, char** argv)
{
    if (argc != 5)
    {
        fprintf(stderr, "usage: %s N PHI COLLISIONS SEED\n", argv[0]);
        return 2;
    }
    N = atoi(argv[1]);
    packfrac = atof(argv[2]);
    double collisions = atof(argv[3]);
    sweep_seed = strtoul(argv[4], NULL, 10);
    initialconfig = 1;
    double e = packfrac;
    double z = (1 + e + e * e - 2.0 / 3.0 * e * e * e * (1 + e)) / pow(1 - e, 3);
    double rho = 6 * e / M_PI;
    double g = (z - 1) / (4 * e);
    maxtime = collisions / (N * 2 * rho * g * sqrt(M_PI));
    return measured_run(-1.0);
}
