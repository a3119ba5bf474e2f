/* Bounded work and cancellation through the C interface (issue #24, items 1 and 2):
 *  - two facing mirrors at vlRecursion(64) render, and the middle pixel is the closed form
 *    (64 + 1) * a (each bounce adds the mirror's ambient colour a, KS = 1);
 *  - a step of 1e-9 through a 100-unit object is refused with VL_BADVALUE, no file written;
 *  - vlProgress: the function sees increasing fractions ending at 1; returning 0 cancels
 *    (VL_CANCELLED, no file, no temporary left); inside it, commands other than vlCancel,
 *    vlSample, vlError, vlErrorString are refused with VL_BADSCOPE and the render goes on;
 *  - vlCancel from a field function, and from another thread while a render that would take
 *    many minutes runs: VL_CANCELLED, no file; vlCancel with no render: nothing;
 *  - vlProgress outside library and scene scope: VL_BADSCOPE.
 * An alarm turns a hang into a failure. Prints one line per check, exits non-zero if any
 * fails. C89 with POSIX threads; argv[1] is the image width (default 64; valgrind runs it at
 * 32). Built and run by capi/tests/c_examples.rs, under valgrind by capi/tests/memcheck.rs. */
#include <dirent.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "checks.h"
#include <vlib.h>

/* ---- Facing mirrors ---- */

#define MIRROR_A 0.012f

static void mirrors(int width, const char *file, vlint depth)
{
    VLCAMERA cam = {{0.0f, 0.0f, -50.0f}, {0.0f, 0.0f, 100.0f}, {0.0f, 1.0f, 0.0f}, 1.0f};
    int i;
    vlScene();
    vlImage(file, 1.0f, width, width);
    vlCamera(&cam);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5f);
    vlStepSize(1.0f, 1.0f);
    vlRecursion(depth);
    vlToggle(VL_RECEIVEREFLECTIONS, VL_TRUE);
    vlToggle(VL_CASTREFLECTIONS, VL_TRUE);
    for (i = 0; i < 2; i++) {
        vlObject();
        vlTranslate(-0.5f, -0.5f, 0.0f);
        vlScale(1000.0f, 1000.0f, 4.0f);
        vlTranslate(0.0f, 0.0f, i == 0 ? 100.0f : -104.0f);
        vlSet(VL_F | VL_O | VL_KA | VL_KS, 1.0f);
        vlSet(VL_COLORS, MIRROR_A);
        vlEnd();
    }
    vlEnd();
}

/* ---- Progress ---- */

static int progress_calls = 0, progress_stop_at = 0, progress_rising = 1;
static float progress_last = -1.0f;
static vlint progress_scope_error = VL_NOERROR;

static vlint progress(vlfloat done, void *misc)
{
    (void)misc;
    if (done < progress_last || done < 0.0f || done > 1.0f)
        progress_rising = 0;
    progress_last = done;
    progress_calls++;
    if (progress_calls == 1) {
        vlScene(); /* illegal while the scene renders */
        progress_scope_error = vlError();
    }
    return progress_stop_at == 0 || progress_calls < progress_stop_at;
}

/* A scene of one object whose field function is `f`, at step `step`, the object scaled by
   `size`, writing `file` at `width` x `width`. */
static void scene_with(const char *file, int width, void (*f)(vlvector, void *), float step,
                       float size)
{
    vlScene();
    vlImage(file, 1.0f, width, width);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlStepSize(step, 1.0f);
    vlObject();
    vlTranslate(-0.5f, -0.5f, -0.5f);
    vlScale(size, size, size);
    vlFunction(VL_ALLFIELDS, f, NULL);
    vlEnd();
    vlEnd();
}

static void ball(vlvector p, void *misc)
{
    float x = p[0] - 0.5f, y = p[1] - 0.5f, z = p[2] - 0.5f;
    (void)misc;
    vlSet(VL_O, x * x + y * y + z * z < 0.16f ? 0.05f : 0.0f);
    vlSet(VL_COLORS | VL_KA, 1.0f);
}

/* ---- vlCancel ---- */

static volatile int field_calls = 0;

static void cancelling(vlvector p, void *misc)
{
    (void)p;
    (void)misc;
    field_calls++;
    vlCancel();
    vlSet(VL_O, 0.01f);
}

static volatile int render_started = 0;

