#include "segment_roots.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "on_cores.hpp"

namespace rdmesh {
namespace {

struct Piece {
  double t0, t1;
};

// The sign f's bounds prove (+1, -1), or 0.
int sign_of(const BoxBounds& e) {
  if (e.undefined) return 0;
  return e.lo > 0 ? 1 : (e.hi < 0 ? -1 : 0);
}

// Segments [begin, end): results in `out`, in segment order.
void isolate_range(const double* A, const double* B, const double* T0, const double* T1,
                   std::size_t begin, std::size_t end,
                   double min_length, std::size_t budget, BoxEvaluator& piece,
                   BoxEvaluator& point, SegmentRoots& out) {
  std::vector<Piece> stack;
  BoxBounds enc, e0, e1;
  for (std::size_t i = begin; i < end; ++i) {
    const double* a = A + 3 * i;
    const double* b = B + 3 * i;
    double d[3], length2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      d[k] = b[k] - a[k];
      length2 += d[k] * d[k];
    }
    const double length = std::sqrt(length2);
    std::size_t used = 0;
    stack.assign(1, T0 ? Piece{T0[i], T1[i]} : Piece{0.0, 1.0});
    while (!stack.empty()) {
      const Piece p = stack.back();
      stack.pop_back();
      double p0[3], p1[3], lo[3], hi[3];
      for (int k = 0; k < 3; ++k) {
        p0[k] = a[k] + p.t0 * d[k];
        p1[k] = a[k] + p.t1 * d[k];
        lo[k] = std::min(p0[k], p1[k]);
        hi[k] = std::max(p0[k], p1[k]);
      }
      piece.evaluate(lo, hi, enc);
      ++out.boxes;
      ++used;
      if (!(enc.lo <= 0 && enc.hi >= 0)) continue;
      piece.tighten(lo, hi, enc);  // the mean-value form, only where it decides
      if (!(enc.lo <= 0 && enc.hi >= 0)) continue;
      if (!enc.undefined && gradient_keeps_sign(enc, d)) {
        point.evaluate(p0, p0, e0);
        point.evaluate(p1, p1, e1);
        out.boxes += 2;
        const int s0 = sign_of(e0), s1 = sign_of(e1);
        if (s0 != 0 && s1 != 0) {
          if (s0 != s1) {
            out.found_segment.push_back(static_cast<std::int64_t>(i));
            out.found_lo.push_back(p.t0);
            out.found_hi.push_back(p.t1);
          }
          continue;
        }
      }
      if ((p.t1 - p.t0) * length <= min_length || used >= budget) {
        out.pending_segment.push_back(static_cast<std::int64_t>(i));
        out.pending_lo.push_back(p.t0);
        out.pending_hi.push_back(p.t1);
        continue;
      }
      const double mid = 0.5 * (p.t0 + p.t1);
      stack.push_back(Piece{mid, p.t1});
      stack.push_back(Piece{p.t0, mid});
    }
  }
}

// Segments per work item: threads take the next item as they go.
constexpr std::size_t kChunk = 256;

void append(SegmentRoots& to, const SegmentRoots& from) {
  const auto add = [](auto& x, const auto& y) { x.insert(x.end(), y.begin(), y.end()); };
  add(to.found_segment, from.found_segment);
  add(to.found_lo, from.found_lo);
  add(to.found_hi, from.found_hi);
  add(to.pending_segment, from.pending_segment);
  add(to.pending_lo, from.pending_lo);
  add(to.pending_hi, from.pending_hi);
  to.boxes += from.boxes;
}

}  // namespace

SegmentRoots isolate_segment_roots(const std::vector<IntervalInstruction>& program,
                                   const double* a, const double* b, const double* t0,
                                   const double* t1, std::size_t n, double min_length,
                                   std::size_t budget) {
  check_interval_program(program);
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<SegmentRoots> parts(chunks);
  struct Worker {
    BoxEvaluator piece, point;
  };
  for_each_on_cores(
      chunks,
      [&] { return Worker{BoxEvaluator(program, true, false), BoxEvaluator(program, false, false)}; },
      [&](Worker& w, std::size_t c) {
        isolate_range(a, b, t0, t1, c * kChunk, std::min(n, (c + 1) * kChunk), min_length, budget,
                      w.piece, w.point, parts[c]);
      });
  // Chunks in order: segments in order, and pieces by t0 within a segment
  // (depth first, lower half first).
  SegmentRoots out;
  for (const auto& p : parts) append(out, p);
  return out;
}

namespace {

// Segments [begin, end) of segment_pieces, into `out`.
void pieces_range(const double* a, const double* b, const std::int64_t* host, std::size_t begin,
                  std::size_t end, const std::int64_t* first, const double* lo, const double* hi,
                  double slack, SegmentPieces& out) {
  std::vector<Piece> parts;
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t i = begin; i < end; ++i) {
    const std::int64_t h = host[i];
    if (h < 0) {
      out.segment.push_back(static_cast<std::int64_t>(i));
      out.t0.push_back(0.0);
      out.t1.push_back(1.0);
      continue;
    }
    parts.clear();
    const double* p = a + 3 * i;
    double d[3];
    for (int k = 0; k < 3; ++k) d[k] = b[3 * i + k] - p[k];
    for (std::int64_t r = first[h]; r < first[h + 1]; ++r) {
      double t0 = -inf, t1 = inf;
      for (int k = 0; k < 3 && t0 <= t1; ++k) {
        const double l = lo[3 * r + k], u = hi[3 * r + k];
        if (d[k] == 0.0) {  // parallel to the slab: inside it or not at all
          if (p[k] < l || p[k] > u) t0 = inf;
          continue;
        }
        const double x = (l - p[k]) / d[k], y = (u - p[k]) / d[k];
        t0 = std::max(t0, std::min(x, y));
        t1 = std::min(t1, std::max(x, y));
      }
      t0 = std::max(t0 - slack, 0.0);
      t1 = std::min(t1 + slack, 1.0);
      if (t0 <= t1) parts.push_back(Piece{t0, t1});
    }
    std::sort(parts.begin(), parts.end(),
              [](const Piece& x, const Piece& y) { return x.t0 < y.t0; });
    for (std::size_t k = 0; k < parts.size();) {
      Piece m = parts[k];
      for (++k; k < parts.size() && parts[k].t0 <= m.t1; ++k) m.t1 = std::max(m.t1, parts[k].t1);
      out.segment.push_back(static_cast<std::int64_t>(i));
      out.t0.push_back(m.t0);
      out.t1.push_back(m.t1);
    }
  }
}

}  // namespace

SegmentPieces segment_pieces(const double* a, const double* b, const std::int64_t* host,
                             std::size_t n, const std::int64_t* first, const double* lo,
                             const double* hi, double slack) {
  // Chunks over the cores, joined in order: by segment, then t0.
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<SegmentPieces> parts(chunks);
  for_each_on_cores(
      chunks, [] { return 0; },
      [&](int&, std::size_t c) {
        pieces_range(a, b, host, c * kChunk, std::min(n, (c + 1) * kChunk), first, lo, hi, slack,
                     parts[c]);
      });
  SegmentPieces out;
  for (const auto& p : parts) {
    out.segment.insert(out.segment.end(), p.segment.begin(), p.segment.end());
    out.t0.insert(out.t0.end(), p.t0.begin(), p.t0.end());
    out.t1.insert(out.t1.end(), p.t1.begin(), p.t1.end());
  }
  return out;
}

}  // namespace rdmesh
