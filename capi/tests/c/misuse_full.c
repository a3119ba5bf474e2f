/* Robustness of the C interface (issue 6): numbered misuse and malformed-input cases, each
 * checking that vlError reports exactly the expected code and that the queue is then empty:
 * malformed .vlb files of every kind, NULL for every pointer argument, illegal scopes, bad
 * values, enumerations, field masks and ids, unwritable outputs (no file, no temporary left, an
 * existing file kept whole), misuse from field functions on worker threads, and the bounded
 * error queue. Afterwards a scene with a known answer is rendered and read back to show that
 * the library is still healthy.
 *
 * One line per case; exits non-zero if any case fails. C89 plus POSIX (directories, rlimits).
 * Built and run in a fresh directory by capi/tests/misuse.rs (and by c_examples.rs and
 * memcheck.rs with every C program). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <dirent.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/resource.h>
#include <unistd.h>
#include <vlib.h>
#include <vlaux.h>

static int cases = 0;
static int failures = 0;

/* Prints one case and counts it. */
static void report(int ok, const char *what, const char *detail)
{
    cases++;
    printf("case %3d %-4s %-58s %s\n", cases, ok ? "ok" : "FAIL", what, detail);
    if (!ok)
        failures++;
}

/* The oldest queued error must be `want`, and nothing else may be queued. */
static void expect(const char *what, vlint want)
{
    char detail[160];
    vlint got = vlError();
    vlint extra = vlError();
    int ok = got == want && extra == VL_NOERROR;
    sprintf(detail, "want %2d, got %2d%s (%s)", (int)want, (int)got,
            extra != VL_NOERROR ? " and more" : "", vlErrorString(got));
    report(ok, what, detail);
    while (vlError() != VL_NOERROR)
        ;
}

/* Every queued error must be `want`, and there must be at least one (errors recorded on
   rendering threads, once per sample, so their number is not fixed). */
static void expect_all(const char *what, vlint want)
{
    char detail[160];
    long n = 0, other = 0;
    vlint e, first_other = VL_NOERROR;
    while ((e = vlError()) != VL_NOERROR) {
        n++;
        if (e != want) {
            if (other == 0)
                first_other = e;
            other++;
        }
    }
    sprintf(detail, "want %2d, got %ld of them, %ld others (first %d)", (int)want, n - other,
            other, (int)first_other);
    report(n > 0 && other == 0, what, detail);
}

static void check(int ok, const char *what)
{
    report(ok, what, "");
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Whether the current directory holds a file whose name contains `part` (temporaries are named
   .vl-<16 hex digits>.tmp beside their destination). */
static int dir_has(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int found = 0;
    if (d == NULL)
        return 0;
    while ((e = readdir(d)) != NULL)
        if (strstr(e->d_name, part) != NULL)
            found = 1;
    closedir(d);
    return found;
}

/* Reads a whole file into buf (at most cap bytes); returns its length or -1. */
static long slurp(const char *path, unsigned char *buf, long cap)
{
    FILE *f = fopen(path, "rb");
    long n;
    if (f == NULL)
        return -1;
    n = (long)fread(buf, 1, (size_t)cap, f);
    fclose(f);
    return n;
}

static void put_u32(FILE *f, unsigned long v)
{
    fputc((int)(v & 0xff), f);
    fputc((int)((v >> 8) & 0xff), f);
    fputc((int)((v >> 16) & 0xff), f);
    fputc((int)((v >> 24) & 0xff), f);
}

static void put_f32(FILE *f, float v)
{
    unsigned long bits = 0;
    unsigned char b[4];
    int i;
    memcpy(b, &v, 4); /* the host's float, assumed IEEE 754; byte order fixed below */
    {
        unsigned long one = 1;
        int little = *(unsigned char *)&one == 1;
        for (i = 0; i < 4; i++)
            bits |= (unsigned long)b[little ? i : 3 - i] << (8 * i);
    }
    put_u32(f, bits);
}

/* Writes a .vlb file: magic, dimensions, voxel width, a, b, then `body` bytes of voxels
   (whatever the header says: the malformed files lie). */
static void write_vlb(const char *path, const char *magic, unsigned long nx, unsigned long ny,
                      unsigned long nz, unsigned long width, float a, float b, long body)
{
    FILE *f = fopen(path, "wb");
    long i;
    if (f == NULL) {
        printf("cannot write %s\n", path);
        exit(2);
    }
    fwrite(magic, 1, 4, f);
    put_u32(f, nx);
    put_u32(f, ny);
    put_u32(f, nz);
    put_u32(f, width);
    put_f32(f, a);
    put_f32(f, b);
    for (i = 0; i < body; i++)
        fputc((int)(i * 255 / (body > 1 ? body - 1 : 1)), f);
    fclose(f);
}

static void write_bytes(const char *path, const char *bytes, long n)
{
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        printf("cannot write %s\n", path);
        exit(2);
    }
    fwrite(bytes, 1, (size_t)n, f);
    fclose(f);
}

