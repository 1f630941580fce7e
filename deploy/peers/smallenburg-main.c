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
 * Prints, as its last line, {"tau_c_us", "tau_c_wall_us", "collisions", "pressure", "z",
 * "init_s", "run_s"}: tau_c_us is the CPU time of the event loop alone per collision (as our
 * EDMD's CPU tau_c), the initial state (FCC, random velocities, lists) excluded and reported as
 * init_s. The peer writes a pressure file every time unit: the run happens in a temporary
 * folder, removed at the end.
 */
#include "smallenburg-clock.h"
#include "mdSingle.c"

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

    char dir[] = "/tmp/md-single.XXXXXX";
    if (!mkdtemp(dir) || chdir(dir) != 0)
    {
        perror("temporary folder");
        return 3;
    }

    double w0 = now_s(CLOCK_MONOTONIC), c0 = now_s(CLOCK_PROCESS_CPUTIME_ID);
    init();
    double w1 = now_s(CLOCK_MONOTONIC), c1 = now_s(CLOCK_PROCESS_CPUTIME_ID);
    unsigned int before = colcounter;
    double dvbefore = dvtot, tbefore = simtime;
    while (simtime <= maxtime) step();
    double w2 = now_s(CLOCK_MONOTONIC), c2 = now_s(CLOCK_PROCESS_CPUTIME_ID);
    unsigned int ran = colcounter - before;

    double volume = xsize * ysize * zsize;
    double pressure = N / volume - (dvtot - dvbefore) / (3.0 * volume * (simtime - tbefore));
    char command[64];
    snprintf(command, sizeof command, "rm -rf %s", dir);
    if (chdir("/") != 0 || system(command) != 0) fprintf(stderr, "could not remove %s\n", dir);
    (void)w0;
    (void)c0;
    printf("{\"tau_c_us\": %.6f, \"tau_c_wall_us\": %.6f, \"collisions\": %u, \"pressure\": %.6f, "
           "\"z\": %.6f, \"init_s\": %.6f, \"run_s\": %.6f}\n",
           1e6 * (c2 - c1) / ran, 1e6 * (w2 - w1) / ran, ran, pressure, pressure / (N / volume),
           w1 - w0, w2 - w1);
    return 0;
}
