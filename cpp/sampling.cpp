#include "sampling.hpp"

#include <algorithm>
#include <cmath>

namespace rdmesh {

void SegmentSamples::reserve(std::size_t segments, std::size_t per_segment) {
  offsets.reserve(offsets.size() + segments);
  s.reserve(s.size() + segments * per_segment);
  interior.reserve(interior.size() + 3 * segments * per_segment);
}

void SegmentSamples::add(const double* a, const double* b, const double* apex,
                         double rho, const SegmentSampling& spec) {
  const double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  // The order of operations of rdmesh._vectors.segment_directions, without
  // fused multiply-adds (CMakeLists.txt): the interior points a + s u then
  // have the bits of numpy's, where the root search evaluates f.
  const double len = std::sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]);
  const double div = len > 0.0 ? len : 1.0;
  const double u[3] = {d[0] / div, d[1] / div, d[2] / div};
  if (!(rho > 0.0) || !std::isfinite(rho)) rho = std::max(len, 1e-300);
  // Signed distance of the start from the facet's circumcentre along u.
  const double sigma0 = u[0] * (a[0] - apex[0]) + u[1] * (a[1] - apex[1]) +
                        u[2] * (a[2] - apex[2]);
  const double w0 = std::asinh(sigma0 / rho);
  const double w1 = std::asinh((sigma0 + len) / rho);
  const double want = std::ceil((w1 - w0) * spec.per_radius);
  // Clamped as doubles first: a huge per_radius can make `want` exceed int64.
  std::int64_t n = spec.max_intervals;
  if (want < static_cast<double>(spec.max_intervals))
    n = std::max(static_cast<std::int64_t>(std::max(want, 0.0)),
                 spec.min_intervals);
  if (len == 0.0) n = 1;
  s.push_back(0.0);
  // sinh(w0 + j dw) by the addition theorem: one expm1 per segment instead
  // of a sinh per sample (sinh w0 = sigma0 / rho exactly).
  const double dw = (w1 - w0) / static_cast<double>(n);
  const double em = std::expm1(dw);
  const double sh = 0.5 * (em + em / (1.0 + em));
  const double ch = 1.0 + 0.5 * em * em / (1.0 + em);
  double S = sigma0 / rho, C = std::sqrt(1.0 + S * S);
  for (std::int64_t j = 1; j < n; ++j) {
    const double S1 = S * ch + C * sh;
    C = C * ch + S * sh;
    S = S1;
    const double sj = std::clamp(rho * S - sigma0, 0.0, len);
    s.push_back(sj);
    for (int k = 0; k < 3; ++k) interior.push_back(a[k] + sj * u[k]);
  }
  s.push_back(len);
  offsets.push_back(static_cast<std::int64_t>(s.size()));
}

}  // namespace rdmesh