/* A small scene around an object built by `build`, rendered to `image` (NULL: none). */
static void small_scene(const char *image, void (*build)(void))
{
    vlScene();
    if (image != NULL)
        vlImage(image, 1.0, 4, 4);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-2.0, 2.0, -2.0, VL_NOATTENUATION, WHITE, 1.0);
    vlStepSize(0.25, 1.0);
    vlObject();
    build();
    vlEnd();
    vlEnd();
}

/* ---- field, spatial and normal functions that misuse the API (run on worker threads) ---- */

static void calls_vl_scene(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlScene();
}

static void calls_vl_load(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlLoad(7, "good.vlb");
}

static void null_position(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlPosition(NULL);
}

static void two_fields(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlSet(VL_O, vlField(VL_O | VL_F));
}

static void unknown_field_bit(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlSet(1 << 12, 1.0);
}

static void missing_child(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlSet(VL_O, (vlfloat)vlChildHit(3));
}

static void child_normal_in_field_function(vlfloat *p, void *misc)
{
    vlfloat n[3];
    (void)p;
    (void)misc;
    vlChildNormal(1, n);
}

static void unknown_dataset(vlfloat *p, void *misc)
{
    (void)misc;
    vlSet(VL_O, vlSample(99, p[0], p[1], p[2]));
}

static void to_nan(vlfloat *p, void *misc)
{
    volatile double zero = 0.0;
    (void)misc;
    p[0] = (vlfloat)(zero / zero);
}

static void set_in_normal_function(vlfloat *n, vlfloat *p, void *misc)
{
    (void)n;
    (void)p;
    (void)misc;
    vlSet(VL_O, 1.0);
}

static void null_child_normal(vlfloat *n, vlfloat *p, void *misc)
{
    (void)n;
    (void)p;
    (void)misc;
    vlChildNormal(1, NULL);
}

static void bad_set_in_normal_function(vlfloat *n, vlfloat *p, void *misc)
{
    (void)n;
    (void)p;
    (void)misc;
    vlSet(0, 1.0); /* an empty mask, in a function that may not set at all */
}

static void bad_calls_in_spatial_function(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlSet(VL_O | 4096, 1.0);  /* an unknown bit, in a function that may not set */
    vlChildNormal(1, NULL);   /* NULL, in a function that may not take child normals */
}

static void opaque(vlfloat *p, void *misc)
{
    (void)p;
    (void)misc;
    vlSet(VL_ALLFIELDS, 0.8);
}

static void (*current)(vlfloat *, void *);

static void build_function(void)
{
    vlSet(VL_ALLFIELDS, 0.5);
    vlFunction(VL_O, current, NULL);
}

static void build_spatial(void)
{
    vlSpatial(to_nan, NULL);
    vlSet(VL_ALLFIELDS, 0.5);
}

static void build_normal(void)
{
    vlFunction(VL_ALLFIELDS, opaque, NULL);
    vlNormal(set_in_normal_function, NULL);
}

static void build_null_child_normal(void)
{
    vlFunction(VL_ALLFIELDS, opaque, NULL);
    vlNormal(null_child_normal, NULL);
}

static void build_bad_normal(void)
{
    vlFunction(VL_ALLFIELDS, opaque, NULL);
    vlNormal(bad_set_in_normal_function, NULL);
}

static void build_bad_spatial(void)
{
    vlSpatial(bad_calls_in_spatial_function, NULL);
    vlSet(VL_ALLFIELDS, 0.5);
}

static void build_plain(void)
{
    vlSet(VL_ALLFIELDS, 0.5);
}

static void in_sample_scope(const char *what, void (*f)(vlfloat *, void *), vlint want)
{
    current = f;
    small_scene("sample.ppm", build_function);
    expect_all(what, want);
}

/* ---- reading a PPM back ---- */

static int read_ppm(const char *path, int *w, int *h, unsigned char *rgb, long cap)
{
    FILE *f = fopen(path, "rb");
    int maxval = 0, ok;
    if (f == NULL)
        return 0;
    ok = fscanf(f, "P6 %d %d %d", w, h, &maxval) == 3 && maxval == 255 && fgetc(f) != EOF &&
         (long)*w * *h * 3 <= cap &&
         fread(rgb, 1, (size_t)(*w * *h * 3), f) == (size_t)(*w * *h * 3);
    fclose(f);
    return ok;
}

