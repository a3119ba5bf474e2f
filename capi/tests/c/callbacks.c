/* Callbacks as new code writes them: each of the field, spatial, normal and progress functions
 * below has exactly the type of its command's parameter, and the program must compile clean
 * with -std=c99 -pedantic -Wall -Wextra -Werror (and as C89) with every compiler, whether the
 * header's legacy-callback macros are on (the default) or off (-DVL_NO_LEGACY_CASTS). It calls
 * vlFunction in the three ways C allows: through the macro, with the name parenthesised (which
 * bypasses it) and through a pointer taken with &vlFunction; vlSpatial and vlNormal through the
 * macro and parenthesised.
 *
 * Each scene renders a 16 x 16 PPM of the unit cube (centred, camera on the -z axis, a point
 * light at the camera) whose field function makes the half p[0] < 0.5 opaque, white, with
 * F = p[2] (so the normal -grad F faces the camera and the light). Checks, from the pixels:
 *  - plain.ppm: opaque pixels on one side of the middle only, lit: the front face, 2.5 units
 *    from the light, sees it within 16 degrees of its normal, so ka + kd N.L >= 0.97 (247);
 *  - mirror.ppm (a spatial function p[0] -> 1 - p[0]): the same count on the other side;
 *  - away.ppm (a normal function negating n): the same pixels, lit by the ambient term only
 *    (ka = 0.25: 64 of 255);
 *  - the progress function saw fractions ending at 1.
 * Prints one line per check, exits non-zero if any fails. Built and run by
 * capi/tests/c_examples.rs; compiled by every compiler by capi/tests/compilers.rs. */
#include <stdio.h>
#include "checks.h"
#include <vlib.h>
#include <vlaux.h>

#define SIZE 16
#define KA 0.25f

static int progress_calls = 0;
static vlfloat progress_last = -1.0f;

static void half(vlfloat *p, void *misc)
{
    (void)misc;
    vlSet(VL_O, p[0] < 0.5f ? 1.0f : 0.0f);
    vlSet(VL_F, p[2]);
    vlSet(VL_COLORS, 1.0f);
}

static void mirror(vlfloat *p, void *misc)
{
    (void)misc;
    p[0] = 1.0f - p[0];
}

static void away(vlfloat *n, vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    n[0] = -n[0];
    n[1] = -n[1];
    n[2] = -n[2];
}

/* Called one call at a time, and vlEnd waits for the render: no lock needed. */
static vlint progress(vlfloat done, void *misc)
{
    (void)misc;
    progress_calls++;
    progress_last = done;
    return 1;
}

/* How a scene registers its functions. */
enum form { MACRO, PARENTHESISED, POINTER };

/* Renders `path`: the half cube, with the spatial function `spatial` and the normal function
   `normal` when not NULL, registered in the given form. */
static void scene(const char *path, enum form how, void (*spatial)(vlfloat *, void *),
                  void (*normal)(vlfloat *, vlfloat *, void *))
{
    void (*function)(vlint, void (*)(vlfloat *, void *), void *) = &vlFunction;
    VLCAMERA cam = {{0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 40.0f};
    vlScene();
    vlCamera(&cam);
    vlImage(path, 1.0f, SIZE, SIZE);
    vlBackground(BLACK);
    vlAmbient(WHITE, 1.0f);
    vlPointLight(0.0f, 0.0f, -3.0f, VL_NOATTENUATION, WHITE, 1.0f);
    vlStepSize(0.02f, 0.02f);
    vlObject();
    vlTranslate(-0.5f, -0.5f, -0.5f);
    if (spatial != NULL) {
        if (how == MACRO)
            vlSpatial(spatial, NULL);
        else
            (vlSpatial)(spatial, NULL);
    }
    if (how == MACRO)
        vlFunction(VL_O | VL_F | VL_COLORS, half, NULL);
    else if (how == PARENTHESISED)
        (vlFunction)(VL_O | VL_F | VL_COLORS, half, NULL);
    else
        function(VL_O | VL_F | VL_COLORS, half, NULL);
    vlSet(VL_KA, KA);
    vlSet(VL_KD, 1.0f - KA);
    if (normal != NULL) {
        if (how == MACRO)
            vlNormal(normal, NULL);
        else
            (vlNormal)(normal, NULL);
    }
    vlEnd();
    vlEnd();
}

/* Counts the pixels of `path` with a red value of at least 16 in the left and right halves,
   and the brightest and darkest of them; returns 0 if the file is unreadable. */
static int count(const char *path, int *left, int *right, int *low, int *high)
{
    int x, y, r;
    *left = *right = 0;
    *low = 255;
    *high = 0;
    for (y = 0; y < SIZE; y++)
        for (x = 0; x < SIZE; x++) {
            r = ppm_red(path, SIZE, x, y);
            if (r < 0)
                return 0;
            if (r < 16)
                continue;
            if (x < SIZE / 2)
                (*left)++;
            else
                (*right)++;
            if (r < *low)
                *low = r;
            if (r > *high)
                *high = r;
        }
    return 1;
}

int main(void)
{
    int l0, r0, lo0, hi0, l1, r1, lo1, hi1, l2, r2, lo2, hi2, e;
    int ambient = (int)(KA * 255.0f + 0.5f);
    char line[200];

    vlInit();
    vlProgress(progress, NULL);
    scene("plain.ppm", MACRO, NULL, NULL);
    scene("mirror.ppm", PARENTHESISED, mirror, NULL);
    scene("away.ppm", POINTER, NULL, away);
    vlEnd();
    e = vlError();
    sprintf(line, "three scenes rendered without error (%d)", e);
    check(line, e == VL_NOERROR);

    check("plain.ppm read", count("plain.ppm", &l0, &r0, &lo0, &hi0));
    sprintf(line, "plain: %d pixels left, %d right: one side only, lit (%d ... %d)", l0, r0,
            lo0, hi0);
    check(line, (l0 == 0) != (r0 == 0) && l0 + r0 >= 20 && lo0 >= 246);

    check("mirror.ppm read", count("mirror.ppm", &l1, &r1, &lo1, &hi1));
    sprintf(line, "mirror: %d pixels left, %d right: plain's, swapped", l1, r1);
    check(line, l1 == r0 && r1 == l0);

    check("away.ppm read", count("away.ppm", &l2, &r2, &lo2, &hi2));
    sprintf(line, "away: %d pixels left, %d right, %d ... %d: ambient only (%d)", l2, r2, lo2,
            hi2, ambient);
    check(line, l2 == l0 && r2 == r0 && lo2 >= ambient - 1 && hi2 <= ambient + 1);

    sprintf(line, "progress: %d call(s), last %g", progress_calls, (double)progress_last);
    check(line, progress_calls >= 3 && progress_last == 1.0f);

    printf("%d failure(s)\n", failures);
    return failures == 0 ? 0 : 1;
}
