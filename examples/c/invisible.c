/* The invisible tank (the paper's Figure 7(a), section 5.1).
 *
 * A tank stands on a checkered floor in front of a mirror. The tank is invisible to primary
 * rays (vlToggle(VL_VISIBLE, VL_FALSE)), so the camera looks straight through it at the floor;
 * yet it casts a shadow on the floor (VL_CASTSHADOWS on the tank, VL_RECEIVESHADOWS on the
 * floor) and is seen in the mirror (VL_CASTREFLECTIONS on the tank, VL_RECEIVEREFLECTIONS on
 * the mirror): mirror rays see every object that casts reflections, visible or not.
 *
 * The tank is a scene graph: a parent object with five children, two tracks, a hull, a turret
 * and a gun barrel, each a rounded box placed in the parent's space, combined by the parent's
 * program
 *     vlFunction(VL_ALLFIELDS, VLU_UNION, 0);   every field from the child of largest opacity
 *     vlSet(VL_O, 1.0);
 * Each child's geometry is smooth across its surface, F = 0.5 + d / (2 M) with d the signed
 * distance to its rounded box in world units (positive inside) and M = 4, clamped to [0, 1];
 * and its opacity is F itself, so that where children overlap, the union (which takes the child
 * of largest opacity) takes the largest F: the union's F = 0.5 is the union of the parts,
 * smooth enough for the normals of its reflection. Once the union is taken, the parent sets its
 * opacity to 1: a surface shadows by its opacity at each crossing, and the tank's shadow should
 * be solid. The parent's box is clipped close round the tank with vlBoundary.
 *
 * Everything is rendered with VL_DSR (iso-surface F = 0.5): mirror rays start at surfaces, and
 * a solid shadow needs a surface. The mirror is a thin upright slab (a rounded box too, so its
 * surface normal is exact) whose fields vary across it: within 10 units of its edges it is a
 * matte wooden frame (KS = 0), inside that a mirror (dark, KD 0.05, KS 0.9), so only the glass
 * reflects. It also has VL_REFLECTBACKGROUND, so the sky shows in it above the floor. The floor
 * casts reflections too, so the mirror shows the floor, with the tank standing on it, and the
 * tank's shadow as well (the mirror ray that reaches the floor is lit and shadowed like any
 * other).
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/invisible.c -Iinclude -Ltarget/release -lvlib -lm -o invisible
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./invisible [width]   (writes invisible.png, 8:5, default 640)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define S 180.0f      /* the tank's parent cube, world units */
#define M 4.0f        /* the width of the ramp of F across a part's surface */
#define SQUARE 40.0f  /* the floor's squares */

/* A rounded box: its centre and half-sizes in world units relative to its object (for the
   tank's parts, relative to the tank's centre), the radius of its rounded edges, and its
   colour. */
typedef struct {
    vlfloat centre[3], half[3], round, rgb[3];
} Part;

/* The tank's parts, in world units about the tank's centre; the tank is 66 high, its
   barrel along +x. */
static Part parts[] = {
    {{-10.0f, -18.0f, -38.0f}, {70.0f, 15.0f, 10.0f}, 8.0f, {0.20f, 0.20f, 0.18f}}, /* track */
    {{-10.0f, -18.0f, 38.0f}, {70.0f, 15.0f, 10.0f}, 8.0f, {0.20f, 0.20f, 0.18f}},  /* track */
    {{-10.0f, -7.0f, 0.0f}, {65.0f, 16.0f, 30.0f}, 3.0f, {0.36f, 0.40f, 0.22f}},    /* hull */
    {{-18.0f, 20.0f, 0.0f}, {30.0f, 11.0f, 23.0f}, 6.0f, {0.40f, 0.44f, 0.25f}},    /* turret */
    {{47.5f, 20.0f, 0.0f}, {37.5f, 4.0f, 4.0f}, 3.9f, {0.30f, 0.33f, 0.20f}},       /* barrel */
};
#define PARTS (sizeof(parts) / sizeof(parts[0]))

