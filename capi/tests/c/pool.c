/* A render whose threads cannot be started fails, and the next one recovers (issue #24, item 6:
 * the library owns its thread pool, so a failure to build it is not kept); before any render,
 * vlSample of a dataset's node values starts no pool (no thread is left running). With 256 rendering
 * threads asked for (RAYON_NUM_THREADS; the library starts at most four a core) and an
 * address-space soft limit 4 MiB above what the process has mapped (setrlimit(RLIMIT_AS)), the
 * first render cannot map a thread's stack (8 MiB): its vlEnd reports VL_NOMEMORY and writes
 * nothing. With the limit restored, the next render
 * starts its threads and writes its image. Prints one line per check and exits non-zero if any
 * fails. C89 (with POSIX); built and run by capi/tests/nomemory.rs and c_examples.rs, never
 * under valgrind (which does not run under an address-space limit: see memcheck.rs). */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include "checks.h"
#include <vlaux.h>
#include <vlib.h>

/* The threads of this process now (the entries of /proc/self/task); -1 if unknown. */
static int threads_now(void)
{
    int n = 0;
    struct dirent *d;
    DIR *dir = opendir("/proc/self/task");
    if (!dir)
        return -1;
    while ((d = readdir(dir)) != NULL)
        if (d->d_name[0] != '.')
            n++;
    closedir(dir);
    return n;
}

/* A .vlb of 4^3 one-byte voxels, voxel i of value i (a = 0, b = 255). */
static int small_vlb(const char *path)
{
    unsigned char b[28 + 64];
    FILE *f = fopen(path, "wb");
    int i, ok;
    vlb_header(b, 4, 4, 4, 1, 0.0f, 255.0f);
    for (i = 0; i < 64; i++)
        b[28 + i] = (unsigned char)i;
    if (!f)
        return 0;
    ok = fwrite(b, 1, sizeof b, f) == sizeof b;
    return fclose(f) == 0 && ok;
}

static void render(const char *path)
{
    vlScene();
    vlImage(path, 1.0f, 64, 64);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlObject();
    vlFunction(VL_O, VLU_SPHERE, NULL);
    vlSet(VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
}

int main(void)
{
    struct rlimit saved, lim;
    vlint e;
    int before;
    float v;
    setenv("RAYON_NUM_THREADS", "256", 1);
    vlInit();
    /* vlSample outside a render makes the dataset's node values (the nearest filter reads them)
     * on helper threads that end with the work: no pool is built for it, rayon's global one
     * (256 threads, kept for the process) least of all. */
    check("a 4^3 .vlb", small_vlb("small.vlb"));
    vlLoad(1, "small.vlb");
    remove("small.vlb");
    vlInterpolationType(VL_NEAREST);
    before = threads_now();
    v = vlSample(1, 0.0f, 0.0f, 0.0f);
    check("vlSample of node values", vlError() == VL_NOERROR && v == 0.0f);
    v = vlSample(1, 1.0f, 1.0f, 1.0f);
    check("at the last node", vlError() == VL_NOERROR && v == 63.0f / 255.0f);
    check("leaves no thread of its own running", before > 0 && threads_now() == before);
    vlInterpolationType(VL_TRILINEAR);
    check("getrlimit(RLIMIT_AS)", getrlimit(RLIMIT_AS, &saved) == 0);
    lim = saved;
    lim.rlim_cur = (rlim_t)(mapped_bytes() + 4.0 * 1024 * 1024);
    check("the address space is known", mapped_bytes() > 0.0);
    check("setrlimit(RLIMIT_AS) to 4 MiB above it", setrlimit(RLIMIT_AS, &lim) == 0);
    render("first.ppm");
    e = vlError();
    check("a render whose threads cannot start reports VL_NOMEMORY", e == VL_NOMEMORY);
    check("and writes nothing", !exists("first.ppm"));
    check("the limit restored", setrlimit(RLIMIT_AS, &saved) == 0);
    render("second.ppm");
    check("the next render starts its threads and completes",
          vlError() == VL_NOERROR && exists("second.ppm"));
    remove("second.ppm");
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
