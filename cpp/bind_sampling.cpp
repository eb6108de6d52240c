// Bindings of the dual segments' sampling and sign scan, and the slope field
// (sampling.hpp, sample_scan.hpp, grid_field.hpp): rdmesh.sampling.roots,
// rdmesh.sampling.screen and the facet pipeline use them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <stdexcept>
#include <vector>

#include "bindings.hpp"
#include "grid_field.hpp"
#include "sample_scan.hpp"
#include "sampling.hpp"

namespace rdmesh::bind {

SegmentSampling sampling_spec(double per_radius, std::int64_t lo, std::int64_t hi) {
  if (!(per_radius > 0.0) || !std::isfinite(per_radius) || lo < 1 || hi < lo)
    throw std::invalid_argument(
        "sampling needs per_radius > 0 and 1 <= min_intervals <= max_intervals");
  return {per_radius, lo, hi};
}

py::tuple samples_tuple(SegmentSamples& m) {
  const auto rows = static_cast<py::ssize_t>(m.interior.size() / 3);
  return py::make_tuple(to_numpy(m.offsets), to_numpy(m.s), to_numpy(m.interior, {rows, 3}));
}

void register_sampling(py::module_& m) {
  m.def(
      "sample_segments",
      [](const InArray& seg, const InArray& apex, const InArray& rho, double per_radius,
         std::int64_t min_intervals, std::int64_t max_intervals) {
        const auto spec = sampling_spec(per_radius, min_intervals, max_intervals);
        if (seg.ndim() != 3 || seg.shape(1) != 2 || seg.shape(2) != 3)
          throw std::invalid_argument("seg must have shape (k, 2, 3)");
        const py::ssize_t k = seg.shape(0);
        if (apex.ndim() != 2 || apex.shape(0) != k || apex.shape(1) != 3)
          throw std::invalid_argument("apex must have shape (k, 3) matching seg");
        if (rho.ndim() != 1 || rho.shape(0) != k)
          throw std::invalid_argument("rho must have shape (k,) matching seg");
        // Checked after copying: the copies are what is used.
        const std::vector<double> S = copy_of<double>(seg), A = copy_of<double>(apex),
                                  Rh = copy_of<double>(rho);
        for (double x : S)
          if (!std::isfinite(x)) throw std::invalid_argument("seg has a non-finite coordinate");
        for (double x : A)
          if (!std::isfinite(x)) throw std::invalid_argument("apex has a non-finite coordinate");
        SegmentSamples out;
        {
          py::gil_scoped_release release;
          out.reserve(static_cast<std::size_t>(k), 6);
          for (py::ssize_t i = 0; i < k; ++i)
            out.add(&S[6 * i], &S[6 * i + 3], &A[3 * i], Rh[i], spec);
        }
        return samples_tuple(out);
      },
      py::arg("seg"), py::arg("apex"), py::arg("rho"), py::arg("per_radius") = 1.0,
      py::arg("min_intervals") = 3, py::arg("max_intervals") = 64,
      "Samples along dual segments (k, 2, 3) of facets with a vertex apex (k, 3) "
      "and circumradius rho (k,), evenly in asinh(distance from the facet's "
      "circumcentre / rho), clamped to [min_intervals, max_intervals] intervals: "
      "((k+1,) offsets, (P,) distances from each start, (P - 2k, 3) interior "
      "points).");

  m.def(
      "scan_samples",
      [](const IdArray& offsets, const InArray& s, const InArray& values,
         std::optional<InArray> ends, double dip_fraction) {
        if (offsets.ndim() != 1 || offsets.shape(0) < 1)
          throw std::invalid_argument("offsets must have shape (k + 1,)");
        if (s.ndim() != 1 || values.ndim() != 1)
          throw std::invalid_argument("s and values must be 1-D");
        const std::vector<std::int64_t> off = copy_of<std::int64_t>(offsets);
        const std::size_t k = off.size() - 1;
        if (off[0] != 0 || off[k] != s.shape(0))
          throw std::invalid_argument("offsets must run from 0 to len(s)");
        for (std::size_t i = 0; i < k; ++i)
          if (off[i + 1] - off[i] < 2)
            throw std::invalid_argument("every segment needs at least its two ends");
        const py::ssize_t want = ends ? s.shape(0) - 2 * static_cast<py::ssize_t>(k) : s.shape(0);
        if (values.shape(0) != want)
          throw std::invalid_argument("values must have one entry per sample (per interior "
                                      "sample when ends are given)");
        if (ends && (ends->ndim() != 2 || ends->shape(0) != static_cast<py::ssize_t>(k) ||
                     ends->shape(1) != 2))
          throw std::invalid_argument("ends must have shape (k, 2)");
        const std::vector<double> S = copy_of<double>(s), V = copy_of<double>(values);
        const std::vector<double> E = ends ? copy_of<double>(*ends) : std::vector<double>();
        SampleScan r;
        {
          py::gil_scoped_release release;
          r = scan_samples(off.data(), k, S.data(), V.data(),
                                   ends ? E.data() : nullptr, dip_fraction);
        }
        auto sign = py::make_tuple(to_numpy(r.seg), to_numpy(r.lo), to_numpy(r.hi),
                                   to_numpy(r.rising), to_numpy(r.f_lo), to_numpy(r.f_hi));
        auto dips = py::make_tuple(to_numpy(r.dip_seg), to_numpy(r.dip_x1), to_numpy(r.dip_x2),
                                   to_numpy(r.dip_x3), to_numpy(r.dip_sign));
        auto valleys = py::make_tuple(to_numpy(r.val_seg), to_numpy(r.val_lo), to_numpy(r.val_hi),
                                      to_numpy(r.val_inside), to_numpy(r.val_a_lo),
                                      to_numpy(r.val_a_hi));
        return py::make_tuple(sign, dips, valleys);
      },
      py::arg("offsets"), py::arg("s"), py::arg("values"), py::arg("ends") = py::none(),
      py::arg("dip_fraction") = 0.25,
      "The sign scan of sampled segments (see rdmesh.sampling.roots): "
      "((seg, lo, hi, rising, f at lo, f at hi) sign changes, (seg, x1, x2, x3, sign) dips, "
      "(seg, lo, hi, inside, |f| at lo, |f| at hi) valleys). values: f at every "
      "sample, or at the interior samples only when ends (k, 2) are given.");

  py::class_<GridField>(m, "GridField",
                        "A field on the nodes of a rotated grid, looked up at the node "
                        "nearest a point (see rdmesh.sampling.screen).")
      .def(py::init([](const InArray& values, const InArray& centre, const InArray& rotation,
                       const InArray& offset, double h) {
             if (values.ndim() != 3) throw std::invalid_argument("values must be 3-D");
             if (centre.size() != 3 || offset.size() != 3 || rotation.size() != 9)
               throw std::invalid_argument("centre and offset need 3 values, rotation 9");
             std::array<double, 3> c, o;
             std::array<double, 9> r;
             std::copy(centre.data(), centre.data() + 3, c.begin());
             std::copy(offset.data(), offset.data() + 3, o.begin());
             std::copy(rotation.data(), rotation.data() + 9, r.begin());
             return GridField(copy_of<double>(values),
                              {values.shape(0), values.shape(1), values.shape(2)}, c, r, o, h);
           }),
           py::arg("values"), py::arg("centre"), py::arg("rotation"), py::arg("offset"),
           py::arg("h"))
      .def(
          "at",
          [](const GridField& g, const InArray& points) {
            const auto P = rows3(points, "points");
            std::vector<double> out(P.size() / 3);
            for (std::size_t i = 0; i < out.size(); ++i) out[i] = g.at(&P[3 * i]);
            return to_numpy(out);
          },
          py::arg("points"), "The value at each point's nearest node; inf off the grid.")
      .def(
          "raise_to",
          [](GridField& g, const InArray& points, const InArray& values, std::int64_t cells) {
            const auto P = rows3(points, "points");
            if (values.ndim() != 1 || static_cast<std::size_t>(values.shape(0)) != P.size() / 3)
              throw std::invalid_argument("values must have one entry per point");
            if (cells < 0) throw std::invalid_argument("cells must be >= 0");
            const double* v = values.data();
            for (std::size_t i = 0; i < P.size() / 3; ++i) g.raise(&P[3 * i], v[i], cells);
          },
          py::arg("points"), py::arg("values"), py::arg("cells"),
          "Raise the nodes within cells steps of each point's nearest node to its value.")
      .def(
          "segment_bounds",
          [](const GridField& g, const InArray& seg, double reach, double scale, double cap) {
            if (seg.ndim() != 3 || seg.shape(1) != 2 || seg.shape(2) != 3)
              throw std::invalid_argument("seg must have shape (k, 2, 3)");
            std::vector<double> out(static_cast<std::size_t>(seg.shape(0)));
            g.segment_bounds(seg.data(), out.size(), reach, scale, cap, out.data());
            return to_numpy(out);
          },
          py::arg("seg"), py::arg("reach"), py::arg("scale"), py::arg("cap"),
          "Per segment: min(cap, scale * the value at its middle) if it is at most "
          "reach long, else cap.")
      .def(
          "clearing_values",
          [](const GridField& g, const InArray& seg, const InArray& bound) {
            if (seg.ndim() != 3 || seg.shape(1) != 2 || seg.shape(2) != 3)
              throw std::invalid_argument("seg must have shape (k, 2, 3)");
            if (bound.ndim() != 1 || bound.shape(0) != seg.shape(0))
              throw std::invalid_argument("bound must have one entry per segment");
            std::vector<double> out(static_cast<std::size_t>(seg.shape(0)));
            g.clearing_values(seg.data(), out.size(), bound.data(), out.data());
            return to_numpy(out);
          },
          py::arg("seg"), py::arg("bound"),
          "Where the field holds f and bound (k,) bounds |grad f|: per segment, f "
          "at the node nearest its middle when that node's |f| exceeds bound times "
          "the distance from the node to every point of the segment (no zero on it); "
          "NaN elsewhere.")
      .def_property_readonly("values", [](const GridField& g) {
        std::vector<double> v = g.values();
        const auto& n = g.shape();
        return to_numpy(v, {n[0], n[1], n[2]});
      });
}

}  // namespace rdmesh::bind
