/* Text as a volume object: the idea of the paper's Figure 3(b). A word drawn into a grey image
 * (examples/word_png.rs) and converted with `vlconvert image word.png word.vlb` is a 2D dataset
 * (nx x ny x 1): vlib treats a dimension of size 1 as constant, so cast onto an object it is an
 * extruded word, a slab as deep as the object. Here it becomes a solid word standing in space.
 *
 * Geometry. Cast directly, `vlDataset(VL_F, WORD)`, the word would already render as a solid
 * extrusion, but the normals of a dataset-defined F are the dataset's gradients, which are zero
 * along z: the front and back faces would get no directional normal and be lit
 * "isotropically", a flat wash of colour. So F is composed in a field function instead: the
 * minimum of the letter coverage (vlSample of the word, which varies across the letters' edges)
 * and a slab profile along z (0.5 on the front and back faces, rising to 1 one world unit
 * inside, falling to 0 outside), about as steep as the letters' softened edges. Its
 * normals then come from central differences of the function: the front face points at -z, the
 * sides across the letters' edges, and the edge between them stays sharp.
 *
 * Opacity comes from F through a steep VL_RAMP (F 0.35 -> 0, F 0.5 -> 1), so the letters are
 * solid with a surface at F = 0.5. One world unit is one pixel of the word image.
 *
 * Build (from the workspace root) and run in the directory holding word.vlb:
 *   cc -std=gnu89 examples/c/text.c -Iinclude -Ltarget/release -lvlib -lm -o text
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./text [width]     (writes text.png, 16:9, default 640 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define WORD 1             /* dataset id */
#define SLAB 56.0f         /* thickness of the letters, world units */
#define BOX (SLAB + 6.0f)  /* depth of the object's box: a margin of 3 on each side */
#define RAMP 1.0f          /* width over which F rises from 0.5 to 1 inside the faces */

/* Geometry: min(letter coverage, slab profile along z). */
static void solid(vlfloat *p, void *misc)
{
    vlint id = *(vlint *)misc;
    vlfloat letters = vlSample(id, p[0], p[1], 0.0f);
    vlfloat inside = 0.5f * SLAB - (vlfloat)fabs(p[2] - 0.5f) * BOX; /* from the nearer face */
    vlfloat slab = 0.5f + inside / (2.0f * RAMP);
    vlSet(VL_F, letters < slab ? letters : slab);
}

/* The extent of a .vlb dataset's grid, (nx - 1) x (ny - 1): one world unit per pixel. Read from
   the file's header (api.md: "VLB1", then little-endian u32 nx, ny, nz). */
static int vlb_size(const char *path, vlfloat *w, vlfloat *h)
{
    unsigned char b[16];
    FILE *f = fopen(path, "rb");
    int ok = f && fread(b, 1, 16, f) == 16 && b[0] == 'V' && b[1] == 'L' && b[2] == 'B';
    if (f)
        fclose(f);
    if (!ok)
        return 0;
    *w = (vlfloat)(b[4] + 256.0 * b[5] + 65536.0 * b[6] + 16777216.0 * b[7] - 1.0);
    *h = (vlfloat)(b[8] + 256.0 * b[9] + 65536.0 * b[10] + 16777216.0 * b[11] - 1.0);
    return *w >= 1.0f && *h >= 1.0f;
}

/* Colour: a warm gold on the top of the letters shading to copper at their feet. */
static void gold(vlfloat *p, void *misc)
{
    vlfloat y = p[1];
    (void)misc;
    vlSet(VL_R, 0.93f);
    vlSet(VL_G, 0.42f + 0.36f * y);
    vlSet(VL_B, 0.12f + 0.10f * y);
}

int main(int argc, char **argv)
{
    static vlint word = WORD;
    static vlfloat opacity[] = {0.35f, 0.0f, 0.5f, 1.0f}; /* VL_RAMP: F -> O */
    vlint width = argc > 1 ? atoi(argv[1]) : 640;
    vlint height = width * 9 / 16;
    vlfloat nx, ny;
    vlint e;

    if (width < 16) {
        fprintf(stderr, "usage: text [width >= 16]\n");
        return 2;
    }
    if (!vlb_size("word.vlb", &nx, &ny)) {
        fprintf(stderr, "text: cannot read word.vlb (make it with word_png and vlconvert)\n");
        return 1;
    }
    vlInit();
    vlLoad(WORD, "word.vlb");
    vlMapping(1, VL_RAMP, 2, 1, opacity);

    vlScene();
    vlImage("text.png", (vlfloat)width / height, width, height);
    {
        VLCAMERA cam;
        cam.eye[0] = 0.5f * nx - 0.5f * nx;
        cam.eye[1] = 0.5f * ny + 0.9f * ny;
        cam.eye[2] = -1.45f * nx;
        cam.at[0] = 0.5f * nx + 0.02f * nx;
        cam.at[1] = 0.5f * ny - 0.05f * ny;
        cam.at[2] = 0.5f * BOX;
        cam.up[0] = 0.0f; cam.up[1] = 1.0f; cam.up[2] = 0.0f;
        cam.fov = 27.0f;
        vlCamera(&cam);
    }
    vlBackground(0.10, 0.12, 0.16);
    vlAmbient(WHITE, 1.0);
    vlPointLight(1.2f * nx, 2.5f * ny, -1.5f * nx, VL_NOATTENUATION, WHITE, 0.9);
    vlPointLight(-1.5f * nx, 0.5f * ny, -0.3f * nx, VL_NOATTENUATION, 0.55, 0.65, 0.9, 0.3);
    vlSuperSample(3);
    vlStepSize(0.5, 0.5);

    vlObject();
    vlScale(nx, ny, BOX);
    vlFunction(VL_F, solid, &word);
    vlMap(VL_O, VL_F, 1, 1);
    vlFunction(VL_COLORS, gold, NULL);
    vlSet(VL_KA, 0.22);
    vlSet(VL_KD, 0.75);
    vlSet(VL_KS, 0.55);
    vlSet(VL_N, VLSPECULAR(40));
    vlEnd();

    vlEnd(); /* renders text.png */
    vlEnd();
    while ((e = vlError()) != VL_NOERROR)
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
    return 0;
}
