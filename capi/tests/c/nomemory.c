/* Allocation failure is an error, not an abort (issue #24, item 3). Under an address-space
 * limit (setrlimit(RLIMIT_AS) at 1 GiB above what the process has mapped), vlLoad of a sparse
 * .vlb of 2^31 one-byte voxels must report VL_NOMEMORY, keep the id unloaded and leave the
 * library usable; and a voxelization of more than 2^27 nodes (5 GiB of fields if held whole)
 * must be written in full within the limit (it holds one slab of nodes at a time). Before the limit, the peak
 * memory of a 256^3 × 1-byte voxelization (a 16 MiB file) is measured with getrusage: it must
 * grow by at most twice the file plus 8 MiB. Prints one line per check and exits non-zero if
 * any fails. Last, under a tighter limit: a render whose dataset's node values (computed on
 * first use, 4 bytes a voxel) do not fit is VL_NOMEMORY, not VL_INTERNAL (and so is vlSample
 * of it); a 16384^2 image is
 * VL_NOMEMORY; a 4096^2 one renders in strips; a 4096^2 PNG of noise is written under a
 * limit that holds its pixels and not a second copy. C89 (with POSIX); built and run by
 * capi/tests/nomemory.rs and c_examples.rs, never under valgrind (which does not run under an address-space limit: see memcheck.rs). */
#include <dirent.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>
#include "checks.h"
#include <vlaux.h>
#include <vlib.h>

/* The codes vlError reports now, all of them; 1 if the queue held exactly `code` (or nothing,
 * for VL_NOERROR). */
static int only(vlint code)
{
    vlint e, first = VL_NOERROR;
    int n = 0;
    while ((e = vlError()) != VL_NOERROR) {
        if (n++ == 0)
            first = e;
        printf("     (vlError %d)\n", (int)e);
    }
    return code == VL_NOERROR ? n == 0 : n == 1 && first == code;
}

/* Sets the voxels of the cube of 64^3 at the centre of a one-byte n^3 .vlb to 255. */
static int poke_centre(const char *path, unsigned long n)
{
    unsigned char row[64];
    unsigned long y, z, c = n / 2 - 32;
    int fd = open(path, O_WRONLY), ok = fd >= 0;
    memset(row, 255, sizeof row);
    for (z = c; ok && z < c + 64; z++)
        for (y = c; ok && y < c + 64; y++)
            ok = pwrite(fd, row, 64, (off_t)(28 + ((double)z * n + y) * n + c)) == 64;
    return fd >= 0 && close(fd) == 0 && ok;
}

/* The peak resident memory so far, in KiB. */
static long peak_kib(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss;
}

