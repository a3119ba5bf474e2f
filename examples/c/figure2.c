/* Figure 2 of Winter & Chen, "vlib: A Volume Graphics API" (2001): a basic vlib program.
 *
 * The part between the "Figure 2" markers below is the paper's listing, line for line, with
 * only the OCR slips of the scan corrected: vllnit -> vlInit, viuCamera -> vluCamera,
 * vfloat -> vlfloat (and v!Set / vSet -> vlSet where they occur). Everything else is kept as
 * printed, including `main()` without a return type (C89 implicit int), `&VL_PARAB1`, and
 * line 20, `vlMap(VL_KS, VL_F, 1, 2)`, which asks for output 2 of a one-output table: vlib
 * records that as an error (VL_BADINDEX, reported here by vlError) and skips the instruction.
 *
 * The paper does not list the field function `stone`; the one above main is ours: a granite-like
 * solid texture of greys and browns made from vluTurbulence and vluNoise. After the listing,
 * main prints what vlError reports and returns 0 (C89 gives no exit status to a main that falls
 * off its end).
 *
 * Build (from the workspace root) and run:
 *   cc -std=gnu89 examples/c/figure2.c -Iinclude -Ltarget/release -lvlib -lm -o figure2
 *   ln -sf libvlib.so target/release/libvlib.so.0   (once: the name programs ask for)
 *   LD_LIBRARY_PATH=target/release ./figure2        (writes stone.ppm, 100 x 100)
 */
#include <stdio.h>
#include <vlib.h>
#include <vlaux.h>

/* Granite: a base grey-brown whose lightness follows turbulence, a low-frequency warm/cool tint,
   dark mica specks and light quartz grains from higher-frequency noise. Writes r, g, b. */
void stone(vlvector p, void *misc)
{
    vlfloat t = vluTurbulence(p, 5.0f, 5, 1);           /* mostly 0.1 .. 0.9 */
    vlfloat warm = 0.5f + 0.5f * vluNoise(p, 2.5f, 2);  /* 0 .. 1 */
    vlfloat grain = vluNoise(p, 48.0f, 3);              /* -1 .. 1 */
    vlfloat speck = vluNoise(p, 23.0f, 4);              /* -1 .. 1 */
    vlfloat shade = 0.42f + 0.35f * (t > 1.0f ? 1.0f : t) + 0.08f * grain;
    vlfloat r = shade * (0.88f + 0.22f * warm);
    vlfloat g = shade * (0.84f + 0.12f * warm);
    vlfloat b = shade * (0.80f + 0.04f * warm);

    (void)misc;
    if (speck > 0.42f) {                /* dark mica flakes */
        r *= 0.35f; g *= 0.35f; b *= 0.38f;
    } else if (grain > 0.55f) {         /* light quartz grains */
        r = 0.5f * (r + 0.95f); g = 0.5f * (g + 0.93f); b = 0.5f * (b + 0.90f);
    }
    vlSet(VL_R, r);
    vlSet(VL_G, g);
    vlSet(VL_B, b);
}

/* ---- Figure 2, as printed (OCR slips fixed) ---- */

vlfloat myMap[] = {0.001, 1.0, 1.0, 0.3};
main() {
    vlInit();
    vlScene();
    vluCamera(175.0, 250.0, -350.0,
            175.0, 140.0, 70.0);
    vlImage("stone.ppm", 1.0, 100, 100);
    vlBackground(WHITE);
    vlMapping(1, VL_LOOKUP, 2, 1, myMap);
    vlPointLight(-200.0, 380.0, -200.0,
               VL_NOATTENUATION, WHITE, 1.0);
    vlAmbient(WHITE, 1.0);
    vlObject();
    vlScale(350.0, 300.0, 300.0);
    vlFunction(VL_F, &VL_PARAB1, 0);
    vlMap(VL_O, VL_F, 1, 1);
    vlMap(VL_KS, VL_F, 1, 2);
    vlFunction(VL_R|VL_G|VL_B, &stone, 0);
    vlSet(VL_KA, 0.3);
    vlSet(VL_KD, 0.6);
    vlSet(VL_N, VLSPECULAR(20));
    vlEnd();
    vlEnd();
vlEnd();
    /* ---- end of Figure 2; ours: report the errors and exit with 0 ---- */
    {
        vlint e;
        while ((e = vlError()) != VL_NOERROR) {
            printf("vlError: %d (%s)", (int)e, vlErrorString(e));
            if (e == VL_BADINDEX)
                printf(": expected, the paper's line 20 asks for output 2 of a one-output table");
            printf("\n");
        }
    }
    return 0;
}
