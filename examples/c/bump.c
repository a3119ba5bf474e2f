/* Bump mapping: normals perturbed by a noise function (the paper's Figure 7(b), section 5.3).
 *
 * Two identical ivory balls, VLU_SPHERE's iso-surface F = 0.5 rendered with VL_DSR, lit by a
 * light from the left. The left ball is plain. The right one has a normal function,
 *     vlNormal(bumps, &bumpiness);
 * which receives the system's normal (minus the gradient of F, by central differences) and the
 * object-space point, and tilts the normal against the slope of a bump height field
 *     h(p) = vluNoise(p, 9) + 0.5 vluTurbulence(p, 26, 3)
 * (soft dimples, with finer creased wrinkles from the turbulence, whose absolute values fold
 * the noise into sharp valleys): n <- normalize(n - k (g - (g . n) n)), g the gradient of h by
 * central differences, its part along n removed so that only the tilt remains. The ball's
 * geometry is untouched (its silhouette stays a perfect circle); only its shading shows the
 * bumps, strongest where the light grazes the surface, towards the terminator.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/bump.c -Iinclude -Ltarget/release -lvlib -lm -o bump
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./bump [width]   (writes bump.png, 2:1, default 640 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define R 70.0f       /* the balls' radius, world units */
#define H 1.0e-3f     /* the step of the height field's central differences, object units */

/* The bump height field at object point p. */
static vlfloat height(const vlfloat *p)
{
    return vluNoise(p, 9.0f, 5) + 0.5f * vluTurbulence(p, 26.0f, 3, 6);
}

/* The normal function: tilts n against the gradient of the height field. misc points to the
   strength k. */
static void bumps(vlfloat *n, vlfloat *p, void *misc)
{
    vlfloat k = *(const vlfloat *)misc;
    vlfloat g[3], q[3], gn, len;
    int i;
    for (i = 0; i < 3; i++) {
        vlfloat hi, lo;
        q[0] = p[0];
        q[1] = p[1];
        q[2] = p[2];
        q[i] = p[i] + H;
        hi = height(q);
        q[i] = p[i] - H;
        lo = height(q);
        g[i] = (hi - lo) / (2.0f * H);
    }
    /* The balls are scaled uniformly and not rotated, so object and world directions agree. */
    gn = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
    for (i = 0; i < 3; i++)
        n[i] -= k * (g[i] - gn * n[i]);
    len = (vlfloat)sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len > 0.0f)
        for (i = 0; i < 3; i++)
            n[i] /= len;
}

/* A ball of radius R centred at (x, 0, 0); bumped when k is not NULL. */
static void ball(vlfloat x, vlfloat *k)
{
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(4.0f * R, 4.0f * R, 4.0f * R); /* VLU_SPHERE's F = 0.5 is a quarter of the cube */
    vlTranslate(x, 0.0, 0.0);
    vlBoundary(0.55, 0.55, 0.55);          /* clip the box close round it: F = 0.45 there */
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlSet(VL_O, 1.0);
    vlSet(VL_R, 0.93);
    vlSet(VL_G, 0.86);
    vlSet(VL_B, 0.72);
    vlSet(VL_KA, 0.25);
    vlSet(VL_KD, 0.85);
    vlSet(VL_KS, 0.35);
    vlSet(VL_N, VLSPECULAR(25));
    if (k != NULL)
        vlNormal(bumps, k);
    vlEnd();
}

int main(int argc, char **argv)
{
    /* k: the height field's slope (about 13 per object unit on average, much more across the
       turbulence's creases) times k is the tilt of the normal, about 0.05 on average. */
    static vlfloat bumpiness = 0.0035f;
    int width = argc > 1 ? atoi(argv[1]) : 640, height_px = width / 2, failed = 0;
    VLCAMERA camera = {{0.0, 40.0, -520.0}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, 24.0};
    vlint e;

    if (width < 8) {
        fprintf(stderr, "usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlScene();
    vlCamera(&camera);
    vlImage("bump.png", (vlfloat)width / height_px, width, height_px);
    vlBackground(0.10, 0.10, 0.12);
    vlAmbient(WHITE, 0.4);
    vlPointLight(-700.0, 250.0, -150.0, VL_NOATTENUATION, 1.0, 0.97, 0.9, 1.0);
    vlSuperSample(2);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5);
    vlStepSize(1.0, 1.0);

    ball(-85.0, NULL);        /* plain */
    ball(85.0, &bumpiness);   /* bump-mapped */

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
