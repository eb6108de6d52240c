// Bindings of MeshDistance (mesh_distance.hpp), behind rdmesh.MeshSurface.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mesh_distance.hpp"
#include "point_map.hpp"

namespace rdmesh::bind {

void register_mesh_distance(py::module_& m) {
  py::class_<MeshDistance>(m, "MeshDistance")
      .def(py::init([](const InArray& vertices, const IdArray& faces, bool side, bool winding) {
             const std::vector<double> v = rows3(vertices, "vertices");
             if (faces.ndim() != 2 || faces.shape(1) != 3)
               throw std::invalid_argument("faces must have shape (m, 3)");
             const std::vector<std::int64_t> f = copy_of<std::int64_t>(faces);
             py::gil_scoped_release release;
             return new MeshDistance(v.data(), v.size() / 3, f.data(), f.size() / 3, side,
                                     winding);
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("side") = true,
           py::arg("winding") = true,
           "A triangle mesh's AABB tree, with a side oracle when ``side`` (and "
           "the mesh allows one) and the winding-number hierarchy when ``winding`` "
           "(winding_number raises RuntimeError without it).")
      .def(
          "query",
          [](const MeshDistance& self, const InArray& points) {
            const std::vector<double> p = rows3(points, "points");
            const std::size_t k = p.size() / 3;
            std::vector<double> dist(k), closest(3 * k);
            std::vector<std::int64_t> face(k);
            std::vector<std::int8_t> side(k);
            {
              py::gil_scoped_release release;
              self.query(p.data(), k, dist.data(), closest.data(), face.data(), side.data());
            }
            const auto n = static_cast<py::ssize_t>(k);
            return py::make_tuple(to_numpy(dist, {n}), to_numpy(closest, {n, 3}),
                                  to_numpy(face, {n}), to_numpy(side, {n}));
          },
          py::arg("points"),
          "((k,) distances, (k, 3) closest points, (k,) their faces, (k,) int8 "
          "sides: +1 outside, -1 inside, 0 on the surface or without a side oracle).")
      .def(
          "side",
          [](const MeshDistance& self, const InArray& points) {
            if (!self.has_side())
              throw std::invalid_argument(std::string("this mesh has no side oracle: ") +
                                          self.side_failure());
            const std::vector<double> p = rows3(points, "points");
            std::vector<std::int8_t> side(p.size() / 3);
            {
              py::gil_scoped_release release;
              self.side(p.data(), side.size(), side.data());
            }
            return to_numpy(side, {static_cast<py::ssize_t>(side.size())});
          },
          py::arg("points"),
          "(k,) int8 sides from Side_of_triangle_mesh: +1 outside, -1 inside, 0 on "
          "the surface. ValueError without a side oracle (has_side False).")
      .def(
          "winding_number",
          [](const MeshDistance& self, const InArray& points, double beta) {
            const std::vector<double> p = rows3(points, "points");
            std::vector<double> w(p.size() / 3);
            {
              py::gil_scoped_release release;
              self.winding_number(p.data(), w.size(), w.data(), beta);
            }
            return to_numpy(w, {static_cast<py::ssize_t>(w.size())});
          },
          py::arg("points"), py::arg("beta") = 2.5,
          "(k,) generalized winding numbers; clusters farther than beta radii "
          "are approximated by their dipole.")
      .def(
          "segment_hits",
          [](const MeshDistance& self, const InArray& segments) {
            if (segments.ndim() != 3 || segments.shape(1) != 2 || segments.shape(2) != 3)
              throw std::invalid_argument("segments must have shape (k, 2, 3)");
            const std::vector<double> ab = copy_of<double>(segments);
            std::vector<std::int64_t> segment, face;
            std::vector<double> t;
            {
              py::gil_scoped_release release;
              self.segment_hits(ab.data(), ab.size() / 6, segment, t, face);
            }
            const auto n = static_cast<py::ssize_t>(t.size());
            return py::make_tuple(to_numpy(segment, {n}), to_numpy(t, {n}), to_numpy(face, {n}));
          },
          py::arg("segments"),
          "The faces that (k, 2, 3) segments meet (CGAL's exact test): (m,) segment "
          "indices, (m,) t in [0, 1] (the point a + t (b - a); NaN when the segment "
          "lies almost in the face's plane or has zero length) and (m,) faces, in "
          "segment order, then by t.")
      .def(
          "self_intersections",
          [](const MeshDistance& self) {
            std::vector<std::int64_t> pairs = self.self_intersections();
            return to_numpy(pairs, {static_cast<py::ssize_t>(pairs.size() / 2), 2});
          },
          "(k, 2) int64: the pairs of intersecting faces of a closed manifold mesh that "
          "intersects itself (empty otherwise).")
      .def_property_readonly("has_side", &MeshDistance::has_side)
      .def_property_readonly("has_pseudo_normals", &MeshDistance::has_pseudo_normals)
      .def_property_readonly("side_failure", &MeshDistance::side_failure)
      .def_property_readonly("number_of_faces", &MeshDistance::number_of_faces);

  py::class_<PointMap>(m, "PointMap")
      .def(py::init<>())
      .def(
          "add",
          [](PointMap& self, const InArray& points, const IdArray& ids) {
            const std::vector<double> p = rows3(points, "points");
            if (ids.ndim() != 1 || static_cast<std::size_t>(ids.shape(0)) != p.size() / 3)
              throw std::invalid_argument("ids must have shape (n,), one per point");
            const std::vector<std::int64_t> id = copy_of<std::int64_t>(ids);
            py::gil_scoped_release release;
            self.add(p.data(), id.data(), id.size());
          },
          py::arg("points"), py::arg("ids"),
          "Remember an id (>= 0) for each of (n, 3) points, keyed by their exact "
          "coordinates (-0.0 as 0.0); where one is held already, the smaller "
          "stays. Points with a non-finite coordinate are skipped.")
      .def(
          "get",
          [](const PointMap& self, const InArray& points) {
            const std::vector<double> p = rows3(points, "points");
            std::vector<std::int64_t> out(p.size() / 3);
            {
              py::gil_scoped_release release;
              self.get(p.data(), out.size(), out.data());
            }
            return to_numpy(out);
          },
          py::arg("points"), "(n,) int64: the id held for each point, or -1.")
      .def("clear", &PointMap::clear, "Forget every point.")
      .def_property_readonly("size", &PointMap::size, "How many points are held.");
}

}  // namespace rdmesh::bind