/* The signed distance (positive inside) from w to the rounded box of half-sizes half and edge
   radius round, centred at the origin. */
static vlfloat inside_distance(const vlfloat *w, const vlfloat *half, vlfloat round)
{
    vlfloat q[3], out = 0.0f, in = -1e30f;
    int i;
    for (i = 0; i < 3; i++) {
        q[i] = (vlfloat)fabs(w[i]) - (half[i] - round);
        if (q[i] > 0.0f)
            out += q[i] * q[i];
        if (q[i] > in)
            in = q[i];
    }
    return round - ((vlfloat)sqrt(out) + (in < 0.0f ? in : 0.0f));
}

/* A part of the tank: F from the distance to its box, O = F (for VLU_UNION), its colour. The
   part's object is its box grown by M on every side, so p maps to world units by the box's
   size. */
static void part(vlfloat *p, void *misc)
{
    const Part *b = (const Part *)misc;
    vlfloat w[3], f;
    int i;
    for (i = 0; i < 3; i++)
        w[i] = (p[i] - 0.5f) * 2.0f * (b->half[i] + M);
    f = 0.5f + 0.5f * inside_distance(w, b->half, b->round) / M;
    f = f < 0.0f ? 0.0f : f > 1.0f ? 1.0f : f;
    vlSet(VL_F, f);
    vlSet(VL_O, f);
    vlSet(VL_R, b->rgb[0]);
    vlSet(VL_G, b->rgb[1]);
    vlSet(VL_B, b->rgb[2]);
}

/* The mirror: 260 x 180 x 6 world units, with rounded edges; the frame is its outer 10
   units. misc points to its half-sizes. */
static void mirror(vlfloat *p, void *misc)
{
    const vlfloat *half = (const vlfloat *)misc;
    vlfloat w[3], f, edge;
    int i;
    for (i = 0; i < 3; i++)
        w[i] = (p[i] - 0.5f) * 2.0f * (half[i] + M);
    f = 0.5f + 0.5f * inside_distance(w, half, 2.5f) / M;
    vlSet(VL_F, f);
    edge = half[0] - (vlfloat)fabs(w[0]);
    if (half[1] - (vlfloat)fabs(w[1]) < edge)
        edge = half[1] - (vlfloat)fabs(w[1]);
    if (edge < 10.0f) { /* the frame: dark wood, matte */
        vlSet(VL_R, 0.36f);
        vlSet(VL_G, 0.22f);
        vlSet(VL_B, 0.12f);
        vlSet(VL_KD, 0.8f);
        vlSet(VL_KS, 0.0f);
    } else {            /* the glass: a dark, almost perfect mirror */
        vlSet(VL_R, 0.1f);
        vlSet(VL_G, 0.12f);
        vlSet(VL_B, 0.12f);
        vlSet(VL_KD, 0.05f);
        vlSet(VL_KS, 0.9f);
    }
}

/* The floor's geometry: 1 at its bottom face, 0 at its top, 0.5 at y = 0. */
static void floor_field(vlfloat *p, void *misc)
{
    (void)misc;
    vlSet(VL_F, 1.0f - p[1]);
}

/* The floor's colours: sand and light grey squares by world position. */
static void checker(vlfloat *p, void *misc)
{
    vlfloat w[3];
    (void)p;
    (void)misc;
    vlPosition(w);
    if (((int)floor(w[0] / SQUARE) + (int)floor(w[2] / SQUARE)) & 1) {
        vlSet(VL_R, 0.62f);
        vlSet(VL_G, 0.60f);
        vlSet(VL_B, 0.56f);
    } else {
        vlSet(VL_R, 0.86f);
        vlSet(VL_G, 0.80f);
        vlSet(VL_B, 0.66f);
    }
}

