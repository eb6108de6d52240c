// The extension module rdmesh.core._rdt: CGAL's error handling, the facet
// flag bits and the RestrictedDelaunay family (rdt.hpp); the other families
// register themselves from their own files (bindings.hpp lists them).
// Bindings convert arrays, release the GIL, lock and translate exceptions.
#include <pybind11/gil_safe_call_once.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <CGAL/assertions_behaviour.h>
#include <CGAL/exceptions.h>
#include <CGAL/version.h>

#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "bindings.hpp"
#include "complex_status.hpp"
#include "rdt.hpp"

namespace py = pybind11;
using rdmesh::RestrictedDelaunay;
using rdmesh::bind::copy_of;
using rdmesh::bind::FlagArray;
using rdmesh::bind::IdArray;
using rdmesh::FineField;
using rdmesh::bind::InArray;
using rdmesh::bind::rows3;
using rdmesh::bind::samples_tuple;
using rdmesh::bind::sampling_spec;
using rdmesh::bind::to_numpy;

namespace {

// Runs fn() on the core with the GIL released and the core's lock held.  The
// lock is taken only after the GIL is released and dropped before the GIL is
// taken back, so no thread waits for one while holding the other (no
// deadlock); a second thread using the same core waits for its turn.  fn must
// not touch Python objects.
template <typename Fn>
decltype(auto) locked(RestrictedDelaunay& self, Fn&& fn) {
  py::gil_scoped_release release;
  std::lock_guard<std::mutex> lock(self.mutex());
  return fn();
}

py::tuple facet_pair(rdmesh::ChangedFacets& f) {
  const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
  return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.seg, {k, 2, 3}));
}

py::tuple facet_quad(rdmesh::ChangedFacets& f) {
  const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
  const auto u = static_cast<py::ssize_t>(f.ends.size() / 3);
  return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.seg, {k, 2, 3}),
                        to_numpy(f.end_index, {k, 2}), to_numpy(f.ends, {u, 3}),
                        to_numpy(f.rho, {k}), samples_tuple(f.samples),
                        to_numpy(f.end_f, {u}), to_numpy(f.end_prev, {u}));
}

void silent_handler(const char*, const char*, const char*, int, const char*) {}

}  // namespace

