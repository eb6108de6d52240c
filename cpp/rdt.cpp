#include "rdt.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <CGAL/Exact_rational.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/hilbert_sort.h>
#include <CGAL/property_map.h>

namespace rdmesh {

namespace {

using Vec3 = std::array<double, 3>;

bool finite3(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

Vec3 to_vec(const Point& p) { return {p.x(), p.y(), p.z()}; }

// Largest spread of a circumcentre's squared distances to its cell's four
// vertices, relative to the largest, accepted from doubles (well-shaped cells
// give about 1e-15; the centre is then off by about 1e-12 of the radius at most).
constexpr double kEquidistance = 1e-12;

bool lex_less(const Vec3& a, const Vec3& b) {
  return std::lexicographical_compare(a.begin(), a.end(), b.begin(), b.end());
}

// Grows v's capacity to hold `more` further elements, geometrically (an exact
// reserve per call would copy v every call): push_back cannot throw after it.
template <typename T>
void reserve_more(std::vector<T>& v, std::size_t more) {
  const std::size_t need = v.size() + more;
  if (v.capacity() < need) v.reserve(std::max(need, 2 * v.capacity()));
}

}  // namespace

RestrictedDelaunay::RestrictedDelaunay(const std::array<double, 3>& centre,
                                       double radius)
    : c0_(centre), radius_(radius) {
  if (!finite3(centre.data()) || !std::isfinite(radius) || radius <= 0.0)
    throw std::invalid_argument(
        "bounding sphere needs a finite centre and a positive finite radius");
  // Cube corners at 4R: inside the ball every point is nearer to any sample
  // than to any dummy, so Vor(P + dummies) = Vor(P) there and no dual is a ray.
  const double h = 4.0 * radius;
  std::array<Point, 8> corners;
  for (int k = 0; k < 8; ++k) {
    const double p[3] = {centre[0] + ((k & 1) ? h : -h),
                         centre[1] + ((k & 2) ? h : -h),
                         centre[2] + ((k & 4) ? h : -h)};
    if (!finite3(p))
      throw std::invalid_argument(
          "bounding sphere too large: 4 x radius from the centre overflows");
    corners[k] = Point(p[0], p[1], p[2]);
  }
  cell_epoch = 0;  // not a stale value from another object's insert
  for (const Point& p : corners) {
    Vertex_handle v = dt_.insert(Weighted_point(p, 0.0));
    v->info().id = -1;
    hint_ = v;
  }
  // Everything else assumes a 3D triangulation with no sample on the hull.
  if (dt_.dimension() != 3 || dt_.number_of_vertices() != 8)
    throw std::invalid_argument(
        "bounding sphere radius too small for its centre: the corner points "
        "at 4 x radius are not distinct in double precision");
}

bool RestrictedDelaunay::is_dummy(Vertex_handle v) const {
  return dt_.is_infinite(v) || v->info().id < 0;
}

std::vector<std::int64_t> RestrictedDelaunay::insert(const double* xyz,
                                                     std::size_t n, const double* w) {
  const double limit = 2.0 * radius_;
  std::vector<Point> pts;
  pts.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double* p = xyz + 3 * k;
    if (!finite3(p))
      throw std::invalid_argument("point " + std::to_string(k) +
                                  " has a non-finite coordinate");
    // hypot: squares of far points would overflow.
    if (std::hypot(p[0] - c0_[0], p[1] - c0_[1], p[2] - c0_[2]) > limit)
      throw std::invalid_argument("point " + std::to_string(k) +
                                  " lies outside twice the bounding radius");
    if (w && !(w[k] >= 0.0 && w[k] < radius_ * radius_))
      throw std::invalid_argument("point " + std::to_string(k) + " has weight " +
                                  std::to_string(w[k]) +
                                  "; weights must be >= 0 and below the bounding radius squared");
    pts.emplace_back(p[0], p[1], p[2]);
  }
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = k;
  using Map = CGAL::Pointer_property_map<Point>::type;
  using Traits = CGAL::Spatial_sort_traits_adapter_3<K, Map>;
  // hilbert_sort, unlike spatial_sort, draws no random numbers.
  CGAL::hilbert_sort(order.begin(), order.end(),
                     Traits(CGAL::make_property_map(pts)));
  std::vector<std::int64_t> ids(n);

