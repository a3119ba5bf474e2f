/* A program for the MPI tests (capi/tests/mpi.rs), the same for the plain library and the MPI
 * build: vlRenderBuffer calls that rank 1 alone makes with arguments it refuses, each followed
 * by a valid render on every rank. Rank 0 makes the valid call every time; rank 1 (under
 * mpirun -np 2) refuses, one step each: a NULL buffer, an unknown format, a width of 0 (the C
 * layer's checks), an aspect of -1 and a buffer one byte short (the core's), and a call inside
 * an object (the scope). Under MPI every rank must fail each of these calls (the other rank
 * would otherwise wait for it) and go on to the next render.
 *
 * The rank is the launcher's (OMPI_COMM_WORLD_RANK, PMIX_RANK or PMI_RANK; 0 without one). For
 * each call it prints a line "<step> rank <r>: <1 or 0, the call's result> <the codes vlError
 * then reports, comma-separated, or none>"; each valid render after a step writes its buffer to
 * "<step>.r<rank>.ppm" (a binary PPM). It exits with 1 when one of those valid renders fails,
 * else 0: the test (capi/tests/mpi.rs) judges the lines and compares the files with one
 * process's. C89. */
#include <stdio.h>
#include <stdlib.h>
#include <vlib.h>
#include <vlaux.h>

#define W 48
#define H 36
#define ASPECT (4.0f / 3.0f)
#define BYTES ((unsigned long)W * H * 3)

static unsigned char *image;

/* Prints the line of `step`'s call, which returned `ok`, with the codes vlError reports. */
static void report(const char *step, int rank, vlint ok)
{
    vlint e;
    int n = 0;
    printf("%s rank %d: %d ", step, rank, ok == VL_TRUE ? 1 : 0);
    while ((e = vlError()) != VL_NOERROR)
        printf(n++ ? ",%d" : "%d", (int)e);
    printf("%s\n", n ? "" : "none");
    fflush(stdout);
}

/* A valid render on every rank, after `step`; written to "<step>.r<rank>.ppm". 0 if it fails. */
static int render(const char *step, int rank)
{
    char name[64];
    FILE *f;
    vlint ok = vlRenderBuffer(image, BYTES, W, H, ASPECT, VL_RGB8);
    report(step, rank, ok);
    if (ok != VL_TRUE)
        return 0;
    sprintf(name, "%s.r%d.ppm", step, rank);
    f = fopen(name, "wb");
    if (!f)
        return 0;
    fprintf(f, "P6\n%d %d\n255\n", W, H);
    fwrite(image, 1, BYTES, f);
    return fclose(f) == 0;
}

vlfloat ramp[] = {0.001f, 1.0f, 1.0f, 0.4f};

int main(void)
{
    const char *env = getenv("OMPI_COMM_WORLD_RANK");
    unsigned char *scratch;
    int rank, bad = 0;
    vlint ok;

    if (!env)
        env = getenv("PMIX_RANK");
    if (!env)
        env = getenv("PMI_RANK");
    rank = env ? atoi(env) : 0;
    image = malloc(BYTES);
    scratch = malloc(BYTES);
    if (!image || !scratch)
        return 2;

    vlInit();
    vlScene();
    vluCamera(175.0, 250.0, -350.0, 175.0, 140.0, 70.0);
    vlBackground(0.2, 0.3, 0.4);
    vlMapping(1, VL_LOOKUP, 2, 1, ramp);
    vlPointLight(-200.0, 380.0, -200.0, VL_NOATTENUATION, 1.0, 1.0, 1.0, 1.0);
    vlAmbient(1.0, 1.0, 1.0, 1.0);
    vlObject();
    vlScale(350.0, 300.0, 300.0);
    vlFunction(VL_F, &VL_PARAB1, 0);
    vlMap(VL_O, VL_F, 1, 1);
    vlSet(VL_R, 0.9);
    vlSet(VL_G, 0.6);
    vlSet(VL_B, 0.3);
    vlSet(VL_KA, 0.3);
    vlSet(VL_KD, 0.6);
    vlEnd();
    bad |= !render("first", rank);

    /* The C layer's checks. */
    ok = vlRenderBuffer(rank == 1 ? NULL : scratch, BYTES, W, H, ASPECT, VL_RGB8);
    report("null", rank, ok);
    bad |= !render("after-null", rank);

    ok = vlRenderBuffer(scratch, BYTES, W, H, ASPECT, rank == 1 ? 99 : VL_RGB8);
    report("format", rank, ok);
    bad |= !render("after-format", rank);

    ok = vlRenderBuffer(scratch, BYTES, rank == 1 ? 0 : W, H, ASPECT, VL_RGB8);
    report("width", rank, ok);
    bad |= !render("after-width", rank);

    /* The core's. */
    ok = vlRenderBuffer(scratch, BYTES, W, H, rank == 1 ? -1.0f : ASPECT, VL_RGB8);
    report("aspect", rank, ok);
    bad |= !render("after-aspect", rank);

    ok = vlRenderBuffer(scratch, rank == 1 ? BYTES - 1 : BYTES, W, H, ASPECT, VL_RGB8);
    report("short", rank, ok);
    bad |= !render("after-short", rank);

    /* The scope: rank 1 inside an object it opens for the call (and closes empty). */
    if (rank == 1)
        vlObject();
    ok = vlRenderBuffer(scratch, BYTES, W, H, ASPECT, VL_RGB8);
    report("scope", rank, ok);
    if (rank == 1)
        vlEnd();
    bad |= !render("after-scope", rank);

    vlEnd();
    vlEnd();
    free(image);
    free(scratch);
    return bad;
}
