/* An output named relative to the working directory is written where that name pointed when the
 * scene's vlEnd began, even if the working directory changes during the render (here the
 * progress function calls chdir, as another thread of the program could): the image is in the
 * first directory, whole, and no temporary file is left in either. Prints one line per check
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
    check("up again", chdir("..") == 0);
    rmdir("a");
    rmdir("b");
    vlEnd();
    printf("%d failure(s)\n", failures);
    return failures != 0;
}