  // Cell handles of an unfinished round die with the insertion: report the
  // whole neighbourhood of that round's vertices again next round.
  restart_round();
  // So that a vertex in the triangulation is always a listed sample, even
  // when dt_.insert throws half-way (the points before it stay inserted).
  reserve_more(samples_, n);
  reserve_more(last_new_, n);
  cell_epoch = ++epoch_;
  std::vector<Vertex_handle> inside;
  for (std::size_t k : order) {
    const Weighted_point wp(pts[k], w ? w[k] : 0.0);
    Regular::Locate_type lt;
    int li, lj;
    const Cell_handle c = dt_.locate(wp, lt, li, lj, hint_);
    if (wp.weight() > 0.0) {
      // A ball must not hide a vertex: its handle would dangle in samples_.
      inside.clear();
      if (lt != Regular::VERTEX) dt_.vertices_inside_conflict_zone(wp, c, std::back_inserter(inside));
      if (lt == Regular::VERTEX || !inside.empty())
        throw std::invalid_argument(
            "point " + std::to_string(k) + " (weight " + std::to_string(wp.weight()) +
            ") would hide " +
            (lt == Regular::VERTEX ? std::string("the vertex at its own position")
                                   : std::to_string(inside.size()) + " vertices") +
            ": insert protecting balls before the samples, with no centre inside another ball");
    }
    Vertex_handle v = dt_.insert(wp, lt, c, li, lj);
    if (v == Vertex_handle()) {
      ids[k] = -1;  // hidden by the balls
      continue;
    }
    if (v->info().id == -2) {
      v->info().id = static_cast<std::int64_t>(samples_.size());
      samples_.push_back(v);
      last_new_.push_back(v);
    }
    ids[k] = v->info().id;
    hint_ = v;
  }
  return ids;
}

namespace {

// Spread of the powers of x to the four weighted points (squared distance
// minus weight), relative to the largest squared distance (T: the arithmetic
// it is computed in).  With weights 0: the spread of the squared distances.
template <typename T>
T spread(const std::array<T, 3>& x, const Weighted_point* const v[4]) {
  T lo = std::numeric_limits<T>::infinity(), hi = -lo, top = 0;
  for (int i = 0; i < 4; ++i) {
    const T d[3] = {x[0] - T(v[i]->x()), x[1] - T(v[i]->y()), x[2] - T(v[i]->z())};
    const T d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const T pw = v[i]->weight() != 0.0 ? d2 - T(v[i]->weight()) : d2;
    lo = std::min(lo, pw);
    hi = std::max(hi, pw);
    top = std::max(top, d2);
  }
  return (hi - lo) / top;  // NaN for a non-finite x
}

// The weighted circumcentre in T arithmetic (long double, or
// CGAL::Exact_rational for the exact one), by Cramer's rule on coordinates
// relative to the first point: 2 m_i . x = |m_i|^2 - (w_i - w_0).  Every
// expression is stored in a T: gmpxx's expression templates would dangle.
template <typename T>
std::array<T, 3> circumcentre_in(const Weighted_point* const v[4]) {
  T m[3][3], rhs[3];
  for (int i = 0; i < 3; ++i) {
    m[i][0] = T(v[i + 1]->x()) - T(v[0]->x());
    m[i][1] = T(v[i + 1]->y()) - T(v[0]->y());
    m[i][2] = T(v[i + 1]->z()) - T(v[0]->z());
    rhs[i] = m[i][0] * m[i][0] + m[i][1] * m[i][1] + m[i][2] * m[i][2];
    if (v[i + 1]->weight() != v[0]->weight())
      rhs[i] = rhs[i] - (T(v[i + 1]->weight()) - T(v[0]->weight()));
    rhs[i] = rhs[i] / 2;
  }
  auto det = [](const T a[3][3]) -> T {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  };
  const T d = det(m);
  std::array<T, 3> out{};
  const T base[3] = {T(v[0]->x()), T(v[0]->y()), T(v[0]->z())};
  for (int k = 0; k < 3; ++k) {
    T a[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] = j == k ? rhs[i] : m[i][j];
    out[k] = base[k] + det(a) / d;
  }
  return out;
}

bool weighted(const Weighted_point* const v[], int n) {
  for (int i = 0; i < n; ++i)
    if (v[i]->weight() != 0.0) return true;
  return false;
}

}  // namespace

const std::array<double, 3>& RestrictedDelaunay::circumcentre(Cell_handle c) {
  CellInfo& info = c->info();
  if (std::isnan(info.cc[0]) && dt_.is_infinite(c)) {
    // No centre; callers skip infinite cells.
    info.cc.fill(std::numeric_limits<double>::infinity());
  } else if (std::isnan(info.cc[0])) {
    const Weighted_point* v[4] = {&c->vertex(0)->point(), &c->vertex(1)->point(),
                                  &c->vertex(2)->point(), &c->vertex(3)->point()};
    // A Voronoi vertex must have equal power to its four vertices. Doubles
    // lose that on nearly flat cells with nearly cocircular vertices (as
    // regular samples make); long doubles, then exact arithmetic, settle them.
    const Point x =
        weighted(v, 4)
            ? K().construct_weighted_circumcenter_3_object()(*v[0], *v[1], *v[2], *v[3])
            : CGAL::circumcenter(v[0]->point(), v[1]->point(), v[2]->point(), v[3]->point());
    const std::array<double, 3> xd = to_vec(x);
    if (spread(xd, v) <= kEquidistance) {
      info.cc = xd;
    } else {
      const auto xl = circumcentre_in<long double>(v);
      const std::array<double, 3> rounded{static_cast<double>(xl[0]), static_cast<double>(xl[1]),
                                          static_cast<double>(xl[2])};
      if (spread(xl, v) <= kEquidistance && spread(rounded, v) <= kEquidistance) {
        info.cc = rounded;
      } else {
        ++exact_circumcentres_;
        const auto xq = circumcentre_in<CGAL::Exact_rational>(v);
        for (int k = 0; k < 3; ++k) info.cc[k] = CGAL::to_double(xq[k]);
      }
    }
  }
  return info.cc;
}

bool RestrictedDelaunay::clip(Vec3& a, Vec3& b) const {
  const Vec3 d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const Vec3 f{a[0] - c0_[0], a[1] - c0_[1], a[2] - c0_[2]};
  const double A = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  if (!(A > 0.0)) return false;
  const double B = f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
  const double C = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - radius_ * radius_;
  const double disc = B * B - A * C;
  if (!(disc > 0.0)) return false;
  const double s = std::sqrt(disc);
  double lo = std::max(0.0, (-B - s) / A);
  double hi = std::min(1.0, (-B + s) / A);
  if (has_box_) {
    // Slab clipping: the parameter range inside each pair of face planes.
    for (int k = 0; k < 3 && lo < hi; ++k) {
      if (d[k] == 0.0) {
        if (a[k] < box_lo_[k] || a[k] > box_hi_[k]) return false;
        continue;
      }
      double t0 = (box_lo_[k] - a[k]) / d[k], t1 = (box_hi_[k] - a[k]) / d[k];
      if (t0 > t1) std::swap(t0, t1);
      lo = std::max(lo, t0);
      hi = std::min(hi, t1);
    }
  }
  if (!(lo < hi)) return false;
  const Vec3 a0 = a;
  if (lo > 0.0)
    for (int k = 0; k < 3; ++k) a[k] = a0[k] + lo * d[k];
  if (hi < 1.0)
    for (int k = 0; k < 3; ++k) b[k] = a0[k] + hi * d[k];
  return true;
}

void RestrictedDelaunay::set_clip_box(const Vec3& lo, const Vec3& hi) {
  if (!finite3(lo.data()) || !finite3(hi.data()))
    throw std::invalid_argument("clip box corners must be finite");
  for (int k = 0; k < 3; ++k)
    if (!(lo[k] < hi[k]))
      throw std::invalid_argument(
          "clip box needs lo < hi on every axis (lo is the lowest corner, hi the highest)");
  if (!samples_.empty())
    throw std::logic_error("set_clip_box must come before the first insertion");
  box_lo_ = lo;
  box_hi_ = hi;
  has_box_ = true;
}

void RestrictedDelaunay::mark_fresh(Cell_handle c) {
  // Listed first: if that throws, the cell is not marked either.
  fault_point_for_testing();
  fresh_.push_back(c);
  for (int k = 0; k < 4; ++k) {
    Vertex_handle v = c->vertex(k);
    if (is_dummy(v)) continue;
    const auto id = static_cast<std::size_t>(v->info().id);
    if (id < touched_.size()) touched_[id] = 1;
    else touched_all_ = true;
  }
  CellInfo& info = c->info();
  info.stamp = round_;
  info.order = static_cast<std::int32_t>(fresh_.size() - 1);
  // Facets shared with a cell gathered earlier are that cell's to report
  // (and may be updated already); the others are this cell's.
  for (int i = 0; i < 4; ++i)
    if (c->neighbor(i)->info().stamp != round_) {
      info.flags[i] = 0;
      info.centre[i] = -1;
    }
}

bool RestrictedDelaunay::gather_more() {
  if (gathered_all_) return false;
  const std::size_t before = fresh_.size();
  if (scan_) {
    const auto end = dt_.finite_cells_end();
    for (; scan_it_ != end && fresh_.size() - before < 256; ++scan_it_) {
      Cell_handle c = scan_it_;
      if (c->info().born >= round_from_) mark_fresh(c);
    }
    gathered_all_ = scan_it_ == end;
  } else {
    while (vertex_cursor_ < round_vertices_.size() && fresh_.size() == before) {
      around_.clear();
      dt_.incident_cells(round_vertices_[vertex_cursor_],
                         std::back_inserter(around_));
      for (Cell_handle c : around_)
        if (c->info().stamp != round_) mark_fresh(c);
      // Only now: after a throw above, the star is gathered again (cells
      // already marked are skipped).
      ++vertex_cursor_;
    }
    gathered_all_ = vertex_cursor_ == round_vertices_.size();
  }
  return fresh_.size() > before;
}

bool RestrictedDelaunay::round_unfinished() const {
  return !pending_.empty() || cursor_ < fresh_.size() || !gathered_all_;
}

namespace {

// The side of a restricted facet that moves its centre in compact_centres:
// the outward side, or the only restricted one (a fresh cell across an old
// one keeps no status until its round is evaluated; the old side must keep a
// valid centre for changed_facets to reuse).
bool owns_centre(Cell_handle c, int i, std::uint8_t fl) {
  if (!(fl & RESTRICTED)) return false;
  if (fl & OUTWARD) return true;
  const Cell_handle nb = c->neighbor(i);
  return !(nb->info().flags[nb->index(c)] & RESTRICTED);
}

}  // namespace

void RestrictedDelaunay::compact_centres() {
  // Restricted facets are about two per sample; entries of destroyed cells
  // pile up otherwise.
  if (centres_.size() / 3 < 8 * samples_.size() + 4096) return;
  // Counted first, so that the only allocation comes before cells change.
  std::size_t live = 0;
  for (auto c = dt_.finite_cells_begin(); c != dt_.finite_cells_end(); ++c)
    for (int i = 0; i < 4; ++i) {
      const std::uint8_t fl = c->info().flags[i];
      live += c->info().centre[i] >= 0 && owns_centre(c, i, fl);
    }
  std::vector<double> kept;
  kept.reserve(3 * live);
  for (auto c = dt_.finite_cells_begin(); c != dt_.finite_cells_end(); ++c) {
    CellInfo& info = c->info();
    for (int i = 0; i < 4; ++i) {
      const std::int32_t old = info.centre[i];
      if (old < 0) continue;
      const std::uint8_t fl = info.flags[i];
      if (!(fl & RESTRICTED)) {
        info.centre[i] = -1;
        continue;
      }
      if (!owns_centre(c, i, fl)) continue;  // the other side moves it for both
      const auto idx = static_cast<std::int32_t>(kept.size() / 3);
      kept.insert(kept.end(), centres_.begin() + 3 * old,
                  centres_.begin() + 3 * old + 3);
      Cell_handle nb = c->neighbor(i);
      info.centre[i] = idx;
      nb->info().centre[nb->index(c)] = idx;
    }
  }
  centres_.swap(kept);
}

void RestrictedDelaunay::reset_end_stamps() {
  // Once per 2^31 calls: a stamp must not come round again while a cell
  // still carries it.
  for (auto c = dt_.all_cells_begin(); c != dt_.all_cells_end(); ++c)
    c->info().end_stamp = -1;
  call_ = 0;
  voronoi_call_ = 0;
}

void RestrictedDelaunay::start_round() {
  // Cells created since the last round: exactly those around new vertices,
  // gathered chunk by chunk.  No chunk is pending at a round's start.
  compact_centres();  // may throw; nothing below does
  ++round_;
  fresh_.clear();
  cursor_ = 0;
  vertex_cursor_ = 0;
  round_vertices_.swap(last_new_);
  last_new_.clear();
  round_from_ = report_from_;
  report_from_ = epoch_ + 1;
  // Visiting the stars of many vertices costs more than one scan of all
  // cells in memory order (measured at 100k samples).
  scan_ = 32 * round_vertices_.size() > dt_.number_of_cells();
  if (scan_) scan_it_ = dt_.finite_cells_begin();
  gathered_all_ = false;
}

ChangedFacets RestrictedDelaunay::changed_facets(
    std::size_t max_facets, const SegmentSampling& sampling) {
  // New samples are touched; sized before any cell is marked (may throw).
  if (touched_.size() < samples_.size()) touched_.resize(samples_.size(), 1);
  if (!last_new_.empty()) start_round();
  if (call_ == std::numeric_limits<std::int32_t>::max()) reset_end_stamps();
  ++call_;
  if (max_facets == 0) max_facets = static_cast<std::size_t>(-1);

  ChangedFacets out;
  const std::size_t guess = std::min<std::size_t>(max_facets, 1 << 16) + 16;
  out.tri.reserve(3 * guess);
  out.seg.reserve(6 * guess);
  out.end_index.reserve(2 * guess);
  out.rho.reserve(guess);
  out.ends.reserve(3 * guess);
  out.end_f.reserve(guess);
  out.end_prev.reserve(guess);
  out.samples.reserve(guess, 6);
  Chunk chunk;
  chunk.facets.reserve(guess);
  chunk.end_cells.reserve(guess);
  auto cell_end = [&](Cell_handle c) {
    CellInfo& info = c->info();
    if (info.end_stamp != call_) {
      out.end_prev.push_back(info.end_stamp == call_ - 1 ? info.end_idx : -1);
      info.end_stamp = call_;
      info.end_idx = static_cast<std::int32_t>(out.ends.size() / 3);
      const Vec3& p = circumcentre(c);
      out.ends.insert(out.ends.end(), p.begin(), p.end());
      out.end_f.push_back(info.f);
      chunk.end_cells.push_back(c);
    }
    return static_cast<std::int64_t>(info.end_idx);
  };
  auto point_end = [&](const Vec3& p) {
    out.ends.insert(out.ends.end(), p.begin(), p.end());
    out.end_f.push_back(std::numeric_limits<double>::quiet_NaN());
    out.end_prev.push_back(-1);
    chunk.end_cells.push_back(Cell_handle());
    return static_cast<std::int64_t>(out.ends.size() / 3 - 1);
  };
  // The round's progress (cursor_) is committed only at the end, once the
  // chunk is queued: a throw before that leaves this chunk to the next call.
  std::size_t cursor = cursor_;
  while (chunk.facets.size() < max_facets) {
    if (cursor == fresh_.size() && !gather_more()) break;
    Cell_handle c = fresh_[cursor++];
    circumcentre(c);
    for (int i = 0; i < 4; ++i) {
      Cell_handle nb = c->neighbor(i);
      const CellInfo& ni = nb->info();
      if (ni.stamp == round_ && ni.order < c->info().order) continue;
      const int j = nb->index(c);
      // An old neighbour keeps the facet's last status (read before it goes).
      const bool old_side = ni.stamp != round_;
      const std::uint8_t was = nb->info().flags[j];
      const std::int32_t was_centre = nb->info().centre[j];
      nb->info().flags[j] = 0;  // the dual moved: old status is stale
      std::array<std::int64_t, 3> t{};
      bool skip = dt_.is_infinite(c) || dt_.is_infinite(nb);
      for (int k = 1; k < 4 && !skip; ++k) {
        Vertex_handle v = c->vertex((i + k) & 3);
        if (is_dummy(v)) skip = true;
        else t[k - 1] = v->info().id;
      }
      if (skip) continue;
      Cell_handle ca = c, cb = nb;
      Vec3 a = circumcentre(c), b = circumcentre(nb);
      // Canonical orientation: the same facet always gives the same segment.
      const bool swapped = lex_less(b, a);
      if (swapped) {
        std::swap(a, b);
        std::swap(ca, cb);
      }
      const Vec3 a0 = a, b0 = b;
      if (!clip(a, b)) continue;
      if (old_side && reuse(c, i, nb, j, was, was_centre, a, b)) continue;
      if (clear_f_ && cleared_by_grid(a, b)) {
        // No crossing, as a clean search would have found: KNOWN, so that a
        // shorter segment later keeps the status without a search.
        c->info().flags[i] = nb->info().flags[j] = KNOWN;
        c->info().centre[i] = nb->info().centre[j] = -1;
        ++cleared_;
        continue;
      }
      fault_point_for_testing();
      std::sort(t.begin(), t.end());
      out.tri.insert(out.tri.end(), t.begin(), t.end());
      out.seg.insert(out.seg.end(), a.begin(), a.end());
      out.seg.insert(out.seg.end(), b.begin(), b.end());
      const double rho = facet_radius(c, i);
      out.rho.push_back(rho);
      const Vec3 apex = to_vec(samples_[t[0]]->point().point());
      out.samples.add(a.data(), b.data(), apex.data(), rho, sampling);
      out.end_index.push_back(a == a0 ? cell_end(ca) : point_end(a));
      out.end_index.push_back(b == b0 ? cell_end(cb) : point_end(b));
      chunk.facets.push_back({c, nb, static_cast<std::int8_t>(i),
                              static_cast<std::int8_t>(j),
                              static_cast<std::int8_t>(swapped ? 1 : 0)});
    }
  }
  if (!chunk.facets.empty()) {
    chunk.begin = cursor_;
    chunk.serial = serial_ + 1;
    pending_.push_back(std::move(chunk));
    out.chunk = ++serial_;
  }
  cursor_ = cursor;
  return out;
}

bool RestrictedDelaunay::reuse(Cell_handle c, int i, Cell_handle nb, int j, std::uint8_t was,
                               std::int32_t centre, const Vec3& a, const Vec3& b) {
  // Inserting samples only shrinks a Voronoi edge, on the same line, and the
  // facet's circumradius (its sampling density) and criteria stay: the new
  // segment lies in the old one, which a clean search covered.
  if (!(was & KNOWN)) return false;
  std::uint8_t f = KNOWN;
  std::int32_t idx = -1;
  if (was & RESTRICTED) {
    if (centre < 0 || static_cast<std::size_t>(centre) >= centres_.size() / 3) return false;
    const double* x = &centres_[3 * static_cast<std::size_t>(centre)];
    const Vec3 d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Vec3 v{x[0] - a[0], x[1] - a[1], x[2] - a[2]};
    const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (!(dd > 0.0)) return false;
    const double t = (v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) / dd;
    const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    // Off the line (rounding aside) or at an end of the new segment: search again.
    constexpr double kMargin = 1e-9;
    if (vv - t * t * dd > kMargin * kMargin * dd) return false;
    if (std::fabs(t) <= kMargin || std::fabs(t - 1.0) <= kMargin) return false;
    if (t > 0.0 && t < 1.0) {
      f = was & (LABELS | KNOWN);  // the same crossing: same centre, same criteria
      idx = centre;
    }  // else the one crossing left the segment: none is on it
  }
  const bool restricted = (f & RESTRICTED) != 0;
  // nb's OUTWARD bit (outside towards its neighbour, now c) still holds.
  nb->info().flags[j] = f | (restricted ? (was & OUTWARD) : 0);
  c->info().flags[i] = f | (restricted && !(was & OUTWARD) ? OUTWARD : 0);
  nb->info().centre[j] = idx;
  c->info().centre[i] = idx;
  mark(c, i, f);
  ++reused_;
  return true;
}

void RestrictedDelaunay::set_clearing(const GridField& f, const GridField& slopes, double scale,
                                      double reach, double cap) {
  if (!(scale > 0.0) || !(reach >= 0.0) || !(cap > 0.0) || !std::isfinite(scale) ||
      !std::isfinite(reach))
    throw std::invalid_argument("clearing needs scale > 0, reach >= 0 and cap > 0");
  clear_f_ = std::make_unique<GridField>(f);
  clear_slopes_ = std::make_unique<GridField>(slopes);
  clear_scale_ = scale;
  clear_reach_ = reach;
  clear_cap_ = cap;
  fine_.reset();
}

void RestrictedDelaunay::set_fine_clearing(int m, std::uint32_t threshold, double reach) {
  if (!clear_f_) throw std::logic_error("set_fine_clearing needs set_clearing first");
  fine_ = std::make_unique<FineField>(*clear_f_, m, threshold, reach);
}

bool RestrictedDelaunay::cleared_by_grid(const Vec3& a, const Vec3& b) {
  const double seg[6] = {a[0], a[1], a[2], b[0], b[1], b[2]};
  double bound, value;
  clear_slopes_->segment_bounds(seg, 1, clear_reach_, clear_scale_, clear_cap_, &bound);
  clear_f_->clearing_values(seg, 1, &bound, &value);
  if (!std::isnan(value)) return true;
  return fine_ && fine_->clears(a.data(), b.data(), clear_cap_);
}

void RestrictedDelaunay::withdraw_chunk(std::uint64_t serial) {
  if (serial == 0 || pending_.empty() || pending_.back().serial != serial)
    return;
  // Only insert and restart_round, which clear pending_, move cursor_ back,
  // so the chunk's cells are still fresh_[begin, cursor_): hand them out
  // again (cells after them that gave no facet are simply visited again).
  cursor_ = pending_.back().begin;
  pending_.pop_back();
  // The caller never saw this call's ends: the next call must not refer to
  // them (at the counter's end, the next call resets every stamp).
  if (call_ < std::numeric_limits<std::int32_t>::max()) ++call_;
}

void RestrictedDelaunay::update_facets(const std::uint8_t* flags,
                                       const double* centres, std::size_t n,
                                       const double* end_f, std::size_t n_ends) {
  const std::size_t want = pending_.empty() ? 0 : pending_.front().facets.size();
  if (n != want)
    throw std::invalid_argument(
        "update_facets needs one entry per facet of the oldest chunk from "
        "changed_facets() not yet updated (expected " + std::to_string(want) +
        ", got " + std::to_string(n) + "); no insert may come in between");
  const std::size_t ends = pending_.empty() ? 0 : pending_.front().end_cells.size();
  if (end_f != nullptr && n_ends != ends)
    throw std::invalid_argument(
        "update_facets needs f at every end of the chunk (expected " + std::to_string(ends) +
        ", got " + std::to_string(n_ends) + ")");
  if (n == 0) return;
  // Allocate before writing: a throw leaves the chunk pending, untouched.
  std::size_t restricted = 0;
  for (std::size_t k = 0; k < n; ++k) restricted += (flags[k] & RESTRICTED) != 0;
  reserve_more(centres_, 3 * restricted);
  fault_point_for_testing();
  const Chunk chunk = std::move(pending_.front());
  pending_.pop_front();
  for (std::size_t k = 0; k < n; ++k) {
    const Side& side = chunk.facets[k];
    Cell_handle c = side.c, nb = side.nb;
    const int i = side.i, j = side.j;
    std::uint8_t f = flags[k] & LABELS;
    if (!(f & RESTRICTED)) f = 0;
    f |= flags[k] & KNOWN;
    // Segment runs c -> nb unless it was swapped for canonical order.
    const bool out_to_nb = (f & RESTRICTED) &&
                           (((flags[k] & OUTWARD) != 0) != (side.swapped != 0));
    c->info().flags[i] = f | (out_to_nb ? OUTWARD : 0);
    nb->info().flags[j] = f | ((f & RESTRICTED) && !out_to_nb ? OUTWARD : 0);
    mark(c, i, f);
    std::int32_t idx = -1;
    if (f & RESTRICTED) {
      idx = static_cast<std::int32_t>(centres_.size() / 3);
      centres_.insert(centres_.end(), centres + 3 * k, centres + 3 * k + 3);
    }
    c->info().centre[i] = idx;
    nb->info().centre[j] = idx;
  }
  if (end_f != nullptr)
    for (std::size_t e = 0; e < n_ends; ++e)
      if (chunk.end_cells[e] != Cell_handle()) chunk.end_cells[e]->info().f = end_f[e];
}

void RestrictedDelaunay::restart_round() {
  if (round_unfinished()) {
    // If this throws (memory), nothing has changed yet.
    last_new_.insert(last_new_.begin(), round_vertices_.begin(),
                     round_vertices_.end());
    report_from_ = round_from_;
  }
  pending_.clear();
  fresh_.clear();
  cursor_ = 0;
  round_vertices_.clear();
  vertex_cursor_ = 0;
  gathered_all_ = true;
}

namespace {

constexpr std::uint8_t kMarks = BAD | TOPO;
constexpr std::uint8_t kNeed = RESTRICTED | OUTWARD;

}  // namespace

void RestrictedDelaunay::mark(Cell_handle c, int i, std::uint8_t flags) {
  if (!(flags & RESTRICTED) || !(flags & kMarks) || !marked_whole_) return;
  std::array<std::int64_t, 3> t;
  for (int k = 1; k < 4; ++k) t[k - 1] = c->vertex((i + k) & 3)->info().id;
  std::sort(t.begin(), t.end());
  try {
    marked_.push_back(t);
  } catch (const std::bad_alloc&) {
    // Not recorded: the next read scans every cell, which rebuilds the list.
    marked_whole_ = false;
  }
}

void RestrictedDelaunay::emit(FacetList& out, Cell_handle c, int i, std::uint8_t fl) const {
  out.flags.push_back(fl & LABELS);
  // The side whose neighbour is outside reports it; the normal points away
  // from vertex i, i.e. reversed CGAL facet order (which faces vertex i).
  const int a = CGAL::Triangulation_utils_3::vertex_triple_index(i, 0);
  const int b = CGAL::Triangulation_utils_3::vertex_triple_index(i, 1);
  const int d = CGAL::Triangulation_utils_3::vertex_triple_index(i, 2);
  out.tri.push_back(c->vertex(a)->info().id);
  out.tri.push_back(c->vertex(d)->info().id);
  out.tri.push_back(c->vertex(b)->info().id);
  const std::int32_t idx = c->info().centre[i];
  if (idx >= 0)
    out.centre.insert(out.centre.end(), centres_.begin() + 3 * idx,
                      centres_.begin() + 3 * idx + 3);
  else
    out.centre.insert(out.centre.end(), 3, 0.0);
}

FacetList RestrictedDelaunay::facets_with(std::uint8_t mask) const {
  // A lookup costs about as much as visiting a hundred cells.
  if (mask != 0 && !(mask & ~kMarks) && marked_whole_ &&
      marked_.size() * 100 <= dt_.number_of_cells())
    return facets_from_marked(mask);
  FacetList out;
  std::vector<std::array<std::int64_t, 3>> marked;
  for (auto c = dt_.finite_cells_begin(); c != dt_.finite_cells_end(); ++c) {
    const CellInfo& info = c->info();
    for (int i = 0; i < 4; ++i) {
      const std::uint8_t fl = info.flags[i];
      if ((fl & kNeed) != kNeed) continue;
      if (fl & kMarks) {
        std::array<std::int64_t, 3> t;
        for (int k = 1; k < 4; ++k) t[k - 1] = c->vertex((i + k) & 3)->info().id;
        std::sort(t.begin(), t.end());
        marked.push_back(t);
      }
      if (mask != 0 && (fl & mask) == 0) continue;
      emit(out, c, i, fl);
    }
  }
  std::sort(marked.begin(), marked.end());
  marked_.swap(marked);
  marked_whole_ = true;
  return out;
}

FacetList RestrictedDelaunay::facets_from_marked(std::uint8_t mask) const {
  std::sort(marked_.begin(), marked_.end());
  marked_.erase(std::unique(marked_.begin(), marked_.end()), marked_.end());
  FacetList out;
  std::size_t kept = 0;
  for (const auto& t : marked_) {
    Cell_handle c;
    int a, b, d;
    if (!dt_.is_facet(samples_[t[0]], samples_[t[1]], samples_[t[2]], c, a, b, d)) continue;
    const int i = 6 - a - b - d;
    Cell_handle nb = c->neighbor(i);
    const int j = nb->index(c);
    const std::uint8_t fc = c->info().flags[i], fn = nb->info().flags[j];
    if (!((fc | fn) & RESTRICTED) || !((fc | fn) & kMarks)) continue;  // relabelled
    marked_[kept++] = t;
    if ((fc & kNeed) == kNeed && (fc & mask)) emit(out, c, i, fc);
    else if ((fn & kNeed) == kNeed && (fn & mask)) emit(out, nb, j, fn);
  }
  marked_.resize(kept);
  return out;
}

FacetList RestrictedDelaunay::facets_around(const std::int64_t* ids, std::size_t m) const {
  const auto n = static_cast<std::int64_t>(samples_.size());
  std::vector<std::uint8_t> asked(samples_.size(), 0);
  for (std::size_t k = 0; k < m; ++k) {
    if (ids[k] < 0 || ids[k] >= n)
      throw std::invalid_argument("vertex id " + std::to_string(ids[k]) + " out of range");
    asked[ids[k]] = 1;
  }
  FacetList out;
  std::vector<Cell_handle> cells;
  for (std::int64_t id = 0; id < n; ++id) {
    if (!asked[id]) continue;
    Vertex_handle v = samples_[id];
    cells.clear();
    dt_.finite_incident_cells(v, std::back_inserter(cells));
    for (Cell_handle c : cells) {
      const int iv = c->index(v);
      for (int i = 0; i < 4; ++i) {
        if (i == iv) continue;
        const std::uint8_t fl = c->info().flags[i];
        if ((fl & kNeed) != kNeed) continue;  // the outward side reports it
        // Once: from its smallest asked vertex.
        std::int64_t first = id;
        for (int k = 1; k < 4; ++k) {
          const std::int64_t u = c->vertex((i + k) & 3)->info().id;
          if (u >= 0 && u < id && asked[u]) first = u;
        }
        if (first == id) emit(out, c, i, fl);
      }
    }
  }
  return out;
}

std::vector<std::int64_t> RestrictedDelaunay::take_touched() {
  std::vector<std::int64_t> out;
  for (std::size_t id = 0; id < samples_.size(); ++id)
    if (touched_all_ || id >= touched_.size() || touched_[id])
      out.push_back(static_cast<std::int64_t>(id));
  std::fill(touched_.begin(), touched_.end(), 0);
  touched_all_ = false;
  return out;
}

std::vector<std::uint8_t> RestrictedDelaunay::is_facet(const std::int64_t* tri,
                                                       std::size_t n) const {
  std::vector<std::uint8_t> out(n, 0);
  const auto m = static_cast<std::int64_t>(samples_.size());
  for (std::size_t k = 0; k < n; ++k) {
    const std::int64_t* t = tri + 3 * k;
    for (int d = 0; d < 3; ++d)
      if (t[d] < 0 || t[d] >= m)
        throw std::invalid_argument("vertex id " + std::to_string(t[d]) +
                                    " out of range");
    Cell_handle c;
    int i, j, l;
    out[k] = dt_.is_facet(samples_[t[0]], samples_[t[1]], samples_[t[2]], c, i,
                          j, l)
                 ? 1
                 : 0;
  }
  return out;
}

void RestrictedDelaunay::neighbours(const std::int64_t* ids, std::size_t n,
                                    std::vector<std::int64_t>& offsets,
                                    std::vector<std::int64_t>& adj) const {
  const auto m = static_cast<std::int64_t>(samples_.size());
  offsets.assign(1, 0);
  std::vector<Vertex_handle> around;
  for (std::size_t k = 0; k < n; ++k) {
    if (ids[k] < 0 || ids[k] >= m)
      throw std::invalid_argument("vertex id " + std::to_string(ids[k]) +
                                  " out of range");
    around.clear();
    dt_.finite_adjacent_vertices(samples_[ids[k]], std::back_inserter(around));
    for (Vertex_handle v : around)
      if (!is_dummy(v)) adj.push_back(v->info().id);
    offsets.push_back(static_cast<std::int64_t>(adj.size()));
  }
}

std::vector<double> RestrictedDelaunay::samples() const {
  std::vector<double> out;
  out.reserve(3 * samples_.size());
  for (Vertex_handle v : samples_) {
    const Weighted_point& p = v->point();
    out.push_back(p.x());
    out.push_back(p.y());
    out.push_back(p.z());
  }
  return out;
}

std::vector<double> RestrictedDelaunay::weights() const {
  std::vector<double> out;
  out.reserve(samples_.size());
  for (Vertex_handle v : samples_) out.push_back(v->point().weight());
  return out;
}

double RestrictedDelaunay::facet_radius(Cell_handle c, int i) const {
  const Weighted_point* v[3] = {&c->vertex((i + 1) & 3)->point(), &c->vertex((i + 2) & 3)->point(),
                                &c->vertex((i + 3) & 3)->point()};
  if (!weighted(v, 3))
    return std::sqrt(CGAL::squared_radius(v[0]->point(), v[1]->point(), v[2]->point()));
  // The smallest sphere orthogonal to the three balls; its squared radius is
  // negative only where the three balls share a point (not for a protected
  // complex, whose balls meet at most in pairs).
  const double r2 =
      K().compute_squared_radius_smallest_orthogonal_sphere_3_object()(*v[0], *v[1], *v[2]);
  return r2 > 0.0 ? std::sqrt(r2) : 0.0;
}

ChangedFacets RestrictedDelaunay::all_facets() {
  ChangedFacets out;
  for (auto f = dt_.finite_facets_begin(); f != dt_.finite_facets_end(); ++f) {
    Cell_handle c = f->first;
    const int i = f->second;
    Cell_handle nb = c->neighbor(i);
    if (dt_.is_infinite(c) || dt_.is_infinite(nb)) continue;
    std::array<std::int64_t, 3> t{};
    bool skip = false;
    for (int k = 1; k < 4 && !skip; ++k) {
      Vertex_handle v = c->vertex((i + k) & 3);
      if (is_dummy(v)) skip = true;
      else t[k - 1] = v->info().id;
    }
    if (skip) continue;
    Vec3 a = circumcentre(c), b = circumcentre(nb);
    if (lex_less(b, a)) std::swap(a, b);
    if (!clip(a, b)) continue;
    std::sort(t.begin(), t.end());
    out.tri.insert(out.tri.end(), t.begin(), t.end());
    out.seg.insert(out.seg.end(), a.begin(), a.end());
    out.seg.insert(out.seg.end(), b.begin(), b.end());
  }
  return out;
}

void RestrictedDelaunay::check() const {
  if (!dt_.is_valid(false))
    throw std::runtime_error("the triangulation is not a valid regular "
                             "(weighted Delaunay) triangulation");
  std::vector<std::array<std::int64_t, 3>> marked(marked_);
  std::sort(marked.begin(), marked.end());
  for (auto c = dt_.finite_cells_begin(); c != dt_.finite_cells_end(); ++c) {
    for (int i = 0; i < 4; ++i) {
      Cell_handle nb = c->neighbor(i);
      const int j = nb->index(c);
      const std::uint8_t a = c->info().flags[i], b = nb->info().flags[j];
      if ((a & LABELS) != (b & LABELS))
        throw std::runtime_error("facet flags differ between its two sides");
      if ((a & RESTRICTED) && ((a & OUTWARD) != 0) == ((b & OUTWARD) != 0))
        throw std::runtime_error(
            "a restricted facet must face outward on exactly one side");
      if (marked_whole_ && (a & RESTRICTED) && (a & kMarks)) {
        std::array<std::int64_t, 3> t;
        for (int k = 1; k < 4; ++k) t[k - 1] = c->vertex((i + k) & 3)->info().id;
        std::sort(t.begin(), t.end());
        if (!std::binary_search(marked.begin(), marked.end(), t))
          throw std::runtime_error("a facet labelled BAD or TOPO is not in the marked list");
      }
    }
  }
}

namespace {

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const {
    return x == o.x && y == o.y && z == o.z;
  }
};

struct CellKeyHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ULL;
    h ^= static_cast<std::uint64_t>(k.y) + 0xC2B2AE3D27D4EB4FULL + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) + 0x165667B19E3779F9ULL + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h);
  }
};

