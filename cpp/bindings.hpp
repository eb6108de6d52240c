// What the binding files share: array types, copies made while the GIL is
// held, numpy arrays that take over a vector's buffer, and the register
// functions of each family (called from module.cpp).
//
//   module.cpp              the module, CGAL's error handling, RestrictedDelaunay
//   bind_intervals.cpp      interval programs: evaluation, box proofs, root isolation
//   bind_sampling.cpp       dual segments: sampling and the sign scan
//   bind_mesh_distance.cpp  MeshDistance, PointMap
//   volume_sampler.cpp      VolumeSampler
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sampling.hpp"

namespace rdmesh::bind {

namespace py = pybind11;

using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IdArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
using FlagArray = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>;
using OpArray = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

// Copies an array's data while the GIL is held: once it is released, other
// Python threads may write to, resize or free the array.
template <typename T, typename A>
std::vector<T> copy_of(const A& a) {
  return std::vector<T>(a.data(), a.data() + a.size());
}

// Copies an (n, 3) array while the GIL is held.
inline std::vector<double> rows3(const InArray& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument(std::string(what) + " must have shape (n, 3)");
  return copy_of<double>(a);
}

// Hands the vector's buffer to numpy without a copy (the vector is left
// empty).  The unique_ptr owns the buffer until the capsule does, so a throw
// from either constructor frees it.
template <typename T>
py::array_t<T> to_numpy(std::vector<T>& v, std::vector<py::ssize_t> shape) {
  auto owner = std::make_unique<std::vector<T>>(std::move(v));
  T* data = owner->data();
  py::capsule free_when_done(owner.get(),
                             [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owner.release();
  return py::array_t<T>(std::move(shape), data, free_when_done);
}

// A 1-D array of the vector's length.
template <typename T>
py::array_t<T> to_numpy(std::vector<T>& v) {
  return to_numpy(v, {static_cast<py::ssize_t>(v.size())});
}

// The sampling of dual segments, checked.
SegmentSampling sampling_spec(double per_radius, std::int64_t lo, std::int64_t hi);

// ((k+1,) offsets, (P,) distances, (P - 2k, 3) interior points).
py::tuple samples_tuple(SegmentSamples& m);

void register_intervals(py::module_& m);       // bind_intervals.cpp
void register_sampling(py::module_& m);        // bind_sampling.cpp
void register_mesh_distance(py::module_& m);   // bind_mesh_distance.cpp
void register_hole_fill(py::module_& m);       // hole_fill.cpp

}  // namespace rdmesh::bind

void register_volume_sampler(pybind11::module_& m);  // volume_sampler.cpp
