#include "cell_boxes.hpp"

#include <cmath>
#include <vector>

namespace rdmesh {

namespace {

// The bisector of P and Q (pn = |P|): the offset of x . (Q - P) on it, with
// the relative margin, so rounding never drops a box that touches the cell.
CellPlane bisector(const double* P, const double* Q, double pn) {
  CellPlane c;
  double off = 0.0, ww = 0.0;
  for (int k = 0; k < 3; ++k) {
    c.w[k] = Q[k] - P[k];
    off += 0.5 * (P[k] + Q[k]) * c.w[k];
    ww += c.w[k] * c.w[k];
  }
  c.limit = off + 1e-12 * (std::fabs(off) + std::sqrt(ww) * pn);
  return c;
}

double norm3(const double* P) { return std::sqrt(P[0] * P[0] + P[1] * P[1] + P[2] * P[2]); }

}  // namespace

void cell_planes(std::int64_t p, std::int64_t skip, const double* points,
                 const std::int64_t* offsets, const std::int64_t* neighbour,
                 std::vector<CellPlane>& out) {
  out.clear();
  const double* P = points + 3 * p;
  const double pn = norm3(P);
  for (std::int64_t j = offsets[p]; j < offsets[p + 1]; ++j)
    if (neighbour[j] != skip) out.push_back(bisector(P, points + 3 * neighbour[j], pn));
}

bool box_outside_cell(const double* L, const double* H, std::int64_t p, std::int64_t skip,
                      const double* points, const std::int64_t* offsets,
                      const std::int64_t* neighbour) {
  // Plane by plane, stopping at the first that proves it.
  const double* P = points + 3 * p;
  const double pn = norm3(P);
  for (std::int64_t j = offsets[p]; j < offsets[p + 1]; ++j) {
    if (neighbour[j] == skip) continue;
    const CellPlane c = bisector(P, points + 3 * neighbour[j], pn);
    if (box_beyond(L, H, c)) return true;
  }
  return false;
}

std::vector<std::uint8_t> boxes_outside_cells(const double* lo, const double* hi,
                                              std::size_t n, const std::int64_t* owner,
                                              const std::int64_t* skip, const double* points,
                                              const std::int64_t* offsets,
                                              const std::int64_t* neighbour) {
  std::vector<std::uint8_t> out(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    out[i] = box_outside_cell(lo + 3 * i, hi + 3 * i, owner[i], skip ? skip[i] : -1, points,
                              offsets, neighbour);
  return out;
}

}  // namespace rdmesh
