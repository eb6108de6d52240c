// Triangulating a hole's rim (CGAL's triangulate_hole_polyline: Liepa's
// minimal-weight triangulation, searched in a 3D Delaunay triangulation of the
// rim first).  MeshSurface closes an open mesh's holes with these caps so that
// the closed-mesh oracle applies, and cuts them off the remesh afterwards.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <vector>

#include "bindings.hpp"

namespace rdmesh::bind {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

std::vector<std::int64_t> fill_hole(const std::vector<double>& xyz) {
  const std::size_t n = xyz.size() / 3;
  std::vector<K::Point_3> rim;
  rim.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    rim.emplace_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  std::vector<CGAL::Triple<int, int, int>> tri;
  CGAL::Polygon_mesh_processing::triangulate_hole_polyline(rim, std::back_inserter(tri));
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
      [](const InArray& points) {
        const std::vector<double> p = rows3(points, "points");
        if (p.size() < 9) throw std::invalid_argument("a hole's rim needs at least 3 points");
        std::vector<std::int64_t> t;
        {
          py::gil_scoped_release release;
          t = fill_hole(p);
        }
        return to_numpy(t, {static_cast<py::ssize_t>(t.size() / 3), 3});
      },
      py::arg("points"),
      "(t, 3) int64: triangles over the closed rim of (k, 3) points in order (the "
      "first not repeated), indices into the points (CGAL's "
      "triangulate_hole_polyline); empty when no triangulation was found.");
}

}  // namespace rdmesh::bind
