// Voronoi facets (duals of Delaunay edges) and Delaunay edge enumeration, for
// the topological-ball facet tests.  Geometry and bookkeeping only: which
// facets to test, and how, is Python's business.
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

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
                                                 std::size_t m) {
  const std::size_t n = samples_.size();
  for (std::size_t k = 0; k < m; ++k) {
    check_id(edges[2 * k], n);
    check_id(edges[2 * k + 1], n);
    if (edges[2 * k] == edges[2 * k + 1])
      throw std::invalid_argument("edge " + std::to_string(k) +
                                  " joins vertex " +
                                  std::to_string(edges[2 * k]) + " to itself");
  }
  // Locate every edge through one visit of its first vertex's star: edges
  // sharing that vertex share the visit (is_edge would visit it per edge).
  struct Where {
    Cell_handle c;
    int i = -1, j = -1;
  };
  std::vector<Where> where(m);
  std::vector<std::size_t> order(m);
  for (std::size_t k = 0; k < m; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return edges[2 * a] < edges[2 * b];
  });
  std::vector<Cell_handle> star;
  for (std::size_t g = 0; g < m;) {
    std::size_t h = g;
    while (h < m && edges[2 * order[h]] == edges[2 * order[g]]) ++h;
    Vertex_handle vp = samples_[edges[2 * order[g]]];
    star.clear();
    dt_.incident_cells(vp, std::back_inserter(star));
    for (Cell_handle c : star) {
      const int ip = c->index(vp);
      for (int d = 0; d < 4; ++d) {
        if (d == ip) continue;
        Vertex_handle v = c->vertex(d);
        if (is_dummy(v)) continue;
        const std::int64_t id = v->info().id;
        for (std::size_t t = g; t < h; ++t) {
          Where& w = where[order[t]];
          if (w.i < 0 && edges[2 * order[t] + 1] == id) w = {c, ip, d};
        }
      }
    }
    g = h;
  }
  VoronoiFacets out;
  out.offsets.reserve(m + 1);
  out.offsets.push_back(0);
  out.points.reserve(3 * 6 * m);
  out.cell.reserve(6 * m);
  out.third.reserve(6 * m);
  // Distinct cells are numbered through their end_idx/end_stamp fields with
  // a negative stamp, which changed_facets (positive stamps) never matches;
  // cheaper than a map from cell to number.  -1 is the initial value.
  if (voronoi_call_ == std::numeric_limits<std::int32_t>::max() - 1)
    reset_end_stamps();
  const std::int32_t stamp = -(++voronoi_call_) - 1;
  std::int64_t n_cells = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const Where& at = where[k];
    if (at.i < 0)
      throw std::invalid_argument(
          "edge " + std::to_string(k) + " (" + std::to_string(edges[2 * k]) +
          ", " + std::to_string(edges[2 * k + 1]) + ") is not a Delaunay edge");
    Vertex_handle vp = samples_[edges[2 * k]], vq = samples_[edges[2 * k + 1]];
    auto start = dt_.incident_cells(at.c, at.i, at.j);
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
      CellInfo& info = a->info();
      if (info.end_stamp != stamp) {
        info.end_stamp = stamp;
        info.end_idx = static_cast<std::int32_t>(n_cells++);
      }
      out.cell.push_back(info.end_idx);
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

std::vector<double> RestrictedDelaunay::voronoi_cell_boxes(const std::int64_t* ids,
                                                           std::size_t n) {
  const std::size_t m = samples_.size();
  for (std::size_t k = 0; k < n; ++k) check_id(ids[k], m);
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> out(6 * n);
  std::vector<Cell_handle> star;
  for (std::size_t k = 0; k < n; ++k) {
    double* box = &out[6 * k];
    for (int d = 0; d < 3; ++d) {
      box[d] = inf;
      box[3 + d] = -inf;
    }
    star.clear();
    dt_.incident_cells(samples_[ids[k]], std::back_inserter(star));
    for (Cell_handle c : star) {
      if (dt_.is_infinite(c)) {
        for (int d = 0; d < 3; ++d) {
          box[d] = -inf;
          box[3 + d] = inf;
        }
        break;
      }
      const auto& cc = circumcentre(c);
      for (int d = 0; d < 3; ++d) {
        box[d] = std::min(box[d], cc[d]);
        box[3 + d] = std::max(box[3 + d], cc[d]);
      }
    }
  }
  return out;
}

}  // namespace rdmesh
