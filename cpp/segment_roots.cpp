#include "segment_roots.hpp"

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

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

// grad f . d keeps one sign over the box (intervals.dot_bounds, as in
// box_proofs.cpp).
bool monotone(const BoxBounds& g, const double* d) {
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

// Segments [begin, end): results in `out`, in segment order.
void isolate_range(const double* A, const double* B, std::size_t begin, std::size_t end,
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
    stack.assign(1, Piece{0.0, 1.0});
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
      if (!enc.undefined && monotone(enc, d)) {
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
                                   const double* a, const double* b, std::size_t n,
                                   double min_length, std::size_t budget) {
  check_interval_program(program);
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<SegmentRoots> parts(chunks);
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_lock;
  const auto work = [&]() {
    try {
      BoxEvaluator piece(program, true, false), point(program, false, false);
      for (std::size_t c = next++; c < chunks; c = next++)
        isolate_range(a, b, c * kChunk, std::min(n, (c + 1) * kChunk), min_length, budget,
                      piece, point, parts[c]);
    } catch (...) {  // rethrown below, never out of a thread
      const std::lock_guard<std::mutex> hold(error_lock);
      if (!error) error = std::current_exception();
      next = chunks;
    }
  };
  const std::size_t cores = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t threads_wanted = std::min<std::size_t>(cores, chunks);
  std::vector<std::thread> threads;
  for (std::size_t t = 1; t < threads_wanted; ++t) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  // Chunks in order: segments in order, and pieces by t0 within a segment
  // (depth first, lower half first).
  SegmentRoots out;
  for (const auto& p : parts) append(out, p);
  return out;
}

}  // namespace rdmesh
