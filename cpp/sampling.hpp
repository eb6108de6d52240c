// Sample positions along dual Voronoi segments, for the crossing search.
//
// A facet's dual line passes through its circumcentre c perpendicular to the
// facet; at signed distance sigma from c the empty ball through the facet's
// vertices has radius sqrt(rho^2 + sigma^2).  Samples evenly spaced in
// asinh(sigma / rho) are therefore spaced by about that radius (algorithm.md,
// 5.2): dense near the surface's own scale, sparse far away.
#pragma once

#include <cstdint>
#include <vector>

namespace rdmesh {

struct SegmentSampling {
  double per_radius = 1.0;          // samples per unit of asinh(sigma / rho)
  std::int64_t min_intervals = 3;
  std::int64_t max_intervals = 64;
};

// Flat samples of many segments: segment k's distances from its start are
// s[offsets[k] : offsets[k+1]] (first 0, last its length, increasing), and
// its interior sample points (all but the two ends) follow in `interior`.
struct SegmentSamples {
  std::vector<std::int64_t> offsets{0};
  std::vector<double> s;
  std::vector<double> interior;  // xyz

  // Appends segment a -> b of a facet with vertex `apex` and circumradius rho.
  void add(const double* a, const double* b, const double* apex, double rho,
           const SegmentSampling& spec);
  void reserve(std::size_t segments, std::size_t per_segment);
};

}  // namespace rdmesh
