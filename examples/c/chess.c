/* A chess board, after 1. e4 e5 2. Nf3 Nc6: 32 pieces turned from 2D profiles, as the paper's
 * chess pieces were made.
 *
 * Each kind of piece is one profile dataset: the right half of its silhouette, drawn by
 * examples/profiles.rs and converted with vlconvert (pawn.vlb, rook.vlb, knight.vlb,
 * bishop.vlb, queen.vlb, king.vlb, knight_head.vlb). The datasets are loaded once and shared by
 * all the pieces: each piece is an object whose F is vlFunction(VL_F, VLU_SWEEP, &id) (the
 * profile turned about the object's vertical axis), whose opacity is F through a steep ramp,
 * and whose colour says whose piece it is. A knight is not rotationally symmetric: its F is the
 * larger of a swept base and a horse's head (a 2D silhouette extruded into a slab, as text.c
 * extrudes a word), composed in a field function that calls VLU_SWEEP itself. The king's cross
 * and the rook's crenellations are not symmetric either: turned, they become a finial and a
 * hollow turret.
 *
 * The board is one flat object: F falls from 1 inside to 0.5 on its faces (so the normals of
 * its top face point up), and a field function paints the squares from the world position,
 * with a little wood grain from vluTurbulence.
 *
 * World units: one square is 40 (the board is 320 across, plus a border), y is up, the board's
 * top is at y = 0, white plays from z < 0 (rank 1 at z = -140) and the a-file is at x = -140.
 * The profiles have 4 pixels per world unit and a margin of 2 units above and below the piece;
 * the sizes of the objects are read from the .vlb headers.
 *
 * Build (from the workspace root) and run in the directory holding the .vlb files:
 *   cc -std=gnu89 examples/c/chess.c -Iinclude -Ltarget/release -lvlib -lm -o chess
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./chess [width]   (writes chess.png, 16:10, default 640 wide)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define PX 4.0f         /* pixels per world unit in the profiles (examples/profiles.rs) */
#define MARGIN 2.0f     /* empty units below and above each profile */
#define SQUARE 40.0f    /* one square of the board */
#define BORDER 14.0f    /* the board's frame around the 8 x 8 squares */
#define THICK 10.0f     /* the board's thickness */
#define RAMP 1.0f       /* F rises from 0.5 on a face to 1 this far inside (board, knight) */
#define HEAD_THICK 10.0f /* thickness of the knight's head */
#define OPACITY 1       /* mapping id: F -> O */

enum { PAWN, ROOK, KNIGHT, BISHOP, QUEEN, KING, HEAD, KINDS };

static const char *const files[KINDS] = {"pawn.vlb",  "rook.vlb",  "knight.vlb",     "bishop.vlb",
                                         "queen.vlb", "king.vlb",  "knight_head.vlb"};
/* Dataset ids (VLU_SWEEP's misc points to one of these: they must outlive the render). */
static vlint ids[KINDS] = {1, 2, 3, 4, 5, 6, 7};
/* The world size of each profile's box: width (the diameter of the sweep, or the head image's
   width) and height, margins included. */
static vlfloat width[KINDS], height[KINDS];

/* Grid extent of a .vlb file in profile pixels, (nx - 1) and (ny - 1), from its header
   (api.md: "VLB1", then little-endian u32 nx, ny, nz). */
static int vlb_extent(const char *path, vlfloat *w, vlfloat *h)
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

static vlfloat clamp01(vlfloat v)
{
    return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
}

/* The knight: max(swept base, extruded head). The head image spans the object's x and y; along
   z it is a slab HEAD_THICK units thick, centred, with faces at F = 0.5. */
static void knight(vlfloat *p, void *misc)
{
    vlfloat base, head, inside, slab;
    (void)misc;
    VLU_SWEEP(p, &ids[KNIGHT]); /* writes F, the field this function's vlFunction named */
    base = vlField(VL_F);
    head = vlSample(ids[HEAD], p[0], p[1], 0.0f);
    inside = 0.5f * HEAD_THICK - (vlfloat)fabs(p[2] - 0.5f) * width[KNIGHT];
    slab = clamp01(0.5f + inside / (2.0f * RAMP));
    if (slab < head)
        head = slab;
    vlSet(VL_F, base > head ? base : head);
}

/* The board: F from the distance to the nearest face (world units), squares by position. */
static void board(vlfloat *p, void *misc)
{
    vlfloat w[3], half = 4.0f * SQUARE + BORDER, d, dx, dz, dy, grain, r, g, b;
    int i, j;
    (void)p;
    (void)misc;
    vlPosition(w);
    dx = half - (vlfloat)fabs(w[0]);
    dz = half - (vlfloat)fabs(w[2]);
    dy = 0.5f * THICK - (vlfloat)fabs(w[1] + 0.5f * THICK);
    d = dx < dz ? dx : dz;
    d = d < dy ? d : dy;
    vlSet(VL_F, 0.5f + d / (2.0f * RAMP));
    i = (int)floor((w[0] + 4.0f * SQUARE) / SQUARE);
    j = (int)floor((w[2] + 4.0f * SQUARE) / SQUARE);
    /* Grain: turbulence stretched along the squares' own direction, alternating per square. */
    {
        vlfloat q[3];
        int along_x = (i + j) % 2 == 0;
        q[0] = along_x ? w[0] * 0.01f : w[0] * 0.25f;
        q[1] = w[1] * 0.25f;
        q[2] = along_x ? w[2] * 0.25f : w[2] * 0.01f;
        grain = 0.85f + 0.3f * vluTurbulence(q, 1.0f, 3, 7);
    }
    if (i < 0 || i > 7 || j < 0 || j > 7) { /* the frame */
        r = 0.30f; g = 0.17f; b = 0.09f;
    } else if ((i + j) % 2 == 0) {          /* dark squares (a1 is dark) */
        r = 0.45f; g = 0.27f; b = 0.14f;
    } else {                                /* light squares */
        r = 0.86f; g = 0.72f; b = 0.50f;
    }
    vlSet(VL_R, r * grain);
    vlSet(VL_G, g * grain);
    vlSet(VL_B, b * grain);
}

