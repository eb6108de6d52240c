// cgal_reference: the CGAL side of the rdmesh benchmarks.
//
// Meshes one of the benchmark implicit surfaces f(x,y,z) = 0 (f < 0 inside)
// with either CGAL's Surface_mesher (make_surface_mesh; "surface_mesher" with
// Manifold_tag, "surface_mesher_boundary" with Manifold_with_boundary_tag,
// which also meshes the "clipped_*" surfaces that leave their bounding
// sphere) or Mesh_3 (make_mesh_3, facet criteria only; "mesh_3" with
// params::manifold(), "mesh_3_fast" without it) and prints one JSON object
// on stdout:
//
//   {"mesher": ..., "surface": ..., "seconds": ..., "vertices": ...,
//    "faces": ..., "evaluations": ..., "cgal_version": ..., ...}
//
// "seconds" is the wall time (std::chrono::steady_clock) of the
// make_surface_mesh / make_mesh_3 call alone; building the domain, converting
// the result to a triangle mesh, the sanity checks and writing --out are not
// timed.  "evaluations" counts the calls of the implicit function made during
// that call.
//
// "mesh_3_box" meshes the "box_*" surfaces, which are clipped to an
// axis-aligned box (tests/clipped_surfaces.py), as a CGAL user would without a
// clipping mesher: Mesh_3 on a labeled domain whose labeling function is 0
// outside the box, 1 where f < 0 inside it and 2 where f >= 0 inside it,
// facet criteria only, no params::manifold() (as "mesh_3_fast").  Mesh_3
// then meshes the box faces too (surface patches (0, 1) and (0, 2)); only the
// complex facets between subdomains 1 and 2 are output.  No 1D features are
// protected, so the boundary of that patch is where Mesh_3's restricted
// Delaunay facets happen to meet the box faces.  "evaluations" counts the
// calls of f (labels of points outside the box need no f); the JSON line also
// has "box" and "complex_facets" (all facets of the complex, the box faces'
// included).
//
// "mesh_3_image" meshes the isosurface of a gray-level volume instead of a
// named surface: Mesh_3's gray-image domain
// (Labeled_mesh_domain_3::create_gray_image_mesh_domain, trilinear
// interpolation of the samples), facet criteria only, params::manifold().
// The volume is a raw file of little-endian float32 samples, x fastest
// (sample (i, j, k) at byte 4 * (i + nx * (j + ny * k)), at position
// origin + (i, j, k) * spacing); --dims, --spacing and --origin describe it,
// so no image file format is involved.  Values above --isovalue are inside
// (CGAL's default Greater_than threshold), everything outside the samples'
// box is outside, so the surface is closed by the box.  "evaluations" counts
// the interpolations of the volume.  Reading the file is not timed.
// --init random (default) is make_mesh_3's own initial points (the domain's
// random segments, as CGAL's mesh_3D_gray_image example); --init components
// seeds every connected component of the samples above the isovalue first
// (initialize_triangulation_from_gray_image, as CGAL's
// mesh_3D_gray_image_with_custom_initialization example), then refine_mesh_3;
// both calls are timed.
//
// "mesh_3_features" is Mesh_3 with protected 1D features on a named surface:
// make_mesh_3 on Mesh_domain_with_polyline_features_3<Labeled_mesh_domain_3>
// (the implicit domain of "mesh_3") after add_features() with the polylines
// of --features FILE, criteria edge_size (--edge-size), facet_angle,
// facet_size, facet_distance (FACET_VERTICES_ON_SAME_SURFACE_PATCH), no cell
// criterion, no params::manifold(), no perturb or exude.  FILE is CGAL's
// polylines text format, one polyline per line: "n x1 y1 z1 ... xn yn zn"
// (n >= 2; a closed loop repeats its first point last).  Polylines may meet
// only at their end points: CGAL 5.5 crashes or fails on polylines that share
// an interior point (CGAL #7356, #4814), so the caller splits them there; the
// program refuses a point shared with another polyline's interior (exactly
// equal coordinates) and consecutive equal points.  The surfaces "box"
// (max(|x|,|y|,|z|) - 1) and "box_ball" (min(box, |p - (1,1,1)| - 0.8)) are
// there for this mode (their creases are benchmarks/cad_shapes.py's
// box_curves / box_ball_curves), but any surface of "mesh_3" is accepted.
//
// "mesh_3_polyhedron" remeshes a closed triangle mesh (--input MESH.off)
// with Polyhedral_mesh_domain_with_features_3: detect_features(A) with
// A = --feature-angle (CGAL's rule: an edge is sharp where the normals of its
// two triangles differ by at least A degrees; sharp edges are chained into
// curves split at corners), then make_mesh_3 with the criteria of
// "mesh_3_features".  Reading the file is not timed; detect_features is
// (its "seconds" also has "detect_seconds" on its own).  "evaluations" is 0.
//
// Both features modes output the complex facets between subdomain 1 (inside)
// and 0, oriented outward, and add to the JSON line "edge_size",
// "feature_vertices" (vertices of the triangulation with
// c3t3.in_dimension(v) <= 1: on a curve or a corner), "corner_vertices"
// (dimension 0), "complex_edges" (edges of the complex: the protected curves'
// pieces), "domain_curves" and "domain_corners" (the domain's curves and
// corners after add_features / detect_features).
//
// Usage:
//   cgal_reference --mesher surface_mesher|surface_mesher_boundary|mesh_3|mesh_3_fast|mesh_3_box
//                  --surface NAME
//                  --angle A --radius R --distance D
//                  [--error-bound E] [--seed S] [--out mesh.off]
//   cgal_reference --mesher mesh_3_image --image FILE --dims NX,NY,NZ
//                  --spacing SX,SY,SZ [--origin OX,OY,OZ] --isovalue V
//                  [--init random|components] --angle A --radius R --distance D
//                  [--error-bound E] [--seed S] [--out mesh.off]
//   cgal_reference --mesher mesh_3_features --surface NAME --features FILE
//                  --edge-size L --angle A --radius R --distance D
//                  [--error-bound E] [--seed S] [--out mesh.off]
//   cgal_reference --mesher mesh_3_polyhedron --input MESH.off
//                  --feature-angle FA --edge-size L --angle A --radius R
//                  --distance D [--seed S] [--out mesh.off]
//   cgal_reference --mesher delaunay --points FILE
//
// The "delaunay" mode is the floor of the benchmarks: it reads points (x y z
// per line, whitespace-separated) and times CGAL's bulk build
// Delaunay_triangulation_3(begin, end) of them (spatial sort + insertion),
// with "seconds", "vertices" (of the triangulation), "points" (read) and
// "cells" (finite cells) in its JSON line.
//
// Exit codes: 0 success, 2 invalid command line, 1 any other failure
// (CGAL exception, output file not writable, ...).
//
// SPDX-License-Identifier: GPL-3.0-or-later

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/version.h>

// Surface_mesher
#include <CGAL/Complex_2_in_triangulation_3.h>
#include <CGAL/IO/facets_in_complex_2_to_triangle_mesh.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/Surface_mesh_default_triangulation_3.h>
#include <CGAL/make_surface_mesh.h>

// Mesh_3
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/facets_in_complex_3_to_triangle_mesh.h>
#include <CGAL/make_mesh_3.h>

// Mesh_3 with protected 1D features
#include <CGAL/Mesh_domain_with_polyline_features_3.h>
#include <CGAL/Mesh_polyhedron_3.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/boost/graph/IO/OFF.h>
#include <boost/iterator/function_output_iterator.hpp>

// Mesh_3 on a gray-level image (ImageIO is header-only in CGAL 5.x)
#include <CGAL/ImageIO.h>
#include <CGAL/Image_3.h>
#include <CGAL/Mesh_3/initialize_triangulation_from_gray_image.h>

// The floor: a bulk 3D Delaunay triangulation
#include <CGAL/Delaunay_triangulation_3.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point_3 = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point_3>;

// ---------------------------------------------------------------------------
// The benchmark surfaces.  f < 0 inside.  Exact transcriptions of the
// formulas of the benchmark table.
// ---------------------------------------------------------------------------

double sq(double a) { return a * a; }

double f_sphere(double x, double y, double z) { return x * x + y * y + z * z - 1.0; }

double f_ellipsoid(double x, double y, double z) {
  return sq(x / 1.5) + y * y + sq(z / 0.5) - 1.0;
}

template <int R_TIMES_10, int r_TIMES_10>
double f_torus_t(double x, double y, double z) {
  const double R = R_TIMES_10 / 10.0, r = r_TIMES_10 / 10.0;
  return sq(x * x + y * y + z * z + R * R - r * r) - 4.0 * R * R * (x * x + y * y);
}

double f_double_torus(double x, double y, double z) {
  return sq(x * sq(x - 1.0) * (x - 2.0) + y * y) + z * z - 0.01;
}

