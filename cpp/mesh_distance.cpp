// Distance, side and winding-number queries against a triangle mesh (see
// mesh_distance.hpp).
#include "mesh_distance.hpp"

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
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

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
void check_finite(const double* p, std::size_t k) {
  for (std::size_t i = 0; i < 3 * k; ++i)
    if (!std::isfinite(p[i]))
      throw std::invalid_argument("query point " + std::to_string(i / 3) + " is not finite");
}

}  // namespace

struct MeshDistance::Impl {
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

  const double* vertex(std::int64_t i) const { return &xyz[3 * static_cast<std::size_t>(i)]; }

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
      mesh.reset();
      return;
    }
    mesh_tree = std::make_unique<MeshTree>(faces(*mesh).first, faces(*mesh).second, *mesh);
    mesh_tree->build();
    side = std::make_unique<Side>(*mesh_tree);
  }
};

MeshDistance::MeshDistance(const double* vertices, std::size_t n, const std::int64_t* faces,
                           std::size_t m, bool want_side)
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

  s.order.resize(m);
  std::iota(s.order.begin(), s.order.end(), 0);
  s.nodes.reserve(2 * (m / kLeafSize + 1));
  s.build(0, static_cast<std::int32_t>(m), centroid, area);

  if (want_side) s.try_side();
  if (s.side) (void)(*s.side)(s.soup.front().vertex(0));
}

MeshDistance::~MeshDistance() = default;

void MeshDistance::query(const double* p, std::size_t k, double* dist, double* closest,
                         std::int64_t* face, std::int8_t* side) const {
  const Impl& s = *impl_;
  check_finite(p, k);
  for (std::size_t i = 0; i < k; ++i) {
    const Point q(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    const auto hit = s.tree.closest_point_and_primitive(q);
    const Point& c = hit.first;
    closest[3 * i] = c.x();
    closest[3 * i + 1] = c.y();
    closest[3 * i + 2] = c.z();
    dist[i] = std::sqrt(CGAL::squared_distance(q, c));
    face[i] = s.soup_face[static_cast<std::size_t>(hit.second - s.soup.cbegin())];
    if (s.side) {
      const CGAL::Bounded_side b = (*s.side)(q);
      side[i] = b == CGAL::ON_UNBOUNDED_SIDE ? 1 : (b == CGAL::ON_BOUNDED_SIDE ? -1 : 0);
    } else {
      side[i] = 0;
    }
  }
}

void MeshDistance::side(const double* p, std::size_t k, std::int8_t* side) const {
  const Impl& s = *impl_;
  if (!s.side) throw std::logic_error("this mesh has no side oracle: " + s.side_failure);
  check_finite(p, k);
  for (std::size_t i = 0; i < k; ++i) {
    const CGAL::Bounded_side b = (*s.side)(Point(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
    side[i] = b == CGAL::ON_UNBOUNDED_SIDE ? 1 : (b == CGAL::ON_BOUNDED_SIDE ? -1 : 0);
  }
}

void MeshDistance::winding_number(const double* p, std::size_t k, double* w, double beta) const {
  if (!(beta > 1.0) || !std::isfinite(beta))
    throw std::invalid_argument("beta must be finite and greater than 1");
  check_finite(p, k);
  for (std::size_t i = 0; i < k; ++i) w[i] = impl_->winding(&p[3 * i], beta);
}

bool MeshDistance::has_side() const { return static_cast<bool>(impl_->side); }
const char* MeshDistance::side_failure() const { return impl_->side_failure.c_str(); }
std::size_t MeshDistance::number_of_faces() const { return impl_->tri.size() / 3; }

}  // namespace rdmesh
