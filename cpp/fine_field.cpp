#include "fine_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rdmesh {

FineField::FineField(const GridField& coarse, int m, std::uint32_t threshold, double reach)
    : coarse_(coarse), m_(m), threshold_(threshold), reach_(reach) {
  if (m < 1 || m > 16) throw std::invalid_argument("subdivisions must be in 1..16");
  if (threshold < 1) throw std::invalid_argument("threshold must be >= 1");
  if (!(reach >= 0.0) || !std::isfinite(reach))
    throw std::invalid_argument("reach must be finite and >= 0");
  const auto& n = coarse.shape();
  const std::size_t nodes = static_cast<std::size_t>(n[0] * n[1] * n[2]);
  cube_.assign(nodes, -1);
  misses_.assign(nodes, 0);
}

bool FineField::clears(const double* a, const double* b, double cap) {
  const double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
  std::int64_t node;
  std::array<double, 3> t;
  if (!coarse_.nearest(mid, node, t)) return false;
  const std::int32_t cube = cube_[static_cast<std::size_t>(node)];
  if (cube < 0) {
    if (++misses_[static_cast<std::size_t>(node)] == threshold_) hot_.push_back(node);
    return false;
  }
  const double len = std::sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                               (b[2] - a[2]) * (b[2] - a[2]));
  if (!(len <= reach_)) return false;
  // The subcube holding the middle.
  std::array<std::int64_t, 3> s;
  std::size_t sub = 0;
  for (int k = 0; k < 3; ++k) {
    s[k] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((t[k] + 0.5) * m_)), 0,
                                    m_ - 1);
    sub = sub * static_cast<std::size_t>(m_) + static_cast<std::size_t>(s[k]);
  }
  const auto x = coarse_.point_at(centre(node, s));
  const double dm = std::sqrt((mid[0] - x[0]) * (mid[0] - x[0]) +
                              (mid[1] - x[1]) * (mid[1] - x[1]) +
                              (mid[2] - x[2]) * (mid[2] - x[2]));
  const std::size_t per = static_cast<std::size_t>(m_) * m_ * m_;
  const double v = values_[static_cast<std::size_t>(cube) * per + sub];
  const double bound = std::min(cap, bounds_[static_cast<std::size_t>(cube)]);
  if (std::abs(v) > bound * (dm + 0.5 * len)) {  // NaN v or bound: not cleared
    ++cleared_;
    return true;
  }
  return false;
}

std::vector<std::int64_t> FineField::take_hot() {
  std::vector<std::int64_t> out;
  out.swap(hot_);
  return out;
}

std::vector<double> FineField::points(const std::vector<std::int64_t>& nodes) const {
  const auto& n = coarse_.shape();
  const std::int64_t total = n[0] * n[1] * n[2];
  std::vector<double> out;
  out.reserve(nodes.size() * 3 * static_cast<std::size_t>(m_ * m_ * m_));
  for (std::int64_t node : nodes) {
    if (node < 0 || node >= total) throw std::invalid_argument("node off the grid");
    for (std::int64_t i = 0; i < m_; ++i)
      for (std::int64_t j = 0; j < m_; ++j)
        for (std::int64_t k = 0; k < m_; ++k) {
          const auto x = coarse_.point_at(centre(node, {i, j, k}));
          out.insert(out.end(), x.begin(), x.end());
        }
  }
  return out;
}

std::array<double, 3> FineField::centre(std::int64_t node,
                                        const std::array<std::int64_t, 3>& s) const {
  const auto& n = coarse_.shape();
  const std::array<std::int64_t, 3> ijk{node / (n[1] * n[2]), (node / n[2]) % n[1], node % n[2]};
  std::array<double, 3> u;
  for (int a = 0; a < 3; ++a)
    u[a] = static_cast<double>(ijk[a]) - 0.5 + (static_cast<double>(s[a]) + 0.5) / m_;
  return u;
}

void FineField::fill(const std::vector<std::int64_t>& nodes, const double* values,
                     const double* bounds) {
  const auto& n = coarse_.shape();
  const std::int64_t total = n[0] * n[1] * n[2];
  for (std::int64_t node : nodes)
    if (node < 0 || node >= total) throw std::invalid_argument("node off the grid");
  const std::size_t per = static_cast<std::size_t>(m_) * m_ * m_;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    std::int32_t& cube = cube_[static_cast<std::size_t>(nodes[i])];
    if (cube < 0) {
      if (bounds_.size() >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::length_error("too many filled cubes");
      cube = static_cast<std::int32_t>(bounds_.size());
      bounds_.push_back(bounds[i]);
      values_.insert(values_.end(), values + i * per, values + (i + 1) * per);
    } else {  // filled again: the new values
      bounds_[static_cast<std::size_t>(cube)] = bounds[i];
      std::copy(values + i * per, values + (i + 1) * per,
                values_.begin() + static_cast<std::ptrdiff_t>(cube) * static_cast<std::ptrdiff_t>(per));
    }
  }
}

}  // namespace rdmesh
