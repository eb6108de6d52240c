// Edge and fan counts of a triangle set (rdmesh.topology.complex_status).
#pragma once

#include <cstdint>
#include <vector>

namespace rdmesh {

struct ComplexCounts {
  std::vector<std::int64_t> edge_key;    // (E,) min * n + max, ascending
  std::vector<std::int64_t> edge_count;  // (E,) faces per edge
  std::vector<std::int32_t> face_edges;  // (F, 3) edges ab, bc, ca of each face
  std::vector<std::int64_t> vertex_fans; // (n,) fans of faces around each vertex
};

// Faces are (F, 3) vertex ids in [0, n), three distinct per face (checked).
// Linear time: edges are bucketed by their smaller end, and a fan is a
// union-find class of spokes (an edge seen from one end) joined at each corner.
ComplexCounts complex_counts(const std::int64_t* faces, std::size_t F, std::int64_t n);

}  // namespace rdmesh
