/* vlRenderBuffer (the extension that renders the open scene into the caller's memory; issue
 * #25, item 3), through the C interface:
 *  - the buffers in VL_RGB8, VL_RGB16 and VL_RGB32F are the files vlImage writes of the same
 *    scene (.ppm, .rgb16.ppm, .pfm) byte for byte, once the files' byte and row orders are
 *    undone (16-bit PPM big-endian, PFM little-endian bottom row first);
 *  - VL_RGBA8, VL_RGBA16 and VL_RGBA32F hold alpha = 1 - T of the closed form T = (1 - o)^(L /
 *    reference) through a constant slab, straight colour in the integer formats and
 *    premultiplied colour in the float one, and 0 where no ray meets the slab; the 8-bit
 *    buffer is the 16-bit one rounded;
 *  - bytes past the image are left alone; a NULL buffer, a buffer one byte short, an unknown
 *    format, a bad size or aspect, and a call outside scene scope (library, object, inside a
 *    field function) return VL_FALSE with their error and write nothing;
 *  - vlProgress hears the render rise to 1; vlCancel in it stops the render (VL_CANCELLED),
 *    and the next render completes.
 * Prints one line per check, exits non-zero if any fails. C89. Built and run by
 * capi/tests/c_examples.rs, under valgrind by capi/tests/memcheck.rs. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "checks.h"
#include <vlib.h>

#define W 33
#define H 25
#define OPACITY 0.1f
#define DEPTH 10.0f
#define REFERENCE 5.0f

static const float colour[3] = {0.9f, 0.2f, 0.1f};

/* The slab scene, 20 units wide (the image's corners miss it), opened and left open. */
static void slab(void)
{
    VLCAMERA cam = {{0.0f, 0.0f, -100.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 20.0f};
    vlScene();
    vlCamera(&cam);
    vlBackground(0.25f, 0.5f, 0.125f);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlStepSize(0.7f, REFERENCE);
    vlObject();
    vlTranslate(-0.5f, -0.5f, 0.0f);
    vlScale(20.0f, 400.0f, DEPTH);
    vlSet(VL_O, OPACITY);
    vlSet(VL_R, colour[0]);
    vlSet(VL_G, colour[1]);
    vlSet(VL_B, colour[2]);
    vlSet(VL_KA, 1.0f);
    vlEnd();
}

/* The body of a file after its header `header`; NULL unless the file starts with it and has
   `bytes` bytes after it. */
static unsigned char *body(unsigned char *file, long n, const char *header, long bytes)
{
    long h = (long)strlen(header);
    if (!file || n != h + bytes || memcmp(file, header, (size_t)h) != 0)
        return NULL;
    return file + h;
}

static int progress_calls = 0, progress_cancels = 0;
static float progress_last = -1.0f;

static vlint progress(vlfloat done, void *misc)
{
    (void)misc;
    progress_calls++;
    progress_last = done;
    if (progress_cancels)
        vlCancel();
    return 1;
}

static vlint in_field = VL_NOERROR, in_field_result = -1;

static void field(vlvector p, void *misc)
{
    unsigned char b[4];
    (void)p;
    (void)misc;
    if (in_field == VL_NOERROR) {
        in_field_result = vlRenderBuffer(b, sizeof b, 1, 1, 1.0f, VL_RGB8);
        in_field = vlError();
    }
    vlSet(VL_O, 0.1f);
}

int main(void)
{
    const unsigned long px = (unsigned long)W * H;
    const float aspect = (float)W / (float)H;
    unsigned char *rgb8 = malloc(px * 3 + 16), *rgba8 = malloc(px * 4);
    unsigned short *rgb16 = malloc(px * 6), *rgba16 = malloc(px * 8);
    float *rgb32 = malloc(px * 12), *rgba32 = malloc(px * 16);
    unsigned char *file, *b;
    long n;
    unsigned long i, bad;
    vlint ok;
    double t, a;
    char line[200];
    int c, x, y;
    if (!rgb8 || !rgba8 || !rgb16 || !rgba16 || !rgb32 || !rgba32)
        return 2;

    vlInit();
    memset(rgb8, 0xA5, px * 3 + 16);
    ok = vlRenderBuffer(rgb8, px * 3, W, H, aspect, VL_RGB8);
    check("at library scope: VL_FALSE, VL_BADSCOPE, nothing written",
          ok == VL_FALSE && vlError() == VL_BADSCOPE && all_bytes(rgb8, px * 3 + 16, 0xA5));

    slab();
    vlImage("b.ppm", aspect, W, H);
    vlImage("b.rgb16.ppm", aspect, W, H);
    vlImage("b.pfm", aspect, W, H);

    /* Refusals: nothing written. */
    ok = vlRenderBuffer(NULL, px * 3, W, H, aspect, VL_RGB8);
    check("a NULL buffer: VL_FALSE, VL_NULLPOINTER", ok == VL_FALSE && vlError() == VL_NULLPOINTER);
    ok = vlRenderBuffer(rgb8, px * 3 - 1, W, H, aspect, VL_RGB8);
    check("a buffer one byte short: VL_BADVALUE, nothing written",
          ok == VL_FALSE && vlError() == VL_BADVALUE && all_bytes(rgb8, px * 3 + 16, 0xA5));
    ok = vlRenderBuffer(rgb8, px * 3, W, H, aspect, 0);
    c = vlError();
    ok |= vlRenderBuffer(rgb8, px * 3, W, H, aspect, VL_RGBA32F + 1);
    check("formats 0 and VL_RGBA32F + 1: VL_BADENUM",
          ok == VL_FALSE && c == VL_BADENUM && vlError() == VL_BADENUM);
    ok = vlRenderBuffer(rgb8, px * 3, 0, H, aspect, VL_RGB8);
    c = vlError();
    ok |= vlRenderBuffer(rgb8, px * 3, W, -3, aspect, VL_RGB8);
    c = c == VL_BADVALUE && vlError() == VL_BADVALUE;
    ok |= vlRenderBuffer(rgb8, px * 3, W, H, 0.0f, VL_RGB8);
    check("width 0, height -3, aspect 0: VL_BADVALUE, nothing written",
          ok == VL_FALSE && c && vlError() == VL_BADVALUE && all_bytes(rgb8, px * 3 + 16, 0xA5));

    /* The renders, with progress. */
    vlProgress(progress, NULL);
    ok = vlRenderBuffer(rgb8, px * 3 + 16, W, H, aspect, VL_RGB8);
    sprintf(line, "VL_RGB8 renders (%d), progress %d call_bytes(s) ending at %g, bytes past it kept",
            (int)ok, progress_calls, (double)progress_last);
    check(line, ok == VL_TRUE && vlError() == VL_NOERROR && progress_calls >= 1 &&
                    progress_last == 1.0f && all_bytes(rgb8 + px * 3, 16, 0xA5));
    ok = vlRenderBuffer(rgba8, px * 4, W, H, aspect, VL_RGBA8);
    ok &= vlRenderBuffer(rgb16, px * 6, W, H, aspect, VL_RGB16);
    ok &= vlRenderBuffer(rgba16, px * 8, W, H, aspect, VL_RGBA16);
    ok &= vlRenderBuffer(rgb32, px * 12, W, H, aspect, VL_RGB32F);
    ok &= vlRenderBuffer(rgba32, px * 16, W, H, aspect, VL_RGBA32F);
    check("every other format renders", ok == VL_TRUE && vlError() == VL_NOERROR);

    /* vlCancel in the progress function stops the render; the next one completes. */
    progress_cancels = 1;
    memset(rgb8, 0, px * 3);
    ok = vlRenderBuffer(rgb8, px * 3, W, H, aspect, VL_RGB8);
    check("vlCancel in the progress function: VL_FALSE, VL_CANCELLED",
          ok == VL_FALSE && vlError() == VL_CANCELLED);
    progress_cancels = 0;
    vlProgress(NULL, NULL);
    ok = vlRenderBuffer(rgb8, px * 3, W, H, aspect, VL_RGB8);
    check("the next render completes", ok == VL_TRUE && vlError() == VL_NOERROR);

    /* In an object: VL_BADSCOPE. */
    vlObject();
    ok = vlRenderBuffer(rgb8, px * 3, W, H, aspect, VL_RGB8);
    check("in an object: VL_BADSCOPE", ok == VL_FALSE && vlError() == VL_BADSCOPE);
    vlEnd();
    vlEnd(); /* the scene: writes the three files */
    check("the scene's files are written", vlError() == VL_NOERROR);

    /* The buffers against the files. */
    file = read_file("b.ppm", &n);
    sprintf(line, "P6\n%d %d\n255\n", W, H);
    b = body(file, n, line, (long)px * 3);
    check("VL_RGB8 is the .ppm byte for byte", b && memcmp(b, rgb8, px * 3) == 0);
    free(file);

    file = read_file("b.rgb16.ppm", &n);
    sprintf(line, "P6\n%d %d\n65535\n", W, H);
    b = body(file, n, line, (long)px * 6);
    for (bad = 0, i = 0; b && i < px * 3; i++)
        bad += rgb16[i] != (unsigned short)(b[2 * i] << 8 | b[2 * i + 1]);
    check("VL_RGB16 is the .rgb16.ppm (big-endian) value for value", b && bad == 0);
    free(file);

    file = read_file("b.pfm", &n);
    sprintf(line, "PF\n%d %d\n-1.0\n", W, H);
    b = body(file, n, line, (long)px * 12);
    for (bad = 0, y = 0; b && y < H; y++)
        for (x = 0; x < W * 3; x++) {
            const unsigned char *v = b + ((unsigned long)(H - 1 - y) * W * 3 + x) * 4;
            unsigned int le = v[0] | v[1] << 8 | v[2] << 16 | (unsigned int)v[3] << 24, mine;
            memcpy(&mine, &rgb32[(unsigned long)y * W * 3 + x], 4);
            bad += le != mine;
        }
    check("VL_RGB32F is the .pfm (little-endian, bottom row first) bit for bit", b && bad == 0);
    free(file);

    /* Alpha and colour against the closed form at the centre (its ray along the axis) and a
       corner (no slab). */
    i = (unsigned long)(H / 2) * W + W / 2;
    t = pow(1.0 - OPACITY, DEPTH / REFERENCE);
    a = 1.0 - t;
    sprintf(line,
            "RGBA centre (8-bit %d %d %d %d): straight colour in VL_RGBA8 and VL_RGBA16, "
            "premultiplied in VL_RGBA32F, alpha 1 - T = %.4f",
            rgba8[4 * i], rgba8[4 * i + 1], rgba8[4 * i + 2], rgba8[4 * i + 3], a);
    for (ok = 1, c = 0; c < 4; c++) {
        double want = c < 3 ? colour[c] : a;
        ok &= fabs(rgba8[4 * i + c] - want * 255.0) <= 0.5 + 1e-3;
        ok &= fabs(rgba16[4 * i + c] - want * 65535.0) <= 0.5 + 0.7;
        ok &= fabs(rgba32[4 * i + c] - want * (c < 3 ? a : 1.0)) <= 1e-5;
    }
    check(line, ok);
    check("a corner the slab misses is transparent black",
          all_bytes(rgba8, 4, 0) && rgba16[0] == 0 && rgba16[3] == 0 && rgba32[0] == 0.0f &&
              rgba32[3] == 0.0f);
    for (bad = 0, i = 0; i < px * 4; i++)
        bad += rgba8[i] != (rgba16[i] * 255UL + 32767UL) / 65535UL;
    for (i = 0; i < px * 3; i++)
        bad += rgb8[i] != (rgb16[i] * 255UL + 32767UL) / 65535UL;
    check("the 8-bit buffers are the 16-bit ones rounded", bad == 0);

    /* Inside a field function (sample scope): VL_BADSCOPE. */
    vlScene();
    {
        VLCAMERA cam = {{0.5f, 0.5f, -3.0f}, {0.5f, 0.5f, 0.5f}, {0.0f, 1.0f, 0.0f}, 40.0f};
        vlCamera(&cam);
    }
    vlObject();
    vlFunction(VL_O, field, NULL);
    vlEnd();
    ok = vlRenderBuffer(rgb8, 3, 1, 1, 1.0f, VL_RGB8);
    check("inside a field function: VL_FALSE, VL_BADSCOPE",
          ok == VL_TRUE && in_field_result == VL_FALSE && in_field == VL_BADSCOPE);
    vlEnd();
    vlEnd();
    while (vlError() != VL_NOERROR)
        ;
    free(rgb8);
    free(rgba8);
    free(rgb16);
    free(rgba16);
    free(rgb32);
    free(rgba32);
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