/* One piece of `kind` on square (file 0..7 = a..h, rank 1..8). */
static void piece(int kind, int white, int file, int rank)
{
    vlfloat x = -3.5f * SQUARE + file * SQUARE, z = -3.5f * SQUARE + (rank - 1) * SQUARE;
    vlObject();
    vlTranslate(-0.5, 0.0, -0.5); /* the axis through the origin, the base at y = 0 */
    vlScale(width[kind], height[kind], width[kind]);
    if (kind == KNIGHT && !white)
        vlRotate(0.0, 180.0, 0.0); /* white knights face +x, black ones -x: side on to the
                                      camera, as a photographer would turn them */
    vlTranslate(x, -MARGIN, z);
    if (kind == KNIGHT)
        vlFunction(VL_F, knight, NULL);
    else
        vlFunction(VL_F, VLU_SWEEP, &ids[kind]);
    vlMap(VL_O, VL_F, OPACITY, 1);
    if (white) {
        vlSet(VL_R, 0.93); vlSet(VL_G, 0.87); vlSet(VL_B, 0.74);
        vlSet(VL_KA, 0.30); vlSet(VL_KD, 0.70); vlSet(VL_KS, 0.35);
        vlSet(VL_N, VLSPECULAR(25));
    } else {
        vlSet(VL_R, 0.16); vlSet(VL_G, 0.12); vlSet(VL_B, 0.11);
        vlSet(VL_KA, 0.30); vlSet(VL_KD, 0.80); vlSet(VL_KS, 0.55);
        vlSet(VL_N, VLSPECULAR(45));
    }
    vlEnd();
}

int main(int argc, char **argv)
{
    static vlfloat opacity[] = {0.35f, 0.0f, 0.5f, 1.0f}; /* VL_RAMP: F -> O, solid above 0.5 */
    static const int back[8] = {ROOK, KNIGHT, BISHOP, QUEEN, KING, BISHOP, KNIGHT, ROOK};
    vlint w = argc > 1 ? atoi(argv[1]) : 640, h = w * 5 / 8;
    vlint e;
    int k, f;

    if (w < 16) {
        fprintf(stderr, "usage: chess [width >= 16]\n");
        return 2;
    }
    for (k = 0; k < KINDS; k++) {
        vlfloat nx, ny;
        if (!vlb_extent(files[k], &nx, &ny)) {
            fprintf(stderr, "chess: cannot read %s (make it with the profiles example and "
                            "vlconvert)\n", files[k]);
            return 1;
        }
        width[k] = (k == HEAD ? 1.0f : 2.0f) * nx / PX;
        height[k] = ny / PX;
    }
    vlInit();
    for (k = 0; k < KINDS; k++)
        vlLoad(ids[k], files[k]);
    vlMapping(OPACITY, VL_RAMP, 2, 1, opacity);

    vlScene();
    vlImage("chess.png", (vlfloat)w / h, w, h);
    {
        VLCAMERA cam;
        cam.eye[0] = -175.0f; cam.eye[1] = 320.0f; cam.eye[2] = -435.0f;
        cam.at[0] = 12.0f;    cam.at[1] = -12.0f;  cam.at[2] = 8.0f;
        cam.up[0] = 0.0f;     cam.up[1] = 1.0f;    cam.up[2] = 0.0f;
        cam.fov = 41.0f; /* the whole board in the frame, with a margin */
        vlCamera(&cam);
    }
    vlBackground(0.58, 0.63, 0.70);
    vlAmbient(WHITE, 1.0);
    vlPointLight(-260.0, 520.0, -330.0, VL_NOATTENUATION, 1.0, 0.97, 0.92, 0.85);
    vlSuperSample(3);
    vlStepSize(0.5, 1.0); /* 1 leaves ridges where the surface falls between samples */

    /* The board. */
    vlObject();
    vlTranslate(-0.5, -1.0, -0.5); /* top face of the box at y = 0 */
    vlScale(8.0f * SQUARE + 2.0f * BORDER + 6.0f, THICK + 6.0f, 8.0f * SQUARE + 2.0f * BORDER + 6.0f);
    vlTranslate(0.0, 3.0, 0.0);    /* a margin of 3 around the board itself */
    vlFunction(VL_F | VL_COLORS, board, NULL);
    vlMap(VL_O, VL_F, OPACITY, 1);
    vlSet(VL_KA, 0.30);
    vlSet(VL_KD, 0.75);
    vlSet(VL_KS, 0.25);
    vlSet(VL_N, VLSPECULAR(20));
    vlEnd();

    /* The pieces, after 1. e4 e5 2. Nf3 Nc6. */
    for (f = 0; f < 8; f++) {
        int moved = f == 4;                                  /* the e-pawns */
        piece(back[f], 1, f == 6 ? 5 : f, f == 6 ? 3 : 1);   /* Ng1-f3 */
        piece(PAWN, 1, f, moved ? 4 : 2);
        piece(PAWN, 0, f, moved ? 5 : 7);
        piece(back[f], 0, f == 1 ? 2 : f, f == 1 ? 6 : 8);   /* Nb8-c6 */
    }

    vlEnd(); /* renders chess.png */
    vlEnd();
    while ((e = vlError()) != VL_NOERROR)
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
    return 0;
}
