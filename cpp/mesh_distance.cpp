// Distance, side and winding-number queries against a triangle mesh (see
// mesh_distance.hpp).
#include "mesh_distance.hpp"
#include "power_scale.hpp"

#include "on_cores.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include <algorithm>
#include <atomic>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace rdmesh {

namespace {

using K = CGAL::Epick;
using Point = K::Point_3;
using Triangle = K::Triangle_3;
using Soup = std::vector<Triangle>;
using SoupPrimitive = CGAL::AABB_triangle_primitive<K, Soup::const_iterator>;
using SoupTree = CGAL::AABB_tree<CGAL::AABB_traits<K, SoupPrimitive>>;
using Mesh = CGAL::Surface_mesh<Point>;
using MeshPrimitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
using MeshTree = CGAL::AABB_tree<CGAL::AABB_traits<K, MeshPrimitive>>;
using Side = CGAL::Side_of_triangle_mesh<Mesh, K, CGAL::Default, MeshTree>;

constexpr double kFourPi = 4.0 * 3.14159265358979323846;

using Vec = std::array<double, 3>;

inline Vec sub(const double* a, const double* b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm(const Vec& a) { return std::sqrt(dot(a, a)); }

// A node of the winding-number hierarchy: a cluster of faces with the
// centre and radius of a ball holding them and their summed area vector.
struct WNode {
  Vec centre{};
  double radius = 0.0;
  Vec area{};  // sum of (b - a) x (c - a) / 2
  std::int32_t left = -1, right = -1;
  std::int32_t begin = 0, end = 0;  // faces order[begin:end] (leaves)
};

constexpr std::int32_t kLeafSize = 8;

// Queries at non-finite points would send CGAL's ray casting into endless
// retries; refuse them up front.
void check_finite(const double* p, std::size_t k, const char* where = "") {
  for (std::size_t i = 0; i < 3 * k; ++i)
    if (!std::isfinite(p[i]))
      throw std::invalid_argument("query point " + std::to_string(i / 3) + " is not finite" +
                                  where);
}

// The second check, in the mesh's scaled frame (power_scale.hpp).
constexpr const char* kScaled = " scaled to the mesh's size (it is too far from so small a mesh)";

}  // namespace

struct MeshDistance::Impl {
  double scale = 1.0;               // xyz = the user's coordinates times scale (a power of 2)
  std::vector<double> xyz;          // n x 3
  std::vector<std::int64_t> tri;    // m x 3
  Soup soup;                        // non-degenerate faces
  std::vector<std::int64_t> soup_face;  // their indices in tri
  SoupTree tree;
  std::unique_ptr<Mesh> mesh;
  std::unique_ptr<MeshTree> mesh_tree;
  std::unique_ptr<Side> side;
  std::string side_failure;
  std::vector<WNode> nodes;
  std::vector<std::int32_t> order;  // faces (indices into tri) in hierarchy order
  // Angle-weighted pseudo-normals (Baerentzen and Aanaes 2005), built with the
  // side oracle: per face, per edge (opposite each corner) and per vertex.
  std::vector<Vec> face_normal;
  std::vector<std::array<Vec, 3>> edge_normal;
  std::vector<Vec> vertex_normal;
  bool pseudo = false;  // the pseudo-normals give the side (faces oriented outwards)
  // Pairs of faces that intersect (a bounded number), when the mesh does.
  std::vector<std::pair<std::int64_t, std::int64_t>> crossing_faces;

  const double* vertex(std::int64_t i) const { return &xyz[3 * static_cast<std::size_t>(i)]; }

  // k query points p, checked finite, in the mesh's scaled frame (a copy in
  // `store` when scaled, checked again: a far point of a tiny mesh overflows).
  const double* in_frame(const double* p, std::size_t k, std::vector<double>& store) const {
    check_finite(p, k);
    const double* q = scaled(p, k, scale, store);
    if (q != p) check_finite(q, k, kScaled);
    return q;
  }

