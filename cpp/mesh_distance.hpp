// Distance, side and winding-number queries against a triangle mesh: the
// oracle behind rdmesh.MeshSurface.  No Python headers.
//
// Everything is built in the constructor (the AABB trees with their distance
// acceleration, the winding-number hierarchy); the queries are const and
// touch no shared mutable state, so several threads may query one object at
// once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace rdmesh {

class MeshDistance {
 public:
  // vertices: n x 3 doubles; faces: m x 3 vertex indices.  Throws
  // std::invalid_argument for an empty mesh, non-finite coordinates, indices
  // out of range or a mesh whose faces all have zero area.  With want_side,
  // also tries to build a CGAL Surface_mesh and its Side_of_triangle_mesh
  // oracle; that succeeds (has_side() true) only if the faces form a closed,
  // combinatorially manifold surface without degenerate faces that does not
  // intersect itself.  Without want_winding, the winding-number hierarchy is
  // not built (a third of the build on a 100,000-face mesh) and
  // winding_number throws std::logic_error.
  MeshDistance(const double* vertices, std::size_t n, const std::int64_t* faces, std::size_t m,
               bool want_side, bool want_winding = true);
  ~MeshDistance();
  MeshDistance(const MeshDistance&) = delete;
  MeshDistance& operator=(const MeshDistance&) = delete;

  // For k points p (k x 3): the unsigned distance, the closest point (k x 3)
  // and the index of the face it lies on (k), and with has_side() the side:
  // +1 outside, -1 inside, 0 on the surface (0 everywhere without
  // has_side()), from the angle-weighted pseudo-normal of the closest
  // feature (exact for the closed, oriented, non-self-intersecting meshes
  // that have a side oracle), and from Side_of_triangle_mesh where that is
  // too close to call.  Runs on the cores.
  void query(const double* p, std::size_t k, double* dist, double* closest, std::int64_t* face,
             std::int8_t* side) const;

  // With has_side(): the side of k points only (as in query); throws
  // std::logic_error without it.
  void side(const double* p, std::size_t k, std::int8_t* side) const;

  // Generalized winding number (Jacobson et al. 2013) of the faces at k
  // points: exact solid angles near each point, dipole approximations of far
  // clusters (Barill et al. 2018) beyond `beta` cluster radii.  Throws
  // std::logic_error when built without want_winding.
  void winding_number(const double* p, std::size_t k, double* w, double beta = 2.5) const;

  // Every face that k segments (a_i, b_i; k x 2 x 3 doubles) meet, found
  // with CGAL's exact do_intersect, as (segment, t, face) with the point
  // a + t (b - a), t in [0, 1], in segment order then by t then by face.  t is
  // NaN where the segment lies in (or almost in) the face's plane, or has
  // zero length.  Runs on the cores.
  void segment_hits(const double* ab, std::size_t k, std::vector<std::int64_t>& segment,
                    std::vector<double>& t, std::vector<std::int64_t>& face) const;

  // Pairs of intersecting faces (2 indices each, flattened) when the faces
  // form a closed manifold surface that intersects itself; empty otherwise.
  std::vector<std::int64_t> self_intersections() const;

  bool has_side() const;
  // Whether query() takes the side from the pseudo-normals (has_side() and
  // every face oriented outwards) rather than from ray casting.
  bool has_pseudo_normals() const;
  // Why has_side() is false ("" when it is true or was not asked for).
  const char* side_failure() const;
  std::size_t number_of_faces() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rdmesh
