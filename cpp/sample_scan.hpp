// The sign scan of sampled segments: where f changes sign between neighbouring
// samples, and where |f| dips towards zero without changing sign (places a
// pair of crossings may hide).  One pass over the samples of many segments,
// so the crossing search's bookkeeping never loops over samples in Python
// (algorithm.md 5.2; rdmesh.sampling.roots).  Inside means f < 0.
#pragma once

#include <cstdint>
#include <vector>

namespace rdmesh {

struct SampleScan {
  // Sign changes: segment, the bracket [lo, hi], f going inside -> outside,
  // and f at lo and hi (so the root search need not evaluate it again).
  std::vector<std::int64_t> seg;
  std::vector<double> lo, hi;
  std::vector<std::uint8_t> rising;
  std::vector<double> f_lo, f_hi;
  // Dips: a sample m whose |f| is below dip_fraction x the larger of its two
  // neighbours' and below both, with one sign over all three: segment, the
  // three positions, and the sign of f (-1 inside, +1 outside).
  std::vector<std::int64_t> dip_seg;
  std::vector<double> dip_x1, dip_x2, dip_x3, dip_sign;
  // Valleys: an interval without a sign change, next to no dip sample, whose
  // two ends are both below dip_fraction x the larger |f| of its outer
  // neighbour samples (0 where the interval ends its segment): segment, the
  // interval, whether it is inside, |f| at both ends.
  std::vector<std::int64_t> val_seg;
  std::vector<double> val_lo, val_hi, val_a_lo, val_a_hi;
  std::vector<std::uint8_t> val_inside;
};

// Scans segments k = 0..K-1 whose samples are s[offsets[k] : offsets[k+1]].
// f at the samples: `values` (P) when `ends` is null; otherwise `values`
// holds the interior samples only (P - 2K, in order) and `ends` (2K) the
// values at each segment's start and end.
SampleScan scan_samples(const std::int64_t* offsets, std::size_t K, const double* s,
                        const double* values, const double* ends, double dip_fraction);

}  // namespace rdmesh
