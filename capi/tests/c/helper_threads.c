/* A field function that starts a thread and waits for it, as OpenMP or a worker pool inside a
 * field function would: the helper thread calls vlSample (legal anywhere) and vlSet (legal only
 * in the sample scope of the calling thread, which a helper thread is not in) while the scene's
 * vlEnd is rendering. Neither may wait for the render: vlSample returns the dataset's value
 * (that of the scene being rendered), vlSet is refused with VL_BADSCOPE. An alarm turns a
 * deadlock into a failure. Prints one line per check and exits non-zero if any fails. C89
 * (with POSIX threads); built and run by capi/tests/c_examples.rs, under valgrind by
 * capi/tests/memcheck.rs. */
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>
#include <vlib.h>

static int failures = 0;

/* Set by the first field function call that runs the helper (a benign race: the helper may
   run a few times, each storing the same values). */
static volatile int helped = 0;
static volatile float helper_sample = -1.0f;

static void check(const char *what, int ok)
{
    printf("%-4s %s\n", ok ? "ok" : "FAIL", what);
    if (!ok)
        failures++;
}

static void *helper(void *arg)
{
    (void)arg;
    helper_sample = vlSample(1, 0.5f, 0.5f, 0.5f);
    vlSet(VL_R, 0.5f);
    return NULL;
}

static void field(vlvector p, void *misc)
{
    pthread_t t;
    (void)misc;
    if (!helped) {
        helped = 1;
        if (pthread_create(&t, NULL, helper, NULL) == 0)
            pthread_join(t, NULL);
    }
    vlSet(VL_O, p[0] > 0.5f ? 0.5f : 0.0f);
}

/* A 2×2×2 8-bit dataset, every voxel 204, normalised by a = 0, b = 255: 0.8 everywhere. */
static int write_dataset(const char *path)
{
    unsigned int header[4] = {2, 2, 2, 1};
    float ab[2] = {0.0f, 255.0f};
    unsigned char voxels[8] = {204, 204, 204, 204, 204, 204, 204, 204};
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite("VLB1", 1, 4, f);
    fwrite(header, 4, 4, f);
    fwrite(ab, 4, 2, f);
    fwrite(voxels, 1, 8, f);
    return fclose(f) == 0;
}

static void on_alarm(int sig)
{
    (void)sig;
    fputs("FAIL the render did not finish: a helper thread waited for it\n", stdout);
    fflush(stdout);
    _exit(2);
}

int main(void)
{
    vlint err, bad_scope = 0, others = 0;
    signal(SIGALRM, on_alarm);
    alarm(120);
    check("dataset written", write_dataset("helper.vlb"));
    vlInit();
    vlLoad(1, "helper.vlb");
    check("vlSample before the render is 0.8", vlSample(1, 0.5f, 0.5f, 0.5f) > 0.799f);
    vlScene();
    vlImage("helper.ppm", 1.0, 16, 16);
    vlObject();
    vlScale(10.0, 10.0, 10.0);
    vlFunction(VL_O, field, NULL);
    vlEnd();
    vlEnd(); /* renders: the helper runs inside it */
    check("the field function ran its helper", helped);
    check("vlSample from the helper read the dataset", helper_sample > 0.799f
          && helper_sample < 0.801f);
    while ((err = vlError()) != VL_NOERROR) {
        if (err == VL_BADSCOPE)
            bad_scope++;
        else
            others++;
    }
    check("vlSet from the helper was refused with VL_BADSCOPE", bad_scope >= 1);
    check("no other error", others == 0);
    check("the image was written", access("helper.ppm", F_OK) == 0);
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