double f_tanglecube(double x, double y, double z) {
  const double x2 = x * x, y2 = y * y, z2 = z * z;
  return x2 * x2 - 5.0 * x2 + y2 * y2 - 5.0 * y2 + z2 * z2 - 5.0 * z2 + 11.8;
}

double f_two_spheres(double x, double y, double z) {
  const double c = 1.05;
  return (sq(x - c) + y * y + z * z - 1.0) * (sq(x + c) + y * y + z * z - 1.0);
}

double f_blob_line(double x, double y, double z) {
  double s = 0.0;
  for (int i = -1; i <= 1; ++i)
    s += std::exp(-(sq(x - 0.9 * i) + y * y + z * z) / 0.25);
  return 0.5 - s;
}

// Surfaces that leave their bounding sphere (tests/clipped_surfaces.py):
// only "surface_mesher_boundary" meshes them, as manifolds with boundary.
double f_clipped_gyroid(double x, double y, double z) {
  return std::sin(3 * x) * std::cos(3 * y) + std::sin(3 * y) * std::cos(3 * z) +
         std::sin(3 * z) * std::cos(3 * x);
}

double f_clipped_plane(double x, double, double z) { return z - 0.3 - 0.1 * x; }

double f_clipped_cylinder(double x, double y, double) { return x * x + y * y - 0.25; }

double f_clipped_half_torus(double x, double y, double z) {
  const double q = std::sqrt(sq(x - 1.0) + y * y) - 0.6;
  return q * q + z * z - 0.04;
}

// Surfaces clipped to a box (tests/clipped_surfaces.py): only "mesh_3_box"
// meshes them.  The gyroid of period 2 pi, and a tilted plane.
double f_box_gyroid(double x, double y, double z) {
  return std::sin(x) * std::cos(y) + std::sin(y) * std::cos(z) + std::sin(z) * std::cos(x);
}

double f_box_plane(double x, double y, double z) { return z - 0.2 - 0.5 * x - 0.2 * y; }

// Surfaces with creases, for "mesh_3_features" (and any mode of "mesh_3"):
// the cube [-1, 1]^3 and its union with the ball of radius 0.8 about
// (1, 1, 1) (design note creases.md, section 1).  Their crease curves are in
// benchmarks/cad_shapes.py.
double f_box(double x, double y, double z) {
  return std::max({std::abs(x), std::abs(y), std::abs(z)}) - 1.0;
}

double f_box_ball(double x, double y, double z) {
  return std::min(f_box(x, y, z),
                  std::sqrt(sq(x - 1.0) + sq(y - 1.0) + sq(z - 1.0)) - 0.8);
}

// Surfaces whose creases rdmesh finds by itself (issue 28; the same
// functions, curves and spheres are in benchmarks/crease_shapes.py): the
// cube rotated by 0.6 rad about (1, 2, 3) (rows rounded to doubles), a
// cylinder, a lens (two unit balls intersected), the cube with a spherical
// dimple, and the cube with a round hole (genus 1).
double f_box_rotated(double x, double y, double z) {
  const double u = 0.8378116424161298 * x + -0.4277690910152775 * y + 0.33924217987147504 * z;
  const double v = 0.4776732010410837 * x + 0.8752397249354845 * y + -0.0760508836373509 * z;
  const double w = -0.26438601483276575 * x + 0.22576321371476948 * y + 0.9376198624677422 * z;
  return std::max({std::abs(u), std::abs(v), std::abs(w)}) - 1.0;
}

double f_cylinder(double x, double y, double z) {
  return std::max(x * x + y * y - 1.0, std::abs(z) - 1.0);
}

double f_lens(double x, double y, double z) {
  return std::max(std::sqrt(x * x + y * y + sq(z - 0.6)) - 1.0,
                  std::sqrt(x * x + y * y + sq(z + 0.6)) - 1.0);
}

double f_box_dimple(double x, double y, double z) {
  return std::max(f_box(x, y, z), 0.6 - std::sqrt(x * x + y * y + sq(z - 1.3)));
}

double f_box_hole(double x, double y, double z) {
  return std::max(f_box(x, y, z), 0.5 - std::hypot(x, y));
}

// Global evaluation counter.  The meshers run sequentially (no TBB, no
// CGAL_CONCURRENT_MESH_3), so a plain integer is enough.
std::uint64_t g_evaluations = 0;

using Raw_function = double (*)(double, double, double);

template <Raw_function F>
double counted(const Point_3& p) {
  ++g_evaluations;
  return F(p.x(), p.y(), p.z());
}

using Counted_function = double (*)(const Point_3&);

struct Surface_entry {
  Raw_function raw;
  Counted_function counted;
  // Bounding sphere handed to CGAL.  Both meshers shoot their initial points
  // along segments from the sphere centre towards random points of the
  // sphere (of its bounding box's circumsphere for Mesh_3), which only works
  // well when the centre is INSIDE the surface (f(centre) < 0); the sphere
  // must also strictly contain the surface (f > 0 on it).  Where the centre
  // of the public benchmark table (origin, or (1,0,0) for double_torus) is
  // outside, the centre is moved inside and the radius enlarged:
  //
  //   surface       public table          used here
  //   sphere        (0,0,0)    r 2        (0,0,0)          r 2
  //   ellipsoid     (0,0,0)    r 2        (0,0,0)          r 2
  //   torus         (0,0,0)    r 2        (1,0,0)          r 2.5 (surface <= 2.4)
  //   thin_torus    (0,0,0)    r 1.5      (1,0,0)          r 2.2 (surface <= 2.1)
  //   double_torus  (1,0,0)    r 1.5      (1,0,0)          r 1.5 (f(1,0,0) = -0.01)
  //   tanglecube    (0,0,0)    r 4        (1.25,1.25,1.25) r 6   (surface <= 5.65)
  //   two_spheres   (0,0,0)    r 2.5      (1.05,0,0)       r 3.2 (surface <= 3.1)
  //   blob_line     (0,0,0)    r 2        (0,0,0)          r 2
  //
  // main() re-checks both conditions (f(centre) < 0, f > 0 on a dense
  // sample of the sphere) before meshing.
  //
  // two_spheres has two components and CGAL shoots all its initial points
  // from one centre, i.e. onto the sphere around (1.05,0,0).  The other one
  // is still found by the refinement itself (checked: seeds 0-4, sizes 0.2
  // and 0.1, both meshers).  At size 0.2 both meshers bridge the 0.1 gap
  // between the spheres (one component, Euler characteristic 2): that is
  // CGAL's genuine result at that size, reported as such ("components").
  std::array<double, 3> centre;
  double radius;
  // The surface crosses the sphere: not checked, meshed with boundary only.
  // Surface_mesher's oracle clips every dual to the sphere, and its initial
  // points come from segments between the centre (moved at random while a
  // segment finds no sign change) and the sphere, so f(centre) < 0 is not
  // needed.
  bool clipped = false;
  // The surface is clipped to the axis-aligned box (x0, y0, z0, x1, y1, z1):
  // meshed by "mesh_3_box" only; the sphere above is the box's circumscribed
  // sphere, reported as "bounding_sphere" and not used for meshing.
  bool boxed = false;
  std::array<double, 6> box{};
};

const std::map<std::string, Surface_entry>& surfaces() {
  static const std::map<std::string, Surface_entry> table = {
      {"sphere", {f_sphere, counted<f_sphere>, {0.0, 0.0, 0.0}, 2.0}},
      {"ellipsoid", {f_ellipsoid, counted<f_ellipsoid>, {0.0, 0.0, 0.0}, 2.0}},
      {"torus", {f_torus_t<10, 4>, counted<f_torus_t<10, 4>>, {1.0, 0.0, 0.0}, 2.5}},
      {"thin_torus", {f_torus_t<10, 1>, counted<f_torus_t<10, 1>>, {1.0, 0.0, 0.0}, 2.2}},
      {"double_torus", {f_double_torus, counted<f_double_torus>, {1.0, 0.0, 0.0}, 1.5}},
      {"tanglecube", {f_tanglecube, counted<f_tanglecube>, {1.25, 1.25, 1.25}, 6.0}},
      {"two_spheres", {f_two_spheres, counted<f_two_spheres>, {1.05, 0.0, 0.0}, 3.2}},
      {"blob_line", {f_blob_line, counted<f_blob_line>, {0.0, 0.0, 0.0}, 2.0}},
      // The cube reaches 1.74 from the origin.  box_ball reaches 2.19 from
      // (0.2, 0.2, 0.2) (the ball's far point; the cube's corner (-1,-1,-1)
      // is at 2.08), and the centre is inside the cube.
      {"box", {f_box, counted<f_box>, {0.0, 0.0, 0.0}, 2.0}},
      {"box_ball", {f_box_ball, counted<f_box_ball>, {0.2, 0.2, 0.2}, 2.4}},
      // The hole's axis is outside the solid: its centre is moved to x = 0.75.
      {"box_rotated", {f_box_rotated, counted<f_box_rotated>, {0.0, 0.0, 0.0}, 2.0}},
      {"cylinder", {f_cylinder, counted<f_cylinder>, {0.0, 0.0, 0.0}, 2.0}},
      {"lens", {f_lens, counted<f_lens>, {0.0, 0.0, 0.0}, 1.5}},
      {"box_dimple", {f_box_dimple, counted<f_box_dimple>, {0.0, 0.0, 0.0}, 2.0}},
      {"box_hole", {f_box_hole, counted<f_box_hole>, {0.75, 0.0, 0.0}, 2.5}},
      {"clipped_gyroid",
       {f_clipped_gyroid, counted<f_clipped_gyroid>, {0.0, 0.0, 0.0}, 2.0, true}},
      {"clipped_plane", {f_clipped_plane, counted<f_clipped_plane>, {0.0, 0.0, 0.0}, 1.0, true}},
      {"clipped_cylinder",
       {f_clipped_cylinder, counted<f_clipped_cylinder>, {0.0, 0.0, 0.0}, 1.0, true}},
      {"clipped_half_torus",
       {f_clipped_half_torus, counted<f_clipped_half_torus>, {0.0, 0.0, 0.0}, 1.0, true}},
      // Boxes as in tests/clipped_surfaces.py (keep them equal): the gyroid's
      // cube of side 6.6 is off its symmetry centre, so the surface crosses
      // the box edges transversally, away from the corners.
      {"box_gyroid",
       {f_box_gyroid, counted<f_box_gyroid>, {0.3, -0.2, 0.1}, 5.715767664977294, false, true,
        {-3.0, -3.5, -3.2, 3.6, 3.1, 3.4}}},
      {"box_plane",
       {f_box_plane, counted<f_box_plane>, {0.05, -0.05, 0.05}, 1.2031209415515964, false, true,
        {-0.8, -0.7, -0.5, 0.9, 0.6, 0.6}}},
  };
  return table;
}

