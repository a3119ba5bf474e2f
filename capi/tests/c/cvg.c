/* The CVG operators of vlaux (VLU_UNION, VLU_INTERSECTION, VLU_DIFFERENCE, VLU_BLEND) through the
 * public headers, checked node by node against the formulas of docs/cvg.md computed here.
 *
 * For each operator, a parent object (the unit cube scaled to 10 world units) holds two children
 * whose fields come from VLU_SPHERE (the spherical distance field 1 - 2|q - c|) and a constant
 * red: child 1 is moved left, child 2 is squashed and moved right and up. The parent runs
 * vlSet(VL_G, 0.5) and then vlFunction(VL_O | VL_R, operator, 0). vlVolume voxelizes O, R and G
 * at 24^3 nodes with 16 bits, and every node is compared, within 1e-3, with
 *   O: the operator's opacity over the children's opacities (0 outside a child's box);
 *   R: the attribute rule (select for union / intersection / difference, the opacity-weighted
 *      mean for blend), skipped where the selection is ambiguous (near-equal opacities, or a
 *      node within 1e-4 of a child's box, where float rounding decides inside or outside) or the
 *      blend's weights are tiny;
 *   G: 0.5 everywhere (the operator writes only the fields its vlFunction call names).
 * Also: the operators record VL_BADSCOPE at library, scene and object scope and from a spatial
 * transfer function. Prints one line per check and exits non-zero if any fails. C89; built and
 * run by capi/tests/c_examples.rs. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define N 24               /* nodes per axis */
#define SIZE 10.0          /* the parent's world size */
#define R1 0.25            /* the children's red */
#define R2 0.75

enum { UNION, INTERSECTION, DIFFERENCE, BLEND, OPS };

static const char *const names[OPS] = {"VLU_UNION", "VLU_INTERSECTION", "VLU_DIFFERENCE",
                                       "VLU_BLEND"};
static void (*const ops[OPS])(vlfloat *, void *) = {VLU_UNION, VLU_INTERSECTION, VLU_DIFFERENCE,
                                                    VLU_BLEND};

/* Child 2's transforms in the parent's space: vlTranslate(-.5, -.5, -.5); vlScale(S2);
   vlTranslate(T2). */
static const double S2[3] = {0.8, 0.6, 0.8};
static const double T2[3] = {0.7, 0.55, 0.5};
/* Child 1: vlTranslate(-0.2, 0, 0). */
static const double T1[3] = {-0.2, 0.0, 0.0};

static int failures = 0;
static volatile int spatial_calls = 0;

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

/* A child's fields at child point q: the sphere's opacity and the child's red, 0 outside its
   box [0, 1]^3. *edge is set when q lies within 1e-4 of the box's faces. */
static void child_at(const double q[3], double red, double *o, double *r, int *edge)
{
    int i, in = 1;
    double d = 0.0;
    for (i = 0; i < 3; i++) {
        if (q[i] < 0.0 || q[i] > 1.0)
            in = 0;
        if (fabs(q[i]) < 1e-4 || fabs(q[i] - 1.0) < 1e-4)
            *edge = 1;
        d += (q[i] - 0.5) * (q[i] - 0.5);
    }
    d = 1.0 - 2.0 * sqrt(d);
    *o = in ? (d < 0.0 ? 0.0 : d > 1.0 ? 1.0 : d) : 0.0;
    *r = in ? red : 0.0;
}

static unsigned long u32_at(const unsigned char *b)
{
    return b[0] | (unsigned long)b[1] << 8 | (unsigned long)b[2] << 16 | (unsigned long)b[3] << 24;
}

/* Reads a 16-bit N^3 .vlb written by vlVolume (a = 0, b = 65535) into v, normalised. */
static int read_vlb(const char *path, double *v)
{
    unsigned char h[28], b[2];
    FILE *f = fopen(path, "rb");
    long i;
    int ok = f && fread(h, 1, 28, f) == 28 && h[0] == 'V' && h[1] == 'L' && h[2] == 'B' &&
             h[3] == '1' && u32_at(h + 4) == N && u32_at(h + 8) == N && u32_at(h + 12) == N &&
             u32_at(h + 16) == 2;
    for (i = 0; ok && i < (long)N * N * N; i++) {
        ok = fread(b, 1, 2, f) == 2;
        v[i] = (b[0] | b[1] << 8) / 65535.0;
    }
    if (f)
        fclose(f);
    return ok;
}

/* A spatial transfer function that calls an operator: not a field function, VL_BADSCOPE. */
static void misplaced(vlfloat *p, void *misc)
{
    (void)misc;
    spatial_calls++;
    VLU_BLEND(p, NULL);
}

static void voxelize(int op)
{
    char prefix[32];
    sprintf(prefix, "cvg%d", op);
    vlScene();
    vlVolume(prefix, VL_O | VL_R | VL_G, 0.0, 0.0, 0.0, SIZE, SIZE, SIZE, N, N, N, 2);
    vlObject();
    vlScale(SIZE, SIZE, SIZE);
    vlObject(); /* child 1 */
    vlTranslate(T1[0], T1[1], T1[2]);
    vlFunction(VL_O, VLU_SPHERE, 0);
    vlSet(VL_R, R1);
    vlEnd();
    vlObject(); /* child 2 */
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(S2[0], S2[1], S2[2]);
    vlTranslate(T2[0], T2[1], T2[2]);
    vlFunction(VL_O, VLU_SPHERE, 0);
    vlSet(VL_R, R2);
    vlEnd();
    vlSet(VL_G, 0.5);
    vlFunction(VL_O | VL_R, ops[op], 0);
    vlEnd();
    vlEnd();
}