int main(void)
{
    static vlfloat table[] = {0.0, 0.0, 1.0, 1.0};       /* 2 points, 1 output */
    static vlfloat decreasing[] = {0.5, 0.0, 0.2, 1.0};  /* a not increasing */
    static vlfloat out_of_range[] = {0.0, 0.0, 1.0, 1.5}; /* b above 1 */
    static vlfloat identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    static vlfloat singular[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
    static vlfloat projective[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1};
    static unsigned char before[4096], after[4096], rgb[3 * 64 * 64];
    vlfloat nan_table[4];
    vlfloat n3[3];
    VLCAMERA cam, bad;
    volatile double zero = 0.0;
    vlfloat nan = (vlfloat)(zero / zero), inf = (vlfloat)(1.0 / zero);
    long nbefore, nafter;
    int i, w, h;
    struct rlimit old_limit, small_limit;

    memcpy(nan_table, table, sizeof table);
    nan_table[3] = nan;
    cam.eye[0] = 0.5; cam.eye[1] = 0.5; cam.eye[2] = -2.0;
    cam.at[0] = 0.5; cam.at[1] = 0.5; cam.at[2] = 0.5;
    cam.up[0] = 0.0; cam.up[1] = 1.0; cam.up[2] = 0.0;
    cam.fov = 40.0;

    /* The files the dataset cases read. */
    write_vlb("good.vlb", "VLB1", 2, 1, 1, 1, 0.0f, 255.0f, 2); /* voxels 0 and 255 */
    write_vlb("magic.vlb", "VLB2", 2, 1, 1, 1, 0.0f, 255.0f, 2);
    write_vlb("zero.vlb", "VLB1", 2, 0, 1, 1, 0.0f, 255.0f, 0);
    write_vlb("absurd.vlb", "VLB1", 100000, 100000, 100000, 1, 0.0f, 255.0f, 8); /* 10^15 */
    write_vlb("wraps.vlb", "VLB1", 4194304, 4194304, 4194304, 1, 0.0f, 255.0f, 0); /* 2^66 */
    write_vlb("width3.vlb", "VLB1", 2, 1, 1, 3, 0.0f, 255.0f, 6);
    write_vlb("width0.vlb", "VLB1", 2, 1, 1, 0, 0.0f, 255.0f, 0);
    write_vlb("aisb.vlb", "VLB1", 2, 1, 1, 1, 7.0f, 7.0f, 2);
    write_vlb("nan.vlb", "VLB1", 2, 1, 1, 1, nan, 255.0f, 2);
    write_vlb("inf.vlb", "VLB1", 2, 1, 1, 1, 0.0f, inf, 2);
    write_vlb("truncated.vlb", "VLB1", 2, 2, 2, 2, 0.0f, 65535.0f, 15); /* 16 bytes claimed */
    write_vlb("trailing.vlb", "VLB1", 2, 1, 1, 1, 0.0f, 255.0f, 3);
    write_bytes("empty.vlb", "", 0);
    write_bytes("header.vlb", "VLB1\002\000\000\000\001", 9);
    write_bytes("gif.vlb", "GIF89a", 6);
    mkdir("adir.vlb", 0755);

    /* ---- scopes before vlInit ---- */
    expect("the queue starts empty", VL_NOERROR);
    vlScene();
    expect("vlScene before vlInit", VL_BADSCOPE);
    vlEnd();
    expect("vlEnd before vlInit", VL_BADSCOPE);
    vlObject();
    expect("vlObject before vlInit", VL_BADSCOPE);
    vlLoad(1, NULL);
    expect("vlLoad(NULL) before vlInit (scope first)", VL_BADSCOPE);
    vlBackground(nan, 0.0, 0.0);
    expect("vlBackground(NaN) before vlInit (scope first)", VL_BADSCOPE);
    check(vlSample(1, 0.5, 0.5, 0.5) == 0.0 && vlError() == VL_BADSCOPE,
          "vlSample before vlInit: 0 and VL_BADSCOPE");

    vlInit();
    expect("vlInit", VL_NOERROR);
    vlInit();
    expect("vlInit twice", VL_BADSCOPE);

    /* ---- illegal scopes inside the library ---- */
    vlImage("x.ppm", 1.0, 8, 8);
    expect("vlImage at library scope", VL_BADSCOPE);
    vlPointLight(0.0, 0.0, 0.0, VL_NOATTENUATION, WHITE, 1.0);
    expect("vlPointLight at library scope", VL_BADSCOPE);
    vlVolume("v", VL_O, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume at library scope", VL_BADSCOPE);
    vlTranslate(1.0, 0.0, 0.0);
    expect("vlTranslate at library scope", VL_BADSCOPE);
    vlField(VL_O);
    expect("vlField outside a field function", VL_BADSCOPE);
    vlPosition(n3);
    expect("vlPosition outside a field function", VL_BADSCOPE);
    check(vlChildCount() == 0 && vlError() == VL_BADSCOPE,
          "vlChildCount outside a field function: 0 and VL_BADSCOPE");
    vlChildNormal(1, n3);
    expect("vlChildNormal outside a normal function", VL_BADSCOPE);

    /* ---- malformed and missing dataset files (vlLoad) ---- */
    vlLoad(1, "good.vlb");
    expect("vlLoad of a valid file", VL_NOERROR);
    vlLoad(1, "magic.vlb");
    expect("vlLoad: bad magic number", VL_BADMAGIC);
    vlLoad(1, "gif.vlb");
    expect("vlLoad: a short file that is not a .vlb", VL_BADMAGIC);
    vlLoad(1, "zero.vlb");
    expect("vlLoad: a zero dimension", VL_BADDIMENSIONS);
    vlLoad(1, "absurd.vlb");
    expect("vlLoad: 10^15 voxels", VL_BADDIMENSIONS);
    vlLoad(1, "wraps.vlb");
    expect("vlLoad: 2^66 voxels (wraps to 0 in 64 bits)", VL_BADDIMENSIONS);
    vlLoad(1, "width3.vlb");
    expect("vlLoad: voxel width 3", VL_BADVOXELWIDTH);
    vlLoad(1, "width0.vlb");
    expect("vlLoad: voxel width 0", VL_BADVOXELWIDTH);
    vlLoad(1, "aisb.vlb");
    expect("vlLoad: a = b", VL_BADRANGE);
    vlLoad(1, "nan.vlb");
    expect("vlLoad: a is NaN", VL_BADRANGE);
    vlLoad(1, "inf.vlb");
    expect("vlLoad: b is infinite", VL_BADRANGE);
    vlLoad(1, "truncated.vlb");
    expect("vlLoad: truncated voxels", VL_BADSIZE);
    vlLoad(1, "trailing.vlb");
    expect("vlLoad: trailing bytes", VL_BADSIZE);
    vlLoad(1, "empty.vlb");
    expect("vlLoad: an empty file", VL_BADSIZE);
    vlLoad(1, "header.vlb");
    expect("vlLoad: a truncated header", VL_BADSIZE);
    vlLoad(1, "no-such-file.vlb");
    expect("vlLoad: a missing file", VL_IOERROR);
    vlLoad(1, "adir.vlb");
    expect("vlLoad: a directory", VL_IOERROR);
    vlLoad(1, NULL);
    expect("vlLoad(NULL)", VL_NULLPOINTER);
    check(vlSample(1, 1.0, 0.0, 0.0) == 1.0 && vlSample(1, 0.0, 0.0, 0.0) == 0.0 &&
              vlError() == VL_NOERROR,
          "dataset 1 is still the valid file after the refused loads");
    check(vlSample(99, 0.5, 0.5, 0.5) == 0.0 && vlError() == VL_BADID,
          "vlSample of an unknown dataset: 0 and VL_BADID");
    vlSample(1, nan, 0.5, 0.5);
    expect("vlSample at a NaN point", VL_BADVALUE);
    vlUnload(99);
    expect("vlUnload of an unknown id", VL_BADID);

    /* ---- mappings ---- */
    vlMapping(1, VL_LOOKUP, 2, 1, table);
    expect("vlMapping, valid", VL_NOERROR);
    vlMapping(2, 9, 2, 1, table);
    expect("vlMapping type 9", VL_BADENUM);
    vlMapping(2, VL_RAMP, 2, 1, NULL);
    expect("vlMapping(NULL table)", VL_NULLPOINTER);
    vlMapping(2, VL_RAMP, 0, 1, table);
    expect("vlMapping with 0 points", VL_BADVALUE);
    vlMapping(2, VL_RAMP, -1, 1, table);
    expect("vlMapping with -1 points", VL_BADVALUE);
    vlMapping(2, VL_RAMP, 2, 0, table);
    expect("vlMapping with 0 outputs", VL_BADVALUE);
    vlMapping(2, VL_RAMP, (1 << 20) + 1, 1, table);
    expect("vlMapping with 2^20 + 1 points (too large)", VL_BADVALUE);
    vlMapping(2, VL_RAMP, 2, 65, table);
    expect("vlMapping with 65 outputs (too many)", VL_BADVALUE);
    vlMapping(2, VL_RAMP, 2, 1, decreasing);
    expect("vlMapping: inputs not increasing", VL_BADVALUE);
    vlMapping(2, VL_RAMP, 2, 1, out_of_range);
    expect("vlMapping: an output of 1.5", VL_BADVALUE);
    vlMapping(2, VL_RAMP, 2, 1, nan_table);
    expect("vlMapping: a NaN output", VL_BADVALUE);

    /* ---- library-scope settings with bad values ---- */
    vlCamera(NULL);
    expect("vlCamera(NULL)", VL_NULLPOINTER);
    bad = cam;
    bad.at[0] = bad.eye[0]; bad.at[1] = bad.eye[1]; bad.at[2] = bad.eye[2];
    vlCamera(&bad);
    expect("vlCamera with eye = look-at point", VL_BADVALUE);
    bad = cam;
    bad.up[0] = 0.0; bad.up[1] = 0.0; bad.up[2] = 1.0;
    vlCamera(&bad);
    expect("vlCamera with up parallel to the view", VL_BADVALUE);
    bad = cam;
    bad.fov = 0.0;
    vlCamera(&bad);
    expect("vlCamera with fov 0", VL_BADVALUE);
    bad.fov = 180.0;
    vlCamera(&bad);
    expect("vlCamera with fov 180", VL_BADVALUE);
    bad.fov = nan;
    vlCamera(&bad);
    expect("vlCamera with fov NaN", VL_BADVALUE);
    bad = cam;
    bad.eye[1] = inf;
    vlCamera(&bad);
    expect("vlCamera with an infinite eye", VL_BADVALUE);
    vlBackground(2.0, 0.0, 0.0);
    expect("vlBackground red 2", VL_BADVALUE);
    vlBackground(0.0, -0.1, 0.0);
    expect("vlBackground green -0.1", VL_BADVALUE);
    vlBackground(0.0, 0.0, nan);
    expect("vlBackground blue NaN", VL_BADVALUE);
    vlSuperSample(0);
    expect("vlSuperSample(0)", VL_BADVALUE);
    vlSuperSample(17);
    expect("vlSuperSample(17)", VL_BADVALUE);
    vlAmbient(WHITE, -1.0);
    expect("vlAmbient intensity -1", VL_BADVALUE);
    vlAmbient(WHITE, inf);
    expect("vlAmbient intensity Inf", VL_BADVALUE);
    vlAmbient(1.5, 1.0, 1.0, 1.0);
    expect("vlAmbient red 1.5", VL_BADVALUE);
    vlRenderType(99);
    expect("vlRenderType(99)", VL_BADENUM);
    vlRenderType(-1);
    expect("vlRenderType(-1)", VL_BADENUM);
    vlStepSize(0.0, 1.0);
    expect("vlStepSize step 0", VL_BADVALUE);
    vlStepSize(-1.0, 1.0);
    expect("vlStepSize step -1", VL_BADVALUE);
    vlStepSize(nan, 1.0);
    expect("vlStepSize step NaN", VL_BADVALUE);
    vlStepSize(1.0, inf);
    expect("vlStepSize reference Inf", VL_BADVALUE);
    vlStepSize(1.0, 0.0);
    expect("vlStepSize reference 0", VL_BADVALUE);
    vlSurface(VL_O | VL_F, 0.5);
    expect("vlSurface of two fields", VL_BADFIELD);
    vlSurface(0, 0.5);
    expect("vlSurface of no field", VL_BADFIELD);
    vlToggle(42, VL_TRUE);
    expect("vlToggle feature 42", VL_BADENUM);
    vlToggle(VL_VISIBLE, 2);
    expect("vlToggle state 2", VL_BADVALUE);
    vlRecursion(-1);
    expect("vlRecursion(-1)", VL_BADVALUE);
    vlRecursion(65);
    expect("vlRecursion(65)", VL_BADVALUE);
    vlInterpolationType(5);
    expect("vlInterpolationType(5)", VL_BADENUM);
    vlCubicFilter(nan, 0.5);
    expect("vlCubicFilter B NaN", VL_BADVALUE);
    vlNeighborhood(0.0, 1.0, 1.0);
    expect("vlNeighborhood dx 0", VL_BADVALUE);
    vlNeighborhood(1.0, -1.0, 1.0);
    expect("vlNeighborhood dy -1", VL_BADVALUE);
    vlNeighborhood(1.0, 1.0, inf);
    expect("vlNeighborhood dz Inf", VL_BADVALUE);

    /* ---- scene scope ---- */
    vlScene();
    expect("vlScene", VL_NOERROR);
    vlScene();
    expect("vlScene inside a scene", VL_BADSCOPE);
    vlScale(2.0, 2.0, 2.0);
    expect("vlScale at scene scope", VL_BADSCOPE);
    vlSet(VL_O, 1.0);
    expect("vlSet at scene scope", VL_BADSCOPE);
    vlImage(NULL, 1.0, 8, 8);
    expect("vlImage(NULL)", VL_NULLPOINTER);
    vlImage("never.ppm", 1.0, 0, 8);
    expect("vlImage width 0", VL_BADVALUE);
    vlImage("never.ppm", 1.0, 8, -1);
    expect("vlImage height -1", VL_BADVALUE);
    vlImage("never.ppm", 1.0, 40000, 8);
    expect("vlImage width 40000 (a side above 32768)", VL_BADVALUE);
    vlImage("never.ppm", 1.0, 32768, 32768);
    expect("vlImage 32768 x 32768 (above 2^28 pixels)", VL_NOMEMORY);
    vlImage("never.ppm", nan, 8, 8);
    expect("vlImage aspect NaN", VL_BADVALUE);
    vlImage("never.ppm", 0.0, 8, 8);
    expect("vlImage aspect 0", VL_BADVALUE);
    vlImage("never.gif", 1.0, 8, 8);
    expect("vlImage with an unknown format", VL_BADFILE);
    vlImage("", 1.0, 8, 8);
    expect("vlImage with an empty name", VL_BADFILE);
    vlVolume(NULL, VL_O, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume(NULL prefix)", VL_NULLPOINTER);
    vlVolume("", VL_O, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume with an empty prefix", VL_BADFILE);
    vlVolume("never", 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume with no field", VL_BADFIELD);
    vlVolume("never", 1 << 11, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume with an unknown field bit", VL_BADFIELD);
    vlVolume("never", VL_O, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3);
    expect("vlVolume with 3 bytes per voxel", VL_BADVALUE);
    vlVolume("never", VL_O, 0, 0, 0, 1, 1, 1, 0, 2, 2, 1);
    expect("vlVolume with 0 nodes", VL_BADVALUE);
    vlVolume("never", VL_O, 0, 0, 0, -1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume with x1 < x0", VL_BADVALUE);
    vlVolume("never", VL_O, 0, nan, 0, 1, 1, 1, 2, 2, 2, 1);
    expect("vlVolume with a NaN corner", VL_BADVALUE);
    vlVolume("never", VL_O, 0, 0, 0, 1, 1, 1, 2048, 2048, 2048, 1);
    expect("vlVolume 2048^3 nodes (too many to hold)", VL_NOMEMORY);
    vlVolume("never", VL_O, 0, 0, 0, 1, 1, 1, 4194304, 4194304, 4194304, 1);
    expect("vlVolume 2^66 nodes (wraps to 0 in 64 bits)", VL_NOMEMORY);
    vlPointLight(0.0, 0.0, 0.0, 7, WHITE, 1.0);
    expect("vlPointLight attenuation 7", VL_BADENUM);
    vlPointLight(nan, 0.0, 0.0, VL_INVERSE, WHITE, 1.0);
    expect("vlPointLight at NaN", VL_BADVALUE);
    vlPointLight(0.0, 0.0, 0.0, VL_INVERSE, -1.0, 0.0, 0.0, 1.0);
    expect("vlPointLight red -1", VL_BADVALUE);
    vlDirectionalLight(0.0, 0.0, 0.0, WHITE, 1.0);
    expect("vlDirectionalLight with no direction", VL_BADVALUE);
    vlDirectionalLight(0.0, -1.0, 0.0, WHITE, -2.0);
    expect("vlDirectionalLight intensity -2", VL_BADVALUE);

    /* ---- object scope ---- */
    vlObject();
    expect("vlObject", VL_NOERROR);
    vlStepSize(1.0, 1.0);
    expect("vlStepSize inside an object", VL_BADSCOPE);
    vlMapping(3, VL_LOOKUP, 2, 1, table);
    expect("vlMapping inside an object", VL_BADSCOPE);
    vlLoad(3, "good.vlb");
    expect("vlLoad inside an object", VL_BADSCOPE);
    vlImage("never.ppm", 1.0, 8, 8);
    expect("vlImage inside an object", VL_BADSCOPE);
    vlScale(0.0, 1.0, 1.0);
    expect("vlScale x 0", VL_BADVALUE);
    vlScale(1.0, nan, 1.0);
    expect("vlScale y NaN", VL_BADVALUE);
    vlTranslate(inf, 0.0, 0.0);
    expect("vlTranslate x Inf", VL_BADVALUE);
    vlRotate(0.0, nan, 0.0);
    expect("vlRotate y NaN", VL_BADVALUE);
    vlFlip(8);
    expect("vlFlip with an unknown axis bit", VL_BADENUM);
    vlMatrix(NULL);
    expect("vlMatrix(NULL)", VL_NULLPOINTER);
    vlMatrix(singular);
    expect("vlMatrix singular", VL_BADVALUE);
    vlMatrix(projective);
    expect("vlMatrix projective (bottom row not 0 0 0 1)", VL_BADVALUE);
    vlMatrix(identity);
    expect("vlMatrix identity", VL_NOERROR);
    vlBoundary(0.0, 1.0, 1.0);
    expect("vlBoundary x 0", VL_BADVALUE);
    vlBoundary(1.0, -1.0, 1.0);
    expect("vlBoundary y -1", VL_BADVALUE);
    vlSpatial(NULL, NULL);
    expect("vlSpatial(NULL)", VL_NULLPOINTER);
    vlFunction(VL_F, NULL, NULL);
    expect("vlFunction(NULL)", VL_NULLPOINTER);
    vlFunction(0, opaque, NULL);
    expect("vlFunction with no field", VL_BADFIELD);
    vlNormal(NULL, NULL);
    expect("vlNormal(NULL)", VL_NULLPOINTER);
    vlSet(0, 1.0);
    expect("vlSet with no field", VL_BADFIELD);
    vlSet(1 << 12, 1.0);
    expect("vlSet with an unknown field bit", VL_BADFIELD);
    vlSet(-1, 1.0);
    expect("vlSet with mask -1", VL_BADFIELD);
    vlDataset(VL_O, 99);
    expect("vlDataset of an unknown id", VL_BADID);
    vlDataset(0, 1);
    expect("vlDataset with no field", VL_BADFIELD);
    vlMap(VL_O, VL_F, 99, 1);
    expect("vlMap through an unknown mapping", VL_BADID);
    vlMap(VL_O, VL_F, 1, 2);
    expect("vlMap output 2 of a 1-output mapping (Figure 2)", VL_BADINDEX);
    vlMap(VL_O, VL_F, 1, 0);
    expect("vlMap output 0", VL_BADINDEX);
    vlMap(VL_O, VL_F | VL_O, 1, 1);
    expect("vlMap from two source fields", VL_BADFIELD);
    vlMap(0, VL_F, 1, 1);
    expect("vlMap to no field", VL_BADFIELD);
    for (i = 0; i < 63; i++)
        vlObject();
    expect("objects nested 64 deep", VL_NOERROR);
    vlObject();
    expect("an object nested 65 deep", VL_BADVALUE);
    for (i = 0; i < 63; i++)
        vlEnd();
    vlEnd();
    expect("closing the nested objects", VL_NOERROR);
    vlEnd();
    expect("the scene renders nothing and closes", VL_NOERROR);
    check(!exists("never.ppm") && !exists("never_o.vlb") && !dir_has(".", ".tmp"),
          "refused outputs wrote no file");

    /* ---- misuse from field, spatial and normal functions, on rendering threads ---- */
    in_sample_scope("vlScene in a field function", calls_vl_scene, VL_BADSCOPE);
    in_sample_scope("vlLoad in a field function", calls_vl_load, VL_BADSCOPE);
    in_sample_scope("vlPosition(NULL) in a field function", null_position, VL_NULLPOINTER);
    in_sample_scope("vlField of two fields in a field function", two_fields, VL_BADFIELD);
    in_sample_scope("vlSet with an unknown bit in a field function", unknown_field_bit,
                    VL_BADFIELD);
    in_sample_scope("vlChildHit(3) of an object without children", missing_child, VL_BADINDEX);
    in_sample_scope("vlChildNormal in a field function", child_normal_in_field_function,
                    VL_BADSCOPE);
    in_sample_scope("vlSample of an unknown dataset in a field function", unknown_dataset,
                    VL_BADID);
    small_scene("sample.ppm", build_spatial);
    expect_all("a spatial function moving the point to NaN", VL_BADVALUE);
    small_scene("sample.ppm", build_normal);
    expect_all("vlSet in a normal function", VL_BADSCOPE);
    small_scene("sample.ppm", build_null_child_normal);
    expect_all("vlChildNormal(1, NULL) in a normal function", VL_NULLPOINTER);
    /* Scope first, however bad the arguments. */
    small_scene("sample.ppm", build_bad_normal);
    expect_all("vlSet(0) in a normal function (scope first)", VL_BADSCOPE);
    small_scene("sample.ppm", build_bad_spatial);
    expect_all("vlSet of an unknown bit and vlChildNormal(NULL) in a spatial function (scope "
               "first)",
               VL_BADSCOPE);
    check(exists("sample.ppm"), "the scenes with misbehaving functions still rendered");

    /* ---- outputs that cannot be written ---- */
    small_scene("no-such-dir/x.ppm", build_plain);
    expect("an image into a missing directory (at vlEnd)", VL_IOERROR);
    check(!exists("no-such-dir") && !dir_has(".", ".tmp"),
          "no file and no temporary left behind");
    mkdir("adir.ppm", 0755);
    small_scene("adir.ppm", build_plain);
    expect("an image onto an existing directory (at vlEnd)", VL_IOERROR);
    check(!dir_has(".", ".adir.ppm") && !dir_has(".", ".tmp"),
          "the temporary beside it was removed");
    vlScene();
    vlVolume("no-such-dir/v", VL_O | VL_F, 0, 0, 0, 1, 1, 1, 2, 2, 2, 1);
    vlImage("both.ppm", 1.0, 4, 4);
    vlImage("no-such-dir/y.ppm", 1.0, 4, 4);
    vlObject();
    vlSet(VL_ALLFIELDS, 0.5);
    vlEnd();
    vlEnd();
    expect("three outputs, two unwritable: one VL_IOERROR", VL_IOERROR);
    check(exists("both.ppm"), "the writable output of that scene was written");

    /* An existing file is replaced only by a complete new one: a render into it whose write
       fails (the file size limit stands in for a full disk) leaves it as it was. */
    small_scene("keep.ppm", build_plain);
    expect("keep.ppm written", VL_NOERROR);
    nbefore = slurp("keep.ppm", before, sizeof before);
    signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old_limit);
    small_limit = old_limit;
    small_limit.rlim_cur = 40;
    if (setrlimit(RLIMIT_FSIZE, &small_limit) != 0) {
        check(0, "setrlimit(RLIMIT_FSIZE)");
    } else {
        vlScene();
        vlImage("keep.ppm", 1.0, 16, 16);
        vlObject();
        vlSet(VL_ALLFIELDS, 0.9);
        vlEnd();
        vlEnd();
        setrlimit(RLIMIT_FSIZE, &old_limit);
        expect("a render into keep.ppm that cannot be written", VL_IOERROR);
        nafter = slurp("keep.ppm", after, sizeof after);
        check(nbefore > 0 && nafter == nbefore && memcmp(before, after, (size_t)nbefore) == 0,
              "keep.ppm is unchanged, not truncated");
        check(!dir_has(".", ".tmp"), "no temporary left behind");
    }

    /* ---- the error queue ---- */
    for (i = 0; i < 1100; i++)
        vlSuperSample(0);
    for (i = 0; i < 1100 && vlError() == VL_BADVALUE; i++)
        ;
    check(i == 1024 && vlError() == VL_NOERROR,
          "1100 errors: the oldest 1024 are kept, the rest dropped");
    {
        int distinct = 1, known = 1;
        for (i = 0; i <= VL_CANCELLED; i++) {
            int j;
            if (vlErrorString(i) == NULL || strcmp(vlErrorString(i), "unknown error code") == 0)
                known = 0;
            for (j = 0; j < i; j++)
                if (strcmp(vlErrorString(i), vlErrorString(j)) == 0)
                    distinct = 0;
        }
        check(known && distinct, "vlErrorString: codes 0 to 18 each have their own text");
        check(strcmp(vlErrorString(VL_CANCELLED + 1), "unknown error code") == 0 &&
                  strcmp(vlErrorString(-1), "unknown error code") == 0,
              "vlErrorString of unknown codes");
    }

    /* ---- after the final vlEnd ---- */
    vlEnd();
    expect("the final vlEnd", VL_NOERROR);
    vlScene();
    expect("vlScene after the final vlEnd", VL_BADSCOPE);
    vlEnd();
    expect("vlEnd after the final vlEnd", VL_BADSCOPE);
    vlMapping(1, VL_LOOKUP, 2, 1, table);
    expect("vlMapping after the final vlEnd", VL_BADSCOPE);
    check(vlSample(1, 0.5, 0.5, 0.5) == 0.0 && vlError() == VL_BADSCOPE,
          "vlSample after the final vlEnd: datasets are gone");

    /* ---- a valid scene with a known answer: the library is still healthy ----
       A constant slab (the unit cube) seen head-on along +z through its centre, lit by ambient
       light only: the centre pixel is (1 - T) C + T background with the transmittance
       T = (1 - o)^(L / reference), L = 1, o = 0.5, reference 0.5, so T = 0.25; with
       C = (1, 0.5, 0) and a blue background: 255 (0.75, 0.375, 0.25) = (191.25, 95.6, 63.75).
       The corners miss the cube and show the background. Refused settings in between must
       not have changed any of it. */
    vlInit();
    vlScene();
    vlCamera(&cam);
    vlImage("final.ppm", 1.0, 9, 9);
    vlBackground(0.0, 0.0, 1.0);
    vlBackground(nan, 0.0, 0.0); /* refused */
    vlAmbient(WHITE, 1.0);
    vlAmbient(WHITE, -5.0);      /* refused */
    vlStepSize(0.1, 0.5);
    vlStepSize(0.1, -0.5);       /* refused */
    vlObject();
    vlSet(VL_O, 0.5);
    vlSet(VL_R, 1.0);
    vlSet(VL_G, 0.5);
    vlSet(VL_KA, 1.0);
    vlScale(0.0, 1.0, 1.0);      /* refused */
    vlEnd();
    vlEnd();
    vlEnd();
    check(vlError() == VL_BADVALUE && vlError() == VL_BADVALUE && vlError() == VL_BADVALUE &&
              vlError() == VL_BADVALUE && vlError() == VL_NOERROR,
          "the final scene: four refused settings, nothing else");
    if (read_ppm("final.ppm", &w, &h, rgb, sizeof rgb) && w == 9 && h == 9) {
        unsigned char *c = rgb + 3 * (4 * 9 + 4), *corner = rgb;
        char detail[120];
        int ok = abs((int)c[0] * 4 - 765) <= 4 && abs((int)c[1] * 40 - 3825) <= 40 &&
                 abs((int)c[2] * 4 - 255) <= 4;
        sprintf(detail, "centre (%d, %d, %d), want (191.25, 95.6, 63.75) within 1", c[0],
                c[1], c[2]);
        report(ok, "final.ppm: the slab's centre pixel", detail);
        sprintf(detail, "corner (%d, %d, %d)", corner[0], corner[1], corner[2]);
        report(corner[0] == 0 && corner[1] == 0 && corner[2] == 255,
               "final.ppm: the corner shows the blue background", detail);
    } else {
        check(0, "final.ppm is a 9 x 9 binary PPM");
    }

    printf("%d cases, %d failure(s)\n", cases, failures);
    return failures == 0 ? 0 : 1;
}