  double solid_angle(std::int64_t f, const double* p) const {
    const Vec a = sub(vertex(tri[3 * f]), p), b = sub(vertex(tri[3 * f + 1]), p),
              c = sub(vertex(tri[3 * f + 2]), p);
    const double la = norm(a), lb = norm(b), lc = norm(c);
    const double num = dot(a, cross(b, c));
    const double den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    if (num == 0.0 && den <= 0.0) return 0.0;  // p on the face's plane, outside or on it
    return 2.0 * std::atan2(num, den);
  }

  std::int32_t build(std::int32_t begin, std::int32_t end, const std::vector<Vec>& centroid,
                     const std::vector<Vec>& area) {
    WNode node;
    node.begin = begin;
    node.end = end;
    double total = 0.0;
    Vec c{0, 0, 0};
    for (std::int32_t i = begin; i < end; ++i) {
      const auto f = order[i];
      const double w = norm(area[f]) + 1e-300;
      total += w;
      for (int d = 0; d < 3; ++d) {
        c[d] += w * centroid[f][d];
        node.area[d] += area[f][d];
      }
    }
    for (int d = 0; d < 3; ++d) c[d] /= total;
    node.centre = c;
    for (std::int32_t i = begin; i < end; ++i)
      for (int j = 0; j < 3; ++j)
        node.radius = std::max(node.radius, norm(sub(vertex(tri[3 * order[i] + j]), c.data())));
    const auto id = static_cast<std::int32_t>(nodes.size());
    nodes.push_back(node);
    if (end - begin > kLeafSize) {
      Vec lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
      for (std::int32_t i = begin; i < end; ++i)
        for (int d = 0; d < 3; ++d) {
          lo[d] = std::min(lo[d], centroid[order[i]][d]);
          hi[d] = std::max(hi[d], centroid[order[i]][d]);
        }
      int axis = 0;
      for (int d = 1; d < 3; ++d)
        if (hi[d] - lo[d] > hi[axis] - lo[axis]) axis = d;
      const std::int32_t mid = begin + (end - begin) / 2;
      std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                       [&](std::int32_t a, std::int32_t b) {
                         return centroid[a][axis] < centroid[b][axis] ||
                                (centroid[a][axis] == centroid[b][axis] && a < b);
                       });
      const std::int32_t l = build(begin, mid, centroid, area);
      const std::int32_t r = build(mid, end, centroid, area);
      nodes[id].left = l;
      nodes[id].right = r;
    }
    return id;
  }

