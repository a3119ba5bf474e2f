/* Smoke: a hypertexture (Perlin & Hoffert) in a cylinder, in the manner of the legacy vlib
 * demos: smoke rising from a brick chimney.
 *
 * The smoke is one object, the unit cube scaled to a tall box and turned upright with
 * vlRotate(90., 0., 0.): VLU_CYLINDER's axis is the object's z axis, and the rotation stands it
 * on end (object z = 0 goes to the top, z = 1 to the bottom). Its program is the demo's:
 *   vlFunction(VL_F, VLU_CYLINDER, 0);             F: the cylinder's distance field
 *   vlFunction(VL_O | VL_COLORS, smoke, 0);        reads F through vlField(VL_F)
 *   vlSet(VL_F, 0.);                               no geometry: the smoke is lit evenly
 * `smoke` turns F back into the distance rho from the axis and builds the density from it: a
 * plume that widens with height, with its edge and inside broken up by turbulence (drifting
 * with height so that the eddies lean downwind), thinning out towards the top. Outside the plume
 * the value it writes is negative; vlSet clamps it to 0, as the demo relies on. With F set to 0
 * everywhere the gradient vanishes and the smoke is lit isotropically (docs/compat.md), as a
 * scattering medium is: the diffuse term would be the same at every point, so the smoke takes
 * all its light from the ambient term (ka = 1, kd = 0), which also spares the renderer the
 * normals it would otherwise estimate, by central differences of the whole program, wherever
 * kd > 0. The opacity is low per unit: vlStepSize(1., 15.), the demo's, makes an opacity o
 * accumulate over 15 world units, and the densest smoke is o = 0.5. The turbulence is skipped
 * where no value it can take (it is below 2) would bring the density above 0.
 *
 * The chimney is a solid box of bricks (field functions for its geometry and colour, the
 * bricks laid in courses by world position) with a dark opening at the top.
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/smoke.c -Iinclude -Ltarget/release -lvlib -lm -o smoke
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./smoke [width]   (writes smoke.png, 3:4, default 480 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define D 160.0f      /* the smoke cylinder's diameter, world units */
#define H 320.0f      /* its height */
#define CW 56.0f      /* the chimney's width and depth */
#define CH 90.0f      /* its height (its top at y = 0) */
#define MARGIN 2.0f   /* world units between the chimney and its object's box */
#define OPACITY 1     /* mapping id: the chimney's F -> O */

static vlfloat clamp01(vlfloat v)
{
    return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
}

/* The smoke's density from F (VLU_CYLINDER's 1 - 2 rho) and the point. */
static void smoke(vlfloat *p, void *misc)
{
    vlfloat rho = 0.5f * (1.0f - vlField(VL_F)); /* distance from the axis, object units */
    vlfloat h = 1.0f - p[2];                     /* height: 0 at the chimney, 1 at the top */
    vlfloat q[3], t, big, width, edge, density, fade;
    (void)misc;
    /* Turbulence in world-proportional coordinates (object z spans H / D times as much),
       sheared with height so the eddies lean. */
    q[0] = p[0] + 0.25f * h;
    q[1] = p[1];
    q[2] = p[2] * (H / D);
    big = vluNoise(q, 1.2f, 8);            /* -1 .. 1: slow swelling of the plume */
    width = 0.07f + 0.38f * h + 0.06f * big * h;
    edge = 1.0f - rho / width;             /* 1 on the axis, 0 at the plume's nominal edge */
    if (edge < -1.1f * (2.0f - 0.45f)) {   /* no turbulence (< 2) reaches this far out */
        vlSet(VL_O, 0.0f);
        return;
    }
    t = vluTurbulence(q, 2.2f, 5, 7);      /* 0 .. ~1 */
    density = edge + 1.1f * (t - 0.45f);   /* turbulence eats into the edge and the inside */
    fade = 1.0f - h * h * h;               /* thinner as it rises */
    if (h < 0.03f)                         /* the plume starts inside the chimney's mouth */
        fade *= h / 0.03f;
    vlSet(VL_O, 0.5f * density * fade - 0.02f); /* negative outside: clamped to 0 */
    /* Greyer and darker low down (fresh smoke), paler above. */
    vlSet(VL_R, 0.55f + 0.35f * h + 0.05f * t);
    vlSet(VL_G, 0.54f + 0.34f * h + 0.05f * t);
    vlSet(VL_B, 0.54f + 0.32f * h + 0.05f * t);
}

/* The chimney's geometry: F = 0.5 + d / 2, d the world distance to the nearest face of the
   stack (positive inside), with the opening at the top: a shaft 60% of the width, 20 deep. */
