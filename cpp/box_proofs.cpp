#include "box_proofs.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "cell_boxes.hpp"
#include "on_cores.hpp"

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

void prove_owner(std::size_t i, const BoxProofInput& in, BoxEvaluator& eval,
                 std::vector<Box>& stack, std::vector<CellPlane>& planes, BoxProofResult& out,
                 std::vector<Box>* leaves) {
  Box own;
  for (int k = 0; k < 3; ++k) {
    own.lo[k] = in.lo[3 * i + k];
    own.hi[k] = in.hi[3 * i + k];
  }
  stack.clear();
  const std::int64_t c = in.cell[i];
  if (in.seeded && in.seeded[c]) {
    // The seeds cut to the owner's box, in reverse: the first is taken first.
    for (std::int64_t r = in.seed_first[c + 1] - 1; r >= in.seed_first[c]; --r) {
      Box b;
      bool empty = false;
      for (int k = 0; k < 3; ++k) {
        b.lo[k] = std::max(in.seed_lo[3 * r + k], own.lo[k]);
        b.hi[k] = std::min(in.seed_hi[3 * r + k], own.hi[k]);
        empty = empty || b.lo[k] > b.hi[k];
      }
      if (!empty) stack.push_back(b);
    }
  } else {
    stack.push_back(own);
  }
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
    if (!b.undefined && gradient_keeps_sign(b, d)) {
      if (leaves) leaves->push_back(box);
      continue;
    }
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
      if (leaves) leaves->clear();
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
  std::vector<std::vector<Box>> leaves(in.leaves ? in.n : 0);
  // Owners take very different work; each writes only its own rows.
  struct Worker {
    BoxEvaluator eval;
    std::vector<Box> stack;
    std::vector<CellPlane> planes;
  };
  for_each_on_cores(
      in.n, [&] { return Worker{BoxEvaluator(program, true, false), {}, {}}; },
      [&](Worker& w, std::size_t i) {
        prove_owner(i, in, w.eval, w.stack, w.planes, out, in.leaves ? &leaves[i] : nullptr);
      },
      std::max<std::size_t>(1, in.n / 8));
  if (in.leaves) {
    out.leaf_first.assign(1, 0);
    for (const auto& owned : leaves) {
      for (const Box& b : owned) {
        out.leaf_lo.insert(out.leaf_lo.end(), b.lo, b.lo + 3);
        out.leaf_hi.insert(out.leaf_hi.end(), b.hi, b.hi + 3);
      }
      out.leaf_first.push_back(out.leaf_first.back() + static_cast<std::int64_t>(owned.size()));
    }
  }
  return out;
}

}  // namespace rdmesh
