// Which boxes lie wholly outside the Voronoi cell of their owner sample: beyond
// the bisector plane of the owner and one of its Delaunay neighbours.  The cell
// pruning of the proven topological-ball tests (rdmesh.topology.proven_cells),
// one pass with an early exit per box instead of a numpy row per neighbour.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rdmesh {

// The bisector of sample p and a neighbour q: a box lies wholly beyond it
// when the least x . w over the box (w = q - p) exceeds limit (the bisector's
// offset plus the relative margin below).
struct CellPlane {
  double w[3];
  double limit;
};

// The bisectors of p and its neighbours other than skip (-1: none).
void cell_planes(std::int64_t p, std::int64_t skip, const double* points,
                 const std::int64_t* offsets, const std::int64_t* neighbour,
                 std::vector<CellPlane>& out);

// Whether the box [L, H] lies wholly beyond the plane.
inline bool box_beyond(const double* L, const double* H, const CellPlane& c) {
  double a = 0.0;
  for (int k = 0; k < 3; ++k) a += (c.w[k] > 0 ? L[k] : H[k]) * c.w[k];
  return a > c.limit;
}

// Whether the box [L, H] lies wholly beyond one of the planes.
inline bool box_beyond(const double* L, const double* H, const std::vector<CellPlane>& planes) {
  for (const CellPlane& c : planes)
    if (box_beyond(L, H, c)) return true;
  return false;
}

// Whether the box [L, H] lies wholly beyond the bisector of sample p and one
// of its neighbours other than skip (-1: none), as below.
bool box_outside_cell(const double* L, const double* H, std::int64_t p, std::int64_t skip,
                      const double* points, const std::int64_t* offsets,
                      const std::int64_t* neighbour);

// Box i is [lo_i, hi_i] (rows of 3), owned by sample owner[i]; the neighbours
// of sample p are neighbour[offsets[p] : offsets[p + 1]].  Neighbour skip[i]
// (when skip is not null) is not used for box i.  A box counts as outside only
// when its least value of x . (q - p) exceeds the bisector's by a relative
// margin of 1e-12, so rounding never drops a box that touches the cell.
std::vector<std::uint8_t> boxes_outside_cells(const double* lo, const double* hi,
                                              std::size_t n, const std::int64_t* owner,
                                              const std::int64_t* skip, const double* points,
                                              const std::int64_t* offsets,
                                              const std::int64_t* neighbour);

}  // namespace rdmesh
