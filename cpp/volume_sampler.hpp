// Tensor-product B-spline sampling of a 3-D volume (linear or cubic), with the
// exact gradient, for rdmesh.VolumeSurface.  No Python headers.
//
// The coefficients are those of scipy.ndimage: the samples themselves for
// degree 1, spline_filter(order=3, mode="mirror") for degree 3; beyond the
// grid they are mirrored about the end samples (mode "mirror").  A point is a
// world position; its sample coordinates are (p - origin) / spacing, clamped
// to the grid, so outside the grid the value is that of the nearest grid
// point and the gradient loses the components that point out of the grid.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace rdmesh {

class VolumeSampler {
 public:
  // coefficients: n0 * n1 * n2 values in C order; each n >= 2; degree 1 or 3.
  // Throws std::invalid_argument on bad sizes, degree, spacing.
  VolumeSampler(std::vector<double> coefficients, std::array<std::int64_t, 3> shape,
                int degree, std::array<double, 3> origin, std::array<double, 3> spacing);

  // values[i] at points[3i..3i+2]; gradient (3 per point) when not null.
  // Read-only: safe to call from several threads at once.
  void sample(const double* points, std::int64_t n, double* values, double* gradient) const;

  int degree() const { return degree_; }
  const std::array<std::int64_t, 3>& shape() const { return shape_; }
  const std::vector<double>& coefficients() const { return c_; }

 private:
  template <int K>
  void sample_k(const double* points, std::int64_t n, double* values, double* gradient) const;

  std::vector<double> c_;
  std::array<std::int64_t, 3> shape_;
  int degree_;
  std::array<double, 3> origin_, spacing_;
};

}  // namespace rdmesh
