/* Solid textures: marble, wood and granite on spheres, cubes and cylinders, in the manner of the
 * paper's colour plate. Every texture is a field function of the object-space point p that
 * writes the colour fields; the shapes come from vlaux's distance fields.
 *
 * Front row, left to right: a white (Carrara) marble sphere, a wooden cube, a pink granite
 * sphere. Back row: a grey granite column, a green marble cube, a log lying on its side.
 *
 * Shapes. Each object's box is its shape plus a margin of MARGIN world units on every side. A
 * field function `solid` computes d, the distance in world units from the point to the shape's
 * surface (positive inside): from VLU_SPHERE (the sphere), from VLU_CYLINDER with its two flat
 * caps (the column and the log: VLU_CYLINDER's axis is the object's z axis, turned upright with
 * vlRotate(90, 0, 0) for the column), or from the nearest face (the cubes). It writes
 * F = 0.5 + d / (2 RAMP), which is 0.5 on the surface and whose gradient gives the normals, and
 * a steep VL_RAMP makes the opacity 1 inside, so the objects are solid.
 *
 * Textures.
 *   marble:  Perlin's marble, v = 1/2 + 1/2 sin(k (p . a) + w vluTurbulence(p, size, 6, seed)),
 *            coloured through three vluSplines (one per channel), as the paper's Figure 5 does
 *            with turbulence alone: the sine lays down parallel bands that the turbulence folds
 *            into veins.
 *   wood:    rings of the distance r from an axis (the log's own axis; for the cube an axis
 *            running front to back below it, so the rings show as arcs on the two faces it
 *            crosses and as stripes on the others), wobbled by vluNoise and
 *            vluTurbulence; dark late wood at the end of each ring, light early wood, and
 *            fine streaks of noise stretched along the axis for the grain.
 *   granite: the stone of examples/c/figure2.c (turbulence for the lightness, a low-frequency
 *            warm tint, dark mica specks and light quartz grains), with a tint per object.
 * The floor is a slab of dark slate with a faint turbulence.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/textures.c -Iinclude -Ltarget/release -lvlib -lm -o textures
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./textures [width]   (writes textures.png, 16:10, default 800)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define MARGIN 3.0f  /* world units between a shape and its object's box */
#define RAMP 1.0f    /* F rises from 0.5 on the surface to 1 this far inside */
#define OPACITY 1    /* mapping id: F -> O */

enum { SPHERE, CYLINDER, BOX };

/* A shape: its kind and the world size of its object's box (margins included). */
typedef struct {
    int kind;
    vlfloat size[3];
} Shape;

static vlfloat clamp01(vlfloat v)
{
    return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
}

static vlfloat smooth(vlfloat a, vlfloat b, vlfloat x)
{
    vlfloat t = clamp01((x - a) / (b - a));
    return t * t * (3.0f - 2.0f * t);
}

/* Geometry: F = 0.5 + d / (2 RAMP), d the world distance to the surface, positive inside. The
   sphere and the cylinder read vlaux's distance fields (1 - 2 * distance from the centre or the
   axis, in object units, which the object's x size turns into world units). */
static void solid(vlfloat *p, void *misc)
{
    const Shape *s = (const Shape *)misc;
    vlfloat d, cap;
    int i;
    switch (s->kind) {
    case SPHERE:
        VLU_SPHERE(p, NULL);
        d = 0.5f * vlField(VL_F) * s->size[0] - MARGIN;
        break;
    case CYLINDER:
        VLU_CYLINDER(p, NULL);
        d = 0.5f * vlField(VL_F) * s->size[0] - MARGIN;
        cap = (0.5f - (vlfloat)fabs(p[2] - 0.5f)) * s->size[2] - MARGIN;
        if (cap < d)
            d = cap;
        break;
    default:
        d = 1e9f;
        for (i = 0; i < 3; i++) {
            vlfloat face = (0.5f - (vlfloat)fabs(p[i] - 0.5f)) * s->size[i] - MARGIN;
            if (face < d)
                d = face;
        }
        break;
    }
    vlSet(VL_F, 0.5f + d / (2.0f * RAMP));
}

/* ---- marble ---- */

typedef struct {
    vlfloat dir[3];          /* the direction across the bands, object units */
    vlfloat bands;           /* k: radians per object unit along dir */
    vlfloat warp;            /* w: how far the turbulence folds the bands */
    vlfloat size;            /* the turbulence's base frequency */
    vlint seed;
    vlfloat r[8], g[8], b[8]; /* spline knots from v = 0 (in a vein) to 1 */
} Marble;

static void marble(vlfloat *p, void *misc)
{
    const Marble *m = (const Marble *)misc;
    vlfloat t = vluTurbulence(p, m->size, 6, m->seed);
    vlfloat a = p[0] * m->dir[0] + p[1] * m->dir[1] + p[2] * m->dir[2];
    vlfloat v = (vlfloat)fabs(sin(m->bands * a + m->warp * t));
    vlSet(VL_R, vluSpline(v, 8, m->r));
    vlSet(VL_G, vluSpline(v, 8, m->g));
    vlSet(VL_B, vluSpline(v, 8, m->b));
}

