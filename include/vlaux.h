/* vlaux: the auxiliary library of vlib (camera shorthand, noise, splines, ready-made field
   functions and colour macros). Written by hand; the functions live in libvlib (capi/src/vlaux.rs).
   C89. */

#ifndef VLAUX_H
#define VLAUX_H

#include "vlib.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Colours, expanding to three comma-separated components: vlBackground(WHITE),
   vlAmbient(WHITE, 1.0). */
#define WHITE 1.0, 1.0, 1.0
#define BLACK 0.0, 0.0, 0.0
#define RED 1.0, 0.0, 0.0
#define GREEN 0.0, 1.0, 0.0
#define BLUE 0.0, 0.0, 1.0
#define YELLOW 1.0, 1.0, 0.0
#define CYAN 0.0, 1.0, 1.0
#define MAGENTA 1.0, 0.0, 1.0
#define GREY 0.5, 0.5, 0.5
#define GRAY 0.5, 0.5, 0.5

/* Sets the camera at eye (ex, ey, ez) looking at (lx, ly, lz), with +y up and the default field
   of view (60 degrees). */
void vluCamera(vlfloat ex, vlfloat ey, vlfloat ez, vlfloat lx, vlfloat ly, vlfloat lz);

/* Places the current object where dataset `id`'s nodes lie in physical space (millimetres, RAS:
   +x right, +y anterior, +z superior), from the geometry sidecar (NAME.vlb.geom) that vlconvert
   writes beside a converted NIfTI or NRRD file: a transform composed like vlMatrix (object
   scope; call it before other transforms, which then act in millimetres). VL_BADID for an unknown id, VL_BADVALUE for a dataset without geometry. */
void vluPlace(vlint id);

/* Perlin's improved gradient noise in [-1, 1] at p * size; seed 0 is Perlin's permutation, other
   seeds shuffle it. p NULL: VL_NULLPOINTER, returns 0. */
vlfloat vluNoise(const vlfloat *p, vlfloat size, vlint seed);

/* Perlin turbulence in [0, 2): the sum over octaves i of |noise(p, size * 2^i)| / 2^i.
   p NULL: VL_NULLPOINTER, returns 0. */
vlfloat vluTurbulence(const vlfloat *p, vlfloat size, vlint octaves, vlint seed);

/* The Catmull-Rom spline through count knots at v in [0, 1] (Ebert et al.). count < 0 or above
   65536: VL_BADVALUE; knots NULL with count > 0: VL_NULLPOINTER; both return 0. */
vlfloat vluSpline(vlfloat v, vlint count, const vlfloat *knots);

/* Field functions for vlFunction. Each of the next three evaluates a distance field at p and
   assigns it with vlSet(VL_ALLFIELDS, value), which writes the fields the vlFunction call
   named. */

/* The paraboloid 1 - 4 |p - c|^2 about the cube centre c, 0 outside the inscribed sphere. */
void VL_PARAB1(vlfloat *p, void *misc);
/* The spherical distance field 1 - 2 |p - c|. */
void VLU_SPHERE(vlfloat *p, void *misc);
/* The cylindrical distance field about the z axis through the cube centre. */
void VLU_CYLINDER(vlfloat *p, void *misc);

/* The rotational sweep of a 2D profile dataset (a lathe; the paper's chess pieces were made so).
   misc points to a vlint holding the id of a loaded profile dataset of nx x ny x 1 nodes:
     profile x = distance from the axis (x = 0, the left column) to the rim (x = 1, the right
                 column), which is the radius of the cube's inscribed cylinder;
     profile y = height (y = 0 at the bottom of the object, y = 1 at its top).
   vlconvert image flips rows so that y runs upwards: row 0 at the TOP of the image becomes the
   top of the profile, so draw the right half of the piece's silhouette, upright, with its axis
   on the left edge of the image. At object point p, with r the distance of p from the vertical
   axis through (0.5, y, 0.5), the value is vlSample(id, 2r, p[1], 0) for 2r <= 1, and 0 outside
   (so leave the right column empty for a closed surface). misc NULL: VL_NULLPOINTER, nothing is
   written; unknown id: VL_BADID, 0 is written. The vlint is read at every sample, so it must
   live until the scene has rendered (a static, for instance):
     static vlint pawn = 1;
     vlLoad(pawn, "pawn.vlb");  ...  vlFunction(VL_F, VLU_SWEEP, &pawn); */
void VLU_SWEEP(vlfloat *p, void *misc);

/* Constructive volume geometry (docs/cvg.md; Chen & Tucker 2000): field functions for a parent
   object, declared after its children, that define the parent's fields point by point from its
   children's (children counted from 1 in declaration order; a child's fields are 0 outside its
   boundary). With o_i the opacity of child i at the point:
     VLU_UNION         o = max_i o_i; the other fields from the child of largest opacity
                       (the first on ties);
     VLU_INTERSECTION  o = min_i o_i; the other fields from the child of smallest opacity
                       (the first on ties);
     VLU_DIFFERENCE    o = min(o_1, 1 - max_{i>=2} o_i); the other fields from child 1;
     VLU_BLEND         o = 1 - prod_i (1 - o_i) (a smooth union); the other fields are
                       sum_i o_i F_i / sum_i o_i (0 where every o_i is 0).
   Each writes only the fields its vlFunction call names, e.g.
     vlObject();
       vlObject(); ... vlEnd();                     (child 1)
       vlObject(); ... vlEnd();                     (child 2)
       vlFunction(VL_ALLFIELDS, VLU_UNION, 0);
     vlEnd();
   With no children every field is 0. p and misc are not read. Called anywhere but inside a field
   function (at library, scene or object scope, or from a normal or spatial function) they
   record VL_BADSCOPE and do nothing. */
void VLU_UNION(vlfloat *p, void *misc);
void VLU_INTERSECTION(vlfloat *p, void *misc);
void VLU_DIFFERENCE(vlfloat *p, void *misc);
void VLU_BLEND(vlfloat *p, void *misc);

#ifdef __cplusplus
}
#endif

#endif /* VLAUX_H */
