// Voronoi facets (duals of Delaunay edges) and Delaunay edge enumeration, for
// the topological-ball facet tests.  Geometry and bookkeeping only: which
// facets to test, and how, is Python's business.
#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <limits>
#include <stdexcept>
#include <string>

#include "rdt.hpp"

namespace rdmesh {

namespace {


}  // namespace

VoronoiFacets RestrictedDelaunay::voronoi_facets(const std::int64_t* edges,
                                                 std::size_t m) {
  const std::size_t n = samples_.size();
  for (std::size_t k = 0; k < m; ++k) {
    check_sample_id(edges[2 * k], n);
    check_sample_id(edges[2 * k + 1], n);
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

void RestrictedDelaunay::voronoi_boxes(std::vector<std::int64_t>& edges,
                                       std::vector<double>& facet_boxes,
                                       std::vector<double>& cell_boxes) {
  // One pass over the cells: each adds its circumcentre to the boxes of its
  // samples and of its edges between samples; the edge entries are then
  // grouped by lower sample (a counting sort) and, within it, by the other.
  const std::size_t n = samples_.size();
  if (n >> 32) throw std::length_error("more than 2**32 samples");
  const double inf = std::numeric_limits<double>::infinity();
  cell_boxes.assign(6 * n, inf);
  for (std::size_t v = 0; v < n; ++v)
    for (int d = 0; d < 3; ++d) cell_boxes[6 * v + 3 + d] = -inf;
  std::vector<std::array<double, 3>> centre;
  struct Entry {
    std::uint32_t p, q, cell;
  };
  std::vector<Entry> entry;
  entry.reserve(6 * dt_.number_of_finite_cells());
  std::vector<std::uint32_t> per(n + 1, 0);
  for (auto c = dt_.all_cells_begin(); c != dt_.all_cells_end(); ++c) {
    std::int64_t id[4];
    int k = 0;
    for (int a = 0; a < 4; ++a) {
      Vertex_handle v = c->vertex(a);
      if (!is_dummy(v)) id[k++] = v->info().id;
    }
    if (k == 0) continue;
    if (dt_.is_infinite(c)) {
      // Dummies surround the samples, so no edge between samples is on the
      // hull; an infinite cell here means the triangulation is broken.
      if (k >= 2)
        throw std::runtime_error("a Delaunay edge between samples has an infinite incident cell");
      for (int d = 0; d < 3; ++d) {
        cell_boxes[6 * id[0] + d] = -inf;
        cell_boxes[6 * id[0] + 3 + d] = inf;
      }
      continue;
    }
    const auto& cc = circumcentre(c);
    for (int a = 0; a < k; ++a) {
      double* box = &cell_boxes[6 * id[a]];
      for (int d = 0; d < 3; ++d) {
        box[d] = std::min(box[d], cc[d]);
        box[3 + d] = std::max(box[3 + d], cc[d]);
      }
    }
    if (k < 2) continue;
    const auto index = static_cast<std::uint32_t>(centre.size());
    centre.push_back(cc);
    for (int a = 0; a < k; ++a)
      for (int b = a + 1; b < k; ++b) {
        const auto p = static_cast<std::uint32_t>(std::min(id[a], id[b]));
        const auto q = static_cast<std::uint32_t>(std::max(id[a], id[b]));
        entry.push_back({p, q, index});
        ++per[p + 1];
      }
  }
  for (std::size_t v = 0; v < n; ++v) per[v + 1] += per[v];
  std::vector<Entry> by_p(entry.size());
  {
    std::vector<std::uint32_t> at(per.begin(), per.end() - 1);
    for (const Entry& e : entry) by_p[at[e.p]++] = e;
  }
  edges.clear();
  facet_boxes.clear();
  for (std::size_t v = 0; v < n; ++v) {
    auto first = by_p.begin() + per[v], last = by_p.begin() + per[v + 1];
    std::sort(first, last, [](const Entry& x, const Entry& y) { return x.q < y.q; });
    for (auto g = first; g != last;) {
      const std::uint32_t q = g->q;
      edges.push_back(static_cast<std::int64_t>(v));
      edges.push_back(static_cast<std::int64_t>(q));
      double box[6] = {inf, inf, inf, -inf, -inf, -inf};
      for (; g != last && g->q == q; ++g) {
        const auto& cc = centre[g->cell];
        for (int d = 0; d < 3; ++d) {
          box[d] = std::min(box[d], cc[d]);
          box[3 + d] = std::max(box[3 + d], cc[d]);
        }
      }
      facet_boxes.insert(facet_boxes.end(), box, box + 6);
    }
  }
}

std::vector<std::int64_t> RestrictedDelaunay::delaunay_edges(
    const std::int64_t* ids, std::size_t n) const {
  // One key per edge and cell (p << 32 | q, p < q), sorted and de-duplicated:
  // cheaper than CGAL's edge iterator, which circulates around every edge.
  if (samples_.size() >> 32)
    throw std::length_error("more than 2**32 samples");
  std::vector<std::uint64_t> keys;
  auto add_cell = [&](Cell_handle c) {
    for (int a = 0; a < 4; ++a) {
      Vertex_handle va = c->vertex(a);
      if (dt_.is_infinite(va) || is_dummy(va)) continue;
      for (int b = a + 1; b < 4; ++b) {
        Vertex_handle vb = c->vertex(b);
        if (dt_.is_infinite(vb) || is_dummy(vb)) continue;
        std::uint64_t x = static_cast<std::uint64_t>(va->info().id);
        std::uint64_t y = static_cast<std::uint64_t>(vb->info().id);
        if (x > y) std::swap(x, y);
        keys.push_back(x << 32 | y);
      }
    }
  };
  if (ids == nullptr) {
    keys.reserve(6 * dt_.number_of_finite_cells());
    for (auto c = dt_.finite_cells_begin(); c != dt_.finite_cells_end(); ++c) add_cell(c);
  } else {
    for (std::size_t k = 0; k < n; ++k) check_sample_id(ids[k], samples_.size());
    std::vector<Cell_handle> around;
    for (std::size_t k = 0; k < n; ++k) {
      around.clear();
      dt_.finite_incident_cells(samples_[ids[k]], std::back_inserter(around));
      for (Cell_handle c : around) add_cell(c);
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<std::int64_t> out(2 * keys.size());
  for (std::size_t k = 0; k < keys.size(); ++k) {
    out[2 * k] = static_cast<std::int64_t>(keys[k] >> 32);
    out[2 * k + 1] = static_cast<std::int64_t>(keys[k] & 0xffffffffULL);
  }
  return out;
}

std::vector<double> RestrictedDelaunay::voronoi_cell_boxes(const std::int64_t* ids,
                                                           std::size_t n) {
  const std::size_t m = samples_.size();
  for (std::size_t k = 0; k < n; ++k) check_sample_id(ids[k], m);
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