// ---------------------------------------------------------------------------
// Command line
// ---------------------------------------------------------------------------

// Why the error bound is tighter than CGAL's default: both oracles locate
// surface points by bisection along segments and stop once the bracketing
// interval is shorter than an error bound relative to the bounding sphere
// (Implicit_surface_3: error_bound * radius; Labeled_mesh_domain_3:
// relative_error_bound * half the bounding-box diagonal = * sqrt(3) * radius).
// With CGAL's default of 1e-3 that interval is 1e-3 * radius (Surface_mesher)
// or 1.7e-3 * radius (Mesh_3), i.e. 1.5e-3 to 1e-2 for the spheres used here,
// and mesh vertices are off the surface by up to half of it.  As soon as the
// facet distance bound (or size) gets near that, the distance criterion
// measures the oracle's noise rather than the surface, and refinement
// over-refines or runs away.  Measured with CGAL
// 5.5.1 on the sphere, --radius 0.05 --distance 0.001: Surface_mesher gives
// 14521 vertices with 1e-3 vs 4298 with 1e-6, and Mesh_3 had not finished
// after 120 s with 1e-3 vs 0.16 s with 1e-6.  1e-6 keeps the point error far
// below any size used in the benchmarks, for ~10 more bisection steps per
// intersection (and so more function evaluations).  When distance = size
// (e.g. torus at 0.01) 1e-3 does not run away and is about twice as fast;
// see benchmarks/README.md.
constexpr double kDefaultErrorBound = 1e-6;

struct Options {
  std::string mesher;
  std::string surface;
  double angle = std::numeric_limits<double>::quiet_NaN();
  double radius = std::numeric_limits<double>::quiet_NaN();
  double distance = std::numeric_limits<double>::quiet_NaN();
  double error_bound = kDefaultErrorBound;
  unsigned int seed = 0;
  std::string out;
  std::string points;  // --points (mesher "delaunay")
  // mesher "mesh_3_image"
  std::string image;
  std::array<std::size_t, 3> dims{};
  std::array<double, 3> spacing{};
  std::array<double, 3> origin{};
  double isovalue = std::numeric_limits<double>::quiet_NaN();
  std::string init;  // "random" or "components"
  // meshers "mesh_3_features" and "mesh_3_polyhedron"
  double edge_size = std::numeric_limits<double>::quiet_NaN();
  std::string features;  // --features: polylines file
  std::string input;     // --input: OFF triangle mesh
  double feature_angle = std::numeric_limits<double>::quiet_NaN();
};

const char* const kUsage =
    "usage: cgal_reference --mesher surface_mesher|surface_mesher_boundary|mesh_3|mesh_3_fast|\n"
    "                               mesh_3_box\n"
    "                      --surface NAME\n"
    "                      --angle A --radius R --distance D\n"
    "                      [--error-bound E] [--seed S] [--out mesh.off]\n"
    "       cgal_reference --mesher mesh_3_image --image FILE --dims NX,NY,NZ\n"
    "                      --spacing SX,SY,SZ [--origin OX,OY,OZ] --isovalue V\n"
    "                      [--init random|components] --angle A --radius R --distance D\n"
    "                      [--error-bound E] [--seed S] [--out mesh.off]\n"
    "       cgal_reference --mesher mesh_3_features --surface NAME --features FILE\n"
    "                      --edge-size L --angle A --radius R --distance D\n"
    "                      [--error-bound E] [--seed S] [--out mesh.off]\n"
    "       cgal_reference --mesher mesh_3_polyhedron --input MESH.off\n"
    "                      --feature-angle FA --edge-size L --angle A --radius R\n"
    "                      --distance D [--seed S] [--out mesh.off]\n"
    "       cgal_reference --mesher delaunay --points FILE\n"
    "  surface_mesher: make_surface_mesh with Manifold_tag;\n"
    "  surface_mesher_boundary: with Manifold_with_boundary_tag\n"
    "  mesh_3: make_mesh_3 with params::manifold(); mesh_3_fast: without it\n"
    "  mesh_3_box: make_mesh_3 without it on a labeled domain (0 outside the\n"
    "              surface's box, 1 where f < 0 in it, 2 where f >= 0), the facets\n"
    "              between 1 and 2 output (box_* surfaces only)\n"
    "  mesh_3_image: make_mesh_3 with params::manifold() on the gray-image domain\n"
    "                of FILE (raw little-endian float32, x fastest, NX*NY*NZ\n"
    "                samples); values > V inside, outside the box outside;\n"
    "                --init components: one seed per connected component of the\n"
    "                samples > V first (default random: make_mesh_3's own)\n"
    "  mesh_3_features: make_mesh_3 (no manifold) on the implicit domain with the\n"
    "                   polylines of FILE protected (one per line: n x1 y1 z1 ...\n"
    "                   xn yn zn; polylines may meet only at their end points)\n"
    "  mesh_3_polyhedron: make_mesh_3 (no manifold) on the closed triangle mesh\n"
    "                     MESH.off with its sharp edges protected\n"
    "                     (detect_features(FA): normals differ by FA or more)\n"
    "  delaunay: time Delaunay_triangulation_3(begin, end) of the points of FILE\n"
    "            (x y z per line)\n"
    "  NAME: sphere ellipsoid torus thin_torus double_torus tanglecube\n"
    "        two_spheres blob_line box box_ball box_rotated cylinder lens\n"
    "        box_dimple box_hole; clipped by their sphere\n"
    "        (surface_mesher_boundary only): clipped_gyroid clipped_plane\n"
    "        clipped_cylinder clipped_half_torus;\n"
    "        clipped by a box (mesh_3_box only): box_gyroid box_plane\n"
    "  A: minimum facet angle bound in degrees, 0 < A < 90 (CGAL guarantees\n"
    "     termination only for A <= 30)\n"
    "  R: facet circumradius bound (Surface_mesher radius, Mesh_3 facet_size) > 0\n"
    "  D: facet centre-to-surface distance bound > 0\n"
    "  E: relative error bound of the implicit-function oracle, 0 < E < 1\n"
    "     (default 1e-6)\n"
    "  S: seed of CGAL's random generators (default 0)\n"
    "  L: edge_size, the largest protecting ball radius on the curves > 0\n"
    "  FA: feature angle in degrees, 0 < FA <= 180\n"
    "Prints one JSON object on stdout.  Exit code 2 on a bad command line,\n"
    "1 on any other failure.\n";

struct Usage_error {
  std::string message;
};

double parse_double(const std::string& opt, const std::string& text) {
  const char* s = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s, &end);
  if (text.empty() || end == s || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw Usage_error{"invalid number for " + opt + ": '" + text + "'"};
  return v;
}

unsigned int parse_seed(const std::string& opt, const std::string& text) {
  const char* s = text.c_str();
  char* end = nullptr;
  errno = 0;
  const unsigned long v = std::strtoul(s, &end, 10);
  if (text.empty() || text[0] == '-' || end == s || *end != '\0' || errno == ERANGE ||
      v > std::numeric_limits<unsigned int>::max())
    throw Usage_error{"invalid integer for " + opt + ": '" + text + "'"};
  return static_cast<unsigned int>(v);
}