std::string number(double x) {
  std::ostringstream s;
  s << std::setprecision(17) << x;
  return s.str();
}

// Is |p - q| <= r?  Decided exactly.  In doubles d2 and r2 are within 7e-16
// relative (plus 1e-323 absolute, from underflow) of the true squares, so a
// difference beyond the bound below has the right sign; near ties, and when
// a square overflows (the test fails on inf or NaN), rationals decide.
bool in_closed_ball(const double* p, const double* q, double r) {
  const double ex = p[0] - q[0], ey = p[1] - q[1], ez = p[2] - q[2];
  const double d2 = ex * ex + ey * ey + ez * ez, r2 = r * r;
  const double diff = d2 - r2;
  if (std::abs(diff) > 1e-15 * (d2 + r2) + 1e-300) return diff < 0.0;
  using Q = CGAL::Exact_rational;
  Q e2(0);
  for (int k = 0; k < 3; ++k) {
    const Q e = Q(p[k]) - Q(q[k]);
    e2 += e * e;
  }
  return e2 <= Q(r) * Q(r);
}

// Smallest grid cell for a ball of radius r: s >= r (1 + 2^-10).  The slack
// keeps the cell keys of two points within r at most one apart despite the
// rounding of x / s (below 2^-1000 the product would lose precision; any s
// above 2r does).  Monotone in r; inf when r (1 + 2^-10) overflows.
double cell_size_for(double r) { return std::max(r + r * 0x1p-10, 0x1p-999); }

