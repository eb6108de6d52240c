#include "complex_status.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace rdmesh {

namespace {

std::int64_t find_root(std::vector<std::int64_t>& parent, std::int64_t s) {
  while (parent[s] != s) {
    parent[s] = parent[parent[s]];  // path halving
    s = parent[s];
  }
  return s;
}

void join(std::vector<std::int64_t>& parent, std::int64_t a, std::int64_t b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

}  // namespace

ComplexCounts complex_counts(const std::int64_t* faces, std::size_t F, std::int64_t n) {
  if (n < 0) throw std::invalid_argument("n_vertices must be non-negative");
  for (std::size_t f = 0; f < F; ++f) {
    const std::int64_t* t = faces + 3 * f;
    for (int j = 0; j < 3; ++j)
      if (t[j] < 0 || t[j] >= n)
        throw std::invalid_argument("face " + std::to_string(f) + " has vertex id " +
                                    std::to_string(t[j]) + " outside [0, " +
                                    std::to_string(n) + ")");
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0])
      throw std::invalid_argument("face " + std::to_string(f) + " repeats a vertex");
  }
  ComplexCounts out;
  out.vertex_fans.assign(static_cast<std::size_t>(n), 0);
  out.face_edges.resize(3 * F);
  if (F == 0) return out;
  // Face edges bucketed by their smaller end (a counting sort), then each
  // bucket sorted by the larger end: the order of the keys min * n + max.
  const std::size_t m = 3 * F;
  std::vector<std::int64_t> start(static_cast<std::size_t>(n) + 1, 0);
  for (std::size_t f = 0; f < F; ++f)
    for (int j = 0; j < 3; ++j)
      ++start[std::min(faces[3 * f + j], faces[3 * f + (j + 1) % 3]) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  // (larger end, 3 f + j): where edge j of face f goes in face_edges.
  std::vector<std::pair<std::int64_t, std::uint32_t>> slot(m);
  for (std::size_t f = 0; f < F; ++f)
    for (int j = 0; j < 3; ++j) {
      const std::int64_t u = faces[3 * f + j], v = faces[3 * f + (j + 1) % 3];
      slot[fill[std::min(u, v)]++] = {std::max(u, v), static_cast<std::uint32_t>(3 * f + j)};
    }
  std::vector<std::int64_t>().swap(fill);
  std::vector<std::int64_t> lo_of;  // smaller end of each edge
  lo_of.reserve(m / 2 + 1);
  out.edge_key.reserve(m / 2 + 1);
  out.edge_count.reserve(m / 2 + 1);
  for (std::int64_t v = 0; v < n; ++v) {
    auto b = slot.begin() + start[v], e = slot.begin() + start[v + 1];
    if (e - b > 16) {
      std::sort(b, e);
    } else {  // insertion sort: a bucket holds a few edges
      for (auto it = b; it != e; ++it)
        for (auto jt = it; jt != b && *jt < *(jt - 1); --jt) std::iter_swap(jt, jt - 1);
    }
    for (auto it = b; it != e; ++it) {
      if (it == b || it->first != (it - 1)->first) {
        out.edge_key.push_back(v * n + it->first);
        out.edge_count.push_back(0);
        lo_of.push_back(v);
      }
      ++out.edge_count.back();
      out.face_edges[it->second] = static_cast<std::int32_t>(out.edge_key.size() - 1);
    }
  }
  // Spoke 2 e + 1 is edge e seen from its larger end, 2 e from its smaller;
  // each corner joins the spokes of its two edges.
  const std::size_t E = out.edge_key.size();
  std::vector<std::int64_t> parent(2 * E);
  std::iota(parent.begin(), parent.end(), std::int64_t{0});
  for (std::size_t f = 0; f < F; ++f) {
    const std::int64_t* t = faces + 3 * f;
    const std::int32_t* e = out.face_edges.data() + 3 * f;  // ab, bc, ca
    for (int j = 0; j < 3; ++j) {
      const std::int64_t v = t[j], next = t[(j + 1) % 3], prev = t[(j + 2) % 3];
      // Edge j is (v, next), edge j + 2 (mod 3) is (prev, v).
      join(parent, 2 * std::int64_t{e[j]} + (v > next), 2 * std::int64_t{e[(j + 2) % 3]} + (v > prev));
    }
  }
  for (std::size_t s = 0; s < 2 * E; ++s)
    if (parent[s] == static_cast<std::int64_t>(s)) {
      const std::size_t edge = s / 2;
      const std::int64_t owner = (s & 1) ? out.edge_key[edge] - lo_of[edge] * n : lo_of[edge];
      ++out.vertex_fans[owner];
    }
  return out;
}

}  // namespace rdmesh