static void verify(int op)
{
    static double o[N * N * N], r[N * N * N], g[N * N * N];
    char path[3][16], what[128];
    int i, j, k, c, nonzero = 0, rchecked = 0;
    double worst_o = 0.0, worst_r = 0.0, worst_g = 0.0;
    sprintf(path[0], "cvg%d_o.vlb", op);
    sprintf(path[1], "cvg%d_r.vlb", op);
    sprintf(path[2], "cvg%d_g.vlb", op);
    sprintf(what, "%s: read %s, %s, %s", names[op], path[0], path[1], path[2]);
    if (!(read_vlb(path[0], o) && read_vlb(path[1], r) && read_vlb(path[2], g))) {
        check(what, 0);
        return;
    }
    for (k = 0; k < N; k++)
        for (j = 0; j < N; j++)
            for (i = 0; i < N; i++) {
                long n = i + (long)N * (j + (long)N * k);
                double p[3], q1[3], q2[3], o1, o2, r1, r2, wo, wr;
                int edge = 0, sure = 1;
                p[0] = i / (N - 1.0);
                p[1] = j / (N - 1.0);
                p[2] = k / (N - 1.0);
                for (c = 0; c < 3; c++) {
                    q1[c] = p[c] - T1[c];
                    q2[c] = (p[c] - T2[c]) / S2[c] + 0.5;
                }
                child_at(q1, R1, &o1, &r1, &edge);
                child_at(q2, R2, &o2, &r2, &edge);
                switch (op) {
                case UNION:
                    wo = o1 > o2 ? o1 : o2;
                    wr = o2 > o1 ? r2 : r1;
                    sure = o1 == o2 ? o1 == 0.0 : fabs(o1 - o2) > 1e-4;
                    break;
                case INTERSECTION:
                    wo = o1 < o2 ? o1 : o2;
                    wr = o2 < o1 ? r2 : r1;
                    sure = o1 == o2 ? o1 == 0.0 : fabs(o1 - o2) > 1e-4;
                    break;
                case DIFFERENCE:
                    wo = o1 < 1.0 - o2 ? o1 : 1.0 - o2;
                    wr = r1;
                    break;
                default:
                    wo = 1.0 - (1.0 - o1) * (1.0 - o2);
                    wr = o1 + o2 > 0.0 ? (o1 * r1 + o2 * r2) / (o1 + o2) : 0.0;
                    sure = o1 + o2 == 0.0 || o1 + o2 > 1e-2;
                    break;
                }
                if (fabs(o[n] - wo) > worst_o)
                    worst_o = fabs(o[n] - wo);
                if (!edge && sure) {
                    rchecked++;
                    if (fabs(r[n] - wr) > worst_r)
                        worst_r = fabs(r[n] - wr);
                }
                if (fabs(g[n] - 0.5) > worst_g)
                    worst_g = fabs(g[n] - 0.5);
                nonzero += wo > 0.01;
            }
    sprintf(what, "%s: O at every node (largest error %.2e)", names[op], worst_o);
    check(what, worst_o < 1e-3);
    sprintf(what, "%s: R at %d nodes (largest error %.2e)", names[op], rchecked, worst_r);
    check(what, worst_r < 1e-3 && rchecked > N * N * N / 2);
    sprintf(what, "%s: G untouched, 0.5 (largest error %.2e)", names[op], worst_g);
    check(what, worst_g < 1e-3);
    sprintf(what, "%s: the shapes are seen (%d nodes with O > 0.01)", names[op], nonzero);
    check(what, nonzero > 100);
}

int main(void)
{
    vlfloat p[3];
    int op;

    p[0] = p[1] = p[2] = 0.5f;
    vlInit();
    for (op = 0; op < OPS; op++) {
        char what[64];
        ops[op](p, NULL);
        sprintf(what, "%s at library scope", names[op]);
        expect(what, VL_BADSCOPE);
    }
    vlScene();
    VLU_UNION(p, NULL);
    expect("VLU_UNION at scene scope", VL_BADSCOPE);
    vlObject();
    VLU_DIFFERENCE(p, NULL);
    expect("VLU_DIFFERENCE at object scope", VL_BADSCOPE);
    vlEnd();
    vlEnd();
    expect("an empty scene", VL_NOERROR);

    /* A spatial function calling an operator, rendered into a tiny image. */
    vlScene();
    vlImage("cvg.ppm", 1.0, 8, 8);
    vlObject();
    vlObject();
    vlFunction(VL_O, VLU_SPHERE, 0);
    vlEnd();
    vlSpatial(misplaced, NULL);
    vlFunction(VL_ALLFIELDS, VLU_UNION, 0);
    vlEnd();
    vlEnd();
    check("the spatial function ran", spatial_calls > 0);
    expect("VLU_BLEND in a spatial function", VL_BADSCOPE);

    for (op = 0; op < OPS; op++) {
        voxelize(op);
        expect("voxelize", VL_NOERROR);
        verify(op);
    }
    vlEnd();
    expect("vlEnd", VL_NOERROR);
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
