// Relabelling Delaunay cells so a triangle set is one disk around given
// vertices (rdmesh.refine.pinches).  Bookkeeping only: which vertices to
// repair, and what to report, is Python's business.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <numeric>
#include <tuple>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "rdt.hpp"

namespace rdmesh {

namespace {

using Key = std::array<std::int64_t, 3>;
constexpr double kNever = std::numeric_limits<double>::infinity();

// FNV-1a over the ids of a facet or a cell.
struct IdsHash {
  template <std::size_t N>
  std::size_t operator()(const std::array<std::int64_t, N>& k) const {
    std::uint64_t h = 1469598103934665603ULL;
    for (std::int64_t v : k) h = (h ^ static_cast<std::uint64_t>(v)) * 1099511628211ULL;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

Key sorted3(std::int64_t a, std::int64_t b, std::int64_t c) {
  Key k{a, b, c};
  std::sort(k.begin(), k.end());
  return k;
}

// The face set: each face once, by its sorted ids, with its orientation.
struct Faces {
  struct Entry {
    Key tri;  // oriented
    bool present;
  };
  std::vector<Entry> entries;
  std::unordered_map<Key, std::size_t, IdsHash> index;

  const Entry* find(const Key& key) const {
    auto it = index.find(key);
    return it == index.end() || !entries[it->second].present ? nullptr : &entries[it->second];
  }
  void toggle(const Key& key, const Key& oriented) {
    auto it = index.find(key);
    if (it == index.end()) {
      index.emplace(key, entries.size());
      entries.push_back({oriented, true});
    } else {
      Entry& e = entries[it->second];
      e.present = !e.present;
      if (e.present) e.tri = oriented;
    }
  }
};

struct Union {
  std::vector<std::size_t> parent;
  explicit Union(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  std::size_t find(std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::size_t a, std::size_t b) { parent[find(a)] = find(b); }
};

}  // namespace

StarCells RestrictedDelaunay::star_cells(const std::int64_t* ids, std::size_t k) {
  StarCells out;
  std::unordered_set<Cell_handle> seen;
  std::vector<Cell_handle> star;
  for (std::size_t i = 0; i < k; ++i) {
    check_sample_id(ids[i], samples_.size());
    star.clear();
    dt_.incident_cells(samples_[ids[i]], std::back_inserter(star));
    for (Cell_handle c : star) {
      if (dt_.is_infinite(c) || !seen.insert(c).second) continue;
      std::array<std::int64_t, 4> q{};
      for (int d = 0; d < 4; ++d) q[d] = is_dummy(c->vertex(d)) ? -1 : c->vertex(d)->info().id;
      std::sort(q.begin(), q.end());
      out.cells.insert(out.cells.end(), q.begin(), q.end());
      const auto& cc = circumcentre(c);
      out.centres.insert(out.centres.end(), cc.begin(), cc.end());
    }
  }
  return out;
}

StarRelabel RestrictedDelaunay::relabel_stars(const std::int64_t* faces, std::size_t F,
                                              const std::int64_t* ids, std::size_t k,
                                              const std::int64_t* cells4, const double* cost,
                                              std::size_t c, double max_seconds) const {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = samples_.size();
  Faces set;
  set.entries.reserve(F + 64);
  set.index.reserve(F + 64);
  for (std::size_t f = 0; f < F; ++f) {
    const Key t{faces[3 * f], faces[3 * f + 1], faces[3 * f + 2]};
    for (std::int64_t id : t) check_sample_id(id, n);
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      throw std::invalid_argument("face " + std::to_string(f) + " repeats a vertex");
    const Key key = sorted3(t[0], t[1], t[2]);
    if (set.index.count(key))
      throw std::invalid_argument("face " + std::to_string(f) + " is given twice");
    set.toggle(key, t);
  }
  for (std::size_t i = 0; i < k; ++i) check_sample_id(ids[i], n);
  std::unordered_map<std::array<std::int64_t, 4>, double, IdsHash> cost_of;
  cost_of.reserve(c);
  for (std::size_t i = 0; i < c; ++i) {
    std::array<std::int64_t, 4> q{cells4[4 * i], cells4[4 * i + 1], cells4[4 * i + 2],
                                  cells4[4 * i + 3]};
    std::sort(q.begin(), q.end());
    cost_of[q] = cost[i];
  }
  std::vector<std::int64_t> order(ids, ids + k);
  std::sort(order.begin(), order.end());
  order.erase(std::unique(order.begin(), order.end()), order.end());

  auto id_of = [this](Vertex_handle v) { return is_dummy(v) ? std::int64_t{-1} : v->info().id; };
  // Which side of the oriented face t the vertex w lies on.
  auto side = [this](const Key& t, Vertex_handle w) {
    return CGAL::orientation(samples_[t[0]]->point().point(), samples_[t[1]]->point().point(),
                             samples_[t[2]]->point().point(), w->point().point());
  };
  StarRelabel out;
  std::vector<Cell_handle> star;
  std::vector<std::array<std::int64_t, 4>> cell_ids;
  for (std::size_t i = 0; i < order.size(); ++i) {
    // The clock is read once per 64 vertices: a star takes microseconds.
    if (i % 64 == 0 && i > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
            max_seconds) {
      out.timed_out = true;
      break;
    }
    const std::int64_t v = order[i];
    const Vertex_handle vp = samples_[v];
    star.clear();
    dt_.incident_cells(vp, std::back_inserter(star));
    // Sorted by their ids, so the choice among equal groups does not depend
    // on memory order.
    cell_ids.resize(star.size());
    for (std::size_t c = 0; c < star.size(); ++c) {
      for (int d = 0; d < 4; ++d) cell_ids[c][d] = id_of(star[c]->vertex(d));
      std::sort(cell_ids[c].begin(), cell_ids[c].end());
    }
    std::vector<std::size_t> by(star.size());
    std::iota(by.begin(), by.end(), 0);
    std::sort(by.begin(), by.end(), [&](std::size_t a, std::size_t b) { return cell_ids[a] < cell_ids[b]; });
    std::vector<Cell_handle> cells(star.size());
    std::vector<double> price(star.size());  // +inf: never flipped
    for (std::size_t j = 0; j < by.size(); ++j) {
      cells[j] = star[by[j]];
      auto it = cost_of.find(cell_ids[by[j]]);
      const bool dummy = cell_ids[by[j]][0] < 0 || dt_.is_infinite(cells[j]);
      price[j] = dummy || it == cost_of.end() || !(it->second >= 0.0) ? kNever : it->second;
    }
    std::unordered_map<Cell_handle, std::size_t> at;  // small: one star
    for (std::size_t c = 0; c < cells.size(); ++c) at.emplace(cells[c], c);
    auto facet_key = [&](Cell_handle c, int d, bool& has_dummy) {
      std::array<std::int64_t, 3> t{};
      int j = 0;
      has_dummy = false;
      for (int e = 0; e < 4; ++e) {
        if (e == d) continue;
        t[j] = id_of(c->vertex(e));
        has_dummy |= t[j++] < 0;
      }
      return sorted3(t[0], t[1], t[2]);
    };
    // Each move removes the faces between the moved group and its
    // neighbours, so it joins them: the groups fall by one or more each time.
    for (;;) {
      Union groups(cells.size());
      for (std::size_t c = 0; c < cells.size(); ++c) {
        for (int d = 0; d < 4; ++d) {
          if (cells[c]->vertex(d) == vp) continue;  // the facet without v
          bool has_dummy;
          const Key key = facet_key(cells[c], d, has_dummy);
          if (has_dummy || !set.find(key)) groups.join(c, at.at(cells[c]->neighbor(d)));
        }
      }
      std::vector<std::size_t> size(cells.size(), 0), first(cells.size(), cells.size());
      std::vector<double> worst(cells.size(), 0.0);
      std::size_t count = 0;
      for (std::size_t c = 0; c < cells.size(); ++c) {
        const std::size_t g = groups.find(c);
        if (size[g]++ == 0) {
          ++count;
          first[g] = c;
        }
        worst[g] = std::max(worst[g], price[c]);
      }
      if (count <= 2) break;
      // The group whose dearest cell is cheapest, then the smallest, then the first.
      std::size_t pick = cells.size();
      for (std::size_t g = 0; g < cells.size(); ++g) {
        if (!size[g] || worst[g] == kNever) continue;
        if (pick == cells.size() ||
            std::tie(worst[g], size[g], first[g]) < std::tie(worst[pick], size[pick], first[pick]))
          pick = g;
      }
      if (pick == cells.size()) break;
      // The group's side, from a face of the set on its boundary.
      int inside = -1;
      for (std::size_t c = 0; c < cells.size() && inside < 0; ++c) {
        if (groups.find(c) != pick) continue;
        for (int d = 0; d < 4 && inside < 0; ++d) {
          bool has_dummy;
          const Faces::Entry* e = set.find(facet_key(cells[c], d, has_dummy));
          if (!e) continue;
          inside = side(e->tri, cells[c]->vertex(d)) == CGAL::NEGATIVE ? 1 : 0;
        }
      }
      if (inside < 0) break;  // no face bounds it: not with more than two groups
      for (std::size_t c = 0; c < cells.size(); ++c) {
        if (groups.find(c) != pick) continue;
        std::array<std::int64_t, 4> q{};
        for (int d = 0; d < 4; ++d) q[d] = id_of(cells[c]->vertex(d));
        for (int d = 0; d < 4; ++d) {
          bool has_dummy;
          const Key key = facet_key(cells[c], d, has_dummy);
          Key t = key;
          // Outward: away from the cell when it becomes inside.
          if ((side(t, cells[c]->vertex(d)) == CGAL::NEGATIVE) != (inside == 0))
            std::swap(t[1], t[2]);
          set.toggle(key, t);
        }
        std::sort(q.begin(), q.end());
        out.flipped.insert(out.flipped.end(), q.begin(), q.end());
      }
    }
  }
  for (const auto& e : set.entries)
    if (e.present) out.faces.insert(out.faces.end(), e.tri.begin(), e.tri.end());
  return out;
}

}  // namespace rdmesh
