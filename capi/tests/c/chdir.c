/* An output named relative to the working directory is written where that name pointed when its
 * write began, even if the working directory changes during the render (here the progress
 * function calls chdir, as another thread of the program could): the image is in the first
 * directory, whole, and no temporary file is left in either; a voxelization's file likewise,
 * the sidecar an earlier file left beside it removed there, not a file of that name in the
 * directory moved to. Prints one line per check
 * and exits non-zero if any fails. C89 (with POSIX); built and run by capi/tests/c_examples.rs
 * (and under valgrind by memcheck.rs) in a fresh directory. */
#include <dirent.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "checks.h"
#include <vlaux.h>
#include <vlib.h>

static int moved = 0;

/* Writes a line of text to a new file at `path`; 1 if it could. */
static int write_text(const char *path)
{
    FILE *f = fopen(path, "w");
    int ok = f && fputs("not a placement\n", f) >= 0;
    return f && fclose(f) == 0 && ok;
}

/* The first call moves the process into the sibling directory "b". */
static vlint progress(vlfloat done, void *misc)
{
    (void)done;
    (void)misc;
    if (!moved)
        moved = chdir("../b") == 0;
    return 1;
}

int main(void)
{
    vlint e;
    int errors = 0;
    check("the directories a and b", mkdir("a", 0755) == 0 && mkdir("b", 0755) == 0);
    check("into a", chdir("a") == 0);
    vlInit();
    vlProgress(progress, NULL);
    vlScene();
    vlImage("out.ppm", 1.0f, 32, 32);
    vlAmbient(1.0f, 1.0f, 1.0f, 1.0f);
    vlObject();
    vlFunction(VL_O, VLU_SPHERE, NULL);
    vlSet(VL_COLORS | VL_KA, 1.0f);
    vlEnd();
    vlEnd();
    while ((e = vlError()) != VL_NOERROR) {
        printf("     (vlError %d)\n", (int)e);
        errors++;
    }
    check("the render moved the process into b", moved);
    check("and reported no error", errors == 0);
    /* Now in b. */
    /* The header "P6\n32 32\n255\n" is 13 bytes. */
    check("the image is whole in a", file_size("../a/out.ppm") == 32.0 * 32.0 * 3 + 13);
    check("none in b", !exists("out.ppm"));
    check("no temporary in b", !temporaries_left());
    check("back in a", chdir("../a") == 0);
    check("no temporary in a", !temporaries_left());
    remove("out.ppm");

    /* A voxelization likewise, with the sidecar an earlier file left beside it: removed in a,
     * and the file of that name in b kept. */
    check("a stale sidecar in a", write_text("vox_o.vlb.geom"));
    check("a file of that name in b", write_text("../b/vox_o.vlb.geom"));
    moved = 0;
    vlScene();
    vlVolume("vox", VL_O, 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 8, 8, 8, 1);
    vlObject();
    vlSet(VL_O, 0.5f);
    vlEnd();
    vlEnd();
    errors = 0;
    while ((e = vlError()) != VL_NOERROR) {
        printf("     (vlError %d)\n", (int)e);
        errors++;
    }
    check("the voxelization moved the process into b", moved);
    check("and reported no error", errors == 0);
    check("its file is whole in a", file_size("../a/vox_o.vlb") == 28 + 8 * 8 * 8);
    check("the stale sidecar in a is gone", !exists("../a/vox_o.vlb.geom"));
    check("the file in b is kept", exists("vox_o.vlb.geom"));
    check("no temporary in b", !temporaries_left());
    remove("vox_o.vlb.geom");
    check("back in a", chdir("../a") == 0);
    check("no temporary in a", !temporaries_left());
    remove("vox_o.vlb");
    check("up again", chdir("..") == 0);
    rmdir("a");
    rmdir("b");
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
