/* A render whose threads cannot be started fails, and the next one recovers (issue #24, item 6:
 * the library owns its thread pool, so a failure to build it is not kept). With 256 rendering
 * threads asked for (RAYON_NUM_THREADS) and an address-space soft limit 64 MiB above what the
 * process has mapped (setrlimit(RLIMIT_AS)), the first render cannot map the threads' stacks:
 * its vlEnd reports VL_NOMEMORY and writes nothing. With the limit restored, the next render
 * starts its threads and writes its image. Prints one line per check and exits non-zero if any
 * fails. C89 (with POSIX); built and run by capi/tests/nomemory.rs and c_examples.rs, never
 * under valgrind (which does not run under an address-space limit: see memcheck.rs). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include "checks.h"
#include <vlaux.h>
#include <vlib.h>

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
    setenv("RAYON_NUM_THREADS", "256", 1);
    vlInit();
    check("getrlimit(RLIMIT_AS)", getrlimit(RLIMIT_AS, &saved) == 0);
    lim = saved;
    lim.rlim_cur = (rlim_t)(mapped_bytes() + 64.0 * 1024 * 1024);
    check("the address space is known", mapped_bytes() > 0.0);
    check("setrlimit(RLIMIT_AS) to 64 MiB above it", setrlimit(RLIMIT_AS, &lim) == 0);
    render("first.ppm");
    e = vlError();
    check("a render whose 256 threads cannot start reports VL_NOMEMORY", e == VL_NOMEMORY);
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
