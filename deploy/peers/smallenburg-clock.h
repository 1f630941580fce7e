/* What both main()s of the peer (smallenburg-main.c, smallenburg-file-main.c) need before they
 * #include its patched source: the clocks, the declarations <unistd.h> would give (it cannot be
 * included: the peer declares a write() of its own), and the seed its init() reads. */
#define _GNU_SOURCE
#include <time.h>

int chdir(const char* path);
char* realpath(const char* path, char* resolved);

unsigned long sweep_seed = 1;

static double now_s(clockid_t clock)
{
    struct timespec t;
    clock_gettime(clock, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}
