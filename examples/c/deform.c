/* Spatial transfer functions (the paper's section 4.7): four striped objects deformed by vlSpatial,
 * left to right a twist, a taper, a bend and an explosion.
 *
 * A spatial transfer function Psi rewrites the sample point p (object space) in place; every
 * later instruction of the object's program sees Psi(p), so the object shows its undeformed
 * fields carried to Psi^-1: what lay at Psi(x) is drawn at x. Each object here is a solid
 * striped box (its geometry and stripes are functions of the point the spatial function hands
 * on) and each deformation carries parts of it out of the unit cube, so each object's
 * vlBoundary is enlarged to hold them (a box outside the boundary would be clipped).
 *
 *   twist    the paper's Psi: (r cos theta + 0.5, y, r sin theta + 0.5), r the distance from the
 *            vertical axis through (0.5, y, 0.5) and theta = (pi / 2) y + atan2(z - 0.5,
 *            x - 0.5) (atan2 rather than the printed arctan, which loses the quadrant): a quarter
 *            turn from bottom to top. The corners swing out to 1/sqrt(2) from the axis:
 *            vlBoundary(1.5, 1, 1.5).
 *   taper    the cross-section scaled by s(y) = 0.55 + 0.9 y about the axis (p -> (p - c) / s
 *            on x and z): narrow at the foot, flaring to 1.45 times at the top:
 *            vlBoundary(1.5, 1, 1.5).
 *   bend     the column bent into an arc of 75 degrees about a horizontal axis (z) on its right,
 *            by polar coordinates about that axis (Barr's bend): its foot stays put and its top
 *            leans over to the right, 1.8 widths beyond its foot: vlBoundary(4.8, 1, 1).
 *   explode  a cube cut into 4 x 4 x 4 cells, each pushed out from the centre by 1.45 times its
 *            distance and nudged by a pseudo-random offset of its own; points between the
 *            pieces are sent outside the cube (empty): vlBoundary(1.5, 1.5, 1.5).
 *
 * Geometry: F = 0.5 + d / 2, with d the world distance to the box's nearest face (and for the
 * explosion to the nearest face of the point's cell, so the cut faces are lit like the others),
 * and a steep VL_RAMP turns it into a solid opacity. Stripes: vertical bands by x and z, dark
 * rings every eighth of the height, computed on the undeformed point.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/deform.c -Iinclude -Ltarget/release -lvlib -lm -o deform
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./deform [width]   (writes deform.png, 2:1, default 800 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define PI 3.14159265358979f
#define MARGIN 2.0f   /* world units between a box and its unit cube */
#define CELLS 4       /* the explosion's cells per axis */
#define SPREAD 1.45f  /* how far the cells are pushed out */
#define OPACITY 1     /* mapping id: F -> O */

/* What the field functions need to know about an object: its world size, and whether its
   geometry is cut into cells (the explosion). */
typedef struct {
    vlfloat size[3];
    int cells;
} Box;

/* ---- the spatial transfer functions ---- */

static void twist(vlfloat *p, void *misc)
{
    vlfloat dx = p[0] - 0.5f, dz = p[2] - 0.5f;
    vlfloat r = (vlfloat)sqrt(dx * dx + dz * dz);
    vlfloat theta = 0.5f * PI * p[1] + (vlfloat)atan2(dz, dx);
    (void)misc;
    p[0] = r * (vlfloat)cos(theta) + 0.5f;
    p[2] = r * (vlfloat)sin(theta) + 0.5f;
}

static void taper(vlfloat *p, void *misc)
{
    vlfloat s = 0.55f + 0.9f * p[1];
    (void)misc;
    p[0] = (p[0] - 0.5f) / s + 0.5f;
    p[2] = (p[2] - 0.5f) / s + 0.5f;
}

/* The bend: the column's centre line (x = 0.5) becomes an arc of radius R about the axis
   (0.5 + R, 0) in the x-y plane; a point at angle phi and radius rho from that axis came from
   height R phi and from x = 0.5 + R - rho. Object units: the object's x and y sizes differ, so
   the arc is computed in world-proportional units (y scaled by ASPECT). */
#define BEND (75.0f * PI / 180.0f)
#define ASPECT 3.2f /* the bent column's height / width (object y size / object x size) */
static void bend(vlfloat *p, void *misc)
{
    vlfloat R = ASPECT / BEND;            /* in units of the object's width */
    vlfloat dx = 0.5f + R - p[0], dy = p[1] * ASPECT;
    vlfloat rho = (vlfloat)sqrt(dx * dx + dy * dy);
    vlfloat phi = (vlfloat)atan2(dy, dx);
    (void)misc;
    p[0] = 0.5f + R - rho;
    p[1] = R * phi / ASPECT;
}

/* A hash of a cell to [-1, 1]. */
static vlfloat jitter(int i, int j, int k, int axis)
{
    unsigned long h = (unsigned long)(i * 73856093L ^ j * 19349663L ^ k * 83492791L ^
                                      axis * 2654435761UL);
    h ^= h >> 13;
    h *= 1274126177UL;
    h ^= h >> 16;
    return (vlfloat)(h & 1023) / 511.5f - 1.0f;
}

