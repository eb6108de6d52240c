// The subdivision behind the proven loop and silhouette tests
// (rdmesh.topology.proven_cells): each owner (a Voronoi facet or cell) starts
// from its box (or from the leaves of an earlier run on its cell, cut to
// that box), and a box is dropped when it cannot meet the owner's region
// (off the facet's plane, or wholly outside the sample's Voronoi cell), when
// 0 is not in the bounds of f over it, or when grad f . d keeps one sign over
// it (settled); other boxes are halved along their longest side.  An owner
// fails at its first unsettled box no longer than its floor (or once it has
// used its budget of boxes).  Whether an owner fails does not depend on the
// order the boxes are taken in: it fails when its tree holds such a box.
// Owners are independent, so they are spread over the cores.  On request the
// settled boxes are kept (the leaves where the gradient decided): with the
// failed owners' regions aside, they cover every zero of f in the region.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "interval_eval.hpp"

namespace rdmesh {

struct BoxProofInput {
  std::size_t n = 0;                      // owners
  const double* lo = nullptr;             // (n, 3) first boxes
  const double* hi = nullptr;             // (n, 3)
  const std::int64_t* cell = nullptr;     // (n,) the sample whose Voronoi cell holds the region
  const std::int64_t* skip = nullptr;     // (n,) a neighbour to leave out, or null
  const double* direction = nullptr;      // (n, 3) d of the settling test
  const double* plane = nullptr;          // (n, 4) unit normal and offset, or null
  const double* floor = nullptr;          // (n,) least box side
  const double* points = nullptr;         // samples (rows of 3)
  const std::int64_t* offsets = nullptr;  // CSR of each sample's Delaunay neighbours
  const std::int64_t* neighbour = nullptr;
  std::size_t budget = 0;                 // boxes bounded per owner at most
  bool leaves = false;                    // keep the boxes the gradient settled
  // Seeds, or null: where seeded[cell[i]], owner i starts instead from the
  // boxes rows seed_first[c]..seed_first[c+1] of seed_lo, seed_hi (c =
  // cell[i]; an earlier run's leaves of that cell) cut to its first box.
  const std::uint8_t* seeded = nullptr;
  const std::int64_t* seed_first = nullptr;
  const double* seed_lo = nullptr;
  const double* seed_hi = nullptr;
};

struct BoxProofResult {
  std::vector<std::uint8_t> failed;  // (n,)
  std::vector<double> lo, hi;        // (n, 3) a failed owner's unsettled box (else 0)
  std::vector<std::int64_t> boxes;   // (n,) boxes bounded per owner
  // With leaves: owner i's settled boxes are rows leaf_first[i]..leaf_first[i+1]
  // (none for a failed owner), in the order they were settled.
  std::vector<std::int64_t> leaf_first;
  std::vector<double> leaf_lo, leaf_hi;
};

// Checks the program; throws std::invalid_argument for a bad one.
BoxProofResult prove_boxes(const std::vector<IntervalInstruction>& program,
                           const BoxProofInput& in);

}  // namespace rdmesh
