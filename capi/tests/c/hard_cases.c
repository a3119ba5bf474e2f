/* Numerical hard cases through the C interface (issue #7, item 4): rays that graze faces, run
 * along edges and touch corners; cameras inside objects, on their faces and at lights;
 * near-singular and absurd transforms; field functions returning NaN, +-Inf and +-1e30; zero
 * gradients; steps from 1e-4 to 1e6 of the object's size; opacity references near 0 and huge;
 * mapping tables with a_1 = 0 or a_n = 1; 16-bit datasets at the extremes of a and b; DSR, MIP
 * and secondary rays on hostile fields.
 *
 * Each case is one scene rendered to a small image in the directory argv[1] (default "."),
 * named "<nn>_<case>.ppm" (one also as .png); after each scene vlError must report exactly the
 * expected codes (usually none). One line per case; exits non-zero if any case reported
 * something unexpected. capi/tests/hard_cases.rs runs it with 1 and 2 rendering threads,
 * checks that the images are byte-identical, and checks the values the comments below predict
 * (the "probe" cases). Also run by c_examples.rs (in ".") and under valgrind by memcheck.rs.
 *
 * The probe: a slab, the unit cube scaled to S x S x L with its front face z = 0 centred on the
 * z axis, seen head-on from (0, 0, -2S) (fov 20: the slab fills the image), lit by ambient light
 * only, white, ka = 1, over a black background. Its pixels are 1 - T with the Beer-Lambert
 * transmittance T = (1 - o)^(length / reference), exact for any step (docs/compat.md); the
 * centre pixel's ray (odd image sides) runs exactly along the axis, length L. With
 * reference = L, the centre pixel is the opacity o itself.
 *
 * C89 plus POSIX mkdir. Each case is small (9 x 9 pixels, a few samples per ray; the 1e-4 step
 * cases take 10^4 samples per ray), so that the program runs in well under a second, and in
 * seconds under valgrind. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <vlib.h>
#include <vlaux.h>

#define N 9          /* image side of most cases (odd: the centre pixel's ray is the axis) */
#define S 100.0f     /* the probe's width and height */
#define L 100.0f     /* the probe's depth */

static const char *outdir = ".";
static int cases = 0;
static int failures = 0;

/* ---- field, normal and spatial functions ---- */

/* Writes the float misc points to into every field the vlFunction call named. */
static void constant(vlfloat *p, void *misc)
{
    (void)p;
    vlSet(VL_ALLFIELDS, *(const vlfloat *)misc);
}

/* NaN, +Inf, -Inf, +1e30 and -1e30, computed at run time (no constant folding of 0/0). */
static vlfloat hostile[5];

/* The geometry of stability.rs: one hostile value on the half x < 0.5, another times the sphere
   field on the other half; misc points to two indices into hostile[]. */
static void halves(vlfloat *p, void *misc)
{
    const int *which = (const int *)misc;
    vlfloat dx = p[0] - 0.5f, dy = p[1] - 0.5f, dz = p[2] - 0.5f;
    vlfloat sphere = 1.0f - 2.0f * (vlfloat)sqrt(dx * dx + dy * dy + dz * dz);
    if (p[0] < 0.5f)
        vlSet(VL_F, hostile[which[0]]);
    else
        vlSet(VL_F, hostile[which[1]] * sphere);
}

/* Opacity, colours, ks and rf from F, hostile where F is. */
static void from_f(vlfloat *p, void *misc)
{
    vlfloat f = vlField(VL_F);
    (void)p;
    (void)misc;
    vlSet(VL_O, 0.7f * f + 0.1f);
    vlSet(VL_COLORS, f);
    vlSet(VL_KS, 0.5f);
    vlSet(VL_RF, 0.3f);
}

/* A wedge of medium: opacity misc[0] where z < x (object space), 0 elsewhere; a ray along z at
   x = X crosses depth X of it. */
static void wedge(vlfloat *p, void *misc)
{
    vlSet(VL_O, p[2] < p[0] ? *(const vlfloat *)misc : 0.0f);
}

/* A normal function that ruins the normal. */
static void nan_normal(vlfloat *n, vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    n[0] = hostile[0];
    n[1] = hostile[1];
    n[2] = hostile[2];
}

/* ---- building blocks ---- */

static void camera(vlfloat ex, vlfloat ey, vlfloat ez, vlfloat ax, vlfloat ay, vlfloat az,
                   vlfloat ux, vlfloat uy, vlfloat uz, vlfloat fov)
{
    VLCAMERA c;
    c.eye[0] = ex;
    c.eye[1] = ey;
    c.eye[2] = ez;
    c.at[0] = ax;
    c.at[1] = ay;
    c.at[2] = az;
    c.up[0] = ux;
    c.up[1] = uy;
    c.up[2] = uz;
    c.fov = fov;
    vlCamera(&c);
}