// "a,b,c": three fields of a comma-separated triple.
std::array<std::string, 3> split_triple(const std::string& opt, const std::string& text) {
  std::array<std::string, 3> parts;
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 2) == (comma == std::string::npos))
      throw Usage_error{opt + " needs three comma-separated values, got '" + text + "'"};
    parts[i] = text.substr(start, i < 2 ? comma - start : std::string::npos);
    start = comma + 1;
  }
  return parts;
}

std::array<double, 3> parse_doubles(const std::string& opt, const std::string& text) {
  const auto parts = split_triple(opt, text);
  return {parse_double(opt, parts[0]), parse_double(opt, parts[1]), parse_double(opt, parts[2])};
}

std::array<std::size_t, 3> parse_dims(const std::string& opt, const std::string& text) {
  std::array<std::size_t, 3> dims{};
  const auto parts = split_triple(opt, text);
  for (int i = 0; i < 3; ++i) {
    dims[i] = parse_seed(opt, parts[i]);
    // Trilinear interpolation needs two samples per axis.
    if (dims[i] < 2) throw Usage_error{opt + " must be at least 2 along every axis"};
  }
  return dims;
}

// The image options: required for mesh_3_image, refused by the other meshers.
void check_image_options(const Options& o, bool have_dims, bool have_spacing,
                         bool have_origin) {
  const bool image = o.mesher == "mesh_3_image";
  const bool any = !o.image.empty() || have_dims || have_spacing || have_origin ||
                   !std::isnan(o.isovalue) || !o.init.empty();
  if (!image) {
    if (any)
      throw Usage_error{
          "--image, --dims, --spacing, --origin, --isovalue and --init are only for --mesher "
          "mesh_3_image"};
    return;
  }
  if (!o.surface.empty()) throw Usage_error{"--mesher mesh_3_image takes --image, not --surface"};
  if (o.image.empty()) throw Usage_error{"--image is required"};
  if (!have_dims) throw Usage_error{"--dims is required"};
  if (!have_spacing) throw Usage_error{"--spacing is required"};
  if (std::isnan(o.isovalue)) throw Usage_error{"--isovalue is required"};
}

// The features options: --edge-size for both features modes, --features for
// mesh_3_features, --input and --feature-angle for mesh_3_polyhedron; refused
// by the other modes.
void check_feature_options(const Options& o) {
  const bool features = o.mesher == "mesh_3_features";
  const bool polyhedron = o.mesher == "mesh_3_polyhedron";
  if (!features && !polyhedron) {
    if (!std::isnan(o.edge_size) || !o.features.empty() || !o.input.empty() ||
        !std::isnan(o.feature_angle))
      throw Usage_error{
          "--edge-size, --features, --input and --feature-angle are only for --mesher "
          "mesh_3_features or mesh_3_polyhedron"};
    return;
  }
  if (std::isnan(o.edge_size)) throw Usage_error{"--edge-size is required"};
  if (features) {
    if (o.features.empty()) throw Usage_error{"--features is required"};
    if (!o.input.empty() || !std::isnan(o.feature_angle))
      throw Usage_error{"--input and --feature-angle are only for --mesher mesh_3_polyhedron"};
    return;
  }
  if (!o.surface.empty())
    throw Usage_error{"--mesher mesh_3_polyhedron takes --input, not --surface"};
  if (!o.features.empty()) throw Usage_error{"--features is only for --mesher mesh_3_features"};
  if (o.input.empty()) throw Usage_error{"--input is required"};
  if (std::isnan(o.feature_angle)) throw Usage_error{"--feature-angle is required"};
}

Options parse_args(int argc, char** argv) {
  Options o;
  bool have_angle = false, have_radius = false, have_distance = false;
  bool have_dims = false, have_spacing = false, have_origin = false;
  bool have_error_bound = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string value;
    bool have_value = false;
    const auto eq = arg.find('=');
    if (arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
      have_value = true;
    }
    if (arg == "-h" || arg == "--help") throw Usage_error{""};
    static const char* const known[] = {"--mesher", "--surface",     "--angle", "--radius",
                                        "--distance", "--error-bound", "--seed", "--out",
                                        "--points", "--image", "--dims", "--spacing",
                                        "--origin", "--isovalue", "--init",
                                        "--edge-size", "--features", "--input",
                                        "--feature-angle"};
    bool is_known = false;
    for (const char* k : known) is_known = is_known || arg == k;
    if (!is_known) throw Usage_error{"unknown argument: '" + std::string(argv[i]) + "'"};
    if (!have_value) {
      if (i + 1 >= argc) throw Usage_error{"missing value for " + arg};
      value = argv[++i];
    }
    if (arg == "--mesher") {
      if (value != "surface_mesher" && value != "surface_mesher_boundary" &&
          value != "mesh_3" && value != "mesh_3_fast" && value != "mesh_3_box" &&
          value != "mesh_3_image" && value != "mesh_3_features" &&
          value != "mesh_3_polyhedron" && value != "delaunay")
        throw Usage_error{"unknown mesher '" + value +
                          "' (surface_mesher, surface_mesher_boundary, mesh_3, mesh_3_fast,"
                          " mesh_3_box, mesh_3_image, mesh_3_features, mesh_3_polyhedron"
                          " or delaunay)"};
      o.mesher = value;
    } else if (arg == "--surface") {
      if (surfaces().count(value) == 0) throw Usage_error{"unknown surface '" + value + "'"};
      o.surface = value;
    } else if (arg == "--angle") {
      o.angle = parse_double(arg, value);
      if (!(o.angle > 0.0 && o.angle < 90.0))
        throw Usage_error{"--angle must be in (0, 90) degrees"};
      have_angle = true;
    } else if (arg == "--radius") {
      o.radius = parse_double(arg, value);
      if (!(o.radius > 0.0)) throw Usage_error{"--radius must be > 0"};
      have_radius = true;
    } else if (arg == "--distance") {
      o.distance = parse_double(arg, value);
      if (!(o.distance > 0.0)) throw Usage_error{"--distance must be > 0"};
      have_distance = true;
    } else if (arg == "--error-bound") {
      o.error_bound = parse_double(arg, value);
      if (!(o.error_bound > 0.0 && o.error_bound < 1.0))
        throw Usage_error{"--error-bound must be in (0, 1)"};
      have_error_bound = true;
    } else if (arg == "--seed") {
      o.seed = parse_seed(arg, value);
    } else if (arg == "--out") {
      if (value.empty()) throw Usage_error{"--out needs a file name"};
      o.out = value;
    } else if (arg == "--points") {
      if (value.empty()) throw Usage_error{"--points needs a file name"};
      o.points = value;
    } else if (arg == "--image") {
      if (value.empty()) throw Usage_error{"--image needs a file name"};
      o.image = value;
    } else if (arg == "--dims") {
      o.dims = parse_dims(arg, value);
      have_dims = true;
    } else if (arg == "--spacing") {
      o.spacing = parse_doubles(arg, value);
      for (double v : o.spacing)
        if (!(v > 0.0)) throw Usage_error{"--spacing must be > 0 along every axis"};
      have_spacing = true;
    } else if (arg == "--origin") {
      o.origin = parse_doubles(arg, value);
      have_origin = true;
    } else if (arg == "--isovalue") {
      o.isovalue = parse_double(arg, value);
    } else if (arg == "--init") {
      if (value != "random" && value != "components")
        throw Usage_error{"--init must be random or components"};
      o.init = value;
    } else if (arg == "--edge-size") {
      o.edge_size = parse_double(arg, value);
      if (!(o.edge_size > 0.0)) throw Usage_error{"--edge-size must be > 0"};
    } else if (arg == "--features") {
      if (value.empty()) throw Usage_error{"--features needs a file name"};
      o.features = value;
    } else if (arg == "--input") {
      if (value.empty()) throw Usage_error{"--input needs a file name"};
      o.input = value;
    } else if (arg == "--feature-angle") {
      o.feature_angle = parse_double(arg, value);
      if (!(o.feature_angle > 0.0 && o.feature_angle <= 180.0))
        throw Usage_error{"--feature-angle must be in (0, 180] degrees"};
    }
  }
  if (o.mesher.empty()) throw Usage_error{"--mesher is required"};
  if (o.mesher == "delaunay") {
    if (o.points.empty()) throw Usage_error{"--mesher delaunay needs --points FILE"};
    return o;
  }
  if (!o.points.empty()) throw Usage_error{"--points is only for --mesher delaunay"};
  check_image_options(o, have_dims, have_spacing, have_origin);
  check_feature_options(o);
  if (o.surface.empty() && o.mesher != "mesh_3_image" && o.mesher != "mesh_3_polyhedron")
    throw Usage_error{"--surface is required"};
  if (!have_angle) throw Usage_error{"--angle is required"};
  if (!have_radius) throw Usage_error{"--radius is required"};
  if (!have_distance) throw Usage_error{"--distance is required"};
  if (o.mesher == "mesh_3_image") {
    if (o.init.empty()) o.init = "random";
    return o;
  }
  if (o.mesher == "mesh_3_polyhedron") {
    // The polyhedral domain intersects exactly (AABB tree): no oracle error.
    if (have_error_bound) throw Usage_error{"--mesher mesh_3_polyhedron takes no --error-bound"};
    return o;
  }
  const Surface_entry& s = surfaces().at(o.surface);
  if (s.clipped && o.mesher != "surface_mesher_boundary")
    throw Usage_error{"surface '" + o.surface +
                      "' leaves its bounding sphere: only --mesher surface_mesher_boundary"};
  if (s.boxed != (o.mesher == "mesh_3_box"))
    throw Usage_error{s.boxed ? "surface '" + o.surface +
                                    "' is clipped to a box: only --mesher mesh_3_box"
                              : "--mesher mesh_3_box meshes the box_* surfaces only, not '" +
                                    o.surface + "'"};
  return o;
}