int main(int argc, char **argv)
{
    static vlfloat mirror_half[3] = {130.0f, 90.0f, 3.0f};
    int width = argc > 1 ? atoi(argv[1]) : 640, height = width * 5 / 8, failed = 0;
    VLCAMERA camera = {{-170.0, 210.0, -520.0}, {-55.0, 62.0, 50.0}, {0.0, 1.0, 0.0}, 30.0};
    unsigned i;
    vlint e;

    if (width < 8) {
        fprintf(stderr, "usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlScene();
    vlCamera(&camera);
    vlImage("invisible.png", (vlfloat)width / height, width, height);
    vlBackground(0.55, 0.70, 0.90);
    vlAmbient(WHITE, 0.45);
    vlPointLight(-450.0, 520.0, -260.0, VL_NOATTENUATION, WHITE, 0.9);
    vlSuperSample(2);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5);

    /* The floor, the plane y = 0: receives shadows, is seen in the mirror. Its field is linear,
       so a coarse step finds its surface as exactly as a fine one. */
    vlStepSize(3.0, 1.0);
    vlToggle(VL_RECEIVESHADOWS, VL_TRUE);
    vlToggle(VL_CASTREFLECTIONS, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(2400.0, 8.0, 1600.0);
    vlTranslate(0.0, 0.0, 500.0);
    vlFunction(VL_F, floor_field, NULL);
    vlSet(VL_O, 1.0);
    vlFunction(VL_COLORS, checker, NULL);
    vlSet(VL_KA, 0.6);
    vlSet(VL_KD, 0.7);
    vlEnd();

    /* The tank: invisible, casts shadows and reflections. */
    vlStepSize(1.5, 1.0);
    vlToggle(VL_RECEIVESHADOWS, VL_FALSE);
    vlToggle(VL_VISIBLE, VL_FALSE);
    vlToggle(VL_CASTSHADOWS, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(S, S, S);
    vlRotate(0.0, -35.0, 0.0);
    vlTranslate(-40.0, 33.5, -40.0);
    vlBoundary(1.0, 0.42, 0.6); /* the tank is 66 high and 104 wide: clip the box round it */
    for (i = 0; i < PARTS; i++) {
        vlObject();
        vlTranslate(-0.5, -0.5, -0.5);
        vlScale(2.0f * (parts[i].half[0] + M) / S, 2.0f * (parts[i].half[1] + M) / S,
                2.0f * (parts[i].half[2] + M) / S);
        vlTranslate(0.5f + parts[i].centre[0] / S, 0.5f + parts[i].centre[1] / S,
                    0.5f + parts[i].centre[2] / S);
        vlFunction(VL_F | VL_O | VL_COLORS, part, &parts[i]);
        vlEnd();
    }
    vlFunction(VL_ALLFIELDS, VLU_UNION, 0);
    vlSet(VL_O, 1.0);
    vlSet(VL_KA, 0.5);
    vlSet(VL_KD, 0.8);
    vlSet(VL_KS, 0.25);
    vlSet(VL_N, VLSPECULAR(20));
    vlEnd();

    /* The mirror, upright on the floor behind the tank, turned a little towards the camera:
       visible, receives reflections and shows the sky where they escape. */
    vlStepSize(1.0, 1.0);
    vlToggle(VL_VISIBLE, VL_TRUE);
    vlToggle(VL_CASTSHADOWS, VL_FALSE);
    vlToggle(VL_CASTREFLECTIONS, VL_FALSE);
    vlToggle(VL_RECEIVEREFLECTIONS, VL_TRUE);
    vlToggle(VL_REFLECTBACKGROUND, VL_TRUE);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(2.0f * (mirror_half[0] + M), 2.0f * (mirror_half[1] + M), 2.0f * (mirror_half[2] + M));
    vlRotate(0.0, -12.0, 0.0);
    vlTranslate(-110.0, mirror_half[1] + 1.0f, 170.0);
    vlFunction(VL_F | VL_COLORS | VL_KD | VL_KS, mirror, mirror_half);
    vlSet(VL_O, 1.0);
    vlSet(VL_KA, 0.5);
    vlSet(VL_N, VLSPECULAR(60));
    vlEnd();

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
