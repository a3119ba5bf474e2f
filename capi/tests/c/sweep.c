/* VLU_SWEEP, the rotational sweep of a 2D profile dataset, through the public headers.
 *
 * Writes a small 16-bit profile whose value is exactly bilinear, P(x, y) = (1 - x)(1 + 3y) / 4,
 * so that trilinear interpolation reproduces it up to the 16-bit quantisation. A field function
 * calls VLU_SWEEP inside a render and compares what it wrote (to F and O, the fields its
 * vlFunction call named, leaving R as it was) with P(2r, y), r the distance from the vertical axis
 * through (0.5, y, 0.5), or 0 for 2r > 1. Also: NULL misc is VL_NULLPOINTER and writes nothing;
 * an unknown id is VL_BADID and writes 0. Prints one line per check and exits non-zero if any
 * fails. C89; built and run by capi/tests/c_examples.rs. */
#include <math.h>
#include <stdio.h>
#include <vlib.h>
#include <vlaux.h>

#define NX 33
#define NY 17

static int failures = 0;

/* Written by the field functions on the render's worker threads: benign races, each only ever
   stores the same value (a flag) or a count whose exact value is not checked. */
static volatile int calls = 0, inside = 0, wrong = 0, leaked = 0, null_wrote = 0, bad_wrote = 0;

static void check(const char *what, int ok)
{
    printf("%-4s %s\n", ok ? "ok" : "FAIL", what);
    if (!ok)
        failures++;
}

static void expect(const char *what, vlint want)
{
    vlint got = vlError();
    int ok = got == want;
    printf("%-4s %-52s want %2d, got %2d\n", ok ? "ok" : "FAIL", what, (int)want, (int)got);
    if (!ok)
        failures++;
    while (vlError() != VL_NOERROR)
        ;
}

static double profile(double x, double y)
{
    return (1.0 - x) * (1.0 + 3.0 * y) / 4.0;
}

static void put_u32(FILE *f, unsigned long v)
{
    putc((int)(v & 255), f);
    putc((int)((v >> 8) & 255), f);
    putc((int)((v >> 16) & 255), f);
    putc((int)((v >> 24) & 255), f);
}

/* A little-endian IEEE float, written byte by byte. */
static void put_f32(FILE *f, float v)
{
    unsigned char b[4];
    unsigned long u = 1;
    int little = *(unsigned char *)&u == 1;
    int i;
    for (i = 0; i < 4; i++)
        b[i] = ((unsigned char *)&v)[little ? i : 3 - i];
    fwrite(b, 1, 4, f);
}

static int write_profile(const char *path)
{
    FILE *f = fopen(path, "wb");
    int i, j;
    if (!f)
        return 0;
    fwrite("VLB1", 1, 4, f);
    put_u32(f, NX);
    put_u32(f, NY);
    put_u32(f, 1);
    put_u32(f, 2);
    put_f32(f, 0.0f);
    put_f32(f, 65535.0f);
    for (j = 0; j < NY; j++)
        for (i = 0; i < NX; i++) {
            long v = (long)floor(65535.0 * profile(i / (NX - 1.0), j / (NY - 1.0)) + 0.5);
            putc((int)(v & 255), f);
            putc((int)(v >> 8), f);
        }
    return fclose(f) == 0;
}

/* The field function under test: the sweep, then what it wrote, compared with P. */
static void probe(vlfloat *p, void *misc)
{
    double dx = p[0] - 0.5, dz = p[2] - 0.5, u = 2.0 * sqrt(dx * dx + dz * dz);
    double want = u <= 1.0 ? profile(u, p[1]) : 0.0;
    VLU_SWEEP(p, misc);
    calls++;
    if (u <= 1.0)
        inside++;
    if (fabs(vlField(VL_F) - want) > 1e-3 || vlField(VL_O) != vlField(VL_F))
        wrong = 1;
    if (vlField(VL_R) != 1.0f)
        leaked = 1;
}

/* NULL misc: nothing written (F keeps the 0.5 set before). */
static void null_misc(vlfloat *p, void *misc)
{
    (void)misc;
    VLU_SWEEP(p, NULL);
    if (vlField(VL_F) != 0.5f)
        null_wrote = 1;
}

/* An unknown id at the axis: 0 written. */
static void unknown_id(vlfloat *p, void *misc)
{
    vlfloat axis[3];
    axis[0] = 0.5f;
    axis[1] = p[1];
    axis[2] = 0.5f;
    VLU_SWEEP(axis, misc);
    if (vlField(VL_F) != 0.0f)
        bad_wrote = 1;
}

int main(void)
{
    static vlint id = 3, missing = 99;
    vlfloat p[3];
    FILE *f;

    check("write profile.vlb", write_profile("profile.vlb"));
    vlInit();
    vlLoad(id, "profile.vlb");
    expect("vlLoad profile.vlb", VL_NOERROR);

    p[0] = 0.5f; p[1] = 0.5f; p[2] = 0.5f;
    VLU_SWEEP(p, NULL);
    expect("VLU_SWEEP(p, NULL) at library scope", VL_NULLPOINTER);
    VLU_SWEEP(NULL, &id);
    expect("VLU_SWEEP(NULL, &id) at library scope", VL_NULLPOINTER);

    vlScene();
    vlImage("sweep.ppm", 1.0, 24, 24);
    vluCamera(0.5, 0.8, -4.0, 0.5, 0.5, 0.5);
    vlAmbient(WHITE, 1.0);
    vlStepSize(0.05, 0.05);
    vlObject();
    vlSet(VL_R | VL_G | VL_B | VL_KA, 1.0);
    vlFunction(VL_F | VL_O, probe, &id);
    vlEnd();
    vlObject();
    vlTranslate(1.5, 0.0, 0.0);
    vlSet(VL_F, 0.5);
    vlFunction(VL_F, null_misc, &id);
    vlSet(VL_O, 0.5); /* a later opacity: the renderer runs the program up to it */
    vlEnd();
    vlObject();
    vlTranslate(-1.5, 0.0, 0.0);
    vlFunction(VL_F, unknown_id, &missing);
    vlSet(VL_O, 0.5);
    vlEnd();
    vlEnd();
    {
        vlint e;
        int nulls = 0, badids = 0, others = 0;
        while ((e = vlError()) != VL_NOERROR) {
            if (e == VL_NULLPOINTER)
                nulls++;
            else if (e == VL_BADID)
                badids++;
            else
                others++;
        }
        printf("     errors during the render: %d VL_NULLPOINTER, %d VL_BADID, %d other\n",
               nulls, badids, others);
        check("NULL misc in a field function records VL_NULLPOINTER", nulls > 0);
        check("an unknown id in a field function records VL_BADID", badids > 0);
        check("no other errors", others == 0);
    }
    vlEnd();
    expect("vlEnd", VL_NOERROR);

    printf("     %d probe calls, %d inside the profile's radius\n", (int)calls, (int)inside);
    check("the sweep was sampled inside and outside its radius", inside > 0 && calls > inside);
    check("VLU_SWEEP wrote P(2r, y) (0 outside) to F and O", !wrong);
    check("VLU_SWEEP wrote only the fields vlFunction named", !leaked);
    check("NULL misc wrote nothing", !null_wrote);
    check("an unknown id wrote 0", !bad_wrote);
    f = fopen("sweep.ppm", "rb");
    check("sweep.ppm written", f != NULL);
    if (f)
        fclose(f);
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