/* Opens a scene writing `image` (w x h) with the probe's camera for a slab of width s, a black
   background and white ambient light. The camera looks at (0, 0, 1), along +z whatever s is. */
static void probe_scene(const char *image, int w, int h, vlfloat s)
{
    vlScene();
    vlImage(image, (vlfloat)w / (vlfloat)h, w, h);
    camera(0.0f, 0.0f, -2.0f * s, 0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 20.0f);
    vlBackground(BLACK);
    vlAmbient(WHITE, 1.0);
}

/* Places the object as the probe's slab, s x s x l, front face z = 0 centred on the z axis. */
static void slab(vlfloat s, vlfloat l)
{
    vlTranslate(-0.5f, -0.5f, 0.0f);
    vlScale(s, s, l);
}

/* The probe's material: white, ka = 1, opacity o. */
static void white(vlfloat o)
{
    vlSet(VL_O, o);
    vlSet(VL_COLORS, 1.0f);
    vlSet(VL_KA, 1.0f);
}

/* A complete probe: a slab of opacity o with the given step and reference; centre pixel
   1 - (1 - o)^(L / reference). */
static void probe(const char *image, vlfloat o, vlfloat step, vlfloat reference)
{
    probe_scene(image, N, N, S);
    vlStepSize(step, reference);
    vlObject();
    slab(S, L);
    white(o);
    vlEnd();
    vlEnd();
}

/* A DSR sphere of radius 25 (VLU_SPHERE's 0.5 iso-surface in a cube of 100) centred on the
   origin, in an open scene. */
static void dsr_sphere(vlfloat o, vlfloat ka, vlfloat kd, vlfloat ks)
{
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5f);
    vlObject();
    vlTranslate(-0.5f, -0.5f, -0.5f);
    vlScale(100.0f, 100.0f, 100.0f);
    vlFunction(VL_F, VLU_SPHERE, NULL);
    vlSet(VL_O, o);
    vlSet(VL_R, 0.2f);
    vlSet(VL_G, 0.6f);
    vlSet(VL_B, 1.0f);
    vlSet(VL_KA, ka);
    vlSet(VL_KD, kd);
    vlSet(VL_KS, ks);
    vlSet(VL_N, VLSPECULAR(20));
    vlEnd();
}

/* ---- .vlb files ---- */

static void put_u32(FILE *f, unsigned long v)
{
    fputc((int)(v & 0xff), f);
    fputc((int)((v >> 8) & 0xff), f);
    fputc((int)((v >> 16) & 0xff), f);
    fputc((int)((v >> 24) & 0xff), f);
}

static void put_f32(FILE *f, float v)
{
    unsigned long bits = 0, one = 1;
    unsigned char b[4];
    int i, little = *(unsigned char *)&one == 1;
    memcpy(b, &v, 4); /* the host's float, assumed IEEE 754; byte order fixed here */
    for (i = 0; i < 4; i++)
        bits |= (unsigned long)b[little ? i : 3 - i] << (8 * i);
    put_u32(f, bits);
}

/* Writes a 2 x 2 x 2 dataset of 16-bit voxels (little-endian), alternately v0 and v1, with
   normalisation a, b, into the output directory; returns its path. */
static const char *write_u16(const char *name, unsigned v0, unsigned v1, float a, float b)
{
    static char path[1024];
    FILE *f;
    int i;
    sprintf(path, "%s/%s", outdir, name);
    f = fopen(path, "wb");
    if (f == NULL) {
        printf("cannot write %s\n", path);
        exit(2);
    }
    fwrite("VLB1", 1, 4, f);
    put_u32(f, 2);
    put_u32(f, 2);
    put_u32(f, 2);
    put_u32(f, 2);
    put_f32(f, a);
    put_f32(f, b);
    for (i = 0; i < 8; i++) {
        unsigned v = i % 2 ? v1 : v0;
        fputc((int)(v & 0xff), f);
        fputc((int)((v >> 8) & 0xff), f);
    }
    fclose(f);
    return path;
}

/* A probe whose opacity is dataset `id` (loaded from `file`) through `interp`. */
static void dataset_probe(const char *image, const char *file, vlint interp)
{
    vlLoad(7, file);
    probe_scene(image, N, N, S);
    vlStepSize(L / 10.0f, L);
    vlInterpolationType(interp);
    vlObject();
    slab(S, L);
    white(0.0f);
    vlDataset(VL_O, 7);
    vlEnd();
    vlEnd();
    vlUnload(7);
}

/* ---- the cases ---- */

/* Runs one case: `build` renders one scene into `<outdir>/<nn>_<name>`; then vlError must give
   `want` (VL_NOERROR: nothing) and nothing more. */
