/* Misuse of the C interface through the public headers: illegal scopes, NULL pointers, bad
 * values, enumerations and field masks. Each case prints one line; the program exits non-zero if
 * any expectation fails. Finally a valid small scene is rendered and its PPM checked.
 * C89; built and run by capi/tests/c_examples.rs. */
#include <stdio.h>
#include <string.h>
#include <vlib.h>
#include <vlaux.h>

static int failures = 0;

/* Checks that the oldest queued error is `want` and that nothing else was queued. */
static void expect(const char *what, vlint want)
{
    vlint got = vlError();
    vlint extra = vlError();
    int ok = got == want && extra == VL_NOERROR;
    printf("%-4s %-52s want %2d (%s), got %2d", ok ? "ok" : "FAIL", what, (int)want,
           vlErrorString(want), (int)got);
    if (extra != VL_NOERROR)
        printf(" then %d", (int)extra);
    printf("\n");
    if (!ok)
        failures++;
    while (vlError() != VL_NOERROR)
        ;
}

int main(void)
{
    static vlfloat table[] = {0.001, 1.0, 1.0, 0.3};
    static vlfloat knots[] = {0.0, 0.5, 1.0};
    vlfloat p[3];
    VLCAMERA cam;
    FILE *f;
    char magic[3] = {0, 0, 0};

    p[0] = p[1] = p[2] = 0.5;
    cam.eye[0] = 0.0; cam.eye[1] = 0.0; cam.eye[2] = -3.0;
    cam.at[0] = 0.0; cam.at[1] = 0.0; cam.at[2] = 0.0;
    cam.up[0] = 0.0; cam.up[1] = 1.0; cam.up[2] = 0.0;
    cam.fov = 40.0;

    expect("empty queue", VL_NOERROR);
    vlScene();
    expect("vlScene before vlInit", VL_BADSCOPE);
    vlEnd();
    expect("vlEnd before vlInit", VL_BADSCOPE);
    vlInit();
    expect("vlInit", VL_NOERROR);
    vlInit();
    expect("vlInit twice", VL_BADSCOPE);
    vlImage("x.ppm", 1.0, 8, 8);
    expect("vlImage at library scope", VL_BADSCOPE);
    vlScene();
    vlImage(NULL, 1.0, 8, 8);
    expect("vlImage(NULL)", VL_NULLPOINTER);
    vlImage("x.ppm", 1.0, 0, 8);
    expect("vlImage with width 0", VL_BADVALUE);
    vlImage("x.gif", 1.0, 8, 8);
    expect("vlImage with an unknown format", VL_BADFILE);
    vlCamera(NULL);
    expect("vlCamera(NULL)", VL_NULLPOINTER);
    vlRenderType(99);
    expect("vlRenderType(99)", VL_BADENUM);
    vlToggle(VL_VISIBLE, 2);
    expect("vlToggle state 2", VL_BADVALUE);
    vlToggle(42, VL_TRUE);
    expect("vlToggle feature 42", VL_BADENUM);
    vlPointLight(0.0, 0.0, 0.0, 7, WHITE, 1.0);
    expect("vlPointLight attenuation 7", VL_BADENUM);
    vlBackground(2.0, 0.0, 0.0);
    expect("vlBackground red 2", VL_BADVALUE);
    vlMapping(1, VL_LOOKUP, 2, 1, NULL);
    expect("vlMapping(NULL table)", VL_NULLPOINTER);
    vlMapping(1, VL_LOOKUP, -1, 1, table);
    expect("vlMapping with -1 points", VL_BADVALUE);
    vlMapping(1, VL_LOOKUP, 2, 1, table);
    expect("vlMapping valid", VL_NOERROR);
    vlScale(2.0, 2.0, 2.0);
    expect("vlScale at scene scope", VL_BADSCOPE);
    vlObject();
    vlStepSize(1.0, 1.0);
    expect("vlStepSize inside an object", VL_BADSCOPE);
    vlSet(0, 1.0);
    expect("vlSet with an empty mask", VL_BADFIELD);
    vlSet(1 << 12, 1.0);
    expect("vlSet with an unknown field bit", VL_BADFIELD);
    vlMap(VL_O, VL_F, 7, 1);
    expect("vlMap through undeclared mapping 7", VL_BADID);
    vlMap(VL_KS, VL_F, 1, 2);
    expect("vlMap output 2 of a 1-output table (Figure 2)", VL_BADINDEX);
    vlMap(VL_O, VL_F | VL_O, 1, 1);
    expect("vlMap from two source fields", VL_BADFIELD);
    vlFunction(VL_F, NULL, 0);
    expect("vlFunction(NULL)", VL_NULLPOINTER);
    vlMatrix(NULL);
    expect("vlMatrix(NULL)", VL_NULLPOINTER);
    vlField(VL_O);
    expect("vlField outside a field function", VL_BADSCOPE);
    vlPosition(p);
    expect("vlPosition outside a field function", VL_BADSCOPE);
    vlEnd();
    vlEnd();
    vlEnd();
    expect("closing object, scene and library", VL_NOERROR);
    vluSpline(0.5, -1, knots);
    expect("vluSpline with -1 knots", VL_BADVALUE);
    vluNoise(NULL, 1.0, 0);
    expect("vluNoise(NULL)", VL_NULLPOINTER);
    if (strcmp(vlErrorString(9999), "unknown error code") != 0) {
        printf("FAIL vlErrorString(9999) = \"%s\"\n", vlErrorString(9999));
        failures++;
    } else {
        printf("ok   vlErrorString(9999) = \"%s\"\n", vlErrorString(9999));
    }

    /* A valid scene: an opaque sphere, 16 x 16. */
    vlInit();
    vlScene();
    vlCamera(&cam);
    vlImage("misuse.ppm", 1.0, 16, 16);
    vlBackground(BLACK);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-3.0, 3.0, -3.0, VL_NOATTENUATION, WHITE, 1.0);
    vlStepSize(0.02, 0.02);
    vlMapping(1, VL_LOOKUP, 2, 1, table);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlFunction(VL_F, VLU_SPHERE, 0);
    vlMap(VL_O, VL_F, 1, 1);
    vlSet(VL_COLORS, 0.8);
    vlSet(VL_KA | VL_KD, 0.5);
    vlEnd();
    vlEnd();
    vlEnd();
    expect("a valid scene", VL_NOERROR);
    f = fopen("misuse.ppm", "rb");
    if (f == NULL || fread(magic, 1, 2, f) != 2 || strcmp(magic, "P6") != 0) {
        printf("FAIL misuse.ppm was not written as a P6 PPM\n");
        failures++;
    } else {
        printf("ok   misuse.ppm written\n");
    }
    if (f != NULL)
        fclose(f);
    printf("%d failure(s)\n", failures);
    return failures == 0 ? 0 : 1;
}
