/* Constructive volume geometry: two spheres combined by each of vlaux's CVG operators, side by
 * side (left to right: VLU_UNION, VLU_INTERSECTION, VLU_DIFFERENCE, VLU_BLEND; docs/cvg.md).
 *
 * Each of the four objects is a parent with two children, declared inside it: child 1 a larger
 * orange sphere, child 2 a smaller blue one, placed right of, above and in front of it (nearer
 * the camera). A child is VLU_SPHERE's distance field F = 1 - 2|q - c| in its own unit cube,
 * with a soft opacity, o = F / 0.4 (a VL_RAMP through (0.4, 1)): 0 at the cube's inscribed
 * sphere, 1 from 0.6 of its radius inwards, and 0.5 at 0.8 of its radius.
 *
 * The parent's program is
 *   vlFunction(VL_ALLFIELDS, operator, 0);   the children's fields combined (docs/cvg.md)
 *   vlMap(VL_F, VL_O, IDENTITY, 1);          geometry = the combined opacity (normals from it)
 *   vlMap(VL_O, VL_O, SOLID, 1);             a steep ramp about 0.5: a solid with a thin edge
 * so each object is the solid where the combined opacity exceeds 1/2: the spheres' union (max),
 * their intersection, a lens (min), the orange sphere with a bite taken out of it (min(o1,
 * 1 - o2)), and their blend (1 - (1 - o1)(1 - o2)), a smooth union whose soft opacities add up
 * into a neck between the spheres. The attribute rules show in the colours: the union and the
 * intersection take each point's colour from the child of largest (smallest) opacity, so both
 * colours appear on their surfaces; the difference is orange all over, even on the hollow the
 * blue sphere carved; the blend mixes the colours in proportion to opacity, so the neck fades
 * from orange to blue through a greyish mauve.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/cvg.c -Iinclude -Ltarget/release -lvlib -lm -o cvg
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./cvg [width]   (writes cvg.png, 10:3, default 800 wide)
 */
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define SOFT 1      /* mapping ids */
#define IDENTITY 2
#define SOLID 3
#define SIZE 120.0  /* a parent's cube, world units */
#define SPACING 132.0

static vlfloat soft[] = {0.7f, 1.0f};                   /* o = F / 0.7, clamped */
static vlfloat identity[] = {0.5f, 0.5f};               /* Phi_r through (0.5, 0.5): v -> v */
static vlfloat solid[] = {0.42f, 0.0f, 0.58f, 1.0f};    /* 0 below 0.42, 1 above 0.58 */

/* A sphere child in the parent's space: diameter `size` (parent units) centred at c. */
static void sphere(vlfloat size, vlfloat cx, vlfloat cy, vlfloat cz, vlfloat r, vlfloat g,
                   vlfloat b)
{
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(size, size, size);
    vlTranslate(cx, cy, cz);
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlMap(VL_O, VL_F, SOFT, 1);
    vlSet(VL_R, r);
    vlSet(VL_G, g);
    vlSet(VL_B, b);
    vlSet(VL_KA, 0.25);
    vlSet(VL_KD, 0.75);
    vlSet(VL_KS, 0.45);
    vlSet(VL_N, VLSPECULAR(30));
    vlEnd();
}

/* A parent at world x = `x`, turned by `yaw` degrees about the vertical, combining its two
   children with `op`. */
static void pair(vlfloat x, vlfloat yaw, void (*op)(vlfloat *, void *))
{
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(SIZE, SIZE, SIZE);
    vlRotate(0.0, yaw, 0.0);
    vlTranslate(x, 0.0, 0.0);
    sphere(0.80f, 0.41f, 0.46f, 0.5f, 0.96f, 0.50f, 0.16f); /* child 1: orange */
    sphere(0.66f, 0.62f, 0.56f, 0.5f, 0.18f, 0.42f, 0.96f); /* child 2: blue */
    vlFunction(VL_ALLFIELDS, op, 0);
    vlMap(VL_F, VL_O, IDENTITY, 1);
    vlMap(VL_O, VL_O, SOLID, 1);
    vlEnd();
}

int main(int argc, char **argv)
{
    static void (*const ops[4])(vlfloat *, void *) = {VLU_UNION, VLU_INTERSECTION,
                                                      VLU_DIFFERENCE, VLU_BLEND};
    static const vlfloat yaw[4] = {30.0f, 0.0f, 50.0f, 20.0f};
    int width = argc > 1 ? atoi(argv[1]) : 800;
    int height = width / 4, i, failed = 0;
    VLCAMERA camera = {{0.0, 150.0, -560.0}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, 14.0};
    vlint e;

    if (width < 10) {
        fprintf(stderr, "usage: %s [width >= 10]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlMapping(SOFT, VL_RAMP, 1, 1, soft);
    vlMapping(IDENTITY, VL_RAMP, 1, 1, identity);
    vlMapping(SOLID, VL_RAMP, 2, 1, solid);
    vlScene();
    vlCamera(&camera);
    vlImage("cvg.png", (vlfloat)width / height, width, height);
    vlBackground(0.10, 0.11, 0.14);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-300.0, 500.0, -600.0, VL_NOATTENUATION, WHITE, 1.0);
    vlStepSize(0.75, 1.0);
    vlSuperSample(2);
    for (i = 0; i < 4; i++)
        pair((vlfloat)((i - 1.5) * SPACING), yaw[i], ops[i]);
    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
