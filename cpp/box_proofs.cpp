#include "box_proofs.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <cfloat>
#include <cmath>
#include <thread>

#include "cell_boxes.hpp"

namespace rdmesh {
namespace {

struct Box {
  double lo[3], hi[3];
};

// Whether the box can meet the plane x . normal = offset, with the margin of
// proven_cells.on_plane, so rounding never drops a box that touches it.
bool meets_plane(const Box& b, const double* plane) {
  double a = 0.0, c = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double w = plane[k];
    a += (w > 0 ? b.lo[k] : b.hi[k]) * w;
    c += (w > 0 ? b.hi[k] : b.lo[k]) * w;
  }
  const double off = plane[3];
  const double slack = 1e-12 * (std::fabs(a) + std::fabs(c) + std::fabs(off)) + 1e-300;
  return a <= off + slack && c >= off - slack;
}

// Whether G . d keeps one sign over the gradient box G (intervals.dot_bounds:
// components with d == 0 add nothing, a non-finite bound settles nothing, and
// a few ulps of slack cover the rounding of three products and two sums).
bool settled(const BoxBounds& g, const double* d) {
  double lo = 0.0, hi = 0.0, mag = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) continue;
    const double p1 = g.glo[k] * d[k], p2 = g.ghi[k] * d[k];
    const double l = p1 < p2 ? p1 : p2, h = p1 < p2 ? p2 : p1;
    if (!std::isfinite(l) || !std::isfinite(h)) return false;
    lo += l;
    hi += h;
    mag += std::fabs(l) > std::fabs(h) ? std::fabs(l) : std::fabs(h);
  }
  const double slack = 8 * DBL_EPSILON * mag + DBL_MIN;
  return lo - slack > 0 || hi + slack < 0;
}

void prove_owner(std::size_t i, const BoxProofInput& in, BoxEvaluator& eval,
                 std::vector<Box>& stack, std::vector<CellPlane>& planes, BoxProofResult& out) {
  Box first;
  for (int k = 0; k < 3; ++k) {
    first.lo[k] = in.lo[3 * i + k];
    first.hi[k] = in.hi[3 * i + k];
  }
  stack.assign(1, first);
  const std::int64_t skip = in.skip ? in.skip[i] : -1;
  // The owner's bisectors once, not per box.
  cell_planes(in.cell[i], skip, in.points, in.offsets, in.neighbour, planes);
  const double* plane = in.plane ? in.plane + 4 * i : nullptr;
  const double* d = in.direction + 3 * i;
  std::size_t count = 0;
  BoxBounds b;
  while (!stack.empty()) {
    const Box box = stack.back();
    stack.pop_back();
    if (plane && !meets_plane(box, plane)) continue;
    if (box_beyond(box.lo, box.hi, planes)) continue;
    // The gradient settles many boxes: the mean-value form (a second pass, at
    // the centre) only where it must decide.
    eval.evaluate(box.lo, box.hi, b);
    ++count;
    if (!b.undefined && settled(b, d)) continue;
    if (!(b.lo <= 0 && b.hi >= 0)) continue;
    eval.tighten(box.lo, box.hi, b);
    if (!(b.lo <= 0 && b.hi >= 0)) continue;
    int axis = 0;
    double side[3];
    for (int k = 0; k < 3; ++k) {
      side[k] = box.hi[k] - box.lo[k];
      if (side[k] > side[axis]) axis = k;
    }
    if (side[axis] <= in.floor[i] || count >= in.budget) {
      out.failed[i] = 1;
      for (int k = 0; k < 3; ++k) {
        out.lo[3 * i + k] = box.lo[k];
        out.hi[3 * i + k] = box.hi[k];
      }
      break;
    }
    // Halve along the longest side; the lower half is taken first.
    const double cut = box.lo[axis] + 0.5 * side[axis];
    Box upper = box, lower = box;
    upper.lo[axis] = cut;
    lower.hi[axis] = cut;
    stack.push_back(upper);
    stack.push_back(lower);
  }
  out.boxes[i] = static_cast<std::int64_t>(count);
}

}  // namespace

BoxProofResult prove_boxes(const std::vector<IntervalInstruction>& program,
                           const BoxProofInput& in) {
  check_interval_program(program);
  BoxProofResult out;
  out.failed.assign(in.n, 0);
  out.lo.assign(3 * in.n, 0.0);
  out.hi.assign(3 * in.n, 0.0);
  out.boxes.assign(in.n, 0);
  // Owners take very different work: threads take the next owner as they go.
  // Each owner writes its own rows, so the result does not depend on the split.
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_lock;
  const auto work = [&]() {
    try {
      BoxEvaluator eval(program, true, false);
      std::vector<Box> stack;
      std::vector<CellPlane> planes;
      for (std::size_t i = next++; i < in.n; i = next++)
        prove_owner(i, in, eval, stack, planes, out);
    } catch (...) {  // e.g. bad_alloc: rethrown below, never out of a thread
      const std::lock_guard<std::mutex> hold(error_lock);
      if (!error) error = std::current_exception();
      next = in.n;
    }
  };
  const std::size_t cores = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t parts = std::max<std::size_t>(1, std::min<std::size_t>(cores, in.n / 8));
  std::vector<std::thread> threads;
  for (std::size_t t = 1; t < parts; ++t) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  return out;
}

}  // namespace rdmesh
