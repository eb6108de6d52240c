// Tensor-product B-spline sampling of a 3-D volume; see volume_sampler.hpp.
// The binding (register_volume_sampler) is called from module.cpp.
#include "volume_sampler.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace rdmesh {

VolumeSampler::VolumeSampler(std::vector<double> coefficients, std::array<std::int64_t, 3> shape,
                             int degree, std::array<double, 3> origin,
                             std::array<double, 3> spacing)
    : c_(std::move(coefficients)), shape_(shape), degree_(degree), origin_(origin),
      spacing_(spacing) {
  if (degree != 1 && degree != 3) throw std::invalid_argument("degree must be 1 or 3");
  std::int64_t total = 1;
  for (int a = 0; a < 3; ++a) {
    if (shape[a] < 2) throw std::invalid_argument("the volume needs 2 samples per axis");
    if (!(spacing[a] > 0) || !std::isfinite(spacing[a]) || !std::isfinite(origin[a]))
      throw std::invalid_argument("spacing must be positive and finite, origin finite");
    total *= shape[a];
  }
  if (static_cast<std::int64_t>(c_.size()) != total)
    throw std::invalid_argument("coefficients do not match the shape");
}

namespace {

// Taps and weights along one axis for a point at world coordinate p.
template <int K>
struct Axis {
  std::int64_t index[K];
  double w[K], dw[K];
  bool outside;

  Axis(double p, double origin, double spacing, std::int64_t n) {
    double x = (p - origin) / spacing;
    const double top = static_cast<double>(n - 1);
    outside = !(x >= 0.0 && x <= top);  // NaN counts as outside
    x = std::isnan(x) ? 0.0 : std::min(std::max(x, 0.0), top);
    const std::int64_t i0 = std::min(static_cast<std::int64_t>(std::floor(x)), n - 2);
    const double t = x - static_cast<double>(i0);
    if constexpr (K == 2) {
      index[0] = i0;
      index[1] = i0 + 1;
      w[0] = 1.0 - t;
      w[1] = t;
      dw[0] = -1.0;
      dw[1] = 1.0;
    } else {
      for (int k = 0; k < 4; ++k) {
        std::int64_t j = std::abs(i0 - 1 + k);  // mirror about sample 0
        if (j > n - 1) j = 2 * (n - 1) - j;     // and about sample n - 1
        index[k] = j;
      }
      const double s = 1.0 - t, t2 = t * t, t3 = t2 * t;
      w[0] = s * s * s / 6.0;
      w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
      w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
      w[3] = t3 / 6.0;
      dw[0] = -0.5 * s * s;
      dw[1] = 1.5 * t2 - 2.0 * t;
      dw[2] = -1.5 * t2 + t + 0.5;
      dw[3] = 0.5 * t2;
    }
  }
};

}  // namespace

template <int K>
void VolumeSampler::sample_k(const double* points, std::int64_t n, double* values,
                             double* gradient) const {
  const std::int64_t n1 = shape_[1], n2 = shape_[2];
  for (std::int64_t i = 0; i < n; ++i) {
    const double* p = points + 3 * i;
    const Axis<K> ax(p[0], origin_[0], spacing_[0], shape_[0]);
    const Axis<K> ay(p[1], origin_[1], spacing_[1], shape_[1]);
    const Axis<K> az(p[2], origin_[2], spacing_[2], shape_[2]);
    // Contract z, then y, then x; the partial sums serve value and gradient.
    double b[K] = {}, by[K] = {}, bz[K] = {};
    for (int a = 0; a < K; ++a) {
      for (int j = 0; j < K; ++j) {
        const double* row = c_.data() + (ax.index[a] * n1 + ay.index[j]) * n2;
        double s = 0.0, sz = 0.0;
        for (int k = 0; k < K; ++k) {
          const double c = row[az.index[k]];
          s += c * az.w[k];
          sz += c * az.dw[k];
        }
        b[a] += s * ay.w[j];
        by[a] += s * ay.dw[j];
        bz[a] += sz * ay.w[j];
      }
    }
    double v = 0.0, gx = 0.0, gy = 0.0, gz = 0.0;
    for (int a = 0; a < K; ++a) {
      v += b[a] * ax.w[a];
      gx += b[a] * ax.dw[a];
      gy += by[a] * ax.w[a];
      gz += bz[a] * ax.w[a];
    }
    values[i] = v;
    if (gradient != nullptr) {
      double* g = gradient + 3 * i;
      g[0] = ax.outside ? 0.0 : gx / spacing_[0];
      g[1] = ay.outside ? 0.0 : gy / spacing_[1];
      g[2] = az.outside ? 0.0 : gz / spacing_[2];
    }
  }
}

void VolumeSampler::sample(const double* points, std::int64_t n, double* values,
                           double* gradient) const {
  if (degree_ == 1)
    sample_k<2>(points, n, values, gradient);
  else
    sample_k<4>(points, n, values, gradient);
}

}  // namespace rdmesh

namespace py = pybind11;

void register_volume_sampler(py::module_& m) {
  using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
  using rdmesh::VolumeSampler;
  py::class_<VolumeSampler>(m, "VolumeSampler",
                            "Cubic or linear B-spline of a 3-D volume with its exact "
                            "gradient (cpp/volume_sampler.hpp).")
      .def(py::init([](const InArray& coefficients, int degree, std::array<double, 3> origin,
                       std::array<double, 3> spacing) {
             if (coefficients.ndim() != 3)
               throw std::invalid_argument("coefficients must be a 3-D array");
             std::array<std::int64_t, 3> shape{coefficients.shape(0), coefficients.shape(1),
                                               coefficients.shape(2)};
             std::vector<double> c(coefficients.data(),
                                   coefficients.data() + coefficients.size());
             return VolumeSampler(std::move(c), shape, degree, origin, spacing);
           }),
           py::arg("coefficients"), py::arg("degree"), py::arg("origin"), py::arg("spacing"),
           "Copies the coefficients (C order; for degree 3 from "
           "scipy.ndimage.spline_filter(order=3, mode='mirror')).")
      .def(
          "sample",
          [](const VolumeSampler& self, const InArray& points, bool gradient) {
            if (points.ndim() != 2 || points.shape(1) != 3)
              throw std::invalid_argument("points must have shape (n, 3)");
            const py::ssize_t n = points.shape(0);
            std::vector<double> p(points.data(), points.data() + points.size());
            py::array_t<double> values(n);
            py::object grad = py::none();
            double* g = nullptr;
            if (gradient) {
              py::array_t<double> ga({n, static_cast<py::ssize_t>(3)});
              g = ga.mutable_data();
              grad = std::move(ga);
            }
            double* v = values.mutable_data();
            {
              py::gil_scoped_release release;
              self.sample(p.data(), n, v, g);
            }
            return py::make_tuple(values, grad);
          },
          py::arg("points"), py::arg("gradient") = false,
          "(values (n,), gradient (n, 3) or None) at world points (n, 3); the GIL "
          "is released while sampling.")
      .def(
          "coefficients",
          [](const VolumeSampler& self) {
            const auto& s = self.shape();
            py::array_t<double> out({s[0], s[1], s[2]});
            std::copy(self.coefficients().begin(), self.coefficients().end(),
                      out.mutable_data());
            return out;
          },
          "A copy of the coefficients, (n0, n1, n2) float64 (for degree 1 the samples).")
      .def_property_readonly("degree", &VolumeSampler::degree)
      .def_property_readonly("shape", [](const VolumeSampler& self) {
        const auto& s = self.shape();
        return py::make_tuple(s[0], s[1], s[2]);
      });
}