/* White Carrara: thin grey veins in white stone. */
static Marble carrara = {
    {1.0f, 0.7f, 0.35f}, 4.0f, 3.0f, 2.2f, 11,
    {0.32f, 0.32f, 0.62f, 0.84f, 0.92f, 0.95f, 0.96f, 0.96f},
    {0.33f, 0.33f, 0.63f, 0.84f, 0.91f, 0.94f, 0.95f, 0.95f},
    {0.37f, 0.37f, 0.66f, 0.86f, 0.92f, 0.94f, 0.93f, 0.93f}};

/* Verde antico: pale veins in dark green stone. */
static Marble verde = {
    {0.4f, 1.0f, 0.6f}, 3.5f, 3.5f, 2.0f, 5,
    {0.82f, 0.82f, 0.45f, 0.16f, 0.08f, 0.05f, 0.07f, 0.07f},
    {0.88f, 0.88f, 0.62f, 0.34f, 0.22f, 0.16f, 0.20f, 0.20f},
    {0.80f, 0.80f, 0.52f, 0.26f, 0.15f, 0.10f, 0.13f, 0.13f}};

/* ---- wood ---- */

typedef struct {
    int axis;                /* the rings' axis is parallel to object axis `axis` ... */
    vlfloat c[2];            /* ... through these object coordinates on the other two axes */
    vlfloat scale;           /* world units per object unit across the axis */
    vlfloat spacing;         /* world units between rings */
    vlint seed;
} Wood;

static void wood(vlfloat *p, void *misc)
{
    const Wood *w = (const Wood *)misc;
    int u = (w->axis + 1) % 3, v = (w->axis + 2) % 3;
    vlfloat du = p[u] - w->c[0], dv = p[v] - w->c[1], q[3], r, f, late, streak, shade;
    r = (vlfloat)sqrt(du * du + dv * dv) * w->scale;
    r += 1.5f * vluNoise(p, 2.5f, w->seed) + 1.2f * vluTurbulence(p, 6.0f, 3, w->seed + 1);
    f = r / w->spacing;
    f -= (vlfloat)floor(f);
    late = smooth(0.70f, 0.94f, f) * (1.0f - smooth(0.94f, 1.0f, f));
    /* Grain: noise stretched 30 times along the axis. */
    q[u] = p[u] * 60.0f;
    q[v] = p[v] * 60.0f;
    q[w->axis] = p[w->axis] * 2.0f;
    streak = vluNoise(q, 1.0f, w->seed + 2);
    shade = 0.92f + 0.10f * streak;
    vlSet(VL_R, shade * (0.80f - 0.38f * late));
    vlSet(VL_G, shade * (0.58f - 0.32f * late));
    vlSet(VL_B, shade * (0.34f - 0.22f * late));
}

/* The cube's rings: an axis from its front to its back (object z), below it, so the rings show
   as arcs on the front and back (end grain) and as stripes on the top and sides. */
static Wood plank = {2, {0.2f, -0.25f}, 86.0f, 4.5f, 21};
/* The log's rings: its own axis (VLU_CYLINDER's z axis), centred. */
static Wood log_rings = {2, {0.5f, 0.5f}, 62.0f, 3.2f, 31};

/* ---- granite (examples/c/figure2.c's stone, with a tint) ---- */

typedef struct {
    vlfloat tint[3];
    vlint seed;
} Granite;

static void granite(vlfloat *p, void *misc)
{
    const Granite *s = (const Granite *)misc;
    vlfloat t = vluTurbulence(p, 5.0f, 5, s->seed);
    vlfloat warm = 0.5f + 0.5f * vluNoise(p, 2.5f, s->seed + 1);
    vlfloat grain = vluNoise(p, 90.0f, s->seed + 2);
    vlfloat speck = vluNoise(p, 45.0f, s->seed + 3);
    vlfloat shade = 0.42f + 0.35f * (t > 1.0f ? 1.0f : t) + 0.08f * grain;
    vlfloat r = shade * s->tint[0] * (0.88f + 0.22f * warm);
    vlfloat g = shade * s->tint[1] * (0.84f + 0.12f * warm);
    vlfloat b = shade * s->tint[2] * (0.80f + 0.04f * warm);
    if (speck > 0.42f) {                /* dark mica flakes */
        r *= 0.35f; g *= 0.35f; b *= 0.38f;
    } else if (grain > 0.55f) {         /* light quartz grains */
        r = 0.5f * (r + 0.95f); g = 0.5f * (g + 0.93f); b = 0.5f * (b + 0.90f);
    }
    vlSet(VL_R, r);
    vlSet(VL_G, g);
    vlSet(VL_B, b);
}

