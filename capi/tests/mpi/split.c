/* A program for the MPI tests (capi/tests/mpi.rs), the same for the plain library and the MPI
 * build: an RGBA image with 2x2 super-sampling of a granite-textured paraboloid whose field
 * function also misuses a command (vlImage in sample scope: VL_BADSCOPE, recorded on the rank
 * that rendered the sample), then a voxelization of three fields (16-bit) and one field
 * (8-bit). It prints "badscope seen" when vlError reported the misuse after the scene's vlEnd,
 * as one process does, and exits with 1 if not. */
#include <stdio.h>
#include <vlib.h>
#include <vlaux.h>

static void granite(vlvector p, void *misc)
{
    vlfloat t = vluTurbulence(p, 5.0f, 4, 1);
    vlfloat g = 0.4f + 0.4f * (t > 1.0f ? 1.0f : t);
    (void)misc;
    vlSet(VL_R, g);
    vlSet(VL_G, 0.9f * g);
    vlSet(VL_B, 0.8f * g);
    vlImage("never.ppm", 1.0, 8, 8); /* not legal here: VL_BADSCOPE (the queue keeps 1024) */
}

vlfloat ramp[] = {0.001f, 1.0f, 1.0f, 0.4f};

int main(void)
{
    vlint e;
    int badscope = 0;

    vlInit();
    vlScene();
    vluCamera(175.0, 250.0, -350.0, 175.0, 140.0, 70.0);
    vlImage("split.rgba.png", 1.25, 100, 80);
    vlSuperSample(2);
    vlVolume("split", VL_O | VL_R | VL_G, 0.0, 0.0, 0.0, 350.0, 300.0, 300.0, 24, 20, 20, 2);
    vlVolume("split8", VL_B, 0.0, 0.0, 0.0, 350.0, 300.0, 300.0, 17, 13, 11, 1);
    vlBackground(0.2, 0.3, 0.4);
    vlMapping(1, VL_LOOKUP, 2, 1, ramp);
    vlPointLight(-200.0, 380.0, -200.0, VL_NOATTENUATION, 1.0, 1.0, 1.0, 1.0);
    vlAmbient(1.0, 1.0, 1.0, 1.0);
    vlObject();
    vlScale(350.0, 300.0, 300.0);
    vlFunction(VL_F, &VL_PARAB1, 0);
    vlMap(VL_O, VL_F, 1, 1);
    vlFunction(VL_R | VL_G | VL_B, &granite, 0);
    vlSet(VL_KA, 0.3);
    vlSet(VL_KD, 0.6);
    vlEnd();
    vlEnd();
    while ((e = vlError()) != VL_NOERROR) {
        if (e == VL_BADSCOPE)
            badscope = 1;
        else
            printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
    }
    vlEnd();
    printf("%s\n", badscope ? "badscope seen" : "no badscope");
    return badscope ? 0 : 1;
}