// ---------------------------------------------------------------------------
// Bounding-sphere check (not timed, evaluations not counted)
// ---------------------------------------------------------------------------

// Returns an empty string when f(centre) < 0 and f > 0 at every point of a
// dense Fibonacci sample of the sphere; otherwise a description of the problem.
std::string check_bounding_sphere(const Surface_entry& s) {
  const auto& c = s.centre;
  const double fc = s.raw(c[0], c[1], c[2]);
  if (!(fc < 0.0)) return "f(centre) = " + std::to_string(fc) + " is not < 0";
  const int n = 100000;
  const double pi = 3.14159265358979323846;
  const double golden = pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    const double x = c[0] + s.radius * rho * std::cos(phi);
    const double y = c[1] + s.radius * rho * std::sin(phi);
    const double zz = c[2] + s.radius * z;
    const double v = s.raw(x, y, zz);
    if (!(v > 0.0))
      return "f = " + std::to_string(v) + " <= 0 on the bounding sphere at (" +
             std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(zz) + ")";
  }
  return {};
}

// ---------------------------------------------------------------------------
// The two meshers.  Each fills `mesh` with the output surface and returns the
// wall time of the meshing call in seconds.
// ---------------------------------------------------------------------------

// Surface_mesher with Manifold_tag, or with Manifold_with_boundary_tag
// (`boundary`): then the surface may cross the sphere, whose inside part is
// meshed with a boundary where the oracle clips the duals.
double run_surface_mesher(const Options& o, const Surface_entry& s, Mesh& mesh, bool boundary) {
  using Tr = CGAL::Surface_mesh_default_triangulation_3;
  using C2t3 = CGAL::Complex_2_in_triangulation_3<Tr>;
  using GT = Tr::Geom_traits;
  using Sphere_3 = GT::Sphere_3;
  using GT_point = GT::Point_3;
  using Surface_3 = CGAL::Implicit_surface_3<GT, Counted_function>;

  Tr tr;
  C2t3 c2t3(tr);
  const GT_point centre(s.centre[0], s.centre[1], s.centre[2]);
  // Implicit_surface_3's error bound is relative to the sphere radius.
  Surface_3 surface(s.counted, Sphere_3(centre, s.radius * s.radius), o.error_bound);
  CGAL::Surface_mesh_default_criteria_3<Tr> criteria(o.angle, o.radius, o.distance);

  g_evaluations = 0;
  const auto t0 = std::chrono::steady_clock::now();
  if (boundary)
    CGAL::make_surface_mesh(c2t3, surface, criteria, CGAL::Manifold_with_boundary_tag());
  else
    CGAL::make_surface_mesh(c2t3, surface, criteria, CGAL::Manifold_tag());
  const auto t1 = std::chrono::steady_clock::now();

  CGAL::facets_in_complex_2_to_triangle_mesh(c2t3, mesh);
  return std::chrono::duration<double>(t1 - t0).count();
}

// Mesh_3's facet criteria from the options (the Mesh_3 modes' only criteria:
// no cell criterion is given, so only the surface is refined).
template <typename Criteria>
Criteria facet_criteria(const Options& o,
                        CGAL::Mesh_facet_topology topology =
                            CGAL::FACET_VERTICES_ON_SAME_SURFACE_PATCH) {
  namespace params = CGAL::parameters;
  return Criteria(params::facet_angle = o.angle, params::facet_size = o.radius,
                  params::facet_distance = o.distance, params::facet_topology = topology);
}

double run_mesh_3(const Options& o, const Surface_entry& s, Mesh& mesh, CGAL::Random& rng,
                  bool manifold) {
  using Mesh_domain = CGAL::Labeled_mesh_domain_3<K>;
  using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
  using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace params = CGAL::parameters;

  const Point_3 centre(s.centre[0], s.centre[1], s.centre[2]);
  // Labeled_mesh_domain_3 replaces the sphere by its bounding box; the error
  // bound is relative to half the box diagonal (sqrt(3) * radius).
  Mesh_domain domain = Mesh_domain::create_implicit_mesh_domain(
      s.counted, K::Sphere_3(centre, s.radius * s.radius),
      params::relative_error_bound = o.error_bound, params::p_rng = &rng);

  // Facet criteria only: no cell criterion is given (cell_size and
  // cell_radius_edge_ratio default to 0 = ignored), so only the boundary
  // surface is refined.
  const auto criteria = facet_criteria<Mesh_criteria>(o);

  g_evaluations = 0;
  const auto t0 = std::chrono::steady_clock::now();
  // "mesh_3" asks for a manifold surface (params::manifold()); "mesh_3_fast"
  // leaves Mesh_3's default (no manifold criterion), which is faster and on
  // these smooth closed surfaces still gives closed manifolds (checked by
  // the suite's quality step).
  C3t3 c3t3 = manifold ? CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(),
                                                 params::no_exude(), params::manifold())
                       : CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(),
                                                 params::no_exude());
  const auto t1 = std::chrono::steady_clock::now();

  CGAL::facets_in_complex_3_to_triangle_mesh(c3t3, mesh);
  return std::chrono::duration<double>(t1 - t0).count();
}

// ---------------------------------------------------------------------------
// Mesh_3 on a surface clipped to a box
// ---------------------------------------------------------------------------

// The labeled domain's labels: 0 outside the box, 1 where f < 0 inside it, 2
// where f >= 0 inside it.  Only the calls of f are counted.
struct Box_labels {
  Raw_function f;
  std::array<double, 6> box;
  int operator()(const Point_3& p) const {
    const double x = p.x(), y = p.y(), z = p.z();
    if (x < box[0] || y < box[1] || z < box[2] || x > box[3] || y > box[4] || z > box[5])
      return 0;
    ++g_evaluations;
    return f(x, y, z) < 0.0 ? 1 : 2;
  }
};

// The complex facets between subdomains `a` and `b` as a triangle mesh, each
// oriented with its normal out of subdomain `a` (into f >= 0 here, as CGAL's
// facets_in_complex_3_to_triangle_soup orients the facets of one subdomain).
// The soup is made a polygon mesh as facets_in_complex_3_to_triangle_mesh
// does (orient_polygon_soup duplicates non-manifold vertices, if any).
template <typename C3t3>
void facets_between_to_mesh(const C3t3& c3t3, int a, int b, Mesh& mesh) {
  namespace PMP = CGAL::Polygon_mesh_processing;
  std::vector<Point_3> points;
  std::vector<std::array<std::size_t, 3>> faces;
  std::map<Point_3, std::size_t> index;
  const auto& tr = c3t3.triangulation();
  for (auto fit = c3t3.facets_in_complex_begin(); fit != c3t3.facets_in_complex_end(); ++fit) {
    const auto c = fit->first;
    const int s = fit->second;
    const int ci = c3t3.subdomain_index(c), oi = c3t3.subdomain_index(c->neighbor(s));
    if (!((ci == a && oi == b) || (ci == b && oi == a))) continue;
    std::array<std::size_t, 3> f{};
    for (int i = 1; i < 4; ++i) {
      const Point_3 p = tr.point(c, (s + i) & 3).point();
      const auto ins = index.emplace(p, points.size());
      if (ins.second) points.push_back(p);
      f[i - 1] = ins.first->second;
    }
    // CGAL's rule for "normals point out of the subdomain a"
    // (facets_in_complex_3_to_triangle_soup with normals_point_outside).
    if ((ci == a) == (s % 2 == 1)) std::swap(f[0], f[1]);
    faces.push_back(f);
  }
  if (!PMP::is_polygon_soup_a_polygon_mesh(faces)) PMP::orient_polygon_soup(points, faces);
  PMP::polygon_soup_to_polygon_mesh(points, faces, mesh);
}

