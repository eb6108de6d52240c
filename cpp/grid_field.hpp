// A scalar field on the nodes of a rotated regular grid, looked up at the
// node nearest a point: rdmesh.sampling.screen keeps the local slopes of f
// seen on the seeding grid in one, and looks them up for every dual segment
// of a round (a numpy lookup cost a tenth of the run on cheap functions).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace rdmesh {

class GridField {
 public:
  // values: n[0] x n[1] x n[2] nodes, C order.  Node (i, j, k) lies at
  // centre + (h * (i, j, k) - offset) @ rotation^T (rotation row-major).
  // Throws std::invalid_argument for a wrong size, a non-finite frame or
  // h <= 0.
  GridField(std::vector<double> values, const std::array<std::int64_t, 3>& n,
            const std::array<double, 3>& centre, const std::array<double, 9>& rotation,
            const std::array<double, 3>& offset, double h);

  // The value at the node nearest to p; +inf off the grid.
  double at(const double* p) const;
  // Raises every node within `cells` steps (per axis) of p's nearest node
  // to at least v (nothing off the grid).
  void raise(const double* p, double v, std::int64_t cells);
  // For k segments (a, b), 6 doubles each: min(cap, scale * at((a + b) / 2))
  // where |b - a| <= reach, otherwise cap.
  void segment_bounds(const double* seg, std::size_t k, double reach, double scale, double cap,
                      double* out) const;

  // For k segments (a, b), 6 doubles each, with bounds L (k) on |grad f|,
  // where this field holds f: the value v at the node q nearest a segment's
  // middle when |v| > L * (|middle - q| + |b - a| / 2), so that no point of
  // the segment, all within that distance of q, can have f = 0; NaN where
  // not (or off the grid).
  void clearing_values(const double* seg, std::size_t k, const double* bound, double* out) const;

  // The node nearest p (its index in C order, false off the grid) and p's
  // offset from it in grid steps, each in [-1/2, 1/2].
  bool nearest(const double* p, std::int64_t& index, std::array<double, 3>& offset) const;
  // Where the point at grid coordinates u lies (node (i, j, k) at u = (i, j, k)).
  std::array<double, 3> point_at(const std::array<double, 3>& u) const;
  double spacing() const { return h_; }

  const std::vector<double>& values() const { return values_; }
  const std::array<std::int64_t, 3>& shape() const { return n_; }

 private:
  // p's nearest node, false off the grid.
  bool node(const double* p, std::array<std::int64_t, 3>& ijk) const;
  // Where node ijk lies.
  std::array<double, 3> position(const std::array<std::int64_t, 3>& ijk) const;

  std::vector<double> values_;
  std::array<std::int64_t, 3> n_;
  std::array<double, 3> centre_, offset_;
  std::array<double, 9> rot_;
  double h_;
};

}  // namespace rdmesh
