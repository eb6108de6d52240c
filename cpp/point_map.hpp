// Exact points -> ids: a thread-safe hash table keyed by the bits of three
// doubles, which keeps the smallest id given for a point, so that what it
// holds does not depend on the order of the calls.  MeshSurface keeps in one
// the face each exact crossing lies on: the crossings become facet centres
// and samples, which pass through the core as the same doubles.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace rdmesh {

class PointMap {
 public:
  // Remembers ids[i] (>= 0) for point i (the smaller id where one is held
  // already); points with a non-finite coordinate are skipped.
  void add(const double* p, const std::int64_t* ids, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i)
      if (ids[i] < 0) throw std::invalid_argument("PointMap ids must be >= 0");
    const std::lock_guard<std::mutex> hold(lock_);
    for (std::size_t i = 0; i < n; ++i) {
      if (!finite(&p[3 * i])) continue;
      if (2 * (size_ + 1) > slots_.size()) grow();
      const Key k = key(&p[3 * i]);
      Slot& s = slots_[slot(slots_, k)];
      if (s.id < 0) {
        s.key = k;
        s.id = ids[i];
        ++size_;
      } else if (ids[i] < s.id) {
        s.id = ids[i];
      }
    }
  }

  // The id held for each point, or -1.
  void get(const double* p, std::size_t n, std::int64_t* out) const {
    const std::lock_guard<std::mutex> hold(lock_);
    for (std::size_t i = 0; i < n; ++i)
      out[i] = slots_.empty() || !finite(&p[3 * i]) ? -1 : slots_[slot(slots_, key(&p[3 * i]))].id;
  }

  void clear() {
    const std::lock_guard<std::mutex> hold(lock_);
    std::vector<Slot>().swap(slots_);
    size_ = 0;
  }

  std::size_t size() const {
    const std::lock_guard<std::mutex> hold(lock_);
    return size_;
  }

 private:
  using Key = std::array<std::uint64_t, 3>;
  struct Slot {
    Key key{};
    std::int64_t id = -1;  // -1: empty
  };

  // splitmix64's finaliser over the three words.
  static std::size_t hash(const Key& k) {
    std::uint64_t h = 0;
    for (const std::uint64_t w : k) {
      h = (h ^ w) + 0x9e3779b97f4a7c15ULL;
      h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ULL;
      h = (h ^ (h >> 27)) * 0x94d049bb133111ebULL;
      h ^= h >> 31;
    }
    return static_cast<std::size_t>(h);
  }

  // The slot holding k, or the empty one where it would go (linear probing;
  // the table is never more than half full).
  static std::size_t slot(const std::vector<Slot>& slots, const Key& k) {
    const std::size_t mask = slots.size() - 1;
    for (std::size_t i = hash(k) & mask;; i = (i + 1) & mask)
      if (slots[i].id < 0 || slots[i].key == k) return i;
  }

  void grow() {
    std::vector<Slot> bigger(slots_.empty() ? 1024 : 2 * slots_.size());
    for (const Slot& s : slots_)
      if (s.id >= 0) bigger[slot(bigger, s.key)] = s;
    slots_.swap(bigger);
  }

  static bool finite(const double* x) {
    return std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]);
  }

  // -0.0 and 0.0 are one point.
  static Key key(const double* x) {
    Key k;
    for (int d = 0; d < 3; ++d) {
      const double v = x[d] + 0.0;
      std::memcpy(&k[d], &v, sizeof v);
    }
    return k;
  }

  mutable std::mutex lock_;
  std::vector<Slot> slots_;  // a power of two long, or empty
  std::size_t size_ = 0;
};

}  // namespace rdmesh
