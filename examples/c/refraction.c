/* Refraction: a glass ball on a checkered floor (the paper's section 5.1, "refract light").
 *
 * Every object is rendered with VL_DSR and shows its iso-surface F = 0.5.
 *
 * The glass ball is VLU_SPHERE's radial field F = 1 - 2 |p - c|, smooth across its surface
 * F = 0.5 (a sphere of radius 60), so the central differences that give the surface normal are
 * accurate there, as docs/compat.md asks of refracting objects. vlBoundary(0.55, 0.55, 0.55)
 * clips its box close round the sphere (F = 0.45 on the faces) so that rays sample less empty
 * space. vlToggle(VL_REFRACT, VL_TRUE) before its vlObject makes it refract, with index 1.5
 * (RF = VLREFRACTION(1.5), crown glass): at each crossing of its surface the rest of the ray
 * goes on along the refracted direction, so a ray through the ball is bent twice, entering and
 * leaving. The glass is nearly clear (O = 0.1, a faint blue tint).
 *
 * Like a lens, the ball shows what lies behind it shrunk and upside down: the checkerboard, its
 * squares curving round the rim, and the two opaque balls behind it, swapped (the yellow one,
 * right of the glass, appears at its left, the red one at its right). Rays through the lower
 * half of the glass are bent upwards so steeply that they leave towards the sky, which the
 * lower half therefore shows (upside down, as the floor is in the upper half).
 *
 * The floor is a slab whose field falls linearly with height, F = 1 - p_y, so its surface
 * F = 0.5 is the plane y = 0 with an exact normal (and a coarse step finds it exactly). Its
 * colours are a checkerboard of 40-unit squares computed from the world position
 * (vlPosition). It receives the balls' shadows (VL_CASTSHADOWS on the balls, VL_RECEIVESHADOWS
 * on the floor); the glass ball's is faint: each crossing of its surface lets 1 - O of the
 * light through.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/refraction.c -Iinclude -Ltarget/release -lvlib -lm -o refraction
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./refraction [width]   (writes refraction.png, 4:3, default 480)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define R 60.0f       /* the ball's radius, world units */
#define SQUARE 40.0f  /* the floor's squares */

/* The floor's geometry: 1 at its bottom face, 0 at its top, 0.5 at y = 0. */
static void floor_field(vlfloat *p, void *misc)
{
    (void)misc;
    vlSet(VL_F, 1.0f - p[1]);
}

/* The floor's colours: ivory and dark slate-blue squares by world position. */
static void checker(vlfloat *p, void *misc)
{
    vlfloat w[3];
    int i, j;
    (void)p;
    (void)misc;
    vlPosition(w);
    i = (int)floor(w[0] / SQUARE);
    j = (int)floor(w[2] / SQUARE);
    if ((i + j) & 1) {
        vlSet(VL_R, 0.16f);
        vlSet(VL_G, 0.22f);
        vlSet(VL_B, 0.40f);
    } else {
        vlSet(VL_R, 0.95f);
        vlSet(VL_G, 0.92f);
        vlSet(VL_B, 0.82f);
    }
}

/* An opaque ball of radius r resting on the floor at (x, z), coloured (red, green, blue). */
static void ball(vlfloat x, vlfloat z, vlfloat r, vlfloat red, vlfloat green, vlfloat blue)
{
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(4.0f * r, 4.0f * r, 4.0f * r);
    vlTranslate(x, r, z);
    vlBoundary(0.55, 0.55, 0.55);
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlSet(VL_O, 1.0);
    vlSet(VL_R, red);
    vlSet(VL_G, green);
    vlSet(VL_B, blue);
    vlSet(VL_KA, 0.5);
    vlSet(VL_KD, 0.7);
    vlSet(VL_KS, 0.4);
    vlSet(VL_N, VLSPECULAR(30));
    vlEnd();
}

int main(int argc, char **argv)
{
    int width = argc > 1 ? atoi(argv[1]) : 480, height = width * 3 / 4, failed = 0;
    VLCAMERA camera = {{-40.0, 190.0, -380.0}, {0.0, 40.0, 40.0}, {0.0, 1.0, 0.0}, 32.0};
    vlint e;

    if (width < 8) {
        fprintf(stderr, "usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlScene();
    vlCamera(&camera);
    vlImage("refraction.png", (vlfloat)width / height, width, height);
    vlBackground(0.55, 0.68, 0.85);
    vlAmbient(WHITE, 0.4);
    vlPointLight(-250.0, 500.0, -120.0, VL_NOATTENUATION, WHITE, 0.8);
    vlSuperSample(2);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5);

    /* The floor: the plane y = 0, 1200 x 1200. Its field is linear, so a coarse step finds
       the surface as exactly as a fine one. */
    vlStepSize(3.0, 1.0);
    vlToggle(VL_RECEIVESHADOWS, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(1200.0, 8.0, 1200.0);
    vlTranslate(0.0, 0.0, 300.0);
    vlFunction(VL_F, floor_field, NULL);
    vlSet(VL_O, 1.0);
    vlFunction(VL_COLORS, checker, NULL);
    vlSet(VL_KA, 0.6);
    vlSet(VL_KD, 0.7);
    vlEnd();

    /* Two opaque balls behind the glass, red on the left and yellow on the right. */
    vlStepSize(1.0, 1.0);
    vlToggle(VL_RECEIVESHADOWS, VL_FALSE);
    vlToggle(VL_CASTSHADOWS, VL_TRUE);
    ball(-120.0, 230.0, 32.0, 0.85, 0.12, 0.10);
    ball(125.0, 260.0, 32.0, 0.95, 0.80, 0.15);

    /* The glass ball, resting just above the floor. */
    vlToggle(VL_REFRACT, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(4.0f * R, 4.0f * R, 4.0f * R);   /* VLU_SPHERE's F = 0.5 is a quarter of the cube */
    vlTranslate(0.0, R + 2.0f, 0.0);
    vlBoundary(0.55, 0.55, 0.55); /* clip the box close round the ball: F = 0.45 on its faces */
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlSet(VL_RF, VLREFRACTION(1.5));
    vlSet(VL_O, 0.1);
    vlSet(VL_R, 0.7);
    vlSet(VL_G, 0.85);
    vlSet(VL_B, 1.0);
    vlSet(VL_KA, 0.3);
    vlSet(VL_KD, 0.3);
    vlSet(VL_KS, 1.0);
    vlSet(VL_N, VLSPECULAR(90));
    vlEnd();

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
