/* Metaballs: three nested iso-surfaces of one field (the paper's Figure 8(b), section 5.2).
 *
 * One object, rendered with VL_DSR. Its geometry F is a sum of five radial blobs ("metaballs",
 * "soft objects"): where blobs come close their fields add up and the surfaces flow into one
 * another. The scene asks for three iso-surfaces of F, as the paper's figure shows,
 *     vlSurface(VL_F, 0.2);  vlSurface(VL_F, 0.35);  vlSurface(VL_F, 0.5);
 * and each surface takes its opacity and colour from the fields where the ray crosses it. They
 * come from F through one lookup table (vlMapping(..., VL_LOOKUP, ...), then vlMap), which is
 * constant between thresholds: just above 0.2 (the outer surface, which wraps all five blobs)
 * a faint blue, O = 0.25; just above 0.35 (the middle one) yellow, O = 0.4; above 0.5 (the
 * cores) an opaque red. The table's breaks sit a little below each threshold, so that the point
 * where a crossing is shaded (just inside the surface, F a hair above its threshold) falls
 * safely in its own row. A ray through a core crosses the two veils in front of it (so the red
 * is seen through blue and yellow, and comes out orange), and the veils' back halves show
 * around the cores.
 *
 * Normals are world-space central differences of F; F is smooth, so they are accurate.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/metaballs.c -Iinclude -Ltarget/release -lvlib -lm -o metaballs
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./metaballs [width]   (writes metaballs.png, 4:3, default 480)
 */
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define SIZE 200.0f   /* the object's cube, world units, centred on the origin */
#define BALLS 5
#define TABLE 1       /* mapping id: F -> (O, R, G, B) */

/* Blob centres in object coordinates, and their weights; every blob has the same width S. */
#define S 0.07f
#define CUT 16.0f     /* a blob ends at d = 4 S ... */
#define TAIL (1.0f / (1.0f + CUT)) /* ... where 1 / (1 + d^2 / S^2) has fallen to this */
static const vlfloat centre[BALLS][3] = {
    {0.28f, 0.57f, 0.52f},
    {0.55f, 0.65f, 0.44f},
    {0.75f, 0.45f, 0.56f},
    {0.48f, 0.36f, 0.42f},
    {0.30f, 0.28f, 0.62f},
};
static const vlfloat weight[BALLS] = {1.25f, 1.10f, 1.15f, 1.05f, 0.95f};

/* The field: the sum of the blobs' falloffs w_i g(d_i^2 / S^2), g(q) = 1 / (1 + q) lowered
   and rescaled to reach 0 at q = CUT (d = 4 S) and stay 0 beyond, so the field fades out
   well inside the cube: no face of the box shows as a surface. This falloff has a long tail,
   so the three surfaces lie far apart: around a lone blob of weight 1 at d = 0.94 S, 1.26 S
   and 1.75 S. The cores (F = 0.5) stay apart, the middle surfaces just touch, and the outer
   one wraps all five blobs in one envelope. */
static void metaballs(vlfloat *p, void *misc)
{
    vlfloat f = 0.0f;
    int i;
    (void)misc;
    for (i = 0; i < BALLS; i++) {
        vlfloat dx = p[0] - centre[i][0], dy = p[1] - centre[i][1], dz = p[2] - centre[i][2];
        vlfloat q = (dx * dx + dy * dy + dz * dz) / (S * S);
        if (q < CUT)
            f += weight[i] * (1.0f / (1.0f + q) - TAIL) / (1.0f - TAIL);
    }
    vlSet(VL_F, f);
}

int main(int argc, char **argv)
{
    /* VL_LOOKUP rows (a, O, R, G, B): F gets the row of the first a at or above it (and 0 at
       or below the first a). */
    static vlfloat table[] = {
        0.195f, 0.00f, 0.00f, 0.00f, 0.00f, /* F <= 0.195: nothing (no surface is here) */
        0.345f, 0.25f, 0.55f, 0.80f, 1.00f, /* the outer veil: faint blue */
        0.495f, 0.40f, 1.00f, 0.85f, 0.25f, /* the middle veil: yellow */
        1.000f, 1.00f, 0.90f, 0.18f, 0.12f, /* the core: opaque red */
    };
    int width = argc > 1 ? atoi(argv[1]) : 480, height = width * 3 / 4, failed = 0;
    VLCAMERA camera = {{-60.0, 90.0, -330.0}, {0.0, -4.0, 0.0}, {0.0, 1.0, 0.0}, 27.0};
    vlint e;

    if (width < 8) {
        fprintf(stderr, "usage: %s [width >= 8]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlMapping(TABLE, VL_LOOKUP, 4, 4, table);
    vlScene();
    vlCamera(&camera);
    vlImage("metaballs.png", (vlfloat)width / height, width, height);
    vlBackground(0.05, 0.06, 0.10);
    vlAmbient(WHITE, 0.45);
    vlPointLight(-300.0, 400.0, -350.0, VL_NOATTENUATION, WHITE, 0.9);
    vlPointLight(350.0, 100.0, -200.0, VL_NOATTENUATION, 0.6, 0.7, 1.0, 0.3);
    vlSuperSample(3);
    vlStepSize(2.0, 1.0);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.2);
    vlSurface(VL_F, 0.35);
    vlSurface(VL_F, 0.5);

    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(SIZE, SIZE, SIZE);
    vlFunction(VL_F, metaballs, NULL);
    vlMap(VL_O, VL_F, TABLE, 1);
    vlMap(VL_R, VL_F, TABLE, 2);
    vlMap(VL_G, VL_F, TABLE, 3);
    vlMap(VL_B, VL_F, TABLE, 4);
    vlSet(VL_KA, 0.6);
    vlSet(VL_KD, 0.7);
    vlSet(VL_KS, 0.5);
    vlSet(VL_N, VLSPECULAR(40));
    vlEnd();

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
