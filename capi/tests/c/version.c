/* The version of the header and of the library (docs/extensions.md, "Version"): VLIB_VERSION is
 * VLIB_VERSION_MAJOR * 1000000 + VLIB_VERSION_MINOR * 1000 + VLIB_VERSION_PATCH, in the
 * preprocessor (#if) as in C, with minor and patch below 1000; vlVersion() returns it (the
 * program runs with the library of its header) before vlInit, at library scope, with an
 * error queued (which it neither takes nor adds to), from a field function and a progress
 * function while a scene renders, from another thread, and after the final vlEnd, and never
 * records an error. Prints one line per check and exits non-zero if any fails. C89 (with
 * POSIX threads); built and run by capi/tests/c_examples.rs (version_program_passes), by
 * capi/tests/compilers.rs with every compiler, and under valgrind by capi/tests/memcheck.rs. */
#include <pthread.h>
#include <stdio.h>
#include "checks.h"
#include <vlib.h>

#if !defined(VLIB_VERSION) || !defined(VLIB_VERSION_MAJOR) || !defined(VLIB_VERSION_MINOR) || \
    !defined(VLIB_VERSION_PATCH)
#error "vlib.h defines the four version macros"
#endif
#if VLIB_VERSION != VLIB_VERSION_MAJOR * 1000000L + VLIB_VERSION_MINOR * 1000L + VLIB_VERSION_PATCH
#error "VLIB_VERSION is the encoding of the other three"
#endif

/* Set by the field and progress functions: 1 while every call saw VLIB_VERSION, 0 after one
   that did not; the calls counted. (Field functions run on several threads: each stores the
   same values, and only a wrong answer stores 0.) */
static volatile int field_ok = 1, progress_ok = 1;
static volatile int field_calls = 0, progress_calls = 0;

static void field(vlfloat *p, void *misc)
{
    (void)misc;
    if (vlVersion() != VLIB_VERSION)
        field_ok = 0;
    field_calls = 1;
    vlSet(VL_F, 0.25f - ((p[0] - 0.5f) * (p[0] - 0.5f) + (p[1] - 0.5f) * (p[1] - 0.5f) +
                         (p[2] - 0.5f) * (p[2] - 0.5f)));
}

static vlint progress(vlfloat done, void *misc)
{
    (void)done;
    (void)misc;
    if (vlVersion() != VLIB_VERSION)
        progress_ok = 0;
    progress_calls = 1;
    return 1;
}

static void *other_thread(void *result)
{
    *(vlint *)result = vlVersion();
    return NULL;
}

int main(void)
{
    long encoded = VLIB_VERSION_MAJOR * 1000000L + VLIB_VERSION_MINOR * 1000L + VLIB_VERSION_PATCH;
    vlint from_thread = -1;
    pthread_t thread;
    printf("vlib.h %d.%d.%d (%d), the library %d\n", VLIB_VERSION_MAJOR, VLIB_VERSION_MINOR,
           VLIB_VERSION_PATCH, VLIB_VERSION, (int)vlVersion());
    check("VLIB_VERSION is MAJOR * 1000000 + MINOR * 1000 + PATCH", VLIB_VERSION == encoded);
    check("MAJOR, MINOR and PATCH are from 0, MINOR and PATCH below 1000",
          VLIB_VERSION_MAJOR >= 0 && VLIB_VERSION_MINOR >= 0 && VLIB_VERSION_MINOR < 1000 &&
              VLIB_VERSION_PATCH >= 0 && VLIB_VERSION_PATCH < 1000);
    check("VLIB_VERSION decodes to the three",
          VLIB_VERSION / 1000000 == VLIB_VERSION_MAJOR &&
              VLIB_VERSION / 1000 % 1000 == VLIB_VERSION_MINOR &&
              VLIB_VERSION % 1000 == VLIB_VERSION_PATCH);

    check("before vlInit, vlVersion() == VLIB_VERSION", vlVersion() == VLIB_VERSION);
    check("and it records no error", vlError() == VL_NOERROR);

    vlInit();
    check("at library scope, vlVersion() == VLIB_VERSION", vlVersion() == VLIB_VERSION);
    check("and it records no error", vlError() == VL_NOERROR);

    vlInit(); /* already running: VL_BADSCOPE, queued */
    check("with an error queued, vlVersion() == VLIB_VERSION", vlVersion() == VLIB_VERSION);
    check("from another thread, vlVersion() == VLIB_VERSION",
          pthread_create(&thread, NULL, other_thread, &from_thread) == 0 &&
              pthread_join(thread, NULL) == 0 && from_thread == VLIB_VERSION);
    check("the queued error is still there", vlError() == VL_BADSCOPE);
    check("and nothing else", vlError() == VL_NOERROR);

    vlProgress(progress, NULL);
    vlScene();
    vlImage("version.ppm", 1.0f, 16, 16);
    vlObject();
    vlFunction(VL_F, field, NULL);
    vlSet(VL_O | VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
    check("the scene renders without an error", vlError() == VL_NOERROR);
    check("in the field functions, vlVersion() == VLIB_VERSION", field_calls && field_ok);
    check("in the progress function, vlVersion() == VLIB_VERSION", progress_calls && progress_ok);

    vlEnd();
    check("after the final vlEnd, vlVersion() == VLIB_VERSION", vlVersion() == VLIB_VERSION);
    check("and no error was recorded", vlError() == VL_NOERROR);
    remove("version.ppm");
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
