// Replays the insertion batches of one rdmesh run (benchmarks/levers.py
// writes them) in CGAL's 3D Delaunay triangulation, with the core's own
// vertex and cell records (cpp/rdt.hpp), and prints one JSON object of
// seconds per way of inserting:
//   sequential   each batch Hilbert-sorted, one insert with a hint per point:
//                what RestrictedDelaunay::insert does;
//   parallel     each batch through CGAL's parallel range insertion (TBB,
//                Parallel_tag data structure, Spatial_lock_grid_3), with
//                --threads threads (absent without TBB);
//   bulk         every point at once: Delaunay_triangulation_3(begin, end),
//                the suite's floor.
// Each way starts from the same eight far dummy points as the core.
//
//   insertion_replay BATCHES.bin [--threads N] [--repeats K]
//
// BATCHES.bin, float64 little-endian: nb, cx, cy, cz, R, then per batch its
// point count m followed by m*3 coordinates.
//
// SPDX-License-Identifier: GPL-3.0-or-later
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CGAL/hilbert_sort.h>
#include <CGAL/property_map.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>

#include "../../cpp/rdt.hpp"

#ifdef CGAL_LINKED_WITH_TBB
#include <CGAL/Spatial_lock_grid_3.h>
#include <tbb/global_control.h>
#endif

namespace {

using rdmesh::K;
using rdmesh::Point;
using Sequential = rdmesh::Delaunay;

struct Batches {
  double centre[3] = {0, 0, 0}, radius = 1;
  std::vector<std::vector<Point>> batches;
  std::size_t points() const {
    std::size_t n = 0;
    for (const auto& b : batches) n += b.size();
    return n;
  }
};

Batches read(const char* path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string("cannot open ") + path);
  auto next = [&]() {
    double x;
    if (!in.read(reinterpret_cast<char*>(&x), sizeof x))
      throw std::runtime_error("batch file ends early");
    return x;
  };
  Batches b;
  const auto nb = static_cast<std::size_t>(next());
  for (double& c : b.centre) c = next();
  b.radius = next();
  b.batches.resize(nb);
  for (auto& batch : b.batches) {
    const auto m = static_cast<std::size_t>(next());
    batch.reserve(m);
    for (std::size_t k = 0; k < m; ++k) {
      const double x = next(), y = next(), z = next();
      batch.emplace_back(x, y, z);
    }
  }
  return b;
}

// The core's dummies: cube corners at 4R.
std::vector<Point> dummies(const Batches& b) {
  std::vector<Point> out;
  const double h = 4.0 * b.radius;
  for (int k = 0; k < 8; ++k)
    out.emplace_back(b.centre[0] + ((k & 1) ? h : -h), b.centre[1] + ((k & 2) ? h : -h),
                     b.centre[2] + ((k & 4) ? h : -h));
  return out;
}

double now() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

// As RestrictedDelaunay::insert: Hilbert order per batch, the last vertex as hint.
double sequential(const Batches& b, std::size_t& cells) {
  const double t0 = now();
  Sequential dt;
  const auto corners = dummies(b);
  dt.insert(corners.begin(), corners.end());
  Sequential::Vertex_handle hint;
  std::int64_t id = 0;
  for (const auto& batch : b.batches) {
    std::vector<std::size_t> order(batch.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    using Map = CGAL::Pointer_property_map<Point>::const_type;
    using Traits = CGAL::Spatial_sort_traits_adapter_3<K, Map>;
    CGAL::hilbert_sort(order.begin(), order.end(), Traits(CGAL::make_property_map(batch)));
    for (std::size_t k : order) {
      auto v = dt.insert(batch[k], hint);
      if (v->info().id == -2) v->info().id = id++;
      hint = v;
    }
  }
  const double t = now() - t0;
  cells = dt.number_of_cells();
  return t;
}

double bulk(const Batches& b, std::size_t& cells) {
  std::vector<Point> all = dummies(b);
  for (const auto& batch : b.batches) all.insert(all.end(), batch.begin(), batch.end());
  const double t0 = now();
  Sequential dt(all.begin(), all.end());
  const double t = now() - t0;
  cells = dt.number_of_cells();
  return t;
}

#ifdef CGAL_LINKED_WITH_TBB
using ParallelTds =
    CGAL::Triangulation_data_structure_3<rdmesh::Vb, rdmesh::Cb, CGAL::Parallel_tag>;
using Parallel = CGAL::Delaunay_triangulation_3<K, ParallelTds, CGAL::Default,
                                                CGAL::Spatial_lock_grid_3<CGAL::Tag_priority_blocking>>;

double parallel(const Batches& b, int threads, std::size_t& cells) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  const double t0 = now();
  const double R = b.radius;
  // The lock grid over the bounding ball's cube, where every sample lies.
  CGAL::Bbox_3 box(b.centre[0] - R, b.centre[1] - R, b.centre[2] - R, b.centre[0] + R,
                   b.centre[1] + R, b.centre[2] + R);
  Parallel::Lock_data_structure locks(box, 50);
  Parallel dt(K(), &locks);
  const auto corners = dummies(b);
  dt.insert(corners.begin(), corners.end());
  for (const auto& batch : b.batches) dt.insert(batch.begin(), batch.end());
  const double t = now() - t0;
  cells = dt.number_of_cells();
  return t;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 2) {
      std::fprintf(stderr, "usage: insertion_replay BATCHES.bin [--threads N] [--repeats K]\n");
      return 2;
    }
    int threads = 2, repeats = 2;
    for (int i = 2; i + 1 < argc; i += 2) {
      const std::string key = argv[i];
      if (key == "--threads") threads = std::atoi(argv[i + 1]);
      else if (key == "--repeats") repeats = std::atoi(argv[i + 1]);
      else throw std::invalid_argument("unknown option " + key);
    }
    if (threads < 1 || repeats < 1) throw std::invalid_argument("--threads and --repeats need >= 1");
    const Batches b = read(argv[1]);
    std::size_t cells_seq = 0, cells_bulk = 0, cells_par = 0;
    std::string rows;
    // Alternating, best of `repeats` per way: the machine is shared.
    double best_seq = 1e300, best_bulk = 1e300, best_par = 1e300;
    for (int r = 0; r < repeats; ++r) {
      best_seq = std::min(best_seq, sequential(b, cells_seq));
#ifdef CGAL_LINKED_WITH_TBB
      best_par = std::min(best_par, parallel(b, threads, cells_par));
#endif
      best_bulk = std::min(best_bulk, bulk(b, cells_bulk));
    }
    std::printf("{\"points\": %zu, \"batches\": %zu, \"cells\": %zu, \"sequential_s\": %.4f, "
                "\"bulk_s\": %.4f",
                b.points(), b.batches.size(), cells_seq, best_seq, best_bulk);
#ifdef CGAL_LINKED_WITH_TBB
    // The same points give the same triangulation, however they are inserted.
    if (cells_par != cells_seq) throw std::runtime_error("parallel build differs");
    std::printf(", \"parallel_s\": %.4f, \"threads\": %d", best_par, threads);
#else
    std::printf(", \"parallel_s\": null, \"threads\": null");
#endif
    std::printf(", \"repeats\": %d}\n", repeats);
    if (cells_bulk != cells_seq) throw std::runtime_error("bulk build differs");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "insertion_replay: %s\n", e.what());
    return 1;
  }
}