/* A scene of a small ball, rendered to `path` at side x side. */
static void image(const char *path, int side)
{
    vlScene();
    vlImage(path, 1.0f, side, side);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlObject(); /* the unit cube, in the middle of the default camera's view */
    vlFunction(VL_O, VLU_SPHERE, NULL);
    vlSet(VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
}

/* A hash of x's bits in [0, 1]: noise that does not compress. */
static float hash01(float x)
{
    unsigned int u;
    memcpy(&u, &x, sizeof u);
    u *= 2654435761u;
    u ^= u >> 13;
    u *= 0x5bd1e995u;
    return (float)((u >> 8) & 0xffffu) / 65535.0f;
}

/* An opaque field of noise colours, lit by the ambient light alone. */
static void noise(vlfloat *p, void *data)
{
    (void)data;
    vlSet(VL_O | VL_KA, 1.0f);
    vlSet(VL_R, hash01(p[0] + p[1]));
    vlSet(VL_G, hash01(3.0f * p[1] + p[2]));
    vlSet(VL_B, hash01(p[2] + 7.0f * p[0]));
}

/* Whether the PNG at `path` is whole: its signature, an IHDR of width x height, and every
 * chunk's length within the file up to IEND as the last chunk. */
static int png_is_whole(const char *path, unsigned long width, unsigned long height)
{
    static const unsigned char sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    long n, at = 8;
    unsigned char *b = read_file(path, &n);
    int ok = b && n > 33 && memcmp(b, sig, 8) == 0 && memcmp(b + 12, "IHDR", 4) == 0 &&
             get_u32be(b + 16) == width && get_u32be(b + 20) == height;
    while (ok) {
        unsigned long len = get_u32be(b + at);
        if (at + 12 + (long)len > n) {
            ok = 0;
            break;
        }
        if (memcmp(b + at + 4, "IEND", 4) == 0) {
            ok = at + 12 == n;
            break;
        }
        at += 12 + (long)len;
    }
    free(b);
    return ok;
}

/* A scene of one object of constant fields voxelized at nx·ny·nz nodes over the unit box. */
static void voxelize(const char *prefix, int nx, int ny, int nz)
{
    vlScene();
    vlVolume(prefix, VL_O, 0, 0, 0, 1, 1, 1, nx, ny, nz, 1);
    vlObject();
    vlSet(VL_O, 0.5f);
    vlEnd();
    vlEnd();
}

int main(void)
{
    const double MiB = 1024.0 * 1024.0;
    struct rlimit lim;
    double limit;
    long before, growth_kib;
    char msg[256];

    /* Two threads, unless the caller chose: a thread's stack and malloc arena take address
     * space, so the headroom under the limit should not depend on the number of cores. */
    setenv("RAYON_NUM_THREADS", "2", 0);
    vlInit();

    /* Peak memory of a voxelization, after a small one has started the library's threads. */
    voxelize("warm", 8, 8, 8);
    check("a small voxelization", only(VL_NOERROR) && file_size("warm_o.vlb") == 28 + 512);
    before = peak_kib();
    voxelize("peak", 256, 256, 256);
    growth_kib = peak_kib() - before;
    check("256^3 nodes voxelized", only(VL_NOERROR));
    check("its file has every voxel", file_size("peak_o.vlb") == 28 + 16 * MiB);
    sprintf(msg, "peak memory grew by %.1f MiB for a 16 MiB file (at most 2 x 16 + 8)",
            growth_kib / 1024.0);
    check(msg, growth_kib <= (long)(2 * 16 + 8) * 1024);
    unlink("warm_o.vlb");
    unlink("peak_o.vlb");

    /* The address-space limit: 1 GiB above what is mapped now. */
    limit = mapped_bytes() + 1024.0 * MiB;
    lim.rlim_cur = lim.rlim_max = (rlim_t)limit;
    check("the address space is known", limit > 1024.0 * MiB);
    check("setrlimit(RLIMIT_AS)", setrlimit(RLIMIT_AS, &lim) == 0);
    printf("     (limit %.0f MiB)\n", limit / MiB);

    /* A dataset of 2^31 voxels does not fit: VL_NOMEMORY, and nothing is filed under its id. */
    check("a sparse .vlb of 2^31 voxels", sparse_vlb("huge.vlb", 2048, 1024, 1024));
    vlLoad(1, "huge.vlb");
    check("vlLoad of 2^31 voxels reports VL_NOMEMORY", only(VL_NOMEMORY));
    unlink("huge.vlb");
    vlScene();
    vlObject();
    vlDataset(VL_O, 1);
    check("the dataset's id stays unloaded (vlDataset: VL_BADID)", only(VL_BADID));
    vlEnd();
    vlEnd();
    only(VL_NOERROR);
    vlUnload(1);
    check("vlUnload of it: VL_BADID", only(VL_BADID));

    /* Later commands work: a small dataset loads and renders. */
    check("a small .vlb", sparse_vlb("small.vlb", 16, 16, 16));
    vlLoad(2, "small.vlb");
    check("a small dataset loads after the failure", only(VL_NOERROR));
    vlScene();
    vlImage("small.ppm", 1.0, 16, 16);
    vlObject();
    vlDataset(VL_O, 2);
    vlEnd();
    vlEnd();
    check("and renders", only(VL_NOERROR) && file_size("small.ppm") > 16 * 16 * 3);
    unlink("small.vlb");
    unlink("small.ppm");

    /* More than 2^27 nodes (their ten f32 fields would be 5 GiB held whole): written in full
     * within the limit. */
    voxelize("big", 1024, 1024, 129);
    check("1024 x 1024 x 129 nodes voxelized under the limit", only(VL_NOERROR));
    check("its file has every voxel", file_size("big_o.vlb") == 28 + 129 * MiB);
    unlink("big_o.vlb");

    /* A dataset of 512^3 one-byte voxels (128 MiB) loads; under the tighter limit below, the
     * f32 node values the renderer computes on first use for the nearest filter (512 MiB) do
     * not fit: the render reports VL_NOMEMORY (not VL_INTERNAL) and writes nothing. */
    check("a sparse .vlb of 512^3 voxels with a bright centre",
          sparse_vlb("mid.vlb", 512, 512, 512) && poke_centre("mid.vlb", 512));
    vlLoad(3, "mid.vlb");
    check("it loads under the limit", only(VL_NOERROR));
    unlink("mid.vlb");

    /* Under a tighter limit, 256 MiB above what is mapped. */
    limit = mapped_bytes() + 256.0 * MiB;
    lim.rlim_cur = lim.rlim_max = (rlim_t)limit;
    check("setrlimit(RLIMIT_AS) lowered", setrlimit(RLIMIT_AS, &lim) == 0);
    vlScene();
    vlImage("mid.ppm", 1.0, 32, 32);
    vlInterpolationType(VL_NEAREST); /* which reads the node values */
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlObject(); /* the unit cube, in the middle of the default camera's view */
    vlDataset(VL_O, 3);
    vlSet(VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
    check("a render whose node values do not fit reports VL_NOMEMORY", only(VL_NOMEMORY));
    check("and writes nothing", file_size("mid.ppm") < 0 && !temporaries_left());
    /* vlSample reads the same node values (the nearest filter, outside any scene): the core
     * unwinds with its NoMemory error, which the C boundary reports as VL_NOMEMORY too. */
    vlInterpolationType(VL_NEAREST);
    check("vlSample whose node values do not fit returns 0",
          vlSample(3, 0.5f, 0.5f, 0.5f) == 0.0f);
    check("and reports VL_NOMEMORY", only(VL_NOMEMORY));
    vlInterpolationType(VL_TRILINEAR);
    only(VL_NOERROR);
    vlUnload(3);
    check("the dataset unloads", only(VL_NOERROR));

    /* Images: a 16384^2 image (768 MiB of pixels) does not fit: VL_NOMEMORY, no file and no
     * temporary; a 4096^2 one (48 MiB) is rendered in strips and written in full. */
    image("wide.ppm", 16384);
    check("a 16384^2 image reports VL_NOMEMORY", only(VL_NOMEMORY));
    check("and writes nothing", file_size("wide.ppm") < 0 && !temporaries_left());
    image("fits.ppm", 4096);
    check("a 4096^2 image renders under the limit", only(VL_NOERROR));
    /* The header "P6\n4096 4096\n255\n" is 17 bytes. */
    check("its file has every pixel", file_size("fits.ppm") == 4096.0 * 4096.0 * 3 + 17);
    unlink("fits.ppm");

    /* A PNG of 4096^2 pixels of noise (48 MiB that do not compress) under a limit of 96 MiB
     * above what is mapped: its pixels and a strip fit, a second image-sized buffer does not.
     * The encoder compresses the rows as they are written, so it renders and is written in
     * full (an encoder that held its whole compressed stream would run out of memory there,
     * and one whose allocation cannot fail would abort the host). */
    limit = mapped_bytes() + 96.0 * MiB;
    lim.rlim_cur = lim.rlim_max = (rlim_t)limit;
    check("setrlimit(RLIMIT_AS) lowered again", setrlimit(RLIMIT_AS, &lim) == 0);
    vlScene();
    vluCamera(0.0f, 0.0f, -1.2f, 0.0f, 0.0f, 0.0f);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlImage("noise.png", 1.0f, 4096, 4096);
    vlObject();
    vlTranslate(-0.5f, -0.5f, -0.5f);
    vlScale(4.0f, 4.0f, 1.0f); /* past the image's edges */
    vlFunction(VL_ALLFIELDS, noise, NULL);
    vlEnd();
    vlEnd();
    check("a 4096^2 PNG of noise renders under the limit", only(VL_NOERROR));
    check("and is written in full", png_is_whole("noise.png", 4096, 4096));
    unlink("noise.png");

    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
