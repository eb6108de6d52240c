// Triangulating a hole's rim (CGAL's triangulate_hole_polyline: Liepa's
// minimal-weight triangulation, searched in a 3D Delaunay triangulation of the
// rim first).  MeshSurface closes an open mesh's holes with these caps so that
// the closed-mesh oracle applies, and cuts them off the remesh afterwards.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <stdexcept>
#include <vector>

#include "bindings.hpp"
#include "power_scale.hpp"

namespace rdmesh::bind {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

std::vector<K::Point_3> points_of(const std::vector<double>& xyz) {
  std::vector<K::Point_3> out;
  out.reserve(xyz.size() / 3);
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) out.emplace_back(xyz[i], xyz[i + 1], xyz[i + 2]);
  return out;
}

// With `third` (the third vertex of the face on each rim edge), Liepa's weight
// (the largest dihedral angle with those faces first, then the area) keeps the
// cap from folding back onto the faces; without it, the least area.
std::vector<std::int64_t> fill_hole(std::vector<double> xyz, std::vector<double> third) {
  // Liepa's weights (dihedral angles, then areas) compare the same in an
  // exactly scaled frame, where CGAL's constructions do not overflow.
  const double scale = power_of_two_scale(xyz);
  for (double& x : xyz) x *= scale;
  for (double& x : third) x *= scale;
  const std::vector<K::Point_3> rim = points_of(xyz);
  std::vector<CGAL::Triple<int, int, int>> tri;
  if (third.empty())
    CGAL::Polygon_mesh_processing::triangulate_hole_polyline(rim, std::back_inserter(tri));
  else
    CGAL::Polygon_mesh_processing::triangulate_hole_polyline(rim, points_of(third),
                                                             std::back_inserter(tri));
  std::vector<std::int64_t> out;
  out.reserve(3 * tri.size());
  for (const auto& t : tri) {
    out.push_back(t.first);
    out.push_back(t.second);
    out.push_back(t.third);
  }
  return out;
}

}  // namespace

void register_hole_fill(py::module_& m) {
  m.def(
      "fill_hole",
      [](const InArray& points, const std::optional<InArray>& third) {
        const std::vector<double> p = rows3(points, "points");
        if (p.size() < 9) throw std::invalid_argument("a hole's rim needs at least 3 points");
        std::vector<double> q;
        if (third) {
          q = rows3(*third, "third");
          if (q.size() != p.size())
            throw std::invalid_argument("third must have one point per rim point");
        }
        std::vector<std::int64_t> t;
        {
          py::gil_scoped_release release;
          t = fill_hole(p, q);
        }
        return to_numpy(t, {static_cast<py::ssize_t>(t.size() / 3), 3});
      },
      py::arg("points"), py::arg("third") = py::none(),
      "(t, 3) int64: triangles over the closed rim of (k, 3) points in order (the "
      "first not repeated), indices into the points (CGAL's "
      "triangulate_hole_polyline); empty when no triangulation was found. "
      "``third`` (k, 3): for each rim edge (point i to i + 1), the third vertex of "
      "the face on it, so that the cap meets those faces at the flattest angles "
      "(Liepa's weight); without it, the least area.");
}

}  // namespace rdmesh::bind