double run_mesh_3_box(const Options& o, const Surface_entry& s, Mesh& mesh, CGAL::Random& rng,
                      std::size_t& complex_facets) {
  using Mesh_domain = CGAL::Labeled_mesh_domain_3<K>;
  using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
  using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace params = CGAL::parameters;

  const auto& b = s.box;
  // The domain's bounding box is the clip box grown by 5% of its diagonal
  // on every side, so that the box faces (label changes 0 -> 1 or 2) lie
  // strictly inside it and are found like any other surface patch.  The
  // error bound is relative to half that box's diagonal.
  const double margin =
      0.05 * std::sqrt(sq(b[3] - b[0]) + sq(b[4] - b[1]) + sq(b[5] - b[2]));
  const K::Iso_cuboid_3 bbox(b[0] - margin, b[1] - margin, b[2] - margin, b[3] + margin,
                             b[4] + margin, b[5] + margin);
  Mesh_domain domain(Box_labels{s.raw, b}, bbox, o.error_bound, CGAL::Null_subdomain_index(),
                     &rng);

  // Facet criteria only, as "mesh_3_fast" (no params::manifold()), on every
  // patch, the box faces' too.  FACET_VERTICES_ON_SURFACE, Mesh_3's default:
  // with no protected 1D features the facets along the curve where the
  // surface meets the box have vertices on two patches, which
  // FACET_VERTICES_ON_SAME_SURFACE_PATCH (the other modes') would keep refining
  // there (not tried).
  const auto criteria = facet_criteria<Mesh_criteria>(o, CGAL::FACET_VERTICES_ON_SURFACE);

  g_evaluations = 0;
  const auto t0 = std::chrono::steady_clock::now();
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(), params::no_exude());
  const auto t1 = std::chrono::steady_clock::now();

  complex_facets = c3t3.number_of_facets_in_complex();
  facets_between_to_mesh(c3t3, 1, 2, mesh);
  return std::chrono::duration<double>(t1 - t0).count();
}

// ---------------------------------------------------------------------------
// The floor: CGAL's bulk Delaunay triangulation of given points
// ---------------------------------------------------------------------------

struct Input_error {
  std::string message;
};

std::string json_double(double v);

// Points of a text file, x y z per point, whitespace-separated.
std::vector<Point_3> read_points(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw Input_error{"cannot open points file '" + path + "'"};
  std::vector<double> xyz;
  std::string token;
  while (is >> token) {
    const char* s = token.c_str();
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s, &end);
    if (end == s || *end != '\0' || errno == ERANGE || !std::isfinite(v))
      throw Input_error{"'" + path + "': not a finite number: '" + token + "' (number " +
                        std::to_string(xyz.size() + 1) + ")"};
    xyz.push_back(v);
  }
  if (is.bad()) throw Input_error{"cannot read points file '" + path + "'"};
  if (xyz.size() % 3 != 0)
    throw Input_error{"'" + path + "': " + std::to_string(xyz.size()) +
                      " numbers, not a multiple of 3 (x y z per point)"};
  if (xyz.size() < 12)
    throw Input_error{"'" + path + "': fewer than 4 points (" + std::to_string(xyz.size() / 3) +
                      ")"};
  std::vector<Point_3> pts;
  pts.reserve(xyz.size() / 3);
  for (std::size_t i = 0; i < xyz.size(); i += 3) pts.emplace_back(xyz[i], xyz[i + 1], xyz[i + 2]);
  return pts;
}

// ---------------------------------------------------------------------------
// Mesh_3 with protected 1D features
// ---------------------------------------------------------------------------

using Polyline = std::vector<Point_3>;

// The polylines of a --features file: one per non-blank line,
// "n x1 y1 z1 ... xn yn zn" (CGAL's polylines text format, as its examples
// read it, but one per line so that errors name the line).  Refused: a count
// below 2 or not matching the line, a token that is not a finite number, two
// consecutive equal points (a zero-length segment: CGAL's protection needs
// positive lengths, cf. CGAL #4814 "minimal_size_ > 0 || sq_d > 0"), a point
// equal to a point in another polyline's interior or twice in one polyline's
// interior (polylines may meet only at their end points, CGAL #7356).  A
// closed loop repeats its first point last.
std::vector<Polyline> read_polylines(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw Input_error{"cannot open polylines file '" + path + "'"};
  std::vector<Polyline> polylines;
  std::vector<std::size_t> line_of;  // each polyline's line number
  std::string line;
  std::size_t lineno = 0;
  while (std::getline(is, line)) {
    ++lineno;
    std::istringstream ls(line);
    std::vector<std::string> tokens;
    for (std::string t; ls >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    const std::string where = "'" + path + "' line " + std::to_string(lineno);
    const char* s = tokens[0].c_str();
    char* end = nullptr;
    errno = 0;
    const unsigned long n = std::strtoul(s, &end, 10);
    if (tokens[0][0] == '-' || end == s || *end != '\0' || errno == ERANGE)
      throw Input_error{where + ": the point count '" + tokens[0] + "' is not an integer"};
    if (n < 2) throw Input_error{where + ": a polyline needs at least 2 points"};
    if (tokens.size() != 1 + 3 * n)
      throw Input_error{where + ": " + std::to_string(tokens.size() - 1) +
                        " coordinates for " + std::to_string(n) + " points"};
    Polyline pl;
    pl.reserve(n);
    double xyz[3];
    for (std::size_t i = 1; i < tokens.size(); ++i) {
      const char* t = tokens[i].c_str();
      errno = 0;
      const double v = std::strtod(t, &end);
      if (end == t || *end != '\0' || errno == ERANGE || !std::isfinite(v))
        throw Input_error{where + ": not a finite number: '" + tokens[i] + "'"};
      xyz[(i - 1) % 3] = v;
      if ((i - 1) % 3 == 2) {
        pl.emplace_back(xyz[0], xyz[1], xyz[2]);
        if (pl.size() > 1 && pl[pl.size() - 2] == pl.back())
          throw Input_error{where + ": points " + std::to_string(pl.size() - 1) + " and " +
                            std::to_string(pl.size()) + " are equal (a zero-length segment)"};
      }
    }
    if (n == 2 && pl.front() == pl.back())
      throw Input_error{where + ": a closed polyline needs at least 3 points"};
    polylines.push_back(std::move(pl));
    line_of.push_back(lineno);
  }
  if (is.bad()) throw Input_error{"cannot read polylines file '" + path + "'"};
  if (polylines.empty()) throw Input_error{"'" + path + "' holds no polyline"};
  // Where each point occurs: (polyline, is an end point).  A closed loop's
  // last point is its first and is counted once.
  std::map<Point_3, std::vector<std::pair<std::size_t, bool>>> seen;
  for (std::size_t k = 0; k < polylines.size(); ++k) {
    const Polyline& pl = polylines[k];
    const bool closed = pl.front() == pl.back();
    const std::size_t m = closed ? pl.size() - 1 : pl.size();
    for (std::size_t i = 0; i < m; ++i)
      seen[pl[i]].emplace_back(k, i == 0 || i + 1 == pl.size());
  }
  for (const auto& [p, where] : seen) {
    if (where.size() < 2) continue;
    for (const auto& [k, is_end] : where)
      if (!is_end)
        throw Input_error{"'" + path + "' line " + std::to_string(line_of[k]) +
                          ": the polyline has the interior point (" + json_double(p.x()) +
                          ", " + json_double(p.y()) + ", " + json_double(p.z()) +
                          ") that another polyline, or itself, also has: polylines may meet "
                          "only at end points (CGAL #7356); split them there"};
  }
  return polylines;
}

// The features modes' criteria: edge_size on the protected curves, facet
// criteria as the other Mesh_3 modes, no cell criterion (cell_size and
// cell_radius_edge_ratio left at 0 = ignored: only the surface is refined).
template <typename Criteria>
Criteria feature_criteria(const Options& o) {
  namespace params = CGAL::parameters;
  return Criteria(params::edge_size = o.edge_size, params::facet_angle = o.angle,
                  params::facet_size = o.radius, params::facet_distance = o.distance,
                  params::facet_topology = CGAL::FACET_VERTICES_ON_SAME_SURFACE_PATCH);
}

// What the features modes add to the JSON line.
struct Feature_counts {
  std::size_t feature_vertices = 0;  // in_dimension <= 1
  std::size_t corner_vertices = 0;   // in_dimension == 0
  std::size_t complex_edges = 0;
  std::size_t domain_curves = 0;
  std::size_t domain_corners = 0;
  double detect_seconds = std::numeric_limits<double>::quiet_NaN();
};

template <typename C3t3>
void count_feature_vertices(const C3t3& c3t3, Feature_counts& counts) {
  const auto& tr = c3t3.triangulation();
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    const int d = c3t3.in_dimension(v);
    if (d == 0) ++counts.corner_vertices;
    if (d == 0 || d == 1) ++counts.feature_vertices;
  }
  counts.complex_edges = c3t3.number_of_edges_in_complex();
}

