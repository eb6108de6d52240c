#include "sample_scan.hpp"

#include <algorithm>
#include <cmath>

namespace rdmesh {

SampleScan scan_samples(const std::int64_t* offsets, std::size_t K, const double* s,
                        const double* values, const double* ends, double dip_fraction) {
  SampleScan out;
  std::vector<double> v;  // one segment's values
  std::vector<std::uint8_t> dip;
  std::int64_t interior = 0;  // next interior value
  for (std::size_t k = 0; k < K; ++k) {
    const std::int64_t b = offsets[k], n = offsets[k + 1] - b;
    const double* x = s + b;
    v.resize(n);
    if (ends != nullptr) {
      v[0] = ends[2 * k];
      for (std::int64_t i = 1; i + 1 < n; ++i) v[i] = values[interior++];
      v[n - 1] = ends[2 * k + 1];
    } else {
      std::copy(values + b, values + b + n, v.begin());
    }
    const auto kk = static_cast<std::int64_t>(k);
    auto in = [&](std::int64_t i) { return v[i] < 0.0; };  // NaN: outside
    auto a = [&](std::int64_t i) { return std::abs(v[i]); };
    for (std::int64_t i = 0; i + 1 < n; ++i)
      if (in(i) != in(i + 1)) {
        out.seg.push_back(kk);
        out.lo.push_back(x[i]);
        out.hi.push_back(x[i + 1]);
        out.rising.push_back(in(i));
        out.f_lo.push_back(v[i]);
        out.f_hi.push_back(v[i + 1]);
      }
    dip.assign(n, 0);
    for (std::int64_t m = 1; m + 1 < n; ++m) {
      const double l = a(m - 1), c = a(m), r = a(m + 1);
      if (c < dip_fraction * std::max(l, r) && c < l && c < r && in(m - 1) == in(m) &&
          in(m) == in(m + 1)) {
        dip[m] = 1;
        out.dip_seg.push_back(kk);
        out.dip_x1.push_back(x[m - 1]);
        out.dip_x2.push_back(x[m]);
        out.dip_x3.push_back(x[m + 1]);
        out.dip_sign.push_back(in(m) ? -1.0 : 1.0);
      }
    }
    for (std::int64_t j = 0; j + 1 < n; ++j) {
      const double left = j >= 1 ? a(j - 1) : 0.0;
      const double right = j + 2 < n ? a(j + 2) : 0.0;
      // std::max(NaN, y) is NaN's first argument rule: written as numpy's
      // maximum, which propagates NaN, so a NaN neighbour keeps no valley.
      const double outer = (std::isnan(left) || std::isnan(right)) ? NAN : std::max(left, right);
      const double inner = (std::isnan(a(j)) || std::isnan(a(j + 1))) ? NAN : std::max(a(j), a(j + 1));
      if (inner < dip_fraction * outer && in(j) == in(j + 1) && !dip[j] && !dip[j + 1]) {
        out.val_seg.push_back(kk);
        out.val_lo.push_back(x[j]);
        out.val_hi.push_back(x[j + 1]);
        out.val_inside.push_back(in(j));
        out.val_a_lo.push_back(a(j));
        out.val_a_hi.push_back(a(j + 1));
      }
    }
  }
  return out;
}

}  // namespace rdmesh
