// Bindings of the interval evaluator and what runs on it (interval_eval.hpp,
// box_proofs.hpp, segment_roots.hpp, cell_boxes.hpp): the opcodes, bounds
// over boxes, the proven tests' subdivision, root isolation on segments and
// the Voronoi-cell pruning of boxes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "box_proofs.hpp"
#include "cell_boxes.hpp"
#include "interval_eval.hpp"
#include "on_cores.hpp"
#include "segment_roots.hpp"

namespace rdmesh::bind {
namespace {

// The interval program (rdmesh.surfaces.interval_program): (t, 3) ops and (t,) constants.
std::vector<IntervalInstruction> program_of(const OpArray& ops, const InArray& consts) {
  if (ops.ndim() != 2 || ops.shape(1) != 3)
    throw std::invalid_argument("ops must have shape (t, 3)");
  if (consts.ndim() != 1 || consts.shape(0) != ops.shape(0))
    throw std::invalid_argument("consts must have shape (t,)");
  std::vector<IntervalInstruction> program(ops.shape(0));
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

}  // namespace

void register_intervals(py::module_& m) {
  py::dict ops;
  for (std::int32_t op = 0; op < IV_OP_COUNT; ++op) ops[kIntervalOpNames[op]] = op;
  m.attr("INTERVAL_OPS") = ops;
  m.attr("INTERVAL_REL_WIDENING") = kRelWidening;

  m.def("usable_cores", &usable_cores,
        "The CPUs this process may run on (its affinity mask): how many threads the "
        "evaluator, the proofs and root isolation spread their work over.");

  m.def(
      "_fail_worker_for_testing",
      [](std::int64_t n) { return worker_fault_for_testing.exchange(n); },
      py::arg("n"),
      "Test hook: the n-th work item from now taken by a worker thread (not the calling "
      "thread) of evaluate_intervals, prove_boxes, isolate_segment_roots or segment_pieces "
      "raises RuntimeError in the caller (n <= 0: none); returns the previous count.");

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
          out = boxes_outside_cells(L.data(), H.data(), n, O.data(),
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
        const std::vector<IntervalInstruction> program = program_of(ops, consts);
        const std::vector<double> L = rows3(lo, "lo"), H = rows3(hi, "hi");
        if (L.size() != H.size()) throw std::invalid_argument("lo and hi must have the same shape");
        const std::size_t n = L.size() / 3;
        IntervalResult r;
        {
          py::gil_scoped_release release;
          r = evaluate_intervals(program, L.data(), H.data(), n, gradient, mean_value);
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
      "rdmesh.surfaces.interval_program; opcodes in INTERVAL_OPS) over (n, 3) boxes: "
      "(lo, hi, glo, ghi, undefined); "
      "glo and ghi are None without gradient.");

  m.def(
      "prove_boxes",
      [](const OpArray& ops, const InArray& consts, const InArray& lo, const InArray& hi,
         const IdArray& cell, const InArray& direction, const InArray& floor,
         const InArray& points, const IdArray& offsets, const IdArray& neighbour,
         std::optional<IdArray> skip, std::optional<InArray> plane, std::int64_t budget,
         bool leaves, std::optional<py::tuple> seeds) {
        const std::vector<IntervalInstruction> program = program_of(ops, consts);
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
          const auto sd = (*seeds)[0].cast<FlagArray>();
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
        BoxProofInput in;
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
        BoxProofResult r;
        {
          py::gil_scoped_release release;
          r = prove_boxes(program, in);
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
        const std::vector<IntervalInstruction> program = program_of(ops, consts);
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
        SegmentRoots r;
        {
          py::gil_scoped_release release;
          r = isolate_segment_roots(program, A.data(), B.data(),
                                            t0 ? T0.data() : nullptr, t0 ? T1.data() : nullptr,
                                            n_seg, min_length, static_cast<std::size_t>(budget));
        }
        return py::make_tuple(to_numpy(r.found_segment), to_numpy(r.found_lo),
                              to_numpy(r.found_hi), to_numpy(r.pending_segment),
                              to_numpy(r.pending_lo), to_numpy(r.pending_hi), r.boxes);
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
        SegmentPieces r;
        {
          py::gil_scoped_release release;
          r = segment_pieces(A.data(), B.data(), S.data(), n, F.data(), L.data(), H.data(),
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
}

}  // namespace rdmesh::bind