template <typename Domain>
void count_domain_features(const Domain& domain, Feature_counts& counts) {
  std::size_t curves = 0, corners = 0;
  domain.get_curves(boost::make_function_output_iterator([&](const auto&) { ++curves; }));
  domain.get_corners(boost::make_function_output_iterator([&](const auto&) { ++corners; }));
  counts.domain_curves = curves;
  counts.domain_corners = corners;
}

double run_mesh_3_features(const Options& o, const Surface_entry& s,
                           const std::vector<Polyline>& polylines, Mesh& mesh, CGAL::Random& rng,
                           Feature_counts& counts) {
  using Mesh_domain = CGAL::Mesh_domain_with_polyline_features_3<CGAL::Labeled_mesh_domain_3<K>>;
  using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Mesh_domain::Corner_index,
                                                       Mesh_domain::Curve_index>;
  using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace params = CGAL::parameters;

  const Point_3 centre(s.centre[0], s.centre[1], s.centre[2]);
  // As "mesh_3": the sphere's bounding box, the error bound relative to half
  // its diagonal.
  Mesh_domain domain = Mesh_domain::create_implicit_mesh_domain(
      s.counted, K::Sphere_3(centre, s.radius * s.radius),
      params::relative_error_bound = o.error_bound, params::p_rng = &rng);
  domain.add_features(polylines.begin(), polylines.end());
  count_domain_features(domain, counts);

  const auto criteria = feature_criteria<Mesh_criteria>(o);

  g_evaluations = 0;
  const auto t0 = std::chrono::steady_clock::now();
  // params::features() is make_mesh_3's default for a domain with features.
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(), params::no_exude());
  const auto t1 = std::chrono::steady_clock::now();

  count_feature_vertices(c3t3, counts);
  facets_between_to_mesh(c3t3, 1, 0, mesh);
  return std::chrono::duration<double>(t1 - t0).count();
}

double run_mesh_3_polyhedron(const Options& o, Mesh& mesh, CGAL::Random& rng,
                             Feature_counts& counts) {
  using Polyhedron = CGAL::Mesh_polyhedron_3<K>::type;
  using Mesh_domain = CGAL::Polyhedral_mesh_domain_with_features_3<K>;
  using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Mesh_domain::Corner_index,
                                                       Mesh_domain::Curve_index>;
  using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace params = CGAL::parameters;

  Polyhedron poly;
  {
    std::ifstream is(o.input);
    if (!is) throw Input_error{"cannot open mesh file '" + o.input + "'"};
    if (!CGAL::IO::read_OFF(is, poly) || poly.empty())
      throw Input_error{"'" + o.input + "' is not an OFF polygon mesh CGAL can read " +
                        "(a non-manifold or badly oriented input fails here)"};
  }
  if (!CGAL::is_triangle_mesh(poly))
    throw Input_error{"'" + o.input + "' is not a triangle mesh"};
  if (!CGAL::is_closed(poly)) throw Input_error{"'" + o.input + "' is not closed"};

  Mesh_domain domain(poly, &rng);
  const auto t0 = std::chrono::steady_clock::now();
  domain.detect_features(o.feature_angle);
  const auto t1 = std::chrono::steady_clock::now();
  count_domain_features(domain, counts);

  const auto criteria = feature_criteria<Mesh_criteria>(o);
  C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(), params::no_exude());
  const auto t2 = std::chrono::steady_clock::now();

  count_feature_vertices(c3t3, counts);
  facets_between_to_mesh(c3t3, 1, 0, mesh);
  counts.detect_seconds = std::chrono::duration<double>(t1 - t0).count();
  return std::chrono::duration<double>(t2 - t0).count();
}

std::string feature_fields(const Options& o, const Feature_counts& c) {
  std::string out = ", \"edge_size\": " + json_double(o.edge_size);
  if (o.mesher == "mesh_3_polyhedron")
    out += ", \"feature_angle\": " + json_double(o.feature_angle) +
           ", \"detect_seconds\": " + json_double(c.detect_seconds);
  out += ", \"feature_vertices\": " + std::to_string(c.feature_vertices) +
         ", \"corner_vertices\": " + std::to_string(c.corner_vertices) +
         ", \"complex_edges\": " + std::to_string(c.complex_edges) +
         ", \"domain_curves\": " + std::to_string(c.domain_curves) +
         ", \"domain_corners\": " + std::to_string(c.domain_corners);
  return out;
}

// ---------------------------------------------------------------------------
// Mesh_3 on a gray-level image
// ---------------------------------------------------------------------------

// Little-endian float32 at `p`, whatever the host's byte order.
float le_float(const unsigned char* p) {
  const std::uint32_t u = std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 |
                          std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
  float v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}

// The raw volume of --image as a float32 CGAL image, x fastest, translation
// 0: ImageIO keeps the translation in single precision, so the output is
// shifted by --origin in double instead (shift_mesh).  Checks the file size,
// that the samples are finite and that the isovalue is strictly between the
// smallest and the largest sample (else there is no surface).
CGAL::Image_3 read_volume(const Options& o) {
  const auto [nx, ny, nz] = o.dims;
  const std::size_t n = nx * ny * nz;
  if (n / nx / ny != nz) throw Input_error{"--dims too large"};
  std::ifstream is(o.image, std::ios::binary);
  if (!is) throw Input_error{"cannot open image file '" + o.image + "'"};
  _image* im = _createImage(nx, ny, nz, 1, o.spacing[0], o.spacing[1], o.spacing[2], 4,
                            WK_FLOAT, SGN_SIGNED);
  if (im == nullptr || im->data == nullptr) throw Input_error{"out of memory for the image"};
  CGAL::Image_3 image(im);  // owns im from here on
  // Read into the image's buffer and decode in place: no second copy.
  unsigned char* bytes = static_cast<unsigned char*>(im->data);
  is.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(4 * n));
  if (static_cast<std::size_t>(is.gcount()) != 4 * n || is.peek() != EOF)
    throw Input_error{"'" + o.image + "' does not hold " + std::to_string(n) +
                      " float32 samples (--dims " + std::to_string(nx) + "," +
                      std::to_string(ny) + "," + std::to_string(nz) + ")"};
  float* data = static_cast<float*>(im->data);
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    data[i] = le_float(bytes + 4 * i);
    if (!std::isfinite(data[i]))
      throw Input_error{"'" + o.image + "': sample " + std::to_string(i) + " is not finite"};
    lo = std::min(lo, data[i]);
    hi = std::max(hi, data[i]);
  }
  if (!(lo < o.isovalue && o.isovalue < hi))
    throw Input_error{"--isovalue " + std::to_string(o.isovalue) + " is not strictly between " +
                      "the smallest and the largest sample (" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "): no surface"};
  return image;
}

// The gray-image domain's label: 1 (inside) above the isovalue, 0 (outside)
// otherwise, which is CGAL's default (Greater_than) and rdmesh's
// inside="greater".  Given explicitly so that each interpolation of the
// volume is counted.
struct Counted_threshold {
  double isovalue;
  int operator()(double value) const {
    ++g_evaluations;
    return value > isovalue ? 1 : 0;
  }
};

// CGAL's initial points from the image: a seed in every connected component
// of the samples above the isovalue (the default threshold, not counted:
// these are samples, not interpolations).  The function reports its progress
// on std::cout, which holds our JSON line: that goes to std::cerr instead.
template <typename C3t3, typename Domain, typename Criteria>
void seed_components(C3t3& c3t3, const Domain& domain, const CGAL::Image_3& image,
                     const Criteria& criteria, double isovalue) {
  std::streambuf* const out = std::cout.rdbuf(std::cerr.rdbuf());
  try {
    initialize_triangulation_from_gray_image(c3t3, domain, image, criteria, isovalue, float(0));
  } catch (...) {
    std::cout.rdbuf(out);
    throw;
  }
  std::cout.rdbuf(out);
}

double run_mesh_3_image(const Options& o, const CGAL::Image_3& image, Mesh& mesh,
                        CGAL::Random& rng) {
  using Mesh_domain = CGAL::Labeled_mesh_domain_3<K>;
  using Tr = CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type;
  using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
  using Mesh_criteria = CGAL::Mesh_criteria_3<Tr>;
  namespace params = CGAL::parameters;

  // Trilinear interpolation of the samples (CGAL's only one for gray
  // images).  Points outside the samples' box get value_outside, below any
  // isovalue: the box closes the surface, as rdmesh's border="closed".  The
  // error bound is relative to half the diagonal of the domain's box (the
  // samples' box grown by 1 in every direction).
  Mesh_domain domain = Mesh_domain::create_gray_image_mesh_domain(
      image, params::iso_value = o.isovalue,
      params::value_outside = std::numeric_limits<double>::lowest(),
      params::image_values_to_subdomain_indices = Counted_threshold{o.isovalue},
      params::relative_error_bound = o.error_bound, params::p_rng = &rng);

  // As "mesh_3": facet criteria only, so only the isosurface is refined.
  const auto criteria = facet_criteria<Mesh_criteria>(o);

  g_evaluations = 0;
  const auto t0 = std::chrono::steady_clock::now();
  C3t3 c3t3;
  if (o.init == "components") {
    seed_components(c3t3, domain, image, criteria, o.isovalue);
    CGAL::refine_mesh_3(c3t3, domain, criteria, params::no_perturb(), params::no_exude(),
                        params::manifold());
  } else {
    c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(), params::no_exude(),
                                   params::manifold());
  }
  const auto t1 = std::chrono::steady_clock::now();

  CGAL::facets_in_complex_3_to_triangle_mesh(c3t3, mesh);
  return std::chrono::duration<double>(t1 - t0).count();
}