static void run(const char *name, void (*build)(const char *image), vlint want)
{
    char image[1024];
    vlint got, e;
    long extra = 0;
    int ok;
    cases++;
    sprintf(image, "%s/%02d_%s", outdir, cases, name);
    build(image);
    got = vlError();
    while ((e = vlError()) != VL_NOERROR)
        extra++;
    ok = got == want && extra == 0;
    if (!ok)
        failures++;
    printf("case %2d %-4s %-30s want %2d, got %2d%s (%s)\n", cases, ok ? "ok" : "FAIL", name,
           (int)want, (int)got, extra ? " and more" : "", vlErrorString(got));
}

/* Steps and references. */
static void c_baseline(const char *image) { probe(image, 0.5f, L / 10.0f, L); }
static void c_step_tiny(const char *image) { probe(image, 0.5f, 1e-4f * L, L); }
static void c_step_huge(const char *image) { probe(image, 0.5f, 1e6f * L, L); }
static void c_step_odd(const char *image) { probe(image, 0.5f, 0.3f * L, L); } /* 3.33 steps */
static void c_reference_tiny(const char *image) { probe(image, 0.5f, L / 10.0f, 1e-30f); }
static void c_reference_subnormal(const char *image) { probe(image, 0.5f, L / 10.0f, 1e-45f); }
static void c_reference_huge(const char *image) { probe(image, 0.5f, L / 10.0f, 1e30f); }
static void c_reference_max(const char *image) { probe(image, 0.5f, L / 10.0f, FLT_MAX); }
static void c_opacity_one(const char *image) { probe(image, 1.0f, L / 10.0f, 1e30f); }

/* Absurd sizes: the probe at 10^30 and 10^-30 world units, with step and reference scaled. */
static void scaled_probe(const char *image, vlfloat k)
{
    probe_scene(image, N, N, S * k);
    vlStepSize(L * k / 10.0f, L * k);
    vlObject();
    slab(S * k, L * k);
    white(0.5f);
    vlEnd();
    vlEnd();
}
static void c_scale_1e30(const char *image) { scaled_probe(image, 1e28f); }
static void c_scale_1e_30(const char *image) { scaled_probe(image, 1e-32f); }

/* Cameras inside the slab, on its faces, and rays that graze it. Probe material o = 0.75
   inside (half the depth: T = 0.25^0.5 = 0.5); the others o = 0.5. */
static void camera_probe(const char *image, vlfloat o, vlfloat ex, vlfloat ey, vlfloat ez,
                         vlfloat ax, vlfloat ay, vlfloat az)
{
    probe_scene(image, N, N, S);
    camera(ex, ey, ez, ax, ay, az, 0.0f, 1.0f, 0.0f, 20.0f);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    white(o);
    vlEnd();
    vlEnd();
}
static void c_camera_inside(const char *image)
{
    camera_probe(image, 0.75f, 0.0f, 0.0f, 0.5f * L, 0.0f, 0.0f, L);
}
static void c_camera_on_front_face(const char *image)
{
    camera_probe(image, 0.5f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, L);
}
static void c_camera_on_back_face(const char *image)
{
    camera_probe(image, 0.5f, 0.0f, 0.0f, L, 0.0f, 0.0f, 2.0f * L);
}
static void c_camera_on_corner(const char *image)
{
    camera_probe(image, 0.5f, 0.5f * S, 0.5f * S, 0.0f, 0.5f * S, 0.5f * S, L);
}
static void c_graze_face(const char *image)
{
    camera_probe(image, 0.5f, 0.0f, 0.5f * S, -2.0f * S, 0.0f, 0.5f * S, 0.0f);
}
static void c_along_edge(const char *image)
{
    camera_probe(image, 0.5f, 0.5f * S, 0.5f * S, -2.0f * S, 0.5f * S, 0.5f * S, 0.0f);
}
/* Along the body diagonal, from corner (-S/2, -S/2, 0) to corner (S/2, S/2, L): the centre ray
   enters and leaves through corners; length 100 sqrt 3, T = 0.5^sqrt 3. */
static void c_through_corners(const char *image)
{
    camera_probe(image, 0.5f, -150.0f, -150.0f, -100.0f, 50.0f, 50.0f, 100.0f);
}
/* Rays that touch the slab in one corner or along one edge only (length 0: background). */
static void c_touch_corner(const char *image)
{
    camera_probe(image, 0.5f, -150.0f, -150.0f, 100.0f, -50.0f, -50.0f, 0.0f);
}
static void c_touch_edge(const char *image)
{
    camera_probe(image, 0.5f, -150.0f, 0.0f, 100.0f, -50.0f, 0.0f, 0.0f);
}

/* Cameras: a tiny and a huge field of view, an up vector nearly along the view, a subnormal
   up vector; the centre pixel is the probe's in every case. */
