/* Heterogeneous reflection coefficients (the paper's Figure 1(a), section 2.2).
 *
 * A long rounded bar lies on a checkered floor. Its reflection fields vary smoothly along its
 * length, from a dull, unglazed ceramic at the left end to a polished metal at the right end:
 *     left (ceramic)   KA 0.35  KD 0.85  KS 0     exponent  -   terracotta colour
 *     right (metal)    KA 0.10  KD 0.12  KS 0.85  exponent 110  steel grey
 * with every field blended between the two by a smoothstep of the position along the bar
 * (one field function, `material`, writes colour, KA, KD, KS and N from the object point;
 * the exponent is written with VLSPECULAR).
 *
 * Everything is rendered with VL_DSR (iso-surface F = 0.5): mirror rays start at surfaces. The
 * bar has VL_RECEIVEREFLECTIONS: at each surface hit vlib traces a mirror ray and adds KS times
 * the colour it sees, so the metal end mirrors the world while the ceramic end (KS = 0) spawns
 * no mirror ray at all. Mirror rays see only objects with VL_CASTREFLECTIONS (here the floor and
 * two balls, a red and a blue one in front of the metal end); where they escape they show the
 * background, a sky blue, because the bar also has VL_REFLECTBACKGROUND. So the metal shows
 * the sky above its middle, the checkerboard below it, curving round the bar, and the two balls,
 * with a sharp highlight of the light (up and to the right, so that the highlight falls on the
 * metal); the ceramic has only a broad, soft diffuse gradient. Across the middle of the bar the
 * matte colour fades as the reflections take over.
 *
 * The bar's field is smooth across its surface, F = 0.5 + d / (2 M) with d the signed distance
 * to the capsule's surface (positive inside) and M = 12 world units, clamped to [0, 1], so the
 * central differences that give the surface normal, and with it the mirror direction, are
 * accurate: docs/compat.md asks this of reflecting objects. The floor's field falls linearly
 * with height, F = 1 - p_y, for the same reason. The floor receives the shadows of the bar and
 * the balls (VL_RECEIVESHADOWS, VL_CASTSHADOWS).
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/reflectance.c -Iinclude -Ltarget/release -lvlib -lm -o reflectance
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./reflectance [width]   (writes reflectance.png, 2:1,
 *                                                            default 640 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define L 300.0f      /* the bar's straight part, along x, world units */
#define RAD 42.0f     /* its radius */
#define M 12.0f       /* the width of the ramp of F across its surface */
#define BX (L + 2.0f * (RAD + M)) /* its object's box */
#define BY (2.0f * (RAD + M))
#define SQUARE 40.0f  /* the floor's squares */

static vlfloat smoothstep(vlfloat a, vlfloat b, vlfloat x)
{
    vlfloat t = (x - a) / (b - a);
    t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
    return t * t * (3.0f - 2.0f * t);
}

static vlfloat mix(vlfloat a, vlfloat b, vlfloat t)
{
    return a + (b - a) * t;
}

/* The bar's geometry: a capsule (a cylinder of radius RAD round the segment |x| <= L / 2 on
   the box's axis, with hemispherical ends). F = 0.5 + d / (2 M), d the signed distance to
   its surface in world units. */
static void capsule(vlfloat *p, void *misc)
{
    vlfloat x = (p[0] - 0.5f) * BX, y = (p[1] - 0.5f) * BY, z = (p[2] - 0.5f) * BY;
    vlfloat ex = x < -0.5f * L ? x + 0.5f * L : x > 0.5f * L ? x - 0.5f * L : 0.0f;
    vlfloat d = RAD - (vlfloat)sqrt(ex * ex + y * y + z * z);
    (void)misc;
    vlSet(VL_F, 0.5f + 0.5f * d / M);
}

/* The bar's material: ceramic at the left end, metal at the right, blended along x. */
static void material(vlfloat *p, void *misc)
{
    vlfloat t = smoothstep(0.2f, 0.8f, p[0]);
    (void)misc;
    vlSet(VL_R, mix(0.78f, 0.62f, t));
    vlSet(VL_G, mix(0.40f, 0.64f, t));
    vlSet(VL_B, mix(0.26f, 0.68f, t));
    vlSet(VL_KA, mix(0.35f, 0.10f, t));
    vlSet(VL_KD, mix(0.85f, 0.12f, t));
    vlSet(VL_KS, mix(0.0f, 0.85f, t));
    vlSet(VL_N, VLSPECULAR(mix(4.0f, 110.0f, t)));
}