// From image coordinates to world coordinates (see read_volume).
void shift_mesh(Mesh& mesh, const std::array<double, 3>& origin) {
  for (const auto v : mesh.vertices()) {
    const Point_3& p = mesh.point(v);
    mesh.point(v) = Point_3(p.x() + origin[0], p.y() + origin[1], p.z() + origin[2]);
  }
}

// Shortest text that reads back as the same double.
std::string json_double(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

// A string as the inside of a JSON string literal.
std::string json_escape(const std::string& text) {
  std::string out;
  for (const char ch : text) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(ch));
      out += buf;
    } else {
      out += ch;
    }
  }
  return out;
}

template <typename T>
std::string json_triple(const std::array<T, 3>& a) {
  return "[" + json_double(double(a[0])) + ", " + json_double(double(a[1])) + ", " +
         json_double(double(a[2])) + "]";
}

// The JSON fields (each after ", ") that describe a named surface's run ...
std::string surface_fields(const Surface_entry& s) {
  std::string out = ", \"bounding_sphere\": [" + json_double(s.centre[0]) + ", " +
                    json_double(s.centre[1]) + ", " + json_double(s.centre[2]) + ", " +
                    json_double(s.radius) + "]";
  if (s.boxed) {
    out += ", \"box\": [";
    for (int i = 0; i < 6; ++i) out += (i ? ", " : "") + json_double(s.box[i]);
    out += "]";
  }
  return out;
}

// ... and an image's.
std::string image_fields(const Options& o) {
  return ", \"dims\": " + json_triple(o.dims) + ", \"spacing\": " + json_triple(o.spacing) +
         ", \"origin\": " + json_triple(o.origin) + ", \"isovalue\": " + json_double(o.isovalue) +
         ", \"init\": \"" + o.init + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    o = parse_args(argc, argv);
  } catch (const Usage_error& e) {
    if (e.message.empty()) {
      std::cout << kUsage;
      return 0;
    }
    std::cerr << "cgal_reference: " << e.message << "\n" << kUsage;
    return 2;
  }

  if (o.mesher == "delaunay") {
    try {
      const std::vector<Point_3> pts = read_points(o.points);
      using Dt = CGAL::Delaunay_triangulation_3<K>;
      const auto t0 = std::chrono::steady_clock::now();
      Dt dt(pts.begin(), pts.end());
      const auto t1 = std::chrono::steady_clock::now();
      const double seconds = std::chrono::duration<double>(t1 - t0).count();
      if (dt.dimension() != 3) {
        std::cerr << "cgal_reference: the points of '" << o.points
                  << "' span dimension " << dt.dimension() << ", not 3\n";
        return 1;
      }
      std::cout << "{\"mesher\": \"delaunay\", \"surface\": null"
                << ", \"seconds\": " << json_double(seconds)
                << ", \"vertices\": " << dt.number_of_vertices()
                << ", \"faces\": 0, \"evaluations\": 0"
                << ", \"points\": " << pts.size()
                << ", \"cells\": " << dt.number_of_finite_cells()
                << ", \"cgal_version\": \"" << CGAL_VERSION_STR << "\"}" << std::endl;
      return 0;
    } catch (const Input_error& e) {
      std::cerr << "cgal_reference: " << e.message << "\n";
      return 1;
    } catch (const std::exception& e) {
      std::cerr << "cgal_reference: Delaunay triangulation failed: " << e.what() << "\n";
      return 1;
    } catch (...) {
      std::cerr << "cgal_reference: Delaunay triangulation failed with an unknown exception\n";
      return 1;
    }
  }

  try {
    // Fixed seed: Surface_mesher draws its initial points from CGAL's default
    // random generator (time-seeded otherwise), Mesh_3 from the domain's.
    CGAL::get_default_random() = CGAL::Random(o.seed);
    CGAL::Random mesh_3_rng(o.seed);

    Mesh mesh;
    double seconds = 0.0;
    std::string input;  // the JSON fields that describe what was meshed
    if (o.mesher == "mesh_3_image") {
      const CGAL::Image_3 image = read_volume(o);
      seconds = run_mesh_3_image(o, image, mesh, mesh_3_rng);
      shift_mesh(mesh, o.origin);
      input = image_fields(o);
    } else if (o.mesher == "mesh_3_polyhedron") {
      Feature_counts counts;
      seconds = run_mesh_3_polyhedron(o, mesh, mesh_3_rng, counts);
      input = ", \"input\": \"" + json_escape(o.input) + "\"" + feature_fields(o, counts);
    } else {
      const Surface_entry& s = surfaces().at(o.surface);
      const std::string bad = s.clipped || s.boxed ? std::string() : check_bounding_sphere(s);
      if (!bad.empty()) {
        std::cerr << "cgal_reference: bounding sphere of '" << o.surface << "' unusable: " << bad
                  << "\n";
        return 1;
      }
      const bool sm = o.mesher == "surface_mesher" || o.mesher == "surface_mesher_boundary";
      input = surface_fields(s);
      if (o.mesher == "mesh_3_features") {
        const std::vector<Polyline> polylines = read_polylines(o.features);
        Feature_counts counts;
        seconds = run_mesh_3_features(o, s, polylines, mesh, mesh_3_rng, counts);
        input += ", \"features\": \"" + json_escape(o.features) +
                 "\", \"polylines\": " + std::to_string(polylines.size()) +
                 feature_fields(o, counts);
      } else if (o.mesher == "mesh_3_box") {
        std::size_t complex_facets = 0;
        seconds = run_mesh_3_box(o, s, mesh, mesh_3_rng, complex_facets);
        input += ", \"complex_facets\": " + std::to_string(complex_facets);
      } else {
        seconds = sm ? run_surface_mesher(o, s, mesh, o.mesher == "surface_mesher_boundary")
                     : run_mesh_3(o, s, mesh, mesh_3_rng, o.mesher == "mesh_3");
      }
    }
    const std::uint64_t evaluations = g_evaluations;

    // Sanity information on the output surface (not timed).
    const bool closed = !mesh.is_empty() && CGAL::is_closed(mesh);
    // facets_in_complex_2_to_triangle_mesh orients each component
    // consistently but not necessarily outward (Surface_mesher does not know
    // the inside; on two_spheres one sphere came out inward).  Make every
    // closed component outward for --out; Mesh_3's output already is.
    if (closed) CGAL::Polygon_mesh_processing::orient(mesh);
    auto fcc = mesh.add_property_map<Mesh::Face_index, std::size_t>("f:cc", 0).first;
    const std::size_t components =
        mesh.is_empty() ? 0 : CGAL::Polygon_mesh_processing::connected_components(mesh, fcc);
    const long long euler = static_cast<long long>(mesh.number_of_vertices()) -
                            static_cast<long long>(mesh.number_of_edges()) +
                            static_cast<long long>(mesh.number_of_faces());

    if (!o.out.empty()) {
      std::ofstream os(o.out);
      if (!os || !CGAL::IO::write_OFF(os, mesh, CGAL::parameters::stream_precision(17)) ||
          !os.flush()) {
        std::cerr << "cgal_reference: cannot write '" << o.out << "'\n";
        return 1;
      }
    }

    std::cout << "{\"mesher\": \"" << o.mesher << "\""
              << ", \"surface\": " << (o.surface.empty() ? "null" : "\"" + o.surface + "\"")
              << ", \"seconds\": " << json_double(seconds)
              << ", \"vertices\": " << mesh.number_of_vertices()
              << ", \"faces\": " << mesh.number_of_faces()
              << ", \"evaluations\": " << evaluations
              << ", \"cgal_version\": \"" << CGAL_VERSION_STR << "\"" << input
              << ", \"angle\": " << json_double(o.angle)
              << ", \"radius\": " << json_double(o.radius)
              << ", \"distance\": " << json_double(o.distance)
              << ", \"error_bound\": "
              << (o.mesher == "mesh_3_polyhedron" ? "null" : json_double(o.error_bound))
              << ", \"seed\": " << o.seed
              << ", \"closed\": " << (closed ? "true" : "false")
              << ", \"components\": " << components
              << ", \"euler_characteristic\": " << euler << "}" << std::endl;
    return 0;
  } catch (const Input_error& e) {
    std::cerr << "cgal_reference: " << e.message << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "cgal_reference: meshing failed: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << "cgal_reference: meshing failed with an unknown exception\n";
    return 1;
  }
}
