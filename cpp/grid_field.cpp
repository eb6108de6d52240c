#include "grid_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rdmesh {

GridField::GridField(std::vector<double> values, const std::array<std::int64_t, 3>& n,
                     const std::array<double, 3>& centre, const std::array<double, 9>& rotation,
                     const std::array<double, 3>& offset, double h)
    : values_(std::move(values)), n_(n), centre_(centre), offset_(offset), rot_(rotation), h_(h) {
  if (n[0] < 1 || n[1] < 1 || n[2] < 1 ||
      static_cast<std::size_t>(n[0] * n[1] * n[2]) != values_.size())
    throw std::invalid_argument("the field's values must fill its grid");
  if (!(h > 0.0) || !std::isfinite(h)) throw std::invalid_argument("h must be positive and finite");
  for (double x : centre) if (!std::isfinite(x)) throw std::invalid_argument("non-finite centre");
  for (double x : offset) if (!std::isfinite(x)) throw std::invalid_argument("non-finite offset");
  for (double x : rotation) if (!std::isfinite(x)) throw std::invalid_argument("non-finite rotation");
}

bool GridField::node(const double* p, std::array<std::int64_t, 3>& ijk) const {
  const double d[3] = {p[0] - centre_[0], p[1] - centre_[1], p[2] - centre_[2]};
  for (int a = 0; a < 3; ++a) {
    // Column a of the rotation: the grid's axis a in world coordinates.
    const double local = d[0] * rot_[a] + d[1] * rot_[3 + a] + d[2] * rot_[6 + a];
    const double x = std::nearbyint((local + offset_[a]) / h_);
    if (!(x >= 0.0 && x < static_cast<double>(n_[a]))) return false;  // also NaN
    ijk[a] = static_cast<std::int64_t>(x);
  }
  return true;
}

double GridField::at(const double* p) const {
  std::array<std::int64_t, 3> q;
  if (!node(p, q)) return std::numeric_limits<double>::infinity();
  return values_[(q[0] * n_[1] + q[1]) * n_[2] + q[2]];
}

void GridField::raise(const double* p, double v, std::int64_t cells) {
  std::array<std::int64_t, 3> q;
  if (!node(p, q)) return;
  std::array<std::int64_t, 3> lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max<std::int64_t>(q[a] - cells, 0);
    hi[a] = std::min<std::int64_t>(q[a] + cells, n_[a] - 1);
  }
  for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
      for (std::int64_t k = lo[2]; k <= hi[2]; ++k) {
        double& x = values_[(i * n_[1] + j) * n_[2] + k];
        x = std::max(x, v);
      }
}

void GridField::segment_bounds(const double* seg, std::size_t k, double reach, double scale,
                               double cap, double* out) const {
  for (std::size_t i = 0; i < k; ++i) {
    const double* a = seg + 6 * i;
    const double* b = a + 3;
    const double d2 = (b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                      (b[2] - a[2]) * (b[2] - a[2]);
    out[i] = cap;
    if (d2 <= reach * reach) {
      const double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
      out[i] = std::min(cap, scale * at(mid));
    }
  }
}

bool GridField::nearest(const double* p, std::int64_t& index,
                        std::array<double, 3>& offset) const {
  const double d[3] = {p[0] - centre_[0], p[1] - centre_[1], p[2] - centre_[2]};
  std::array<std::int64_t, 3> q;
  for (int a = 0; a < 3; ++a) {
    const double u = (d[0] * rot_[a] + d[1] * rot_[3 + a] + d[2] * rot_[6 + a] + offset_[a]) / h_;
    const double x = std::nearbyint(u);
    if (!(x >= 0.0 && x < static_cast<double>(n_[a]))) return false;  // also NaN
    q[a] = static_cast<std::int64_t>(x);
    offset[a] = u - x;
  }
  index = (q[0] * n_[1] + q[1]) * n_[2] + q[2];
  return true;
}

std::array<double, 3> GridField::position(const std::array<std::int64_t, 3>& ijk) const {
  return point_at({static_cast<double>(ijk[0]), static_cast<double>(ijk[1]),
                   static_cast<double>(ijk[2])});
}

std::array<double, 3> GridField::point_at(const std::array<double, 3>& u) const {
  double local[3];
  for (int a = 0; a < 3; ++a) local[a] = h_ * u[a] - offset_[a];
  std::array<double, 3> p;
  for (int r = 0; r < 3; ++r)
    p[r] = centre_[r] + rot_[3 * r] * local[0] + rot_[3 * r + 1] * local[1] +
           rot_[3 * r + 2] * local[2];
  return p;
}

void GridField::clearing_values(const double* seg, std::size_t k, const double* bound,
                                double* out) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < k; ++i) {
    const double* a = seg + 6 * i;
    const double* b = a + 3;
    const double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
    out[i] = nan;
    std::array<std::int64_t, 3> q;
    if (!node(mid, q)) continue;
    const auto x = position(q);
    const double dm = std::sqrt((mid[0] - x[0]) * (mid[0] - x[0]) +
                                (mid[1] - x[1]) * (mid[1] - x[1]) +
                                (mid[2] - x[2]) * (mid[2] - x[2]));
    const double half = 0.5 * std::sqrt((b[0] - a[0]) * (b[0] - a[0]) +
                                        (b[1] - a[1]) * (b[1] - a[1]) +
                                        (b[2] - a[2]) * (b[2] - a[2]));
    const double v = values_[(q[0] * n_[1] + q[1]) * n_[2] + q[2]];
    if (std::abs(v) > bound[i] * (dm + half)) out[i] = v;  // NaN v or bound: not cleared
  }
}

}  // namespace rdmesh
