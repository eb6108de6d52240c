// pybind11 bindings: array conversion, GIL release, locking, exception
// translation.
#include <pybind11/gil_safe_call_once.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <CGAL/assertions_behaviour.h>
#include <CGAL/exceptions.h>
#include <CGAL/version.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "box_proofs.hpp"
#include "cell_boxes.hpp"
#include "interval_eval.hpp"
#include "mesh_distance.hpp"
#include "rdt.hpp"
#include "sample_scan.hpp"
#include "segment_roots.hpp"

namespace py = pybind11;
using rdmesh::RestrictedDelaunay;

namespace {

using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IdArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
using FlagArray = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>;

// Copies an array's data while the GIL is held: once it is released, other
// Python threads may write to, resize or free the array.
template <typename T, typename A>
std::vector<T> copy_of(const A& a) {
  return std::vector<T>(a.data(), a.data() + a.size());
}

// Copies an (n, 3) array while the GIL is held.
std::vector<double> rows3(const InArray& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument(std::string(what) + " must have shape (n, 3)");
  return copy_of<double>(a);
}

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

// Hands the vector's buffer to numpy without a copy (the vector is left
// empty).  The unique_ptr owns the buffer until the capsule does, so a throw
// from either constructor frees it.
template <typename T>
py::array_t<T> to_numpy(std::vector<T>& v, std::vector<py::ssize_t> shape) {
  auto owner = std::make_unique<std::vector<T>>(std::move(v));
  T* data = owner->data();
  py::capsule free_when_done(owner.get(),
                             [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owner.release();
  return py::array_t<T>(std::move(shape), data, free_when_done);
}

using OpArray = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

// The interval program (rdmesh.surfaces.interval_program): (t, 3) ops and (t,) constants.
std::vector<rdmesh::IntervalInstruction> program_of(const OpArray& ops, const InArray& consts) {
  if (ops.ndim() != 2 || ops.shape(1) != 3) throw std::invalid_argument("ops must have shape (t, 3)");
  if (consts.ndim() != 1 || consts.shape(0) != ops.shape(0))
    throw std::invalid_argument("consts must have shape (t,)");
  std::vector<rdmesh::IntervalInstruction> program(ops.shape(0));
  const std::int32_t* o = ops.data();
  for (std::size_t i = 0; i < program.size(); ++i)
    program[i] = {o[3 * i], o[3 * i + 1], o[3 * i + 2], consts.data()[i]};
  return program;
}

// Each sample's Delaunay neighbours as CSR over n_points samples, checked.
void check_neighbours(const std::vector<std::int64_t>& off, const std::vector<std::int64_t>& nb,
                      std::size_t n_points) {
  if (off.size() != n_points + 1)
    throw std::invalid_argument("offsets must have shape (len(points) + 1,)");
  if (off[0] != 0 || off[n_points] != static_cast<std::int64_t>(nb.size()))
    throw std::invalid_argument("offsets must run from 0 to len(neighbour)");
  for (std::size_t i = 0; i < n_points; ++i)
    if (off[i + 1] < off[i]) throw std::invalid_argument("offsets must not decrease");
  for (std::int64_t q : nb)
    if (q < 0 || static_cast<std::size_t>(q) >= n_points)
      throw std::invalid_argument("neighbour ids must be rows of points");
}

// (n,) ids, each a row of points.
std::vector<std::int64_t> sample_ids(const IdArray& a, std::size_t n, std::size_t n_points,
                                     const char* what) {
  if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n)
    throw std::invalid_argument(std::string(what) + " must have shape (n,), one per box");
  std::vector<std::int64_t> v = copy_of<std::int64_t>(a);
  for (std::int64_t p : v)
    if (p < 0 || static_cast<std::size_t>(p) >= n_points)
      throw std::invalid_argument(std::string(what) + " ids must be rows of points");
  return v;
}

py::tuple facet_pair(rdmesh::ChangedFacets& f) {
  const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
  return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.seg, {k, 2, 3}));
}

py::tuple samples_tuple(rdmesh::SegmentSamples& m) {
  return py::make_tuple(
      to_numpy(m.offsets, {static_cast<py::ssize_t>(m.offsets.size())}),
      to_numpy(m.s, {static_cast<py::ssize_t>(m.s.size())}),
      to_numpy(m.interior, {static_cast<py::ssize_t>(m.interior.size() / 3), 3}));
}

