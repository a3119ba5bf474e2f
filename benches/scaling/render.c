/* The MNI peer scene (../shared/bench/README.md) through the C API: vlLoad a .vlb, then one
 * image. What benches/scaling.sh measures the C path's memory and time with.
 *
 *   render VLB PNG [SIZE] [STEP] [--steep]
 *
 * SIZE (default 512) is the image's side, STEP (default 0.5) the sample distance in voxels.
 * --steep replaces the opacity transfer function by a steep ramp (0 at 0.40, 0.9 at 0.45 of
 * the normalised value): a hard surface, where rays end a few samples in. One voxel is one
 * world unit, and a volume of ny nodes in y is taken as the template at (ny − 1)/232 voxels
 * per mm: the camera 360 mm in front of its centre (+y), opacity per mm, the step in voxels
 * (as `examples/mni.rs --fit`), so every volume of the table is seen and weighted alike. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vlib.h>

static int dims_of(const char *path, unsigned d[3]) {
    unsigned char h[28];
    FILE *f = fopen(path, "rb");
    int k, ok;
    if (!f)
        return 0;
    ok = fread(h, 1, sizeof h, f) == sizeof h && memcmp(h, "VLB1", 4) == 0;
    fclose(f);
    for (k = 0; ok && k < 3; k++)
        d[k] = h[4 + 4 * k] | h[5 + 4 * k] << 8 | h[6 + 4 * k] << 16 | (unsigned)h[7 + 4 * k] << 24;
    return ok;
}

int main(int argc, char **argv) {
    /* peer_settings.py on the normalised scale (value / 255). */
    static const vlfloat opacity[] = {40 / 255.f, 0, 80 / 255.f, .10f, 120 / 255.f, .35f,
                                      180 / 255.f, .60f, 1, .85f};
    static const vlfloat steep[] = {0.40f, 0, 0.45f, 0.9f, 1, 0.9f};
    static const vlfloat colour[] = {60 / 255.f, .55f, .35f, .30f, 110 / 255.f, .88f, .66f, .56f,
                                     180 / 255.f, .96f, .92f, .86f, 1, 1, 1, 1};
    unsigned d[3];
    int size = argc > 3 ? atoi(argv[3]) : 512, k, is_steep = 0, errors = 0;
    double step = argc > 4 ? atof(argv[4]) : 0.5;
    vlfloat scale;
    vlfloat ext[3], centre[3];
    VLCAMERA cam;
    vlint e;

    for (k = 1; k < argc; k++)
        is_steep |= strcmp(argv[k], "--steep") == 0;
    if (argc < 3 || size < 1 || !(step > 0) || !dims_of(argv[1], d)) {
        fprintf(stderr, "usage: render VLB PNG [SIZE] [STEP] [--steep]\n");
        return 2;
    }
    for (k = 0; k < 3; k++) {
        ext[k] = (vlfloat)d[k] - 1;
        centre[k] = ext[k] / 2;
    }
    scale = ext[1] / 232.0f; /* voxels per mm: the MNI template spans 232 mm in y */
    vlInit();
    vlLoad(1, argv[1]);
    if (is_steep)
        vlMapping(1, VL_RAMP, 3, 1, steep);
    else
        vlMapping(1, VL_RAMP, 5, 1, opacity);
    vlMapping(2, VL_RAMP, 4, 3, colour);
    vlScene();
    vlImage(argv[2], 1, size, size);
    for (k = 0; k < 3; k++) {
        cam.eye[k] = centre[k];
        cam.at[k] = centre[k];
        cam.up[k] = k == 2;
    }
    cam.eye[1] += 360.0f * scale;
    cam.fov = 30;
    vlCamera(&cam);
    vlBackground(0, 0, 0);
    vlAmbient(1, 1, 1, 1);
    vlDirectionalLight(0, -1, 0, 1, 1, 1, 1);
    vlStepSize((vlfloat)step, scale); /* opacity per mm */
    vlObject();
    vlFlip(VL_X);
    vlScale(ext[0], ext[1], ext[2]);
    vlDataset(VL_F, 1);
    vlMap(VL_O, VL_F, 1, 1);
    vlMap(VL_R, VL_F, 2, 1);
    vlMap(VL_G, VL_F, 2, 2);
    vlMap(VL_B, VL_F, 2, 3);
    vlSet(VL_KA, 0.2f);
    vlSet(VL_KD, 0.7f);
    vlSet(VL_KS, 0.3f);
    vlSet(VL_N, VLSPECULAR(10));
    vlEnd();
    vlEnd(); /* renders PNG */
    vlEnd();
    while ((e = vlError()) != VL_NOERROR) {
        fprintf(stderr, "vlError: %d (%s)\n", (int)e, vlErrorString(e));
        errors++;
    }
    return errors != 0;
}