  double winding(const double* p, double beta) const {
    double omega = 0.0;
    std::int32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const WNode& node = nodes[stack[--top]];
      const Vec d = sub(node.centre.data(), p);
      const double r = norm(d);
      if (r > beta * node.radius) {
        omega += dot(node.area, d) / (r * r * r);  // dipole of the cluster
      } else if (node.left < 0 || top + 2 > 128) {
        for (std::int32_t i = node.begin; i < node.end; ++i) omega += solid_angle(order[i], p);
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
    return omega / kFourPi;
  }

  void try_side() {
    mesh = std::make_unique<Mesh>();
    const std::size_t n = xyz.size() / 3, m = tri.size() / 3;
    if (soup.size() != m) {
      side_failure = "the mesh has faces of zero area";
      mesh.reset();
      return;
    }
    std::vector<Mesh::Vertex_index> v(n);
    for (std::size_t i = 0; i < n; ++i)
      v[i] = mesh->add_vertex(Point(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
    for (std::size_t f = 0; f < m; ++f) {
      const auto a = v[tri[3 * f]], b = v[tri[3 * f + 1]], c = v[tri[3 * f + 2]];
      if (a == b || b == c || a == c || mesh->add_face(a, b, c) == Mesh::null_face()) {
        side_failure = "the faces do not form a manifold surface";
        mesh.reset();
        return;
      }
    }
    if (!CGAL::is_closed(*mesh)) {
      side_failure = "the mesh has boundary edges";
      mesh.reset();
      return;
    }
    if (CGAL::Polygon_mesh_processing::does_self_intersect(*mesh)) {
      side_failure = "the mesh intersects itself";
      find_crossings();
      mesh.reset();
      return;
    }
    mesh_tree = std::make_unique<MeshTree>(faces(*mesh).first, faces(*mesh).second, *mesh);
    mesh_tree->build();
    side = std::make_unique<Side>(*mesh_tree);
    build_pseudo_normals();
  }

  // The intersecting face pairs of a closed mesh (the faces of *mesh were
  // added in the order of tri, so face indices are tri's).
  void find_crossings() {
    std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> pairs;
    CGAL::Polygon_mesh_processing::self_intersections(*mesh, std::back_inserter(pairs));
    crossing_faces.reserve(pairs.size());
    for (const auto& fp : pairs)
      crossing_faces.emplace_back(static_cast<std::int64_t>(fp.first.idx()),
                                  static_cast<std::int64_t>(fp.second.idx()));
  }

  // For a closed, consistently oriented mesh without self-intersections, the
  // sign of (p - c) . n at the closest point c, with n the angle-weighted
  // pseudo-normal of the feature (face, edge or vertex) c lies on, is the side
  // of p (Baerentzen and Aanaes, IEEE TVCG 11(3), 2005).
  void build_pseudo_normals() {
    const std::size_t n = xyz.size() / 3, m = tri.size() / 3;
    face_normal.assign(m, Vec{0, 0, 0});
    vertex_normal.assign(n, Vec{0, 0, 0});
    edge_normal.assign(m, {Vec{0, 0, 0}, Vec{0, 0, 0}, Vec{0, 0, 0}});
    for (std::size_t f = 0; f < m; ++f) {
      const double* v[3] = {vertex(tri[3 * f]), vertex(tri[3 * f + 1]), vertex(tri[3 * f + 2])};
      Vec x = cross(sub(v[1], v[0]), sub(v[2], v[0]));
      const double l = norm(x);
      for (double& c : x) c /= l;
      face_normal[f] = x;
      for (int k = 0; k < 3; ++k) {
        const Vec e1 = sub(v[(k + 1) % 3], v[k]), e2 = sub(v[(k + 2) % 3], v[k]);
        const double angle = std::atan2(norm(cross(e1, e2)), dot(e1, e2));
        auto& vn = vertex_normal[static_cast<std::size_t>(tri[3 * f + k])];
        for (int d = 0; d < 3; ++d) vn[d] += angle * x[d];
      }
    }
    // Each edge has exactly two faces (closed manifold): its pseudo-normal is their sum.
    std::unordered_map<std::uint64_t, std::pair<std::size_t, int>> first;
    first.reserve(3 * m);
    for (std::size_t f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) {
        std::uint64_t a = static_cast<std::uint64_t>(tri[3 * f + (k + 1) % 3]),
                      b = static_cast<std::uint64_t>(tri[3 * f + (k + 2) % 3]);
        if (a > b) std::swap(a, b);
        const std::uint64_t key = a * static_cast<std::uint64_t>(n) + b;
        const auto it = first.find(key);
        if (it == first.end()) {
          first.emplace(key, std::make_pair(f, k));
          continue;
        }
        const auto [g, j] = it->second;
        Vec sum{};
        for (int d = 0; d < 3; ++d) sum[d] = face_normal[f][d] + face_normal[g][d];
        edge_normal[f][k] = sum;
        edge_normal[g][j] = sum;
      }
    // The pseudo-normals assume every face's normal points out of what it
    // bounds. Check each face against the ray-casting oracle just in front of
    // it; one face the other way round (a component oriented against the
    // rest) and the oracle stays ray casting.
    std::atomic<bool> outward{true};
    const std::size_t blocks = (m + 1023) / 1024;
    for_each_on_cores(blocks, [] { return 0; }, [&](int, std::size_t blk) {
      for (std::size_t f = blk * 1024; f < std::min(m, (blk + 1) * 1024) && outward; ++f) {
        const double* v[3] = {vertex(tri[3 * f]), vertex(tri[3 * f + 1]), vertex(tri[3 * f + 2])};
        const Vec x = cross(sub(v[1], v[0]), sub(v[2], v[0]));
        const double step = 1e-6 * std::sqrt(norm(x));
        double q[3];
        for (int d = 0; d < 3; ++d)
          q[d] = (v[0][d] + v[1][d] + v[2][d]) / 3.0 + step * face_normal[f][d];
        if ((*side)(Point(q[0], q[1], q[2])) == CGAL::ON_BOUNDED_SIDE) outward = false;
      }
    });
    pseudo = outward;
    if (!pseudo) {
      face_normal.clear();
      edge_normal.clear();
      vertex_normal.clear();
    }
  }

  // +1 outside, -1 inside, 0 on the surface, for q with closest point c on
  // face f; falls back to the ray-casting oracle where the pseudo-normal's
  // answer is too close to call.
  std::int8_t pseudo_side(const Point& q, const Point& c, std::size_t f) const {
    const double p[3] = {q.x(), q.y(), q.z()}, cc[3] = {c.x(), c.y(), c.z()};
    const Vec d = sub(p, cc);
    const double dn = norm(d);
    if (dn == 0.0) return 0;
    const double* v[3] = {vertex(tri[3 * f]), vertex(tri[3 * f + 1]), vertex(tri[3 * f + 2])};
    // Barycentric coordinates of c, to tell face, edge or vertex.
    const Vec e0 = sub(v[1], v[0]), e1 = sub(v[2], v[0]), w = sub(cc, v[0]);
    const double d00 = dot(e0, e0), d01 = dot(e0, e1), d11 = dot(e1, e1);
    const double d20 = dot(w, e0), d21 = dot(w, e1);
    const double den = d00 * d11 - d01 * d01;
    const double l1 = (d11 * d20 - d01 * d21) / den, l2 = (d00 * d21 - d01 * d20) / den;
    const double lam[3] = {1.0 - l1 - l2, l1, l2};
    constexpr double tol = 1e-9;
    int small = 0, which = -1, big = 0;
    for (int k = 0; k < 3; ++k) {
      if (lam[k] < tol) {
        ++small;
        which = k;
      } else {
        big = k;
      }
    }
    const Vec* n = &face_normal[f];
    if (small == 1) n = &edge_normal[f][static_cast<std::size_t>(which)];
    if (small >= 2) n = &vertex_normal[static_cast<std::size_t>(tri[3 * f + big])];
    const double s = dot(d, *n);
    if (std::abs(s) > 1e-6 * dn * norm(*n)) return s > 0 ? 1 : -1;
    const CGAL::Bounded_side b = (*side)(q);
    return b == CGAL::ON_UNBOUNDED_SIDE ? 1 : (b == CGAL::ON_BOUNDED_SIDE ? -1 : 0);
  }
};

MeshDistance::MeshDistance(const double* vertices, std::size_t n, const std::int64_t* faces,
                           std::size_t m, bool want_side, bool want_winding)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  if (n == 0) throw std::invalid_argument("the mesh has no vertices");
  if (m == 0) throw std::invalid_argument("the mesh has no faces");
  if (m > static_cast<std::size_t>(INT32_MAX / 2))
    throw std::invalid_argument("the mesh has too many faces");
  s.xyz.assign(vertices, vertices + 3 * n);
  s.tri.assign(faces, faces + 3 * m);
  for (double x : s.xyz)
    if (!std::isfinite(x)) throw std::invalid_argument("the mesh has a non-finite vertex coordinate");
  s.scale = power_of_two_scale(s.xyz);
  if (s.scale != 1.0)
    for (double& x : s.xyz) x *= s.scale;
  for (std::int64_t i : s.tri)
    if (i < 0 || static_cast<std::size_t>(i) >= n)
      throw std::invalid_argument("a face refers to a vertex index out of range");

  std::vector<Vec> centroid(m), area(m);
  s.soup.reserve(m);
  for (std::size_t f = 0; f < m; ++f) {
    const double *a = s.vertex(s.tri[3 * f]), *b = s.vertex(s.tri[3 * f + 1]),
                 *c = s.vertex(s.tri[3 * f + 2]);
    const Vec e1 = sub(b, a), e2 = sub(c, a), x = cross(e1, e2);
    area[f] = {0.5 * x[0], 0.5 * x[1], 0.5 * x[2]};
    for (int d = 0; d < 3; ++d) centroid[f][d] = (a[d] + b[d] + c[d]) / 3.0;
    const Triangle t(Point(a[0], a[1], a[2]), Point(b[0], b[1], b[2]), Point(c[0], c[1], c[2]));
    if (!t.is_degenerate()) {
      s.soup.push_back(t);
      s.soup_face.push_back(static_cast<std::int64_t>(f));
    }
  }
  if (s.soup.empty()) throw std::invalid_argument("every face of the mesh has zero area");

  s.tree.insert(s.soup.cbegin(), s.soup.cend());
  s.tree.build();
  s.tree.accelerate_distance_queries();
  // One query now, so that nothing is left to build lazily by a query.
  (void)s.tree.closest_point(s.soup.front().vertex(0));

  if (want_winding) {
    s.order.resize(m);
    std::iota(s.order.begin(), s.order.end(), 0);
    s.nodes.reserve(2 * (m / kLeafSize + 1));
    s.build(0, static_cast<std::int32_t>(m), centroid, area);
  }

  if (want_side) s.try_side();
  if (s.side) (void)(*s.side)(s.soup.front().vertex(0));
}

MeshDistance::~MeshDistance() = default;

namespace {
// Queries run on the cores in blocks of this many points.
constexpr std::size_t kBlock = 512;
}  // namespace

void MeshDistance::query(const double* p_user, std::size_t k, double* dist, double* closest,
                         std::int64_t* face, std::int8_t* side) const {
  const Impl& s = *impl_;
  std::vector<double> store;
  const double* p = s.in_frame(p_user, k, store);
  const double back = 1.0 / s.scale;  // exact: a power of two
  const std::size_t blocks = (k + kBlock - 1) / kBlock;
  for_each_on_cores(blocks, [] { return 0; }, [&](int, std::size_t blk) {
    for (std::size_t i = blk * kBlock; i < std::min(k, (blk + 1) * kBlock); ++i) {
      const Point q(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
      const auto hit = s.tree.closest_point_and_primitive(q);
      const Point& c = hit.first;
      closest[3 * i] = c.x() * back;
      closest[3 * i + 1] = c.y() * back;
      closest[3 * i + 2] = c.z() * back;
      dist[i] = std::sqrt(CGAL::squared_distance(q, c)) * back;
      const auto f = s.soup_face[static_cast<std::size_t>(hit.second - s.soup.cbegin())];
      face[i] = f;
      if (s.pseudo) {
        side[i] = s.pseudo_side(q, c, static_cast<std::size_t>(f));
      } else if (s.side) {
        const CGAL::Bounded_side b = (*s.side)(q);
        side[i] = b == CGAL::ON_UNBOUNDED_SIDE ? 1 : (b == CGAL::ON_BOUNDED_SIDE ? -1 : 0);
      } else {
        side[i] = 0;
      }
    }
  });
}

void MeshDistance::side(const double* p_user, std::size_t k, std::int8_t* side) const {
  const Impl& s = *impl_;
  if (!s.side) throw std::logic_error("this mesh has no side oracle: " + s.side_failure);
  std::vector<double> store;
  const double* p = s.in_frame(p_user, k, store);
  const std::size_t blocks = (k + kBlock - 1) / kBlock;
  for_each_on_cores(blocks, [] { return 0; }, [&](int, std::size_t blk) {
    for (std::size_t i = blk * kBlock; i < std::min(k, (blk + 1) * kBlock); ++i) {
      const CGAL::Bounded_side b = (*s.side)(Point(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
      side[i] = b == CGAL::ON_UNBOUNDED_SIDE ? 1 : (b == CGAL::ON_BOUNDED_SIDE ? -1 : 0);
    }
  });
}

void MeshDistance::winding_number(const double* p_user, std::size_t k, double* w,
                                  double beta) const {
  if (impl_->nodes.empty())
    throw std::logic_error("this MeshDistance was built without its winding-number hierarchy");
  if (!(beta > 1.0) || !std::isfinite(beta))
    throw std::invalid_argument("beta must be finite and greater than 1");
  std::vector<double> store;
  const double* p = impl_->in_frame(p_user, k, store);
  const std::size_t blocks = (k + kBlock - 1) / kBlock;
  for_each_on_cores(blocks, [] { return 0; }, [&](int, std::size_t blk) {
    for (std::size_t i = blk * kBlock; i < std::min(k, (blk + 1) * kBlock); ++i)
      w[i] = impl_->winding(&p[3 * i], beta);
  });
}

void MeshDistance::segment_hits(const double* ab_user, std::size_t k,
                                std::vector<std::int64_t>& segment, std::vector<double>& t,
                                std::vector<std::int64_t>& face) const {
  const Impl& s = *impl_;
  std::vector<double> store;
  const double* ab = s.in_frame(ab_user, 2 * k, store);  // t is the same in either frame
  struct Hit {
    std::int64_t segment;
    double t;
    std::int64_t face;
  };
  const std::size_t blocks = (k + kBlock - 1) / kBlock;
  std::vector<std::vector<Hit>> found(blocks);  // per block: the result does not depend on threads
  for_each_on_cores(blocks, [] { return std::vector<SoupTree::Primitive_id>(); },
                    [&](std::vector<SoupTree::Primitive_id>& prims, std::size_t blk) {
    std::vector<Hit>& out = found[blk];
    for (std::size_t i = blk * kBlock; i < std::min(k, (blk + 1) * kBlock); ++i) {
      const double* a = &ab[6 * i];
      const double* b = a + 3;
      const Vec d = sub(b, a);
      const auto seg = static_cast<std::int64_t>(i);
      if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0) {
        out.push_back({seg, std::nan(""), -1});
        continue;
      }
      prims.clear();
      s.tree.all_intersected_primitives(K::Segment_3(Point(a[0], a[1], a[2]), Point(b[0], b[1], b[2])),
                                        std::back_inserter(prims));
      const std::size_t first = out.size();
      for (const auto& id : prims) {
        const auto f = s.soup_face[static_cast<std::size_t>(id - s.soup.cbegin())];
        const double* v0 = s.vertex(s.tri[3 * f]);
        const Vec n = cross(sub(s.vertex(s.tri[3 * f + 1]), v0), sub(s.vertex(s.tri[3 * f + 2]), v0));
        const double den = dot(n, d);
        // Nearly in the face's plane: the crossing's place is ill-conditioned.
        double ti = std::nan("");
        if (std::abs(den) > 1e-9 * norm(n) * norm(d))
          ti = std::clamp(dot(n, sub(v0, a)) / den, 0.0, 1.0);
        out.push_back({seg, ti, f});
      }
      std::sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                [](const Hit& x, const Hit& y) {
                  const bool xn = std::isnan(x.t), yn = std::isnan(y.t);
                  if (xn != yn) return xn;
                  if (!xn && x.t != y.t) return x.t < y.t;
                  return x.face < y.face;
                });
    }
  });
  std::size_t total = 0;
  for (const auto& v : found) total += v.size();
  segment.resize(total);
  t.resize(total);
  face.resize(total);
  std::size_t j = 0;
  for (const auto& v : found)
    for (const Hit& h : v) {
      segment[j] = h.segment;
      t[j] = h.t;
      face[j] = h.face;
      ++j;
    }
}

std::vector<std::int64_t> MeshDistance::self_intersections() const {
  std::vector<std::int64_t> out;
  for (const auto& [a, b] : impl_->crossing_faces) {
    out.push_back(a);
    out.push_back(b);
  }
  return out;
}

bool MeshDistance::has_side() const { return static_cast<bool>(impl_->side); }
bool MeshDistance::has_pseudo_normals() const { return impl_->pseudo; }
const char* MeshDistance::side_failure() const { return impl_->side_failure.c_str(); }
std::size_t MeshDistance::number_of_faces() const { return impl_->tri.size() / 3; }

}  // namespace rdmesh
