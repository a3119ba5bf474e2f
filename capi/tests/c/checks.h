/* Helpers the test programs of capi/tests/c share: the ok/FAIL lines and their count, small
 * file and buffer queries (a whole file, a run of equal bytes), and .vlb headers and files. Each program includes
 * it once ("checks.h", beside it) and uses what it needs; the functions are static and marked
 * unused, so a program that needs some of them compiles clean with -Wall -Wextra -Werror. C89
 * with POSIX (dirent, fcntl, stat, unistd). */
#ifndef VLIB_TEST_CHECKS_H
#define VLIB_TEST_CHECKS_H

#include <dirent.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define CHECKS_UNUSED __attribute__((unused))

/* The number of checks that failed. */
static int failures = 0;

/* Prints one line, "ok" or "FAIL" and what was checked, and counts a failure. */
static CHECKS_UNUSED void check(const char *what, int ok)
{
    printf("%-4s %s\n", ok ? "ok" : "FAIL", what);
    fflush(stdout);
    if (!ok)
        failures++;
}

/* Whether `path` exists. */
static CHECKS_UNUSED int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* The size of the file at `path` in bytes; -1 if there is none. */
static CHECKS_UNUSED double file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (double)st.st_size : -1.0;
}

/* Whether the current directory holds a temporary file of the library. */
static CHECKS_UNUSED int temporaries_left(void)
{
    DIR *d = opendir(".");
    struct dirent *e;
    int found = 0;
    if (!d)
        return 1;
    while ((e = readdir(d)) != NULL)
        if (strncmp(e->d_name, ".vl-", 4) == 0)
            found = 1;
    closedir(d);
    return found;
}

/* The value (0 ... 255) of channel 0 of pixel (x, y) of a binary PPM of the given width;
   -1 if unreadable. */
static CHECKS_UNUSED int ppm_red(const char *path, int width, int x, int y)
{
    FILE *f = fopen(path, "rb");
    int w, h, max, c = -1;
    if (!f)
        return -1;
    if (fscanf(f, "P6 %d %d %d", &w, &h, &max) == 3 && w == width && fgetc(f) != EOF &&
        fseek(f, (long)(y * w + x) * 3, SEEK_CUR) == 0)
        c = fgetc(f);
    fclose(f);
    return c;
}

/* Writes v as 4 little-endian bytes at p (a .vlb header's integers). */
static CHECKS_UNUSED void put_u32(unsigned char *p, unsigned long v)
{
    p[0] = (unsigned char)(v & 255);
    p[1] = (unsigned char)((v >> 8) & 255);
    p[2] = (unsigned char)((v >> 16) & 255);
    p[3] = (unsigned char)((v >> 24) & 255);
}

/* The 4 big-endian bytes at p as a number (a PNG's integers). */
static CHECKS_UNUSED unsigned long get_u32be(const unsigned char *p)
{
    return ((unsigned long)p[0] << 24) | ((unsigned long)p[1] << 16) |
           ((unsigned long)p[2] << 8) | (unsigned long)p[3];
}

/* The 28-byte header of a .vlb (docs/compat.md) of nx·ny·nz voxels of `width` bytes,
 * normalised by a and b, into h. */
static CHECKS_UNUSED void vlb_header(unsigned char *h, unsigned long nx, unsigned long ny,
                                     unsigned long nz, unsigned long width, float a, float b)
{
    memcpy(h, "VLB1", 4);
    put_u32(h + 4, nx);
    put_u32(h + 8, ny);
    put_u32(h + 12, nz);
    put_u32(h + 16, width);
    memcpy(h + 20, &a, 4); /* little-endian IEEE floats, as on every target vlib builds for */
    memcpy(h + 24, &b, 4);
}

/* A .vlb of nx·ny·nz one-byte voxels (a = 0, b = 255), the voxels a hole: its header, then
 * the last voxel (0) written at the file's full length (lseek and write, which strict C99
 * builds of these programs declare, where ftruncate is not). */
static CHECKS_UNUSED int sparse_vlb(const char *path, unsigned long nx, unsigned long ny,
                                    unsigned long nz)
{
    unsigned char h[28];
    int fd, ok;
    vlb_header(h, nx, ny, nz, 1, 0.0f, 255.0f);
    fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0)
        return 0;
    ok = write(fd, h, 28) == 28 &&
         lseek(fd, (off_t)(28 + (double)nx * ny * nz - 1), SEEK_SET) != (off_t)-1 &&
         write(fd, "", 1) == 1;
    return close(fd) == 0 && ok;
}

/* The address space mapped now (VmSize of /proc/self/status), in bytes; 0 if unknown. */
static CHECKS_UNUSED double mapped_bytes(void)
{
    char line[256];
    double kib = 0.0;
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return 0.0;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "VmSize:", 7) == 0)
            kib = atof(line + 7);
    fclose(f);
    return kib * 1024.0;
}

/* The whole file at `path`, to be freed (its size in *n); NULL if unreadable. */
static CHECKS_UNUSED unsigned char *read_file(const char *path, long *n)
{
    FILE *f = fopen(path, "rb");
    unsigned char *b;
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    *n = ftell(f);
    fseek(f, 0, SEEK_SET);
    b = malloc((size_t)*n + 1);
    if (b && fread(b, 1, (size_t)*n, f) != (size_t)*n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    return b;
}

/* Whether every byte of b[0 .. n) is v. */
static CHECKS_UNUSED int all_bytes(const unsigned char *b, unsigned long n, unsigned char v)
{
    unsigned long i;
    for (i = 0; i < n; i++)
        if (b[i] != v)
            return 0;
    return 1;
}

#endif