PYBIND11_MODULE(_rdt, m) {
  m.doc() = "Restricted Delaunay triangulation core of rdmesh (CGAL 3D Delaunay).";
  m.attr("CGAL_VERSION") = CGAL_STR(CGAL_VERSION);
  // CGAL still throws on failures; this only stops it writing to stderr.
  CGAL::set_error_handler(silent_handler);
  CGAL::set_warning_handler(silent_handler);
  CGAL::set_error_behaviour(CGAL::THROW_EXCEPTION);

  // A plain static py::object would be released after the interpreter is
  // gone; this storage is never destroyed.
  PYBIND11_CONSTINIT static py::gil_safe_call_once_and_store<py::object> cgal_error;
  cgal_error.call_once_and_store_result(
      [] { return py::module_::import("rdmesh._errors").attr("CGALError"); });
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const CGAL::Failure_exception& e) {
      py::set_error(cgal_error.get_stored(), e.what());
    }
  });

  // Facet flag bits (rdt.hpp), for update_facets and facets(mask).
  m.attr("RESTRICTED") = static_cast<int>(rdmesh::RESTRICTED);
  m.attr("BAD") = static_cast<int>(rdmesh::BAD);
  m.attr("OUTWARD") = static_cast<int>(rdmesh::OUTWARD);
  m.attr("KNOWN") = static_cast<int>(rdmesh::KNOWN);
  m.attr("TOPO") = static_cast<int>(rdmesh::TOPO);
  register_volume_sampler(m);
  rdmesh::bind::register_sampling(m);
  rdmesh::bind::register_intervals(m);
  rdmesh::bind::register_mesh_distance(m);
  rdmesh::bind::register_hole_fill(m);

  m.def(
      "_fail_allocation_for_testing",
      [](std::int64_t n) { return rdmesh::fail_countdown_for_testing.exchange(n); },
      py::arg("n"),
      "Test hook: the n-th fault point from now raises MemoryError (n <= 0: "
      "none); returns the previous count. Fault points: each facet "
      "changed_facets appends or cell it gathers, each update_facets, and the "
      "conversion of changed_facets' result.");

  py::class_<RestrictedDelaunay>(m, "RestrictedDelaunay")
      .def(py::init([](const InArray& centre, double radius) {
             if (centre.ndim() != 1 || centre.shape(0) != 3)
               throw std::invalid_argument("centre must have shape (3,)");
             const double* c = centre.data();
             return new RestrictedDelaunay({c[0], c[1], c[2]}, radius);
           }),
           py::arg("centre"), py::arg("radius"))
      .def(
          "set_clip_box",
          [](RestrictedDelaunay& self, const InArray& lo, const InArray& hi) {
            for (const InArray* a : {&lo, &hi})
              if (a->ndim() != 1 || a->shape(0) != 3)
                throw std::invalid_argument("clip box corners must have shape (3,)");
            const double* l = lo.data();
            const double* h = hi.data();
            locked(self, [&] { self.set_clip_box({l[0], l[1], l[2]}, {h[0], h[1], h[2]}); });
          },
          py::arg("lo"), py::arg("hi"),
          "Clip every dual segment to the box [lo, hi] as well as to the ball "
          "(before the first insertion; ValueError for a non-finite box or lo >= hi, "
          "RuntimeError after an insertion).")
      .def_property_readonly(
          "has_clip_box", [](const RestrictedDelaunay& self) { return self.has_clip_box(); })
      .def(
          "insert",
          [](RestrictedDelaunay& self, const InArray& points, std::optional<InArray> weights) {
            const std::vector<double> xyz = rows3(points, "points");
            std::vector<double> w;
            if (weights) {
              if (weights->ndim() != 1 ||
                  static_cast<std::size_t>(weights->shape(0)) * 3 != xyz.size())
                throw std::invalid_argument("weights must have shape (k,) matching points (k, 3)");
              w = copy_of<double>(*weights);
            }
            std::vector<std::int64_t> ids = locked(self, [&] {
              return self.insert(xyz.data(), xyz.size() / 3, weights ? w.data() : nullptr);
            });
            return to_numpy(ids, {static_cast<py::ssize_t>(ids.size())});
          },
          py::arg("points"), py::arg("weights") = py::none(),
          "Insert (k, 3) points with weights (k,) (default 0: samples; a positive weight "
          "w is a protecting ball of radius sqrt(w)); returns (k,) vertex ids (existing "
          "ids for duplicates, -1 for a point of weight 0 that the balls hide). "
          "ValueError for a ball that would hide a vertex.")
      .def(
          "weights",
          [](RestrictedDelaunay& self) {
            std::vector<double> w = locked(self, [&] { return self.weights(); });
            return to_numpy(w, {static_cast<py::ssize_t>(w.size())});
          },
          "(n,) the weight of every vertex, by id.")
      .def(
          "changed_facets",
          [](RestrictedDelaunay& self, std::size_t max_facets, double per_radius,
             std::int64_t min_intervals, std::int64_t max_intervals) {
            const auto spec = sampling_spec(per_radius, min_intervals, max_intervals);
            rdmesh::ChangedFacets f =
                locked(self, [&] { return self.changed_facets(max_facets, spec); });
            try {
              rdmesh::fault_point_for_testing();
              return facet_quad(f);
            } catch (...) {
              // The chunk never reaches Python: let the next call report it.
              locked(self, [&] { self.withdraw_chunk(f.chunk); });
              throw;
            }
          },
          py::arg("max_facets") = 0, py::arg("per_radius") = 1.0,
          py::arg("min_intervals") = 3, py::arg("max_intervals") = 64,
          "Next chunk (about max_facets; 0 = all) of the facets whose dual "
          "changed since the last round; empty when the round is done. "
          "Returns ((k, 3) sorted "
          "vertex ids, (k, 2, 3) clipped dual segments, (k, 2) indices of the "
          "segment ends into (u, 3) distinct end points, (k,) facet "
          "circumradii, samples, (u,) f at the ends where kept from an earlier "
          "update_facets, NaN elsewhere, (u,) each end's index among the ends "
          "of the previous call, -1 if it was none), samples as from "
          "sample_segments. After an exception the next call hands out the "
          "same facets.")
      .def(
          "update_facets",
          [](RestrictedDelaunay& self, const FlagArray& flags, const InArray& centres,
             std::optional<InArray> end_f) {
            const std::vector<double> xyz = rows3(centres, "centres");
            if (flags.ndim() != 1 || flags.shape(0) * 3 != static_cast<py::ssize_t>(xyz.size()))
              throw std::invalid_argument("flags must have shape (k,) matching centres (k, 3)");
            if (end_f && end_f->ndim() != 1) throw std::invalid_argument("end_f must be 1-D");
            const std::vector<std::uint8_t> fl = copy_of<std::uint8_t>(flags);
            const std::vector<double> ef = end_f ? copy_of<double>(*end_f) : std::vector<double>();
            locked(self, [&] {
              self.update_facets(fl.data(), xyz.data(), fl.size(), end_f ? ef.data() : nullptr,
                                 ef.size());
            });
          },
          py::arg("flags"), py::arg("centres"), py::arg("end_f") = py::none(),
          "Set the flags (k,) and surface centres (k, 3) of the oldest chunk "
          "from changed_facets not yet updated, in its order; end_f (u,), f at "
          "the chunk's ends, is kept for later chunks.")
      .def(
          "restart_round",
          [](RestrictedDelaunay& self) { locked(self, [&] { self.restart_round(); }); },
          "Forget chunks not yet updated; the next changed_facets calls hand "
          "out the whole current round again.")
      .def(
          "facets",
          [](RestrictedDelaunay& self, std::uint8_t mask) {
            rdmesh::FacetList f = locked(self, [&] { return self.facets_with(mask); });
            const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
            return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.centre, {k, 3}),
                                  to_numpy(f.flags, {k}));
          },
          py::arg("mask") = 0,
          "Restricted facets having any bit of mask, or all when mask is 0: "
          "((k, 3) outward-oriented vertex ids, (k, 3) surface centres, (k,) "
          "flag bits).")
      .def(
          "facets_around",
          [](RestrictedDelaunay& self, const IdArray& ids) {
            if (ids.ndim() != 1) throw std::invalid_argument("ids must have shape (m,)");
            const std::vector<std::int64_t> v = copy_of<std::int64_t>(ids);
            rdmesh::FacetList f =
                locked(self, [&] { return self.facets_around(v.data(), v.size()); });
            const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
            return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.centre, {k, 3}),
                                  to_numpy(f.flags, {k}));
          },
          py::arg("ids"),
          "Restricted facets having a vertex among the sample ids, each once, as "
          "facets(0).")
      .def(
          "take_touched",
          [](RestrictedDelaunay& self) {
            std::vector<std::int64_t> out = locked(self, [&] { return self.take_touched(); });
            return to_numpy(out, {static_cast<py::ssize_t>(out.size())});
          },
          "Ids of the samples whose restricted facets may have changed since the "
          "last call (vertices of the cells made since), ascending; clears them.")
      .def(
          "all_facets",
          [](RestrictedDelaunay& self) {
            rdmesh::ChangedFacets f = locked(self, [&] { return self.all_facets(); });
            return facet_pair(f);
          },
          "Every facet whose clipped dual meets the ball, as changed_facets.")
      .def(
          "is_facet",
          [](RestrictedDelaunay& self, const IdArray& tri) {
            if (tri.ndim() != 2 || tri.shape(1) != 3)
              throw std::invalid_argument("tri must have shape (k, 3)");
            const std::vector<std::int64_t> t = copy_of<std::int64_t>(tri);
            std::vector<std::uint8_t> out =
                locked(self, [&] { return self.is_facet(t.data(), t.size() / 3); });
            return to_numpy(out, {static_cast<py::ssize_t>(out.size())}).attr("astype")("bool");
          },
          py::arg("tri"))
      .def(
          "neighbours",
          [](RestrictedDelaunay& self, const IdArray& ids) {
            if (ids.ndim() != 1) throw std::invalid_argument("ids must have shape (k,)");
            const std::vector<std::int64_t> v = copy_of<std::int64_t>(ids);
            std::vector<std::int64_t> offsets, adj;
            locked(self, [&] { self.neighbours(v.data(), v.size(), offsets, adj); });
            return py::make_tuple(
                to_numpy(offsets, {static_cast<py::ssize_t>(offsets.size())}),
                to_numpy(adj, {static_cast<py::ssize_t>(adj.size())}));
          },
          py::arg("ids"), "Delaunay neighbours of samples as CSR (offsets, ids).")
      .def(
          "voronoi_facets",
          [](RestrictedDelaunay& self, const IdArray& edges) {
            if (edges.ndim() != 2 || edges.shape(1) != 2)
              throw std::invalid_argument("edges must have shape (m, 2)");
            const std::vector<std::int64_t> e = copy_of<std::int64_t>(edges);
            rdmesh::VoronoiFacets v =
                locked(self, [&] { return self.voronoi_facets(e.data(), e.size() / 2); });
            const auto total = static_cast<py::ssize_t>(v.cell.size());
            return py::make_tuple(
                to_numpy(v.offsets, {static_cast<py::ssize_t>(v.offsets.size())}),
                to_numpy(v.points, {total, 3}), to_numpy(v.cell, {total}),
                to_numpy(v.third, {total}));
          },
          py::arg("edges"),
          "Voronoi facets dual to the Delaunay edges (m, 2) (sample ids) as CSR "
          "polygons: ((m+1,) offsets, (T, 3) vertices = circumcentres of the cells "
          "around each edge in circulator order, (T,) distinct-cell index of each "
          "vertex, (T,) third vertex id w of the Delaunay facet (p, q, w) dual to "
          "the polygon edge from vertex j to j+1 (cyclic), -1 for a dummy). "
          "Raises ValueError for ids out of range or pairs that are not edges.")
      .def(
          "star_cells",
          [](RestrictedDelaunay& self, const IdArray& ids) {
            if (ids.ndim() != 1) throw std::invalid_argument("ids must have shape (k,)");
            const std::vector<std::int64_t> v = copy_of<std::int64_t>(ids);
            rdmesh::StarCells r = locked(self, [&] { return self.star_cells(v.data(), v.size()); });
            const auto c = static_cast<py::ssize_t>(r.cells.size() / 4);
            return py::make_tuple(to_numpy(r.cells, {c, 4}), to_numpy(r.centres, {c, 3}));
          },
          py::arg("ids"),
          "The distinct finite cells incident to samples ids: ((c, 4) sorted vertex ids, "
          "-1 for a dummy; (c, 3) circumcentres). Raises ValueError for ids out of range.")
      .def(
          "relabel_stars",
          [](RestrictedDelaunay& self, const IdArray& faces, const IdArray& ids,
             const IdArray& cells, const InArray& cost, std::optional<double> max_seconds) {
            if (max_seconds && !(*max_seconds >= 0.0))
              throw std::invalid_argument("max_seconds must be at least 0");
            const double seconds =
                max_seconds.value_or(std::numeric_limits<double>::infinity());
            if (faces.ndim() != 2 || faces.shape(1) != 3)
              throw std::invalid_argument("faces must have shape (F, 3)");
            if (ids.ndim() != 1) throw std::invalid_argument("ids must have shape (k,)");
            if (cells.ndim() != 2 || cells.shape(1) != 4)
              throw std::invalid_argument("cells must have shape (c, 4)");
            if (cost.ndim() != 1 || cost.shape(0) != cells.shape(0))
              throw std::invalid_argument("cost must have shape (c,), one per cell");
            const std::vector<std::int64_t> f = copy_of<std::int64_t>(faces);
            const std::vector<std::int64_t> v = copy_of<std::int64_t>(ids);
            const std::vector<std::int64_t> q = copy_of<std::int64_t>(cells);
            const std::vector<double> w = copy_of<double>(cost);
            rdmesh::StarRelabel r = locked(self, [&] {
              return self.relabel_stars(f.data(), f.size() / 3, v.data(), v.size(), q.data(),
                                        w.data(), w.size(), seconds);
            });
            return py::make_tuple(
                to_numpy(r.faces, {static_cast<py::ssize_t>(r.faces.size() / 3), 3}),
                to_numpy(r.flipped, {static_cast<py::ssize_t>(r.flipped.size() / 4), 4}),
                r.timed_out);
          },
          py::arg("faces"), py::arg("ids"), py::arg("cells"), py::arg("cost"),
          py::arg("max_seconds") = py::none(),
          "Faces (F, 3) (outward) read as the boundary of a labelling of the Delaunay "
          "cells, made one disk around each of the vertices ids by moving groups of their "
          "incident cells to the other side: the group whose largest cost is least (cost "
          "(c,) of cells (c, 4); a cell without a cost, with a dummy vertex, or with a "
          "NaN or negative cost is never moved). Vertices go in id order; once max_seconds "
          "(None: no limit) have passed the rest are left as they are. Returns (faces (k, 3) outward, in "
          "their order then the added ones; (m, 4) sorted ids of each cell moved; whether "
          "max_seconds cut it short). Raises ValueError for ids out of range, a face "
          "repeating a vertex or given twice, or a negative max_seconds.")
      .def(
          "voronoi_boxes",
          [](RestrictedDelaunay& self) {
            std::vector<std::int64_t> edges;
            std::vector<double> facets, cells;
            locked(self, [&] { self.voronoi_boxes(edges, facets, cells); });
            const auto m = static_cast<py::ssize_t>(edges.size() / 2);
            const auto n = static_cast<py::ssize_t>(cells.size() / 6);
            return py::make_tuple(to_numpy(edges, {m, 2}), to_numpy(facets, {m, 2, 3}),
                                  to_numpy(cells, {n, 2, 3}));
          },
          "Every Delaunay edge between samples (m, 2), as delaunay_edges() gives them, "
          "the bounding box (m, 2, 3) (lo, hi) of its Voronoi facet (the extremes of the "
          "circumcentres of the cells around the edge), and every sample's Voronoi cell box "
          "(samples, 2, 3), as voronoi_cell_boxes gives it.")
      .def(
          "voronoi_cell_boxes",
          [](RestrictedDelaunay& self, const IdArray& ids) {
            if (ids.ndim() != 1) throw std::invalid_argument("ids must have shape (k,)");
            const std::vector<std::int64_t> v = copy_of<std::int64_t>(ids);
            std::vector<double> out =
                locked(self, [&] { return self.voronoi_cell_boxes(v.data(), v.size()); });
            return to_numpy(out, {static_cast<py::ssize_t>(v.size()), 2, 3});
          },
          py::arg("ids"),
          "Bounding boxes (k, 2, 3) (lo, hi) of the Voronoi cells of samples ids: the "
          "extremes of the circumcentres of their incident cells. Raises ValueError "
          "for ids out of range.")
      .def(
          "delaunay_edges",
          [](RestrictedDelaunay& self, const py::object& ids) {
            std::vector<std::int64_t> v;
            const bool all = ids.is_none();
            if (!all) {
              IdArray a = ids.cast<IdArray>();
              if (a.ndim() != 1) throw std::invalid_argument("ids must have shape (k,)");
              v = copy_of<std::int64_t>(a);
            }
            std::vector<std::int64_t> out = locked(
                self, [&] { return self.delaunay_edges(all ? nullptr : v.data(), v.size()); });
            return to_numpy(out, {static_cast<py::ssize_t>(out.size() / 2), 2});
          },
          py::arg("ids") = py::none(),
          "Delaunay edges between samples as sorted pairs (k, 2), in increasing "
          "order: the edges of the cells incident to the samples ids, or all "
          "edges when ids is None.")
      .def(
          "samples",
          [](RestrictedDelaunay& self) {
            std::vector<double> s = locked(self, [&] { return self.samples(); });
            return to_numpy(s, {static_cast<py::ssize_t>(s.size() / 3), 3});
          },
          "The samples (n, 3), row i the sample with id i.")
      .def_property_readonly(
          "number_of_samples",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] { return self.number_of_samples(); });
          })
      .def(
          "set_clearing",
          [](RestrictedDelaunay& self, const rdmesh::GridField& f, const rdmesh::GridField& slopes,
             double scale, double reach, double cap) {
            locked(self, [&] { self.set_clearing(f, slopes, scale, reach, cap); });
          },
          py::arg("f"), py::arg("slopes"), py::arg("scale"), py::arg("reach"), py::arg("cap"),
          "Clear facets by the seeding grid (see rdmesh.sampling.screen): f, the grid's "
          "f at its nodes; slopes, the local |grad f| estimates; a segment's bound is "
          "min(cap, scale * slopes at its middle) up to reach long, cap beyond. A facet "
          "whose segment the node nearest its middle clears is set KNOWN, not "
          "restricted, and not handed out.")
      .def(
          "set_clearing_cap",
          [](RestrictedDelaunay& self, double cap) {
            if (!(cap > 0.0)) throw std::invalid_argument("cap must be > 0");
            locked(self, [&] { self.set_clearing_cap(cap); });
          },
          py::arg("cap"), "The largest bound of set_clearing's (a raised estimate).")
      .def(
          "set_fine_clearing",
          [](RestrictedDelaunay& self, int m, std::int64_t threshold, double reach) {
            if (threshold < 1 || threshold > std::numeric_limits<std::uint32_t>::max())
              throw std::invalid_argument("threshold must be in 1..2^32-1");
            locked(self, [&] {
              self.set_fine_clearing(m, static_cast<std::uint32_t>(threshold), reach);
            });
          },
          py::arg("m"), py::arg("threshold"), py::arg("reach"),
          "A finer level of the clearing (after set_clearing): the cube of a grid node "
          "(the points nearest it) gets f at its m^3 subcube centres once filled; a "
          "node becomes hot at its threshold-th segment that nothing cleared. A filled "
          "cube clears segments up to reach long by its nearest subcube centre and its "
          "bound (see take_hot_nodes, fine_points, fill_fine).")
      .def(
          "grid_clears",
          [](RestrictedDelaunay& self, const InArray& seg) {
            if (seg.ndim() != 3 || seg.shape(1) != 2 || seg.shape(2) != 3)
              throw std::invalid_argument("seg must have shape (k, 2, 3)");
            const double* s = seg.data();
            std::vector<std::uint8_t> out(static_cast<std::size_t>(seg.shape(0)));
            locked(self, [&] {
              for (std::size_t i = 0; i < out.size(); ++i) {
                const double* a = s + 6 * i;
                out[i] = self.grid_clears({a[0], a[1], a[2]}, {a[3], a[4], a[5]});
              }
            });
            return py::array_t<bool>(static_cast<py::ssize_t>(out.size()),
                                     reinterpret_cast<const bool*>(out.data()));
          },
          py::arg("seg"),
          "Per segment (k, 2, 3): whether the clearing (set_clearing, then the fine "
          "level) clears it, as it would a facet's dual; each uncleared one counts a "
          "miss for the fine level.")
      .def(
          "take_hot_nodes",
          [](RestrictedDelaunay& self) {
            std::vector<std::int64_t> hot = locked(self, [&] {
              FineField* fine = self.fine_clearing();
              return fine ? fine->take_hot() : std::vector<std::int64_t>{};
            });
            return to_numpy(hot);
          },
          "The grid nodes that became hot since the last call (set_fine_clearing).")
      .def(
          "fine_points",
          [](RestrictedDelaunay& self, const IdArray& nodes) {
            if (nodes.ndim() != 1) throw std::invalid_argument("nodes must be 1-D");
            const std::vector<std::int64_t> ids(nodes.data(), nodes.data() + nodes.size());
            std::vector<double> out = locked(self, [&] {
              FineField* fine = self.fine_clearing();
              if (!fine) throw std::logic_error("no fine clearing (set_fine_clearing)");
              return fine->points(ids);
            });
            return to_numpy(out, {static_cast<py::ssize_t>(out.size() / 3), 3});
          },
          py::arg("nodes"), "The m^3 subcube centres of each node's cube (k * m^3, 3).")
      .def(
          "fill_fine",
          [](RestrictedDelaunay& self, const IdArray& nodes, const InArray& values,
             const InArray& bounds) {
            if (nodes.ndim() != 1 || bounds.ndim() != 1 || values.ndim() != 1 ||
                bounds.shape(0) != nodes.shape(0))
              throw std::invalid_argument("nodes and bounds (k,) and values (k * m^3,) are 1-D");
            const std::vector<std::int64_t> ids(nodes.data(), nodes.data() + nodes.size());
            locked(self, [&] {
              FineField* fine = self.fine_clearing();
              if (!fine) throw std::logic_error("no fine clearing (set_fine_clearing)");
              const py::ssize_t m = fine->subdivisions();
              if (values.shape(0) != nodes.shape(0) * m * m * m)
                throw std::invalid_argument("values must hold m^3 entries per node");
              fine->fill(ids, values.data(), bounds.data());
            });
          },
          py::arg("nodes"), py::arg("values"), py::arg("bounds"),
          "Fill the nodes' cubes: f at their fine_points and a bound on |grad f| each.")
      .def_property_readonly(
          "fine_clearing_stats",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] {
              FineField* fine = self.fine_clearing();
              return fine ? std::make_pair(fine->filled(), fine->cleared())
                          : std::make_pair(std::size_t{0}, std::uint64_t{0});
            });
          },
          "(cubes filled, segments they cleared) of the fine clearing.")
      .def_property_readonly(
          "cleared_facets",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] { return self.cleared_facets(); });
          },
          "Facets the grid cleared (see set_clearing), since construction.")
      .def_property_readonly(
          "reused_facets",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] { return self.reused_facets(); });
          },
          "Facets whose status was derived from a KNOWN one instead of being handed "
          "out again (see changed_facets), since construction.")
      .def_property_readonly(
          "exact_circumcentres",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] { return self.exact_circumcentres(); });
          },
          "Circumcentres computed in exact arithmetic, since construction: those "
          "whose double value was not equidistant from the cell's four vertices "
          "to 1e-12 (relative, on squared distances).")
      .def_property_readonly(
          "number_of_cells",
          [](RestrictedDelaunay& self) {
            return locked(self, [&] { return self.number_of_cells(); });
          })
      .def(
          "check", [](RestrictedDelaunay& self) { locked(self, [&] { self.check(); }); },
          "Raise RuntimeError unless the triangulation is Delaunay and the facet "
          "flags are consistent.");

  m.def(
      "select_independent",
      [](const InArray& centres, const InArray& radii) {
        const std::vector<double> c = rows3(centres, "centres");
        if (radii.ndim() != 1 || radii.shape(0) * 3 != static_cast<py::ssize_t>(c.size()))
          throw std::invalid_argument("radii must have shape (k,) matching centres (k, 3)");
        std::vector<double> r(radii.data(), radii.data() + radii.shape(0));
        std::vector<std::int64_t> out;
        {
          py::gil_scoped_release release;
          out = rdmesh::select_independent(c.data(), r.data(), r.size());
        }
        return to_numpy(out, {static_cast<py::ssize_t>(out.size())});
      },
      py::arg("centres"), py::arg("radii"),
      "Indices of a greedy independent set of balls: by decreasing radius, a "
      "ball is kept unless its centre lies in a kept ball.");

  m.def(
      "complex_status",
      [](const IdArray& faces, std::int64_t n_vertices) {
        if (faces.ndim() != 2 || faces.shape(1) != 3)
          throw std::invalid_argument("faces must have shape (F, 3)");
        if (faces.shape(0) > (py::ssize_t{1} << 30))
          throw std::invalid_argument("more than 2**30 faces");
        const std::vector<std::int64_t> t = copy_of<std::int64_t>(faces);
        rdmesh::ComplexCounts c;
        {
          py::gil_scoped_release release;
          c = rdmesh::complex_counts(t.data(), t.size() / 3, n_vertices);
        }
        const auto E = static_cast<py::ssize_t>(c.edge_key.size());
        const auto F = static_cast<py::ssize_t>(faces.shape(0));
        return py::make_tuple(to_numpy(c.edge_key, {E}), to_numpy(c.edge_count, {E}),
                              to_numpy(c.face_edges, {F, 3}),
                              to_numpy(c.vertex_fans, {static_cast<py::ssize_t>(n_vertices)}));
      },
      py::arg("faces"), py::arg("n_vertices"),
      "(edge_key, edge_count, face_edges, vertex_fans) of a triangle set: the "
      "distinct edges by ascending key min * n + max, the faces of each, each "
      "face's edges ab, bc, ca as indices, and the fans of faces around each vertex.");

  m.def(
      "trim_heap",
      []() {
#if defined(__GLIBC__)
        py::gil_scoped_release release;
        return malloc_trim(0) == 1;
#else
        return false;
#endif
      },
      "Return the heap's free pages to the system (glibc's malloc_trim); "
      "True if memory was released, False elsewhere or when none was.");
}
