// A finer level of a GridField's clearing, filled only in the cubes about
// the nodes where many dual segments went uncleared: near a thin part's
// core |f| is small and the coarse grid's nodes lie too far from a segment
// for it to clear anything (rdmesh.sampling.fine fills the cubes).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "grid_field.hpp"

namespace rdmesh {

class FineField {
 public:
  // The cube of a coarse node is the set of points nearest to it; a filled
  // cube holds f at the centres of its m^3 subcubes (side h / m) and one
  // bound on |grad f| over the cube and reach / 2 about it.  A node becomes
  // hot at its `threshold`-th miss (a segment near it that nothing cleared).
  // Throws std::invalid_argument for m < 1, threshold < 1 or reach < 0.
  FineField(const GridField& coarse, int m, std::uint32_t threshold, double reach);

  // Whether the filled cube of the node nearest the segment's middle clears
  // segment a -> b: |b - a| <= reach and its nearest subcube centre's |f|
  // exceeds min(cap, bound) times that centre's distance to every point of
  // the segment.  A middle in an unfilled cube counts a miss there.
  bool clears(const double* a, const double* b, double cap);

  // The nodes that became hot since the last call, in the order they did.
  std::vector<std::int64_t> take_hot();
  // The m^3 subcube centres of each node's cube (3 doubles each, C order).
  std::vector<double> points(const std::vector<std::int64_t>& nodes) const;
  // Fill the nodes' cubes: m^3 values each (as points orders them) and one
  // bound each.  Throws std::invalid_argument for a node off the grid.
  void fill(const std::vector<std::int64_t>& nodes, const double* values, const double* bounds);

  int subdivisions() const { return m_; }
  std::size_t filled() const { return bounds_.size(); }
  std::uint64_t cleared() const { return cleared_; }

 private:
  // Grid coordinates of node's subcube s (per axis, 0..m-1) centre.
  std::array<double, 3> centre(std::int64_t node, const std::array<std::int64_t, 3>& s) const;

  GridField coarse_;
  int m_;
  std::uint32_t threshold_;
  double reach_;
  std::vector<std::int32_t> cube_;     // per coarse node: its filled cube, or -1
  std::vector<std::uint32_t> misses_;  // per coarse node
  std::vector<std::int64_t> hot_;
  std::vector<double> values_, bounds_;
  std::uint64_t cleared_ = 0;
};

}  // namespace rdmesh
