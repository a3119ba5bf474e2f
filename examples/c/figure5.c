/* Figure 5 of Winter & Chen, "vlib: A Volume Graphics API" (2001): two field functions, a
 * spherical distance field and a solid marble texture, used here to render a marble ball.
 *
 * `sphere` and `marble` are the paper's listings unchanged (implicit int return types kept),
 * apart from the OCR slips of the scan: vSet -> vlSet, and the `;` missing at the end of line 05
 * of `sphere` (the statement `float d = ...` cannot end without one). The paper does not list
 * the colour splines rSpline, gSpline and bSpline; ours are below. `marble` evaluates them at
 * v = turbulence + 0.8, and vluSpline clamps v to [0, 1], so only the last two spans of the
 * 10-knot splines are reached: knots 7 and 8 hold the dark vein and the white stone, and veins
 * appear where the turbulence is small (near the noise's zero crossings).
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/figure5.c -Iinclude -Ltarget/release -lvlib -lm -o figure5
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./figure5     (writes marble.png and marble.ppm, 256 x 256)
 */
#include <math.h>
#include <stdio.h>
#include <vlib.h>
#include <vlaux.h>

vlfloat rSpline[10] = {0.80, 0.70, 0.60, 0.50, 0.40, 0.30, 0.22, 0.30, 0.95, 0.97};
vlfloat gSpline[10] = {0.80, 0.70, 0.60, 0.50, 0.40, 0.32, 0.26, 0.34, 0.93, 0.95};
vlfloat bSpline[10] = {0.85, 0.75, 0.65, 0.55, 0.45, 0.38, 0.32, 0.40, 0.88, 0.90};

/* ---- Figure 5, left ---- */
sphere(vlvector p, void *misc) {
    float d =
        (p[0] - .5) * (p[0] - .5)
        + (p[1] - .5) * (p[1] - .5)
        + (p[2] - .5) * (p[2] - .5);
    vlSet(VL_ALLFIELDS, 1.- 2.* sqrt(d));
}

/* ---- Figure 5, right ---- */
marble(vlvector p, void *misc) {
    float v =
        vluTurbulence(p, 2.17, 7, 0) + 0.8;
    vlSet(VL_R, vluSpline(v, 10, rSpline));
    vlSet(VL_G, vluSpline(v, 10, gSpline));
    vlSet(VL_B, vluSpline(v, 10, bSpline));
}

/* A ramp from F = 0 to F = 0.02 makes the ball opaque with a thin soft edge. */
vlfloat solid[] = {0.02, 1.0, 1.0, 1.0};

int main(void)
{
    vlint e;
    int failed = 0;

    vlInit();
    vlScene();
    vluCamera(0.0, 40.0, -320.0, 0.0, 0.0, 0.0);
    vlImage("marble.png", 1.0, 256, 256);
    vlImage("marble.ppm", 1.0, 256, 256);
    vlBackground(0.15, 0.15, 0.2);
    vlMapping(1, VL_RAMP, 2, 1, solid);
    vlPointLight(-300.0, 300.0, -300.0, VL_NOATTENUATION, WHITE, 1.0);
    vlAmbient(WHITE, 1.0);
    vlObject();
    vlTranslate(-0.5, -0.5, -0.5);
    vlScale(200.0, 200.0, 200.0);
    vlFunction(VL_F, sphere, 0);
    vlMap(VL_O, VL_F, 1, 1);
    vlFunction(VL_COLORS, marble, 0);
    vlSet(VL_KA, 0.35);
    vlSet(VL_KD, 0.65);
    vlSet(VL_KS, 0.4);
    vlSet(VL_N, VLSPECULAR(40));
    vlEnd();
    vlEnd();
    vlEnd();

    while ((e = vlError()) != VL_NOERROR) {
        printf("vlError: %d (%s)\n", (int)e, vlErrorString(e));
        failed = 1;
    }
    return failed;
}