py::tuple facet_quad(rdmesh::ChangedFacets& f) {
  const auto k = static_cast<py::ssize_t>(f.tri.size() / 3);
  const auto u = static_cast<py::ssize_t>(f.ends.size() / 3);
  return py::make_tuple(to_numpy(f.tri, {k, 3}), to_numpy(f.seg, {k, 2, 3}),
                        to_numpy(f.end_index, {k, 2}), to_numpy(f.ends, {u, 3}),
                        to_numpy(f.rho, {k}), samples_tuple(f.samples));
}

rdmesh::SegmentSampling sampling_spec(double per_radius, std::int64_t lo,
                                      std::int64_t hi) {
  if (!(per_radius > 0.0) || !std::isfinite(per_radius) || lo < 1 || hi < lo)
    throw std::invalid_argument(
        "sampling needs per_radius > 0 and 1 <= min_intervals <= max_intervals");
  return {per_radius, lo, hi};
}

void silent_handler(const char*, const char*, const char*, int, const char*) {}

}  // namespace

void register_volume_sampler(py::module_& m);  // cpp/volume_sampler.cpp

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

  m.def(
      "_fail_allocation_for_testing",
      [](std::int64_t n) { return rdmesh::fail_countdown_for_testing.exchange(n); },
      py::arg("n"),
      "Test hook: the n-th fault point from now raises MemoryError (n <= 0: "
      "none); returns the previous count. Fault points: each facet "
      "changed_facets appends or cell it gathers, each update_facets, and the "
      "conversion of changed_facets' result.");

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
        rdmesh::SegmentSamples out;
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
        rdmesh::SampleScan r;
        {
          py::gil_scoped_release release;
          r = rdmesh::scan_samples(off.data(), k, S.data(), V.data(),
                                   ends ? E.data() : nullptr, dip_fraction);
        }
        auto n = [](const auto& v) { return std::vector<py::ssize_t>{static_cast<py::ssize_t>(v.size())}; };
        auto sign = py::make_tuple(to_numpy(r.seg, n(r.seg)), to_numpy(r.lo, n(r.lo)),
                                   to_numpy(r.hi, n(r.hi)), to_numpy(r.rising, n(r.rising)));
        auto dips = py::make_tuple(to_numpy(r.dip_seg, n(r.dip_seg)), to_numpy(r.dip_x1, n(r.dip_x1)),
                                   to_numpy(r.dip_x2, n(r.dip_x2)), to_numpy(r.dip_x3, n(r.dip_x3)),
                                   to_numpy(r.dip_sign, n(r.dip_sign)));
        auto valleys = py::make_tuple(
            to_numpy(r.val_seg, n(r.val_seg)), to_numpy(r.val_lo, n(r.val_lo)),
            to_numpy(r.val_hi, n(r.val_hi)), to_numpy(r.val_inside, n(r.val_inside)),
            to_numpy(r.val_a_lo, n(r.val_a_lo)), to_numpy(r.val_a_hi, n(r.val_a_hi)));
        return py::make_tuple(sign, dips, valleys);
      },
      py::arg("offsets"), py::arg("s"), py::arg("values"), py::arg("ends") = py::none(),
      py::arg("dip_fraction") = 0.25,
      "The sign scan of sampled segments (see rdmesh.sampling.roots): "
      "((seg, lo, hi, rising) sign changes, (seg, x1, x2, x3, sign) dips, "
      "(seg, lo, hi, inside, |f| at lo, |f| at hi) valleys). values: f at every "
      "sample, or at the interior samples only when ends (k, 2) are given.");

  m.def(
      "boxes_outside_cells",
      [](const InArray& lo, const InArray& hi, const IdArray& owner, const InArray& points,
         const IdArray& offsets, const IdArray& neighbour, std::optional<IdArray> skip) {
        const std::vector<double> L = rows3(lo, "lo"), H = rows3(hi, "hi");
        const std::vector<double> P = rows3(points, "points");
        const std::size_t n = L.size() / 3, np_ = P.size() / 3;
        if (H.size() != L.size()) throw std::invalid_argument("lo and hi must have the same shape");
        if (skip && (skip->ndim() != 1 || static_cast<std::size_t>(skip->shape(0)) != n))
          throw std::invalid_argument("skip must have shape (n,), one per box");
        const std::vector<std::int64_t> O = sample_ids(owner, n, np_, "owner"),
                                        off = copy_of<std::int64_t>(offsets),
                                        nb = copy_of<std::int64_t>(neighbour);
        const std::vector<std::int64_t> S = skip ? copy_of<std::int64_t>(*skip)
                                                 : std::vector<std::int64_t>();
        if (offsets.ndim() != 1) throw std::invalid_argument("offsets must be 1-D");
        check_neighbours(off, nb, np_);
        std::vector<std::uint8_t> out;
        {
          py::gil_scoped_release release;
          out = rdmesh::boxes_outside_cells(L.data(), H.data(), n, O.data(),
                                            skip ? S.data() : nullptr, P.data(), off.data(),
                                            nb.data());
        }
        return to_numpy(out, {static_cast<py::ssize_t>(n)});
      },
      py::arg("lo"), py::arg("hi"), py::arg("owner"), py::arg("points"), py::arg("offsets"),
      py::arg("neighbour"), py::arg("skip") = py::none(),
      "(n,) uint8: box i lies wholly beyond the bisector of points[owner[i]] and one of "
      "its neighbours (neighbour[offsets[p]:offsets[p + 1]], other than skip[i]).");

  m.def(
      "evaluate_intervals",
      [](const OpArray& ops, const InArray& consts, const InArray& lo, const InArray& hi,
         bool gradient, bool mean_value) {
        const std::vector<rdmesh::IntervalInstruction> program = program_of(ops, consts);
        const std::vector<double> L = rows3(lo, "lo"), H = rows3(hi, "hi");
        if (L.size() != H.size()) throw std::invalid_argument("lo and hi must have the same shape");
        const std::size_t n = L.size() / 3;
        rdmesh::IntervalResult r;
        {
          py::gil_scoped_release release;
          r = rdmesh::evaluate_intervals(program, L.data(), H.data(), n, gradient, mean_value);
        }
        const auto nn = static_cast<py::ssize_t>(n);
        py::object glo = py::none(), ghi = py::none();
        if (gradient) {
          glo = to_numpy(r.glo, {nn, 3});
          ghi = to_numpy(r.ghi, {nn, 3});
        }
        return py::make_tuple(to_numpy(r.lo, {nn}), to_numpy(r.hi, {nn}), glo, ghi,
                              to_numpy(r.undefined, {nn}));
      },
      py::arg("ops"), py::arg("consts"), py::arg("lo"), py::arg("hi"), py::arg("gradient"),
      py::arg("mean_value"),
      "Interval bounds of a compiled expression program (see "
      "rdmesh.surfaces.interval_program) over (n, 3) boxes: (lo, hi, glo, ghi, undefined); "
      "glo and ghi are None without gradient.");

  m.def(
      "prove_boxes",
      [](const OpArray& ops, const InArray& consts, const InArray& lo, const InArray& hi,
         const IdArray& cell, const InArray& direction, const InArray& floor,
         const InArray& points, const IdArray& offsets, const IdArray& neighbour,
         std::optional<IdArray> skip, std::optional<InArray> plane, std::int64_t budget,
         bool leaves, std::optional<py::tuple> seeds) {
        const std::vector<rdmesh::IntervalInstruction> program = program_of(ops, consts);
        const std::vector<double> L = rows3(lo, "lo"), H = rows3(hi, "hi");
        const std::vector<double> P = rows3(points, "points"), D = rows3(direction, "direction");
        const std::size_t n = L.size() / 3, np_ = P.size() / 3;
        if (H.size() != L.size() || D.size() != L.size())
          throw std::invalid_argument("lo, hi and direction must have the same shape");
        for (std::size_t i = 0; i < L.size(); ++i)
          if (!std::isfinite(L[i]) || !std::isfinite(H[i]) || !(L[i] <= H[i]))
            throw std::invalid_argument("boxes must be finite with lo <= hi");
        if (floor.ndim() != 1 || static_cast<std::size_t>(floor.shape(0)) != n)
          throw std::invalid_argument("floor must have shape (n,), one per owner");
        const std::vector<double> F = copy_of<double>(floor);
        for (double f : F)
          if (!(f > 0) || !std::isfinite(f))
            throw std::invalid_argument("floor must be positive and finite");
        if (budget < 1) throw std::invalid_argument("budget must be at least 1");
        if (offsets.ndim() != 1) throw std::invalid_argument("offsets must be 1-D");
        const std::vector<std::int64_t> C = sample_ids(cell, n, np_, "cell"),
                                        off = copy_of<std::int64_t>(offsets),
                                        nb = copy_of<std::int64_t>(neighbour);
        check_neighbours(off, nb, np_);
        std::vector<std::int64_t> S;
        if (skip) {
          if (skip->ndim() != 1 || static_cast<std::size_t>(skip->shape(0)) != n)
            throw std::invalid_argument("skip must have shape (n,), one per owner");
          S = copy_of<std::int64_t>(*skip);
        }
        std::vector<double> Q;
        if (plane) {
          if (plane->ndim() != 2 || static_cast<std::size_t>(plane->shape(0)) != n ||
              plane->shape(1) != 4)
            throw std::invalid_argument("plane must have shape (n, 4): normal and offset");
          Q = copy_of<double>(*plane);
        }
        std::vector<std::uint8_t> seeded;
        std::vector<std::int64_t> seed_first;
        std::vector<double> seed_lo, seed_hi;
        if (seeds) {
          if (seeds->size() != 4)
            throw std::invalid_argument("seeds must be (seeded, first, lo, hi)");
          const auto sd = (*seeds)[0].cast<py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>>();
          const auto sf = (*seeds)[1].cast<IdArray>();
          seeded = copy_of<std::uint8_t>(sd);
          seed_first = copy_of<std::int64_t>(sf);
          seed_lo = rows3((*seeds)[2].cast<InArray>(), "seed lo");
          seed_hi = rows3((*seeds)[3].cast<InArray>(), "seed hi");
          bool ok = sd.ndim() == 1 && sf.ndim() == 1 && seeded.size() == np_ &&
                    seed_first.size() == np_ + 1 && seed_first.front() == 0 &&
                    seed_hi.size() == seed_lo.size() &&
                    seed_first.back() == static_cast<std::int64_t>(seed_lo.size() / 3);
          for (std::size_t i = 1; ok && i < seed_first.size(); ++i)
            ok = seed_first[i - 1] <= seed_first[i];
          if (!ok)
            throw std::invalid_argument(
                "seeds must be (seeded (samples,), first (samples + 1,) rising from 0 to the "
                "number of seed boxes, lo, hi)");
        }
        rdmesh::BoxProofInput in;
        in.n = n;
        in.lo = L.data();
        in.hi = H.data();
        in.cell = C.data();
        in.skip = skip ? S.data() : nullptr;
        in.direction = D.data();
        in.plane = plane ? Q.data() : nullptr;
        in.floor = F.data();
        in.points = P.data();
        in.offsets = off.data();
        in.neighbour = nb.data();
        in.budget = static_cast<std::size_t>(budget);
        in.leaves = leaves;
        if (seeds) {
          in.seeded = seeded.data();
          in.seed_first = seed_first.data();
          in.seed_lo = seed_lo.data();
          in.seed_hi = seed_hi.data();
        }
        rdmesh::BoxProofResult r;
        {
          py::gil_scoped_release release;
          r = rdmesh::prove_boxes(program, in);
        }
        const auto nn = static_cast<py::ssize_t>(n);
        py::tuple out = py::make_tuple(to_numpy(r.failed, {nn}), to_numpy(r.lo, {nn, 3}),
                                       to_numpy(r.hi, {nn, 3}), to_numpy(r.boxes, {nn}));
        if (!leaves) return out;
        const auto nl = static_cast<py::ssize_t>(r.leaf_lo.size() / 3);
        return py::tuple(out + py::make_tuple(to_numpy(r.leaf_first, {nn + 1}),
                                              to_numpy(r.leaf_lo, {nl, 3}),
                                              to_numpy(r.leaf_hi, {nl, 3})));
      },
      py::arg("ops"), py::arg("consts"), py::arg("lo"), py::arg("hi"), py::arg("cell"),
      py::arg("direction"), py::arg("floor"), py::arg("points"), py::arg("offsets"),
      py::arg("neighbour"), py::arg("skip") = py::none(), py::arg("plane") = py::none(),
      py::arg("budget") = 1 << 16, py::arg("leaves") = false, py::arg("seeds") = py::none(),
      "The subdivision of the proven loop and silhouette tests (rdmesh.topology.proven_cells) "
      "for n owners, each from its box, or, with seeds = (seeded, first, lo, hi) and its cell "
      "seeded, from the seed boxes rows first[c]:first[c+1] (c = cell[i]) cut to its box: "
      "(failed (n,) uint8, lo (n, 3), hi (n, 3) of a failed owner's unsettled box, boxes (n,) "
      "bounded per owner), and with leaves also (leaf_first (n + 1,), leaf_lo (L, 3), leaf_hi "
      "(L, 3)): each owner's boxes the gradient settled (none for a failed owner).");

  m.def(
      "isolate_segment_roots",
      [](const OpArray& ops, const InArray& consts, const InArray& a, const InArray& b,
         double min_length, std::int64_t budget, std::optional<InArray> t0,
         std::optional<InArray> t1) {
        const std::vector<rdmesh::IntervalInstruction> program = program_of(ops, consts);
        const std::vector<double> A = rows3(a, "a"), B = rows3(b, "b");
        if (A.size() != B.size()) throw std::invalid_argument("a and b must have the same shape");
        for (std::size_t i = 0; i < A.size(); ++i)
          if (!std::isfinite(A[i]) || !std::isfinite(B[i]))
            throw std::invalid_argument("segment ends must be finite");
        if (!(min_length > 0) || !std::isfinite(min_length))
          throw std::invalid_argument("min_length must be positive and finite");
        if (budget < 1) throw std::invalid_argument("budget must be at least 1");
        const std::size_t n_seg = A.size() / 3;
        std::vector<double> T0, T1;
        if (t0.has_value() != t1.has_value())
          throw std::invalid_argument("t0 and t1 go together");
        if (t0) {
          T0 = copy_of<double>(*t0);
          T1 = copy_of<double>(*t1);
          if (t0->ndim() != 1 || t1->ndim() != 1 || T0.size() != n_seg || T1.size() != n_seg)
            throw std::invalid_argument("t0 and t1 must have shape (n,), one per segment");
          for (std::size_t i = 0; i < n_seg; ++i)
            if (!(0.0 <= T0[i] && T0[i] <= T1[i] && T1[i] <= 1.0))
              throw std::invalid_argument("pieces must have 0 <= t0 <= t1 <= 1");
        }
        rdmesh::SegmentRoots r;
        {
          py::gil_scoped_release release;
          r = rdmesh::isolate_segment_roots(program, A.data(), B.data(),
                                            t0 ? T0.data() : nullptr, t0 ? T1.data() : nullptr,
                                            n_seg, min_length, static_cast<std::size_t>(budget));
        }
        auto n = [](const auto& v) { return std::vector<py::ssize_t>{static_cast<py::ssize_t>(v.size())}; };
        return py::make_tuple(to_numpy(r.found_segment, n(r.found_segment)),
                              to_numpy(r.found_lo, n(r.found_lo)),
                              to_numpy(r.found_hi, n(r.found_hi)),
                              to_numpy(r.pending_segment, n(r.pending_segment)),
                              to_numpy(r.pending_lo, n(r.pending_lo)),
                              to_numpy(r.pending_hi, n(r.pending_hi)), r.boxes);
      },
      py::arg("ops"), py::arg("consts"), py::arg("a"), py::arg("b"), py::arg("min_length"),
      py::arg("budget") = 1 << 16, py::arg("t0") = py::none(), py::arg("t1") = py::none(),
      "Proven root isolation on segments [a_i, b_i] (rdmesh.sampling.isolate), each "
      "on t in [t0_i, t1_i] ([0, 1] without t0, t1): (found segment, t0, t1, pending "
      "segment, t0, t1, boxes), by segment, then t0.");

  m.def(
      "segment_pieces",
      [](const InArray& a, const InArray& b, const IdArray& host, const IdArray& first,
         const InArray& lo, const InArray& hi, double slack) {
        const std::vector<double> A = rows3(a, "a"), B = rows3(b, "b");
        const std::vector<double> L = rows3(lo, "lo"), H = rows3(hi, "hi");
        if (A.size() != B.size()) throw std::invalid_argument("a and b must have the same shape");
        if (L.size() != H.size()) throw std::invalid_argument("lo and hi must have the same shape");
        const std::size_t n = A.size() / 3, boxes = L.size() / 3;
        if (host.ndim() != 1 || static_cast<std::size_t>(host.shape(0)) != n)
          throw std::invalid_argument("host must have shape (n,), one per segment");
        if (first.ndim() != 1 || first.shape(0) < 1)
          throw std::invalid_argument("first must have shape (k + 1,)");
        const std::vector<std::int64_t> S = copy_of<std::int64_t>(host),
                                        F = copy_of<std::int64_t>(first);
        bool ok = F.front() == 0 && F.back() == static_cast<std::int64_t>(boxes);
        for (std::size_t i = 1; i < F.size(); ++i) ok = ok && F[i - 1] <= F[i];
        if (!ok) throw std::invalid_argument("first must rise from 0 to the number of boxes");
        const auto k = static_cast<std::int64_t>(F.size() - 1);
        for (std::int64_t h : S)
          if (h < -1 || h >= k) throw std::invalid_argument("host ids must be -1 or below k");
        for (double x : A)
          if (!std::isfinite(x)) throw std::invalid_argument("segment ends must be finite");
        for (double x : B)
          if (!std::isfinite(x)) throw std::invalid_argument("segment ends must be finite");
        if (!(slack >= 0) || !std::isfinite(slack))
          throw std::invalid_argument("slack must be finite and not negative");
        rdmesh::SegmentPieces r;
        {
          py::gil_scoped_release release;
          r = rdmesh::segment_pieces(A.data(), B.data(), S.data(), n, F.data(), L.data(), H.data(),
                                     slack);
        }
        const auto m_ = static_cast<py::ssize_t>(r.segment.size());
        return py::make_tuple(to_numpy(r.segment, {m_}), to_numpy(r.t0, {m_}),
                              to_numpy(r.t1, {m_}));
      },
      py::arg("a"), py::arg("b"), py::arg("host"), py::arg("first"), py::arg("lo"),
      py::arg("hi"), py::arg("slack"),
      "The parts of segments [a_i, b_i] inside the boxes rows first[h]:first[h+1] of lo, hi "
      "(h = host[i]; -1: the whole segment), widened by slack in t, cut to [0, 1], and "
      "merged where they meet: (segment, t0, t1), by segment, then t0.");

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
          "circumradii, samples), samples as from sample_segments. After an "
          "exception the next call hands out the same facets.")
      .def(
          "update_facets",
          [](RestrictedDelaunay& self, const FlagArray& flags, const InArray& centres) {
            const std::vector<double> xyz = rows3(centres, "centres");
            if (flags.ndim() != 1 || flags.shape(0) * 3 != static_cast<py::ssize_t>(xyz.size()))
              throw std::invalid_argument("flags must have shape (k,) matching centres (k, 3)");
            const std::vector<std::uint8_t> fl = copy_of<std::uint8_t>(flags);
            locked(self, [&] { self.update_facets(fl.data(), xyz.data(), fl.size()); });
          },
          py::arg("flags"), py::arg("centres"),
          "Set the flags (k,) and surface centres (k, 3) of the oldest chunk "
          "from changed_facets not yet updated, in its order.")
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

  // MeshDistance (mesh_distance.hpp): queries are const and build nothing,
  // so two threads may query one object at once: no lock, GIL released.
  py::class_<rdmesh::MeshDistance>(m, "MeshDistance")
      .def(py::init([](const InArray& vertices, const IdArray& faces, bool side) {
             const std::vector<double> v = rows3(vertices, "vertices");
             if (faces.ndim() != 2 || faces.shape(1) != 3)
               throw std::invalid_argument("faces must have shape (m, 3)");
             const std::vector<std::int64_t> f = copy_of<std::int64_t>(faces);
             py::gil_scoped_release release;
             return new rdmesh::MeshDistance(v.data(), v.size() / 3, f.data(), f.size() / 3,
                                             side);
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("side") = true)
      .def(
          "query",
          [](const rdmesh::MeshDistance& self, const InArray& points) {
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
          [](const rdmesh::MeshDistance& self, const InArray& points) {
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
          [](const rdmesh::MeshDistance& self, const InArray& points, double beta) {
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
          "self_intersections",
          [](const rdmesh::MeshDistance& self) {
            std::vector<std::int64_t> pairs = self.self_intersections();
            return to_numpy(pairs, {static_cast<py::ssize_t>(pairs.size() / 2), 2});
          },
          "(k, 2) int64: the pairs of intersecting faces of a closed manifold mesh that "
          "intersects itself (empty otherwise).")
      .def_property_readonly("has_side", &rdmesh::MeshDistance::has_side)
      .def_property_readonly("has_pseudo_normals", &rdmesh::MeshDistance::has_pseudo_normals)
      .def_property_readonly("side_failure", &rdmesh::MeshDistance::side_failure)
      .def_property_readonly("number_of_faces", &rdmesh::MeshDistance::number_of_faces);

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