static void stack(vlfloat *p, void *misc)
{
    vlfloat w[3], d, shaft, depth;
    (void)misc;
    w[0] = (p[0] - 0.5f) * (CW + 2.0f * MARGIN);
    w[1] = (p[1] - 1.0f) * (CH + 2.0f * MARGIN) + MARGIN; /* 0 at the top face */
    w[2] = (p[2] - 0.5f) * (CW + 2.0f * MARGIN);
    d = 0.5f * CW - (vlfloat)fabs(w[0]);
    if (0.5f * CW - (vlfloat)fabs(w[2]) < d)
        d = 0.5f * CW - (vlfloat)fabs(w[2]);
    if (-w[1] < d)
        d = -w[1];
    if (CH + w[1] < d)
        d = CH + w[1];
    /* The opening: outside the shaft's walls or below its floor is solid. */
    shaft = (vlfloat)fabs(w[0]) > (vlfloat)fabs(w[2]) ? (vlfloat)fabs(w[0]) : (vlfloat)fabs(w[2]);
    shaft = shaft - 0.3f * CW;             /* > 0 in the walls */
    depth = -w[1] - 20.0f;                 /* > 0 below the shaft's floor */
    if (shaft < 0.0f && depth < 0.0f) {
        vlfloat inside = shaft > depth ? shaft : depth; /* < 0: distance into the hole */
        if (inside < d)
            d = inside;
    }
    vlSet(VL_F, 0.5f + 0.5f * d);
}

/* Bricks in courses of 8 world units, 22 long, joints offset every other course; mortar 1.2
   wide. Coloured by world position, so the courses run round the corners. */
static void bricks(vlfloat *p, void *misc)
{
    vlfloat w[3], along, row, col, fr, fc, mortar, t, r, g, b;
    int course;
    (void)p;
    (void)misc;
    vlPosition(w);
    row = (w[1] + 200.0f) / 8.0f;
    course = (int)floor(row);
    fr = (row - course) * 8.0f;            /* world units into the course */
    along = fabs(w[0]) > fabs(w[2]) ? w[2] : w[0];
    col = (along + 200.0f + (course % 2) * 11.0f) / 22.0f;
    fc = (col - (vlfloat)floor(col)) * 22.0f;
    mortar = fr < 1.2f || fc < 1.2f;
    t = vluTurbulence(w, 0.08f, 4, 61);
    {
        /* Each brick its own shade. */
        vlfloat cell[3];
        cell[0] = (vlfloat)floor(col) * 7.3f;
        cell[1] = (vlfloat)course * 3.1f;
        cell[2] = 0.5f;
        t = 0.75f * t + 0.25f * (0.5f + 0.5f * vluNoise(cell, 0.37f, 62));
    }
    if (mortar) {
        r = 0.55f; g = 0.53f; b = 0.50f;
    } else {
        r = 0.46f + 0.22f * t; g = 0.18f + 0.08f * t; b = 0.12f + 0.05f * t;
    }
    if (w[1] > -20.5f && fabs(w[0]) < 0.3f * CW + 0.5f && fabs(w[2]) < 0.3f * CW + 0.5f) {
        r = 0.08f; g = 0.07f; b = 0.07f;   /* soot in the opening */
    }
    vlSet(VL_R, clamp01(r));
    vlSet(VL_G, clamp01(g));
    vlSet(VL_B, clamp01(b));
}

int main(int argc, char **argv)
{
    static vlfloat opacity[] = {0.35f, 0.0f, 0.5f, 1.0f}; /* VL_RAMP: F -> O, solid above 0.5 */
    int width = argc > 1 ? atoi(argv[1]) : 480, height = width * 4 / 3, failed = 0;
    VLCAMERA camera = {{-50.0, 30.0, -420.0}, {0.0, 125.0, 0.0}, {0.0, 1.0, 0.0}, 46.0};
    vlint e;

    if (width < 12) {
        fprintf(stderr, "usage: %s [width >= 12]\n", argv[0]);
        return 2;
    }
    vlInit();
    vlMapping(OPACITY, VL_RAMP, 2, 1, opacity);
    vlScene();
    vlCamera(&camera);
    vlImage("smoke.png", (vlfloat)width / height, width, height);
    vlBackground(0.16, 0.20, 0.30);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-400.0, 400.0, -300.0, VL_NOATTENUATION, 1.0, 0.95, 0.85, 1.0);

    /* The chimney (its top face at y = 0), sampled finely: it is solid. */
    vlStepSize(0.5, 1.0);
    vlObject();
    vlTranslate(-0.5, -1.0, -0.5);
    vlScale(CW + 2.0f * MARGIN, CH + 2.0f * MARGIN, CW + 2.0f * MARGIN);
    vlTranslate(0.0, MARGIN, 0.0);
    vlFunction(VL_F, stack, NULL);
    vlMap(VL_O, VL_F, OPACITY, 1);
    vlFunction(VL_COLORS, bricks, NULL);
    vlSet(VL_KA, 0.35);
    vlSet(VL_KD, 0.75);
    vlEnd();

    /* The smoke: the demo's step, and the cylinder turned upright. */
    vlStepSize(1., 15.);
    vlObject();
    vlTranslate(-.5, -.5, -.5);
    vlScale(D, D, H);
    vlRotate(90., 0., 0.);
    vlTranslate(0.0, 0.5f * H - 12.0f, 0.0); /* its bottom 12 units down the chimney's shaft */
    vlFunction(VL_F, VLU_CYLINDER, 0);
    vlFunction(VL_O | VL_COLORS, smoke, 0);
    vlSet(VL_F, 0.);
    vlSet(VL_KA, 1.0); /* lit evenly: see above */
    vlEnd();

    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