// Cell index of coordinate x on a grid of cell size s.  Clamped to +-2^40:
// x / s may be inf or beyond int64 (extreme centres or radii), and below the
// clamp it is accurate to 2^-13.  The key stays monotone in x and changes by
// at most 1 over a distance r, so the 27 cells around a centre still hold
// every ball that can contain it (clamped cells just hold more balls).
std::int64_t cell_index(double x, double s) {
  constexpr double limit = 0x1p40;
  const double v = std::floor(x / s);
  if (!(v < limit)) return static_cast<std::int64_t>(limit);
  if (v < -limit) return -static_cast<std::int64_t>(limit);
  return static_cast<std::int64_t>(v);
}

}  // namespace

std::vector<std::int64_t> select_independent(const double* centres,
                                             const double* radii,
                                             std::size_t n) {
  std::vector<std::int64_t> accepted;
  const char* rule = "; each ball needs a finite centre and a positive radius";
  double rmin = HUGE_VAL;
  for (std::size_t k = 0; k < n; ++k) {
    const double r = radii[k];
    if (finite3(centres + 3 * k) && std::isfinite(r) && r > 0.0) {
      rmin = std::min(rmin, r);
      continue;
    }
    // Only a bad ball pays for the message.
    const std::string ball = "ball " + std::to_string(k);
    if (!finite3(centres + 3 * k))
      throw std::invalid_argument(ball + " has a non-finite centre" + rule);
    if (!std::isfinite(r))
      throw std::invalid_argument(ball + " has a non-finite radius (" +
                                  number(r) + ")" + rule);
    if (!(r > 0.0))
      throw std::invalid_argument(ball + (r < 0.0 ? " has a negative radius (" +
                                                        number(r) + ")"
                                                  : " has radius 0") +
                                  rule);
  }
  if (n == 0) return accepted;
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (radii[a] != radii[b]) return radii[a] > radii[b];
    const double* p = centres + 3 * a;
    const double* q = centres + 3 * b;
    return std::lexicographical_compare(p, p + 3, q, q + 3);
  });
  // Grid levels of cell sizes base * 2^l.  Accepted balls live on the first
  // level whose cells fit them, so a centre inside one of them is at most
  // one cell away: 27 cells per level.  At most about 2100 levels (from
  // 2^-999 to inf).
  using Grid = std::unordered_map<CellKey, std::vector<std::size_t>, CellKeyHash>;
  std::vector<Grid> levels;
  std::vector<double> sizes;
  std::vector<std::size_t> active;  // levels holding a ball
  auto level_of = [&](double r) {
    const double need = cell_size_for(r);
    for (std::size_t l = 0;; ++l) {
      if (l == sizes.size()) {
        sizes.push_back(l == 0 ? cell_size_for(rmin) : 2.0 * sizes.back());
        levels.emplace_back();
      }
      if (sizes[l] >= need) return l;
    }
  };
  auto key_of = [](const double* p, double s) {
    return CellKey{cell_index(p[0], s), cell_index(p[1], s), cell_index(p[2], s)};
  };
  for (std::size_t k : order) {
    const double* p = centres + 3 * k;
    bool free = true;
    for (std::size_t li = 0; li < active.size() && free; ++li) {
      const std::size_t l = active[li];
      const CellKey base = key_of(p, sizes[l]);
      for (int dx = -1; dx <= 1 && free; ++dx)
        for (int dy = -1; dy <= 1 && free; ++dy)
          for (int dz = -1; dz <= 1 && free; ++dz) {
            auto it = levels[l].find({base.x + dx, base.y + dy, base.z + dz});
            if (it == levels[l].end()) continue;
            for (std::size_t a : it->second)
              if (in_closed_ball(p, centres + 3 * a, radii[a])) {
                free = false;
                break;
              }
          }
    }
    if (!free) continue;
    accepted.push_back(static_cast<std::int64_t>(k));
    const std::size_t l = level_of(radii[k]);
    if (levels[l].empty()) active.push_back(l);
    levels[l][key_of(p, sizes[l])].push_back(k);
  }
  return accepted;
}

}  // namespace rdmesh
