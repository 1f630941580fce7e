/* A main() for Smallenburg's hard-sphere EDMD ("Single" variant) started from a configuration
 * file with radii (the peer's initialconfig = 0): polydisperse spheres and mixtures. Built by
 * build-smallenburg.sh beside smallenburg-main.c, from the same patched copy of the peer.
 *
 * usage: md-single-file INIT.sph WARMUP TIME SEED
 *   INIT.sph  the peer's format: N, then "Lx Ly Lz", then "a x y z radius" per sphere (the peer's
 *             cells are 1.5 long, so the largest diameter must not exceed 1)
 *   WARMUP    time run (with random velocities, kT = 1, unit masses) before measuring
 *   TIME      time measured
 *   SEED      the Mersenne Twister's seed
 *
 * Prints, as its last line, {"tau_c_us", "tau_c_wall_us", "collisions", "pressure", "z",
 * "init_s", "run_s"} over the measured time, as smallenburg-main.c does.
 */
#include "smallenburg-clock.h"
#include "mdSingle-file.c"
#include "smallenburg-run.h"

int main(int argc, char** argv)
{
    if (argc != 5)
    {
        fprintf(stderr, "usage: %s INIT.sph WARMUP TIME SEED\n", argv[0]);
        return 2;
    }
    char resolved[4096];
    if (!realpath(argv[1], resolved) || strlen(resolved) >= sizeof inputfilename)
    {
        fprintf(stderr, "%s: not found, or its absolute path is too long for the peer\n", argv[1]);
        return 2;
    }
    strcpy(inputfilename, resolved);
    double warmup = atof(argv[2]);
    double measured = atof(argv[3]);
    sweep_seed = strtoul(argv[4], NULL, 10);
    initialconfig = 0;
    maxtime = warmup + measured;
    return measured_run(warmup);
}