static void slow(vlvector p, void *misc)
{
    (void)misc;
    render_started = 1;
    vlSet(VL_O, p[2] * 1e-4f);
    vlSet(VL_COLORS | VL_KA, 1.0f);
}

static void *canceller(void *arg)
{
    (void)arg;
    while (!render_started)
        usleep(1000);
    usleep(20000);
    vlCancel();
    return NULL;
}

int main(int argc, char **argv)
{
    int width = argc > 1 ? atoi(argv[1]) : 64;
    int red, want;
    vlint e;
    pthread_t t;
    char line[160];
    alarm(120);
    if (width < 8) {
        printf("usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }

    vlProgress(progress, NULL);
    check("vlProgress before vlInit is VL_BADSCOPE", vlError() == VL_BADSCOPE);
    vlCancel();
    check("vlCancel before vlInit does nothing", vlError() == VL_NOERROR);

    vlInit();
    /* 1. Facing mirrors, recursion 64: (64 + 1) * a in the middle. */
    mirrors(width, "mirrors.ppm", 64);
    e = vlError();
    red = ppm_red("mirrors.ppm", width, width / 2, width / 2);
    want = (int)(65.0f * MIRROR_A * 255.0f + 0.5f);
    sprintf(line, "facing mirrors at recursion 64 render (error %d), middle %d = 65 a = %d",
            (int)e, red, want);
    check(line, e == VL_NOERROR && red >= want - 1 && red <= want + 1);

    /* 2. An absurd step is refused before any pixel. */
    scene_with("absurd.ppm", width, ball, 1e-9f, 100.0f);
    check("a step of 1e-9 through 100 units is VL_BADVALUE",
          vlError() == VL_BADVALUE && !exists("absurd.ppm"));

    /* 3. Progress to 1; a scope error inside it; the render goes on. */
    vlCancel();
    check("vlCancel with no render does nothing", vlError() == VL_NOERROR);
    vlProgress(progress, NULL);
    scene_with("progress.ppm", width, ball, 0.01f, 1.0f);
    e = vlError();
    sprintf(line, "progress: %d call(s), rising, last %g, render error %d", progress_calls,
            (double)progress_last, (int)e);
    check(line, e == VL_NOERROR && progress_calls >= 1 && progress_rising &&
                    progress_last == 1.0f && exists("progress.ppm"));
    check("vlScene inside the progress function is VL_BADSCOPE",
          progress_scope_error == VL_BADSCOPE);

    /* 4. A progress function that returns 0 cancels: no file, no temporary. */
    progress_calls = 0;
    progress_stop_at = 1;
    scene_with("stopped.ppm", width * 4, ball, 0.01f, 1.0f);
    e = vlError();
    while (vlError() != VL_NOERROR) /* the scope error of the first call */
        ;
    sprintf(line, "progress returning 0 is VL_CANCELLED (%d), after one call (%d)", (int)e,
            progress_calls);
    check(line, e == VL_CANCELLED && progress_calls == 1 && !exists("stopped.ppm") &&
                    !temporaries_left());
    vlProgress(NULL, NULL);
    check("vlProgress(NULL) removes the function", vlError() == VL_NOERROR);

    /* 5. vlCancel from a field function. */
    scene_with("field.ppm", width, cancelling, 0.01f, 1.0f);
    e = vlError();
    check("vlCancel in a field function is VL_CANCELLED",
          e == VL_CANCELLED && field_calls > 0 && !exists("field.ppm") && !temporaries_left());

    /* 6. vlCancel from another thread, during a render of some 10^5 samples a ray. */
    if (pthread_create(&t, NULL, canceller, NULL) != 0) {
        check("start a thread", 0);
    } else {
        scene_with("slow.ppm", width, slow, 1e-5f, 1.0f);
        e = vlError();
        pthread_join(t, NULL);
        check("vlCancel from another thread is VL_CANCELLED",
              e == VL_CANCELLED && !exists("slow.ppm") && !temporaries_left());
    }

    /* 7. The next render is not cancelled. */
    mirrors(width, "again.ppm", 2);
    check("the next render completes", vlError() == VL_NOERROR && exists("again.ppm"));

    /* 8. vlProgress in an object is VL_BADSCOPE. */
    vlScene();
    vlObject();
    vlProgress(progress, NULL);
    check("vlProgress in an object is VL_BADSCOPE", vlError() == VL_BADSCOPE);
    vlEnd();
    vlEnd();
    vlEnd();
    while (vlError() != VL_NOERROR)
        ;
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
