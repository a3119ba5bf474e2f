/* A process that forks after a render and a dataset's load: the child loads and renders again,
 * as any program may, and must finish (the library's threads are not in the child, so it starts
 * its own: a 16-bit dataset's memory is made on them), and the parent renders on afterwards.
 * An alarm in each process turns a hang into a failure; the child ends by exec, so that under
 * valgrind only the parent's memory is checked. Prints one line per check and exits non-zero if
 * any fails. C89 (with POSIX); built and run by capi/tests/c_examples.rs, under valgrind by
 * capi/tests/memcheck.rs. */
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>
#include "checks.h"
#include <vlib.h>
#include <vlaux.h>

static void on_alarm(int sig)
{
    (void)sig;
    fputs("FAIL a render did not finish\n", stdout);
    fflush(stdout);
    _exit(2);
}

/* A 64×32×32 16-bit .vlb (a = 0, b = 65535): the 28-byte header of docs/compat.md, then more
   voxels than the library fills on one thread. */
static int write_vlb16(const char *path)
{
    unsigned char h[28];
    unsigned long i;
    int ok;
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    vlb_header(h, 64, 32, 32, 2, 0.0f, 65535.0f);
    ok = fwrite(h, 1, sizeof h, f) == sizeof h;
    for (i = 0; i < 64UL * 32 * 32; i++) {
        fputc((int)(i & 0xff), f);
        fputc((int)((i >> 8) & 0xff), f);
    }
    ok = ok && !ferror(f);
    return fclose(f) == 0 && ok;
}

/* A 64×64 image of a sphere: large enough to run on the library's threads. */
static int render(const char *path)
{
    vlScene();
    vlImage(path, 1.0, 64, 64);
    vlAmbient(1.0, 1.0, 1.0, 1.0);
    vlObject();
    vlScale(100.0, 100.0, 100.0);
    vlFunction(VL_O | VL_R | VL_G | VL_B, VLU_SPHERE, NULL);
    vlEnd();
    vlEnd();
    return vlError() == VL_NOERROR && access(path, F_OK) == 0;
}

int main(void)
{
    pid_t child;
    int status = 0;
    signal(SIGALRM, on_alarm);
    alarm(120);
    check("wrote a 16-bit dataset", write_vlb16("fork16.vlb"));
    vlInit();
    vlLoad(1, "fork16.vlb");
    check("the parent loads a 16-bit dataset before the fork", vlError() == VL_NOERROR);
    check("the parent renders before the fork", render("before.ppm"));
    child = fork();
    if (child == 0) {
        int ok;
        alarm(60);
        vlLoad(2, "fork16.vlb");
        ok = vlError() == VL_NOERROR && render("child.ppm");
        vlEnd();
        /* The child reports by the status of a program it becomes: ending by exec, it leaves
           nothing for a memory checker to count of the parent's threads, whose bookkeeping it
           inherited but whose threads it does not have. */
        execl("/bin/sh", "sh", "-c", ok ? "exit 0" : "exit 1", (char *)0);
        _exit(3);
    }
    check("fork", child > 0);
    if (child > 0) {
        check("waited for the child", waitpid(child, &status, 0) == child);
        check("the child rendered and exited 0", WIFEXITED(status) && WEXITSTATUS(status) == 0);
    }
    check("the parent renders after the fork", render("after.ppm"));
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
