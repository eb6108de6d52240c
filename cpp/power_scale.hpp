// Exact power-of-two scaling of coordinates before CGAL sees them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace rdmesh {

// Coordinates this far from 1 in magnitude (largest |x| of the mesh) are
// scaled by a power of two, exactly, before CGAL sees them: CGAL's ray casting
// adds unit-sized random directions to the query point (at 1e20 they vanish
// and it retries forever) and its exact fallback refuses the NaN that
// overflowing constructions give (GMP raises SIGFPE beyond about 1e100).
constexpr int kScaleExponent = 20;

// 2^-e for the exponent e of the largest |x| when it lies outside
// [2^-kScaleExponent, 2^kScaleExponent], else 1.
inline double power_of_two_scale(const std::vector<double>& xyz) {
  double big = 0.0;
  for (double x : xyz) big = std::max(big, std::abs(x));
  if (big == 0.0) return 1.0;
  const int e = std::ilogb(big);
  return std::abs(e) > kScaleExponent ? std::ldexp(1.0, -e) : 1.0;
}

// p (k points, or k segments as 2k points) in the mesh's scaled frame: p
// itself when the scale is 1, else a scaled copy in `store` (which may
// overflow: check it is finite before CGAL sees it).
inline const double* scaled(const double* p, std::size_t k, double scale,
                            std::vector<double>& store) {
  if (scale == 1.0) return p;
  store.assign(p, p + 3 * k);
  for (double& x : store) x *= scale;
  return store.data();
}

}  // namespace rdmesh
