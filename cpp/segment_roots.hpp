// Proven root isolation along segments by interval bisection (Snyder), the
// core of rdmesh.sampling.isolate: g(t) = f(a + t (b - a)) on pieces [t0, t1]
// of [0, 1].  A piece is settled when 0 is not in the bounds of f over the box
// around it (no root), or when grad f . (b - a) keeps one sign over that box
// and f's bounds at both ends exclude 0 (one transversal root if the signs
// differ, none otherwise).  Other pieces are halved down to a floor length;
// an unsettled piece there is pending.  Which pieces are found or pending does
// not depend on the order the pieces are taken in (they are the leaves of one
// bisection tree), so segments are taken one by one, spread over the cores.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "interval_eval.hpp"

namespace rdmesh {

struct SegmentRoots {
  // Root brackets and pending pieces: (segment, t0, t1), by segment, then t0.
  std::vector<std::int64_t> found_segment, pending_segment;
  std::vector<double> found_lo, found_hi, pending_lo, pending_hi;
  std::int64_t boxes = 0;  // interval evaluations (pieces and end points)
};

// Segments [a_i, b_i] (rows of 3), each searched on [t0_i, t1_i] (null t0,
// t1: on [0, 1]).  min_length: pieces this short or shorter are not halved.
// budget: pieces bounded per segment at most; the segment's unsettled pieces
// are pending once it is spent.  Checks the program.
SegmentRoots isolate_segment_roots(const std::vector<IntervalInstruction>& program,
                                   const double* a, const double* b, const double* t0,
                                   const double* t1, std::size_t n, double min_length,
                                   std::size_t budget);

// The parts of segments [a_i, b_i] inside boxes: segment i meets the boxes
// rows first[h]..first[h+1] of lo, hi, where h = host[i] (host -1: the whole
// segment, [0, 1]).  Each part [t0, t1] is widened by `slack` in t (rounding)
// and cut to [0, 1]; a segment's parts that meet are merged, so none overlap.
// Parts come by segment, then t0.
struct SegmentPieces {
  std::vector<std::int64_t> segment;
  std::vector<double> t0, t1;
};
SegmentPieces segment_pieces(const double* a, const double* b, const std::int64_t* host,
                             std::size_t n, const std::int64_t* first, const double* lo,
                             const double* hi, double slack);

}  // namespace rdmesh