static Granite grey = {{1.0f, 1.0f, 1.0f}, 1};
static Granite pink = {{1.18f, 0.86f, 0.80f}, 41};

/* ---- the floor ---- */

static void slate(vlfloat *p, void *misc)
{
    vlfloat t = vluTurbulence(p, 7.0f, 4, 51);
    (void)misc;
    vlSet(VL_R, 0.20f + 0.06f * t);
    vlSet(VL_G, 0.22f + 0.06f * t);
    vlSet(VL_B, 0.26f + 0.07f * t);
}

/* ---- the scene ---- */

/* An object: `shape` (its box filled in here from the shape's world size w x h x depth along
   VLU_CYLINDER's axis), turned by rot (degrees), its centre at (x, y, z), textured by
   `texture(misc)`, with a specular coefficient and exponent. */
static void object(Shape *shape, vlfloat sx, vlfloat sy, vlfloat sz, const vlfloat rot[3],
                   vlfloat x, vlfloat y, vlfloat z, void (*texture)(vlfloat *, void *),
                   void *misc, vlfloat ks, vlfloat exponent)
{
    shape->size[0] = sx + 2.0f * MARGIN;
    shape->size[1] = sy + 2.0f * MARGIN;
    shape->size[2] = sz + 2.0f * MARGIN;
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(shape->size[0], shape->size[1], shape->size[2]);
    vlRotate(rot[0], rot[1], rot[2]);
    vlTranslate(x, y, z);
    vlFunction(VL_F, solid, shape);
    vlMap(VL_O, VL_F, OPACITY, 1);
    vlFunction(VL_COLORS, texture, misc);
    vlSet(VL_KA, 0.30);
    vlSet(VL_KD, 0.70);
    vlSet(VL_KS, ks);
    vlSet(VL_N, VLSPECULAR(exponent));
    vlEnd();
}

int main(int argc, char **argv)
{
    static vlfloat opacity[] = {0.35f, 0.0f, 0.5f, 1.0f}; /* VL_RAMP: F -> O, solid above 0.5 */
    static Shape white_ball = {SPHERE, {0}}, wood_cube = {BOX, {0}},
                 pink_ball = {SPHERE, {0}}, column = {CYLINDER, {0}},
                 green_cube = {BOX, {0}}, log_shape = {CYLINDER, {0}},
                 floor_shape = {BOX, {0}};
    static const vlfloat none[3] = {0.0f, 0.0f, 0.0f}, upright[3] = {90.0f, 0.0f, 0.0f},
                         cube_turn[3] = {0.0f, 28.0f, 0.0f}, green_turn[3] = {0.0f, -22.0f, 0.0f},
                         log_turn[3] = {0.0f, 55.0f, 0.0f};
    int width = argc > 1 ? atoi(argv[1]) : 800, height = width * 5 / 8, failed = 0;
    VLCAMERA camera = {{-40.0, 260.0, -500.0}, {0.0, 40.0, 20.0}, {0.0, 1.0, 0.0}, 36.0};
    vlint e;

    if (width < 16) {
        fprintf(stderr, "usage: %s [width >= 16]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlMapping(OPACITY, VL_RAMP, 2, 1, opacity);
    vlScene();
    vlCamera(&camera);
    vlImage("textures.png", (vlfloat)width / height, width, height);
    vlBackground(0.55, 0.60, 0.68);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-300.0, 500.0, -400.0, VL_NOATTENUATION, 1.0, 0.97, 0.92, 0.9);
    vlSuperSample(2);
    vlStepSize(0.5, 1.0);

    /* The floor: a slab whose top is at y = 0. */
    object(&floor_shape, 560.0f, 10.0f, 380.0f, none, 0.0f, -5.0f, 30.0f, slate, NULL, 0.15f,
           10.0f);
    /* Front row. */
    object(&white_ball, 96.0f, 96.0f, 96.0f, none, -150.0f, 48.0f, -60.0f, marble, &carrara,
           0.55f, 60.0f);
    object(&wood_cube, 80.0f, 80.0f, 80.0f, cube_turn, 0.0f, 40.0f, -70.0f, wood, &plank, 0.30f,
           25.0f);
    object(&pink_ball, 84.0f, 84.0f, 84.0f, none, 150.0f, 42.0f, -60.0f, granite, &pink, 0.40f,
           40.0f);
    /* Back row: the column stands on end (VLU_CYLINDER's z axis turned upright). */
    object(&column, 64.0f, 64.0f, 150.0f, upright, -110.0f, 75.0f, 110.0f, granite, &grey, 0.35f,
           30.0f);
    object(&green_cube, 90.0f, 90.0f, 90.0f, green_turn, 30.0f, 45.0f, 110.0f, marble, &verde,
           0.55f, 60.0f);
    object(&log_shape, 56.0f, 56.0f, 130.0f, log_turn, 175.0f, 28.0f, 90.0f, wood, &log_rings,
           0.20f, 15.0f);
    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
