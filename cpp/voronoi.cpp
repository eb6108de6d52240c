// Voronoi facets (duals of Delaunay edges) and Delaunay edge enumeration, for
// the topological-ball facet tests.  Geometry and bookkeeping only: which
// facets to test, and how, is Python's business.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "rdt.hpp"

namespace rdmesh {

namespace {

void check_id(std::int64_t id, std::size_t n) {
  if (id < 0 || id >= static_cast<std::int64_t>(n))
    throw std::invalid_argument("vertex id " + std::to_string(id) +
                                " out of range");
}

}  // namespace

VoronoiFacets RestrictedDelaunay::voronoi_facets(const std::int64_t* edges,
                                                 std::size_t m) const {
  const std::size_t n = samples_.size();
  for (std::size_t k = 0; k < m; ++k) {
    check_id(edges[2 * k], n);
    check_id(edges[2 * k + 1], n);
    if (edges[2 * k] == edges[2 * k + 1])
      throw std::invalid_argument("edge " + std::to_string(k) +
                                  " joins vertex " +
                                  std::to_string(edges[2 * k]) + " to itself");
  }
  VoronoiFacets out;
  out.offsets.reserve(m + 1);
  out.offsets.push_back(0);
  out.points.reserve(3 * 6 * m);
  out.cell.reserve(6 * m);
  out.third.reserve(6 * m);
  std::unordered_map<const void*, std::int64_t> number;
  number.reserve(4 * m + 16);
  for (std::size_t k = 0; k < m; ++k) {
    Vertex_handle vp = samples_[edges[2 * k]], vq = samples_[edges[2 * k + 1]];
    Cell_handle c;
    int i, j;
    if (!dt_.is_edge(vp, vq, c, i, j))
      throw std::invalid_argument(
          "edge " + std::to_string(k) + " (" + std::to_string(edges[2 * k]) +
          ", " + std::to_string(edges[2 * k + 1]) + ") is not a Delaunay edge");
    auto start = dt_.incident_cells(c, i, j);
    auto cur = start;
    do {
      Cell_handle a = cur;
      ++cur;
      Cell_handle b = cur;
      // Dummies surround the samples, so no edge between samples is on the
      // hull; an infinite cell here means the triangulation is broken.
      if (dt_.is_infinite(a))
        throw std::runtime_error("a Delaunay edge between samples has an "
                                 "infinite incident cell");
      const auto& cc = circumcentre(a);
      out.points.insert(out.points.end(), cc.begin(), cc.end());
      auto it = number.emplace(&*a, static_cast<std::int64_t>(number.size()));
      out.cell.push_back(it.first->second);
      // a and b share the facet (p, q, w): w is a's vertex that is neither
      // p, q nor the one opposite b.
      const int opp = a->index(b);
      std::int64_t w = -1;
      for (int d = 0; d < 4; ++d) {
        Vertex_handle v = a->vertex(d);
        if (d == opp || v == vp || v == vq) continue;
        w = is_dummy(v) ? -1 : v->info().id;
      }
      out.third.push_back(w);
    } while (cur != start);
    out.offsets.push_back(static_cast<std::int64_t>(out.cell.size()));
  }
  return out;
}

std::vector<std::int64_t> RestrictedDelaunay::delaunay_edges(
    const std::int64_t* ids, std::size_t n) const {
  std::vector<std::int64_t> pairs;
  auto add = [&](Vertex_handle a, Vertex_handle b) {
    if (is_dummy(a) || is_dummy(b)) return;
    std::int64_t x = a->info().id, y = b->info().id;
    if (x > y) std::swap(x, y);
    pairs.push_back(x);
    pairs.push_back(y);
  };
  if (ids == nullptr) {
    for (auto e = dt_.finite_edges_begin(); e != dt_.finite_edges_end(); ++e)
      add(e->first->vertex(e->second), e->first->vertex(e->third));
  } else {
    for (std::size_t k = 0; k < n; ++k) check_id(ids[k], samples_.size());
    std::vector<Cell_handle> around;
    for (std::size_t k = 0; k < n; ++k) {
      around.clear();
      dt_.finite_incident_cells(samples_[ids[k]], std::back_inserter(around));
      for (Cell_handle c : around)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b) add(c->vertex(a), c->vertex(b));
    }
  }
  // Sort and de-duplicate the pairs.
  const std::size_t m = pairs.size() / 2;
  std::vector<std::size_t> order(m);
  for (std::size_t k = 0; k < m; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return pairs[2 * a] != pairs[2 * b] ? pairs[2 * a] < pairs[2 * b]
                                        : pairs[2 * a + 1] < pairs[2 * b + 1];
  });
  std::vector<std::int64_t> out;
  out.reserve(pairs.size());
  for (std::size_t k : order) {
    const std::int64_t x = pairs[2 * k], y = pairs[2 * k + 1];
    const std::size_t s = out.size();
    if (s >= 2 && out[s - 2] == x && out[s - 1] == y) continue;
    out.push_back(x);
    out.push_back(y);
  }
  return out;
}

}  // namespace rdmesh