/* The floor's geometry: 1 at its bottom face, 0 at its top, 0.5 at y = 0. */
static void floor_field(vlfloat *p, void *misc)
{
    (void)misc;
    vlSet(VL_F, 1.0f - p[1]);
}

/* The floor's colours: light and dark grey squares by world position. */
static void checker(vlfloat *p, void *misc)
{
    vlfloat w[3], v;
    (void)p;
    (void)misc;
    vlPosition(w);
    v = (((int)floor(w[0] / SQUARE) + (int)floor(w[2] / SQUARE)) & 1) ? 0.18f : 0.85f;
    vlSet(VL_COLORS, v);
}

/* A shiny opaque ball of radius r resting on the floor at (x, z). */
static void ball(vlfloat x, vlfloat z, vlfloat r, vlfloat red, vlfloat green, vlfloat blue)
{
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(4.0f * r, 4.0f * r, 4.0f * r); /* VLU_SPHERE's F = 0.5 is a quarter of the cube */
    vlTranslate(x, r, z);
    vlBoundary(0.55, 0.55, 0.55);          /* clip the box close round it: F = 0.45 there */
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlSet(VL_O, 1.0);
    vlSet(VL_R, red);
    vlSet(VL_G, green);
    vlSet(VL_B, blue);
    vlSet(VL_KA, 0.45);
    vlSet(VL_KD, 0.75);
    vlSet(VL_KS, 0.4);
    vlSet(VL_N, VLSPECULAR(40));
    vlEnd();
}

int main(int argc, char **argv)
{
    int width = argc > 1 ? atoi(argv[1]) : 640, height = width / 2, failed = 0;
    VLCAMERA camera = {{-20.0, 240.0, -540.0}, {0.0, 30.0, 0.0}, {0.0, 1.0, 0.0}, 26.0};
    vlint e;

    if (width < 8) {
        fprintf(stderr, "usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlScene();
    vlCamera(&camera);
    vlImage("reflectance.png", (vlfloat)width / height, width, height);
    vlBackground(0.50, 0.66, 0.90);
    vlAmbient(WHITE, 0.5);
    vlPointLight(350.0, 600.0, -350.0, VL_NOATTENUATION, WHITE, 0.9);
    vlSuperSample(2);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5);

    /* The floor, the plane y = 0: casts reflections, receives shadows. Its field is linear, so
       a coarse step finds its surface as exactly as a fine one. */
    vlStepSize(3.0, 1.0);
    vlToggle(VL_CASTREFLECTIONS, VL_TRUE);
    vlToggle(VL_RECEIVESHADOWS, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(1400.0, 8.0, 1000.0);
    vlTranslate(0.0, 0.0, 250.0);
    vlFunction(VL_F, floor_field, NULL);
    vlSet(VL_O, 1.0);
    vlFunction(VL_COLORS, checker, NULL);
    vlSet(VL_KA, 0.6);
    vlSet(VL_KD, 0.7);
    vlEnd();

    /* Two balls in front of the metal end: cast reflections and shadows. */
    vlStepSize(1.0, 1.0);
    vlToggle(VL_RECEIVESHADOWS, VL_FALSE);
    vlToggle(VL_CASTSHADOWS, VL_TRUE);
    ball(180.0, -95.0, 28.0, 0.90, 0.12, 0.10);
    ball(60.0, -150.0, 24.0, 0.15, 0.30, 0.95);

    /* The bar: receives reflections (and shows the sky where they escape); casts shadows. */
    vlToggle(VL_CASTREFLECTIONS, VL_FALSE);
    vlToggle(VL_RECEIVEREFLECTIONS, VL_TRUE);
    vlToggle(VL_REFLECTBACKGROUND, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(BX, BY, BY);
    vlTranslate(0.0, RAD + 1.0f, 0.0);
    vlFunction(VL_F, capsule, NULL);
    vlSet(VL_O, 1.0);
    vlFunction(VL_COLORS | VL_KA | VL_KD | VL_KS | VL_N, material, NULL);
    vlEnd();

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