static void fov_probe(const char *image, vlfloat ux, vlfloat uy, vlfloat uz, vlfloat fov)
{
    probe_scene(image, N, N, S);
    camera(0.0f, 0.0f, -2.0f * S, 0.0f, 0.0f, 0.0f, ux, uy, uz, fov);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    white(0.5f);
    vlEnd();
    vlEnd();
}
static void c_fov_tiny(const char *image) { fov_probe(image, 0.0f, 1.0f, 0.0f, 1e-4f); }
static void c_fov_wide(const char *image) { fov_probe(image, 0.0f, 1.0f, 0.0f, 179.99f); }
static void c_up_near_view(const char *image) { fov_probe(image, 0.0f, 1e-6f, 1.0f, 20.0f); }
static void c_up_subnormal(const char *image) { fov_probe(image, 1e-45f, 0.0f, 0.0f, 20.0f); }

/* Transforms. */
static void transform_probe(const char *image, int which)
{
    /* Columns (1, 0, 0) and (1, 1e-5, 0): nearly parallel, accepted; with 1e-14 refused. */
    static const vlfloat sliver[16] = {1, 1, 0, 0, 0, 1e-5f, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    static const vlfloat flat[16] = {1, 1, 0, 0, 0, 1e-14f, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    probe_scene(image, N, N, S);
    vlStepSize(L / 10.0f, L);
    vlObject();
    switch (which) {
    case 0: /* the sliver */
        vlMatrix(sliver);
        slab(S, L);
        break;
    case 1: /* refused: the probe stays */
        slab(S, L);
        vlMatrix(flat);
        break;
    case 2: /* mirrored in x: the same box */
        vlTranslate(-0.5f, -0.5f, 0.0f);
        vlScale(-S, S, L);
        break;
    case 3: /* absurd angles */
        vlTranslate(-0.5f, -0.5f, -0.5f);
        vlRotate(1e7f, -3.6e9f, 7.2e8f);
        vlScale(S, S, L);
        vlTranslate(0.0f, 0.0f, 0.5f * L);
        break;
    case 4: /* far from the origin, the camera with it (f32 spacing there: 1) */
        slab(S, L);
        vlTranslate(1e7f, -1e7f, 1e7f);
        break;
    case 5: /* a slab 10^-6 thick */
        slab(S, 1e-6f * L);
        break;
    }
    white(0.5f);
    vlEnd();
    if (which == 4)
        camera(1e7f, -1e7f, 1e7f - 2.0f * S, 1e7f, -1e7f, 1e7f, 0.0f, 1.0f, 0.0f, 20.0f);
    vlEnd();
}
static void c_matrix_sliver(const char *image) { transform_probe(image, 0); }
static void c_matrix_singular(const char *image) { transform_probe(image, 1); }
static void c_mirror(const char *image) { transform_probe(image, 2); }
static void c_absurd_angles(const char *image) { transform_probe(image, 3); }
static void c_far_away(const char *image) { transform_probe(image, 4); }
static void c_paper_thin(const char *image) { transform_probe(image, 5); }

/* Field functions writing hostile values to every field of a probe slab, with a point light:
   NaN, -Inf and -1e30 clamp to 0 (nothing there: background); +Inf and 1e30 to 1 (opaque and
   white, lit beyond 1: 255). */
static void hostile_probe(const char *image, int k)
{
    probe_scene(image, N, N, S);
    vlPointLight(-100.0f, 100.0f, -200.0f, VL_INVERSESQUARE, WHITE, 1e30f);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    vlFunction(VL_ALLFIELDS, constant, &hostile[k]);
    vlEnd();
    vlEnd();
}
static void c_field_nan(const char *image) { hostile_probe(image, 0); }
static void c_field_inf(const char *image) { hostile_probe(image, 1); }
static void c_field_neg_inf(const char *image) { hostile_probe(image, 2); }
static void c_field_1e30(const char *image) { hostile_probe(image, 3); }
static void c_field_neg_1e30(const char *image) { hostile_probe(image, 4); }

/* The NaN scene written as PNG and PPM from one scene. */
static void c_field_nan_png(const char *image)
{
    char png[1024];
    strcpy(png, image);
    strcpy(png + strlen(png) - 3, "png"); /* x.ppm -> x.png */
    probe_scene(png, N, N, S);
    vlImage(image, 1.0f, N, N);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    vlFunction(VL_ALLFIELDS, constant, &hostile[0]);
    vlEnd();
    vlEnd();
}

/* Zero gradient: F is NaN (0) everywhere, the slab opaque, white, ka = 0, kd = 0.5, ks = 1:
   lit isotropically, N.L = 1 and no highlight, so every slab pixel is 0.5 (one light, no
   attenuation, intensity 1). */
static void c_zero_gradient(const char *image)
{
    probe_scene(image, N, N, S);
    vlPointLight(-100.0f, 100.0f, -200.0f, VL_NOATTENUATION, WHITE, 1.0f);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    vlFunction(VL_F, constant, &hostile[0]);
    white(1.0f);
    vlSet(VL_KA, 0.0f);
    vlSet(VL_KD, 0.5f);
    vlSet(VL_KS, 1.0f);
    vlSet(VL_N, VLSPECULAR(10));
    vlEnd();
    vlEnd();
}

/* A normal function that writes NaN: a non-finite normal counts as none, so the sample is lit
   isotropically, ka C + kd C = 1 with ka = kd = 0.5, and the slab's centre pixel is 0.5. */
static void c_normal_nan(const char *image)
{
    probe_scene(image, N, N, S);
    vlPointLight(-100.0f, 100.0f, -200.0f, VL_NOATTENUATION, WHITE, 1.0f);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    vlFunction(VL_F, VLU_SPHERE, NULL);
    white(0.5f);
    vlSet(VL_KA, 0.5f);
    vlSet(VL_KD, 0.5f);
    vlNormal(nan_normal, NULL);
    vlEnd();
    vlEnd();
}

/* Mapping tables with a_1 = 0 and a_n = 1, on constant F (centre pixel = the opacity):
   ramp {(0, 0.2), (1, 0.8)}: F = 0 -> 0, F = 0.5 -> 0.5, F = 1 -> 0.8;
   lookup {(0, 0.9), (1, 0.6)}: F = 0 -> 0, F = 1 -> 0.6. */
static void mapping_probe(const char *image, vlint id, vlfloat f)
{
    probe_scene(image, N, N, S);
    vlStepSize(L / 10.0f, L);
    vlObject();
    slab(S, L);
    white(0.0f);
    vlSet(VL_F, f);
    vlMap(VL_O, VL_F, id, 1);
    vlEnd();
    vlEnd();
}
static void c_ramp_f0(const char *image) { mapping_probe(image, 1, 0.0f); }
static void c_ramp_fhalf(const char *image) { mapping_probe(image, 1, 0.5f); }
static void c_ramp_f1(const char *image) { mapping_probe(image, 1, 1.0f); }
static void c_lookup_f0(const char *image) { mapping_probe(image, 2, 0.0f); }
static void c_lookup_f1(const char *image) { mapping_probe(image, 2, 1.0f); }

/* 16-bit datasets at the extremes of a and b (centre pixel = the normalised value):
   a = -FLT_MAX, b = FLT_MAX: every voxel 0.5 (b - a overflows float, not double);
   a = 0, b = 65535, voxels 65535: 1;  a = 65535, b = 0 (inverted), voxels 0: 1;
   a = 0, b = 1e-30, voxels 1: clamped to 1;  a = 1, b = the next float, voxels 1: 0;
   voxels 0 and 65535 alternating under the tricubic filter: in [0, 1], finite. */
static void c_u16_widest(const char *image)
{
    dataset_probe(image, write_u16("widest.vlb", 0, 65535, -FLT_MAX, FLT_MAX), VL_TRILINEAR);
}
static void c_u16_full(const char *image)
{
    dataset_probe(image, write_u16("full.vlb", 65535, 65535, 0.0f, 65535.0f), VL_NEAREST);
}
static void c_u16_inverted(const char *image)
{
    dataset_probe(image, write_u16("inverted.vlb", 0, 0, 65535.0f, 0.0f), VL_TRILINEAR);
}
static void c_u16_tiny_range(const char *image)
{
    dataset_probe(image, write_u16("tiny.vlb", 1, 1, 0.0f, 1e-30f), VL_TRICUBIC);
}
static void c_u16_ulp_range(const char *image)
{
    dataset_probe(image, write_u16("ulp.vlb", 1, 1, 1.0f, 1.00000012f), VL_TRILINEAR);
}
static void c_u16_checker_cubic(const char *image)
{
    dataset_probe(image, write_u16("checker.vlb", 0, 65535, 0.0f, 65535.0f), VL_TRICUBIC);
}

/* DSR. The sphere from inside: every ray crosses it once, so every pixel is ka C =
   (0.2, 0.6, 1) (o = 1, ambient only). */
static void c_dsr_camera_inside(const char *image)
{
    probe_scene(image, N, N, S);
    camera(0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 60.0f);
    vlStepSize(1.0f, 1.0f);
    dsr_sphere(1.0f, 1.0f, 0.0f, 0.0f);
    vlEnd();
}

/* The sphere from outside with the light at the eye: at the centre pixel N.L = 1 and R.V = 1,
   so the colour is kd C + ks = 0.5 (0.2, 0.6, 1) + 0.25. `attenuation`: VL_NOATTENUATION with
   intensity 1, or VL_INVERSESQUARE with intensity 175^2 (the hit is 175 from the light). */
static void light_at_eye(const char *image, vlint attenuation, vlfloat intensity, int shadows)
{
    probe_scene(image, N, N, S);
    camera(0.0f, 0.0f, -200.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 20.0f);
    vlPointLight(0.0f, 0.0f, -200.0f, attenuation, WHITE, intensity);
    vlStepSize(1.0f, 1.0f);
    vlToggle(VL_CASTSHADOWS, shadows);
    vlToggle(VL_RECEIVESHADOWS, shadows);
    dsr_sphere(1.0f, 0.0f, 0.5f, 0.25f);
    vlEnd();
}
static void c_dsr_light_at_eye(const char *image)
{
    light_at_eye(image, VL_NOATTENUATION, 1.0f, VL_FALSE);
}
static void c_dsr_light_inverse_square(const char *image)
{
    light_at_eye(image, VL_INVERSESQUARE, 175.0f * 175.0f, VL_FALSE);
}
static void c_dsr_light_at_eye_shadows(const char *image)
{
    light_at_eye(image, VL_NOATTENUATION, 1.0f, VL_TRUE);
}

/* The sphere seen head-on from (0, 0, -200) at extreme steps (1e-4 and 1e6 of its cube): the
   centre pixel is ka C. */
static void dsr_step(const char *image, vlfloat step)
{
    probe_scene(image, N, N, S);
    camera(0.0f, 0.0f, -200.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 20.0f);
    vlStepSize(step, 1.0f);
    dsr_sphere(1.0f, 1.0f, 0.0f, 0.0f);
    vlEnd();
}
static void c_dsr_step_tiny(const char *image) { dsr_step(image, 1e-4f * 100.0f); }
static void c_dsr_step_huge(const char *image) { dsr_step(image, 1e6f * 100.0f); }

/* F on the iso-value everywhere (+0 above the threshold: the box's faces are the surface), and
   F NaN (0: no surface at all, background). */
static void dsr_constant(const char *image, vlfloat *value)
{
    probe_scene(image, N, N, S);
    vlStepSize(L / 10.0f, L);
    vlRenderType(VL_DSR);
    vlSurface(VL_F, 0.5f);
    vlObject();
    slab(S, L);
    vlFunction(VL_F, constant, value);
    white(1.0f);
    vlEnd();
    vlEnd();
}
static vlfloat half = 0.5f;
static void c_dsr_on_threshold(const char *image) { dsr_constant(image, &half); }
static void c_dsr_nan(const char *image) { dsr_constant(image, &hostile[0]); }

/* Hostile halves with everything switched on: DSR, shadows, reflections, refraction, super-
   sampling, a light inside the object at the eye. Finite and thread-independent is all. */
static void everything(const char *image, vlint type, int a, int b, vlfloat eye_z)
{
    static int pairs[4][2] = {{0, 1}, {1, 3}, {2, 4}, {3, 0}};
    int *pair = pairs[(a * 2 + b) % 4];
    vlint f;
    probe_scene(image, 7, 5, S);
    camera(10.0f, 20.0f, eye_z, 0.0f, 0.0f, 50.0f, 0.0f, 1.0f, 0.0f, 50.0f);
    vlPointLight(10.0f, 20.0f, eye_z, VL_INVERSESQUARE, WHITE, 1.0f);
    vlPointLight(0.0f, 0.0f, 50.0f, VL_INVERSE, WHITE, 1e20f);
    vlDirectionalLight(1e-45f, -1.0f, 1e30f, WHITE, 1.0f);
    vlSuperSample(3);
    vlRecursion(2);
    vlStepSize(5.0f, 0.01f);
    vlRenderType(type);
    vlSurface(VL_F, 0.5f);
    vlSurface(VL_O, 0.25f);
    for (f = VL_CASTSHADOWS; f <= VL_REFLECTBACKGROUND; f++)
        vlToggle(f, VL_TRUE);
    vlObject();
    slab(S, L);
    vlFunction(VL_F, halves, pair);
    vlFunction(VL_O | VL_COLORS | VL_KS | VL_RF, from_f, NULL);
    vlSet(VL_KA | VL_KD, 0.6f);
    vlEnd();
    vlEnd();
}
static void c_all_dvr(const char *image) { everything(image, VL_DVR, 0, 0, -200.0f); }
static void c_all_dsr(const char *image) { everything(image, VL_DSR, 0, 1, -200.0f); }
static void c_all_mip(const char *image) { everything(image, VL_MIP, 1, 0, -200.0f); }
static void c_all_dsr_inside(const char *image) { everything(image, VL_DSR, 1, 1, 40.0f); }
static void c_all_dvr_inside(const char *image) { everything(image, VL_DVR, 1, 0, 40.0f); }

/* MIP of a constant o = 0.4, white: o C + (1 - o) background = 0.4; of NaN: background. */
static void mip(const char *image, vlfloat *o)
{
    probe_scene(image, N, N, S);
    vlStepSize(L / 10.0f, L);
    vlRenderType(VL_MIP);
    vlObject();
    slab(S, L);
    white(0.0f);
    vlFunction(VL_O, constant, o);
    vlEnd();
    vlEnd();
}
static vlfloat point4 = 0.4f;
static void c_mip(const char *image) { mip(image, &point4); }
static void c_mip_nan(const char *image) { mip(image, &hostile[0]); }

/* A light inside a DVR medium, at the eye, inverse-square: the first samples are next to it. */
static void c_light_in_medium(const char *image)
{
    probe_scene(image, N, N, S);
    camera(0.0f, 0.0f, 0.5f * L, 0.0f, 0.0f, L, 0.0f, 1.0f, 0.0f, 60.0f);
    vlPointLight(0.0f, 0.0f, 0.5f * L, VL_INVERSESQUARE, WHITE, 1e30f);
    vlPointLight(0.0f, 0.0f, 0.5f * L + 0.5f, VL_INVERSE, WHITE, 1.0f); /* on a sample */
    vlStepSize(1.0f, L);
    vlObject();
    slab(S, L);
    vlFunction(VL_F, VLU_SPHERE, NULL);
    white(0.3f);
    vlSet(VL_KD | VL_KS, 1.0f);
    vlEnd();
    vlEnd();
}

/* Transmittance never increases with depth: a dark wedge (o = 0.3 per L / 10) over a white
   background, seen nearly orthographically from far away; column x crosses depth ~ x of it,
   so each row is non-increasing from left to right. At an ordinary step and at 1e-4 of L. */
static vlfloat wedge_o = 0.3f;
static void wedge_scene(const char *image, int w, vlfloat step)
{
    vlScene();
    vlImage(image, (vlfloat)w, w, 1);
    camera(0.0f, 0.0f, -1e4f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.57f / (vlfloat)w);
    vlBackground(WHITE);
    vlStepSize(step, L / 10.0f);
    vlObject();
    slab(S, L);
    vlFunction(VL_O, wedge, &wedge_o);
    vlEnd();
    vlEnd();
}
static void c_wedge(const char *image) { wedge_scene(image, 33, L / 50.0f); }
static void c_wedge_tiny_step(const char *image) { wedge_scene(image, 17, 1e-4f * L); }

int main(int argc, char **argv)
{
    static const vlfloat ramp[] = {0.0f, 0.2f, 1.0f, 0.8f};
    static const vlfloat lookup[] = {0.0f, 0.9f, 1.0f, 0.6f};
    volatile float zero = 0.0f;
    vlint e;

    if (argc > 1)
        outdir = argv[1];
    mkdir(outdir, 0755); /* may exist */
    hostile[0] = zero / zero;
    hostile[1] = 1.0f / zero;
    hostile[2] = -1.0f / zero;
    hostile[3] = 1e30f;
    hostile[4] = -1e30f;

    vlInit();
    vlMapping(1, VL_RAMP, 2, 1, ramp);
    vlMapping(2, VL_LOOKUP, 2, 1, lookup);
    while ((e = vlError()) != VL_NOERROR) {
        printf("setup: vlError %d (%s)\n", (int)e, vlErrorString(e));
        failures++;
    }

    run("baseline.ppm", c_baseline, VL_NOERROR);
    run("step_1e-4.ppm", c_step_tiny, VL_NOERROR);
    run("step_1e6.ppm", c_step_huge, VL_NOERROR);
    run("step_0.3.ppm", c_step_odd, VL_NOERROR);
    run("reference_1e-30.ppm", c_reference_tiny, VL_NOERROR);
    run("reference_subnormal.ppm", c_reference_subnormal, VL_NOERROR);
    run("reference_1e30.ppm", c_reference_huge, VL_NOERROR);
    run("reference_flt_max.ppm", c_reference_max, VL_NOERROR);
    run("opacity_1_reference_1e30.ppm", c_opacity_one, VL_NOERROR);
    run("scale_1e30.ppm", c_scale_1e30, VL_NOERROR);
    run("scale_1e-30.ppm", c_scale_1e_30, VL_NOERROR);
    run("camera_inside.ppm", c_camera_inside, VL_NOERROR);
    run("camera_on_front_face.ppm", c_camera_on_front_face, VL_NOERROR);
    run("camera_on_back_face.ppm", c_camera_on_back_face, VL_NOERROR);
    run("camera_on_corner.ppm", c_camera_on_corner, VL_NOERROR);
    run("graze_face.ppm", c_graze_face, VL_NOERROR);
    run("along_edge.ppm", c_along_edge, VL_NOERROR);
    run("through_corners.ppm", c_through_corners, VL_NOERROR);
    run("touch_corner.ppm", c_touch_corner, VL_NOERROR);
    run("touch_edge.ppm", c_touch_edge, VL_NOERROR);
    run("fov_1e-4.ppm", c_fov_tiny, VL_NOERROR);
    run("fov_179.99.ppm", c_fov_wide, VL_NOERROR);
    run("up_near_view.ppm", c_up_near_view, VL_NOERROR);
    run("up_subnormal.ppm", c_up_subnormal, VL_NOERROR);
    run("matrix_sliver.ppm", c_matrix_sliver, VL_NOERROR);
    run("matrix_singular.ppm", c_matrix_singular, VL_BADVALUE);
    run("mirror.ppm", c_mirror, VL_NOERROR);
    run("absurd_angles.ppm", c_absurd_angles, VL_NOERROR);
    run("far_away.ppm", c_far_away, VL_NOERROR);
    run("paper_thin.ppm", c_paper_thin, VL_NOERROR);
    run("field_nan.ppm", c_field_nan, VL_NOERROR);
    run("field_inf.ppm", c_field_inf, VL_NOERROR);
    run("field_neg_inf.ppm", c_field_neg_inf, VL_NOERROR);
    run("field_1e30.ppm", c_field_1e30, VL_NOERROR);
    run("field_neg_1e30.ppm", c_field_neg_1e30, VL_NOERROR);
    run("field_nan_twice.ppm", c_field_nan_png, VL_NOERROR);
    run("zero_gradient.ppm", c_zero_gradient, VL_NOERROR);
    run("normal_nan.ppm", c_normal_nan, VL_NOERROR);
    run("ramp_a1_0_f0.ppm", c_ramp_f0, VL_NOERROR);
    run("ramp_a1_0_f0.5.ppm", c_ramp_fhalf, VL_NOERROR);
    run("ramp_an_1_f1.ppm", c_ramp_f1, VL_NOERROR);
    run("lookup_a1_0_f0.ppm", c_lookup_f0, VL_NOERROR);
    run("lookup_an_1_f1.ppm", c_lookup_f1, VL_NOERROR);
    run("u16_widest_range.ppm", c_u16_widest, VL_NOERROR);
    run("u16_full_range.ppm", c_u16_full, VL_NOERROR);
    run("u16_inverted.ppm", c_u16_inverted, VL_NOERROR);
    run("u16_tiny_range.ppm", c_u16_tiny_range, VL_NOERROR);
    run("u16_ulp_range.ppm", c_u16_ulp_range, VL_NOERROR);
    run("u16_checker_cubic.ppm", c_u16_checker_cubic, VL_NOERROR);
    run("dsr_camera_inside.ppm", c_dsr_camera_inside, VL_NOERROR);
    run("dsr_light_at_eye.ppm", c_dsr_light_at_eye, VL_NOERROR);
    run("dsr_light_inverse_square.ppm", c_dsr_light_inverse_square, VL_NOERROR);
    run("dsr_light_at_eye_shadows.ppm", c_dsr_light_at_eye_shadows, VL_NOERROR);
    run("dsr_step_1e-4.ppm", c_dsr_step_tiny, VL_NOERROR);
    run("dsr_step_1e6.ppm", c_dsr_step_huge, VL_NOERROR);
    run("dsr_on_threshold.ppm", c_dsr_on_threshold, VL_NOERROR);
    run("dsr_nan.ppm", c_dsr_nan, VL_NOERROR);
    run("all_dvr.ppm", c_all_dvr, VL_NOERROR);
    run("all_dsr.ppm", c_all_dsr, VL_NOERROR);
    run("all_mip.ppm", c_all_mip, VL_NOERROR);
    run("all_dsr_inside.ppm", c_all_dsr_inside, VL_NOERROR);
    run("all_dvr_inside.ppm", c_all_dvr_inside, VL_NOERROR);
    run("mip.ppm", c_mip, VL_NOERROR);
    run("mip_nan.ppm", c_mip_nan, VL_NOERROR);
    run("light_in_medium.ppm", c_light_in_medium, VL_NOERROR);
    run("wedge.ppm", c_wedge, VL_NOERROR);
    run("wedge_step_1e-4.ppm", c_wedge_tiny_step, VL_NOERROR);

    vlEnd();
    while ((e = vlError()) != VL_NOERROR) {
        printf("the final vlEnd: vlError %d (%s)\n", (int)e, vlErrorString(e));
        failures++;
    }
    printf("%d cases, %d failure(s)\n", cases, failures);
    return failures == 0 ? 0 : 1;
}
