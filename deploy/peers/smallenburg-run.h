/* What both main()s of the peer (smallenburg-main.c, smallenburg-file-main.c) do once its
 * parameters are set: #included after its patched source, whose globals and init()/step() this
 * uses.
 *
 * The run happens in a temporary folder (the peer writes a pressure file every time unit),
 * removed at the end: init(), a warm-up until time `warmup` (negative: none), then the measured
 * run until maxtime. Prints, as its last line, {"tau_c_us", "tau_c_wall_us", "collisions",
 * "pressure", "z", "init_s", "run_s"}: tau_c_us is the CPU time of the event loop alone per
 * collision (as our EDMD's CPU tau_c), the initial state and the warm-up excluded and reported
 * as init_s. */
static int measured_run(double warmup)
{
    char dir[] = "/tmp/md-single.XXXXXX";
    if (!mkdtemp(dir) || chdir(dir) != 0)
    {
        perror("temporary folder");
        return 3;
    }
    double w0 = now_s(CLOCK_MONOTONIC);
    init();
    while (simtime <= warmup) step();
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
    printf("{\"tau_c_us\": %.6f, \"tau_c_wall_us\": %.6f, \"collisions\": %u, \"pressure\": %.6f, "
           "\"z\": %.6f, \"init_s\": %.6f, \"run_s\": %.6f}\n",
           1e6 * (c2 - c1) / ran, 1e6 * (w2 - w1) / ran, ran, pressure, pressure / (N / volume),
           w1 - w0, w2 - w1);
    return 0;
}
