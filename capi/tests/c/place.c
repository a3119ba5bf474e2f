/* vluPlace: an object placed at a dataset's physical size and position from the geometry
 * sidecar beside its .vlb (docs/data.md). The program writes a 4 x 3 x 2 dataset and its
 * sidecar (spacing 10 x 20 x 30 mm, node 0 at (100, 200, 300)), places an opaque object by it
 * and renders it from far along -z: the box spans x 100 ... 130 and y 200 ... 240, so the
 * image's middle pixel (the camera looks at the box's centre) is lit, and a pixel beyond the
 * box's edge is not. Also: vluPlace of an unknown id is VL_BADID, of a dataset without a
 * sidecar VL_BADVALUE, outside an object VL_BADSCOPE. Prints one line per check and exits
 * non-zero if any fails. C89; built and run by capi/tests/c_examples.rs, under valgrind by
 * capi/tests/memcheck.rs. */
#include <stdio.h>
#include <string.h>
#include "checks.h"
#include <vlaux.h>
#include <vlib.h>

/* A 4 x 3 x 2 .vlb of one-byte voxels, all 200 (a = 0, b = 255). */
static int write_vlb(const char *path)
{
    unsigned char h[28], body[24];
    FILE *f = fopen(path, "wb");
    int ok;
    if (!f)
        return 0;
    vlb_header(h, 4, 3, 2, 1, 0.0f, 255.0f);
    memset(body, 200, sizeof body);
    ok = fwrite(h, 1, 28, f) == 28 && fwrite(body, 1, 24, f) == 24;
    return fclose(f) == 0 && ok;
}

int main(void)
{
    /* The box's centre is (115, 220, 315); 2 000 mm in front of it, looking along +z. */
    VLCAMERA cam = {{115.0f, 220.0f, -1685.0f}, {115.0f, 220.0f, 315.0f}, {0.0f, 1.0f, 0.0f}, 2.0f};
    FILE *g;
    int inside, outside;
    check("write placed.vlb", write_vlb("placed.vlb"));
    g = fopen("placed.vlb.geom", "w");
    check("write its sidecar", g != NULL);
    if (g) {
        fputs("vlib-geometry 1\ndims 4 3 2\nrow 10 0 0 100\nrow 0 20 0 200\nrow 0 0 30 300\n", g);
        fclose(g);
    }
    check("write bare.vlb (no sidecar)", write_vlb("bare.vlb"));
    vlInit();
    vlLoad(1, "placed.vlb");
    vlLoad(2, "bare.vlb");
    check("both load", vlError() == VL_NOERROR);
    vluPlace(1);
    check("vluPlace at library scope is VL_BADSCOPE", vlError() == VL_BADSCOPE);
    vlScene();
    vlImage("placed.ppm", 1.0f, 64, 64);
    vlCamera(&cam);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlObject();
    vluPlace(99);
    check("vluPlace of an unknown id is VL_BADID", vlError() == VL_BADID);
    vluPlace(2);
    check("vluPlace of a dataset without geometry is VL_BADVALUE", vlError() == VL_BADVALUE);
    vluPlace(1);
    check("vluPlace of a placed dataset", vlError() == VL_NOERROR);
    vlDataset(VL_F, 1);
    vlSet(VL_O | VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
    check("the scene renders", vlError() == VL_NOERROR);
    /* The view is 2 * 2000 * tan(1 degree) = 69.8 mm wide over 64 pixels: the box's 30 mm
       span columns 18 ... 45, its 40 mm rows 13 ... 50. */
    inside = ppm_red("placed.ppm", 64, 32, 32);
    outside = ppm_red("placed.ppm", 64, 8, 32);
    check("the box's centre is lit", inside > 200);
    check("beyond its x edge is not", outside == 0);
    vlEnd();
    remove("placed.vlb");
    remove("placed.vlb.geom");
    remove("bare.vlb");
    remove("placed.ppm");
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