static void explode(vlfloat *p, void *misc)
{
    int c[3], a;
    vlfloat q[3];
    (void)misc;
    /* The cell whose pushed-out copy is nearest, per axis (without its nudge, which is small). */
    for (a = 0; a < 3; a++) {
        vlfloat u = ((p[a] - 0.5f) / SPREAD + 0.5f) * CELLS;
        c[a] = (int)floor(u);
        if (c[a] < 0)
            c[a] = 0;
        if (c[a] > CELLS - 1)
            c[a] = CELLS - 1;
    }
    for (a = 0; a < 3; a++) {
        vlfloat centre = (c[a] + 0.5f) / CELLS;
        vlfloat moved = 0.5f + (centre - 0.5f) * SPREAD + 0.05f * jitter(c[0], c[1], c[2], a);
        vlfloat d = p[a] - moved;
        if (fabs(d) > 0.5f / CELLS) { /* between the pieces: nothing there */
            p[0] = p[1] = p[2] = -1.0f;
            return;
        }
        q[a] = centre + d;
    }
    p[0] = q[0];
    p[1] = q[1];
    p[2] = q[2];
}

/* ---- fields ---- */

/* F = 0.5 + d / 2: d the world distance to the nearest face of the box (MARGIN inside the unit
   cube), or of the point's cell. */
static void solid(vlfloat *p, void *misc)
{
    const Box *b = (const Box *)misc;
    vlfloat d = 1e9f;
    int a;
    for (a = 0; a < 3; a++) {
        vlfloat face = (0.5f - (vlfloat)fabs(p[a] - 0.5f)) * b->size[a] - MARGIN;
        if (face < d)
            d = face;
        if (b->cells > 0 && p[a] > 0.0f && p[a] < 1.0f) {
            vlfloat u = p[a] * b->cells;
            vlfloat f = u - (vlfloat)floor(u);
            vlfloat cut = (0.5f - (vlfloat)fabs(f - 0.5f)) / b->cells * b->size[a] - 0.5f;
            if (cut < d)
                d = cut;
        }
    }
    vlSet(VL_F, 0.5f + 0.5f * d);
}

/* Vertical stripes (eight around each face pair), dark rings every eighth of the height. */
static void stripes(vlfloat *p, void *misc)
{
    const vlfloat *colour = (const vlfloat *)misc; /* two colours, 6 floats */
    int band = ((int)floor(p[0] * 8.0f) + (int)floor(p[2] * 8.0f)) & 1;
    vlfloat h = p[1] * 8.0f, ring = h - (vlfloat)floor(h + 0.5f);
    vlfloat dark = fabs(ring) < 0.06f ? 0.35f : 1.0f;
    vlSet(VL_R, colour[3 * band] * dark);
    vlSet(VL_G, colour[3 * band + 1] * dark);
    vlSet(VL_B, colour[3 * band + 2] * dark);
}

static vlfloat red[6] = {0.92f, 0.30f, 0.22f, 0.96f, 0.88f, 0.74f};
static vlfloat teal[6] = {0.14f, 0.58f, 0.62f, 0.92f, 0.90f, 0.80f};
static vlfloat gold[6] = {0.90f, 0.66f, 0.16f, 0.30f, 0.22f, 0.36f};
static vlfloat blue[6] = {0.22f, 0.38f, 0.86f, 0.95f, 0.93f, 0.88f};

/* An object of world size sx x sy x sz (its unit cube) centred at (x, y, 0), boundary b,
   deformed by `spatial`, coloured by `colour`. */
static void object(Box *box, vlfloat sx, vlfloat sy, vlfloat sz, vlfloat x, vlfloat y,
                   const vlfloat b[3], void (*spatial)(vlfloat *, void *), vlfloat *colour)
{
    box->size[0] = sx;
    box->size[1] = sy;
    box->size[2] = sz;
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(sx, sy, sz);
    vlTranslate(x, y, 0.0);
    vlBoundary(b[0], b[1], b[2]);
    vlSpatial(spatial, NULL);
    vlFunction(VL_F, solid, box);
    vlMap(VL_O, VL_F, OPACITY, 1);
    vlFunction(VL_COLORS, stripes, colour);
    vlSet(VL_KA, 0.30);
    vlSet(VL_KD, 0.75);
    vlSet(VL_KS, 0.35);
    vlSet(VL_N, VLSPECULAR(30));
    vlEnd();
}

int main(int argc, char **argv)
{
    static vlfloat opacity[] = {0.35f, 0.0f, 0.5f, 1.0f}; /* VL_RAMP: F -> O, solid above 0.5 */
    static Box twisted = {{0}, 0}, tapered = {{0}, 0}, bent = {{0}, 0}, exploded = {{0}, CELLS};
    static const vlfloat wide[3] = {1.5f, 1.0f, 1.5f}, bend_box[3] = {4.8f, 1.0f, 1.0f},
                         all[3] = {1.5f, 1.5f, 1.5f};
    int width = argc > 1 ? atoi(argv[1]) : 800, height = width / 2, failed = 0;
    VLCAMERA camera = {{0.0, 230.0, -620.0}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, 29.0};
    vlint e;

    if (width < 16) {
        fprintf(stderr, "usage: %s [width >= 16]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlMapping(OPACITY, VL_RAMP, 2, 1, opacity);
    vlScene();
    vlCamera(&camera);
    vlImage("deform.png", (vlfloat)width / height, width, height);
    vlBackground(0.12, 0.13, 0.16);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-350.0, 450.0, -500.0, VL_NOATTENUATION, WHITE, 1.0);
    vlSuperSample(2);
    vlStepSize(0.5, 1.0);
    object(&twisted, 64.0f, 170.0f, 64.0f, -250.0f, 0.0f, wide, twist, red);
    object(&tapered, 64.0f, 170.0f, 64.0f, -115.0f, 0.0f, wide, taper, teal);
    object(&bent, 170.0f / ASPECT, 170.0f, 50.0f, -15.0f, 0.0f, bend_box, bend, gold);
    object(&exploded, 100.0f, 100.0f, 100.0f, 220.0f, 0.0f, all, explode, blue);
    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
