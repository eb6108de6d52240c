// Restricted Delaunay bookkeeping over CGAL's Regular_triangulation_3.
//
// The class keeps the 3D regular (weighted Delaunay) triangulation of the
// samples plus eight far dummy points, so every Voronoi edge that can meet the
// bounding ball is a finite segment.  Samples have weight 0; protecting balls
// (creases.md) are vertices of positive weight w, the ball of radius sqrt(w).
// Where every weight is 0 the triangulation is the Delaunay triangulation and
// the power diagram the Voronoi diagram: "circumcentre" below is the weighted
// circumcentre (equal power to the four vertices), "radius" the power radius
// sqrt(|x - p|^2 - w_p).  Per-facet restricted data (flags, surface centre) lives in
// the cells, as in CGAL's Surface_mesh_cell_base_3, so it disappears with the
// cells a batch destroys.  No Python headers here.
//
// Threads: the class itself is not thread-safe.  Every call must hold the
// object's mutex(); module.cpp takes it in every binding (after releasing the
// GIL), so Python threads sharing one object take turns.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Regular_triangulation_3.h>
#include <CGAL/Regular_triangulation_vertex_base_3.h>
#include <CGAL/Triangulation_cell_base_3.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_data_structure_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include "fine_field.hpp"
#include "grid_field.hpp"
#include "sampling.hpp"

namespace rdmesh {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Weighted_point = K::Weighted_point_3;

// Facet flag bits, set by Python (module.cpp exports them).  BAD and TOPO are
// opaque labels here (Python: fails a criterion / crosses the surface badly).
enum FacetFlag : std::uint8_t {
  RESTRICTED = 1,
  BAD = 2,
  // Python: outside lies along the reported segment direction.
  // Stored: outside lies towards this side's neighbour cell.
  OUTWARD = 4,
  TOPO = 8,
  LABELS = RESTRICTED | BAD | TOPO,
  // Python: the facet's crossing search was clean: no crossing, or one
  // transversal crossing (the surface centre), no failed root search.  A
  // facet keeps its line, its circumradius (so its sampling density) and its
  // criteria when an insertion only shrinks its dual segment, so such a
  // facet's new status follows from where the old centre lies (see
  // changed_facets) and it is not handed out again.
  KNOWN = 16,
};

// Cells record the insertion (epoch) that created them, read from this
// variable, which RestrictedDelaunay::insert sets in its thread.
inline thread_local std::int32_t cell_epoch = 0;

struct VertexInfo {
  std::int64_t id = -2;  // -1 for dummies, >= 0 for samples
};

// Kept small (72 bytes): cell size is a large part of insertion time and of
// the memory of a run.
struct CellInfo {
  // Cached circumcentre; NaN until computed.
  std::array<double, 3> cc{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  // f at the circumcentre, as Python gave it with a chunk's flags; NaN until
  // then (a cell's circumcentre never moves, so neither does f there).
  double f = std::numeric_limits<double>::quiet_NaN();
  // Surface centre per facet, as an index into RestrictedDelaunay::centres_
  // (both sides of a facet share it; -1: none).
  std::array<std::int32_t, 4> centre{-1, -1, -1, -1};
  std::array<std::uint8_t, 4> flags{};
  std::int32_t stamp = -1;  // round in which the cell was reported as new
  std::int32_t order = -1;  // position in that round's list of new cells
  std::int32_t end_idx = -1;    // index into ChangedFacets::ends ...
  std::int32_t end_stamp = -1;  // ... valid for one changed_facets call
  std::int32_t born = cell_epoch;
};

// The cell base Regular_triangulation_3 needs, without storage for hidden
// points: CGAL's Regular_triangulation_cell_base_3 keeps a std::list in every
// cell (24 bytes) even when its policy discards them.  Hidden points are
// never kept here (a sample inside a protecting ball is not inserted).
template <typename GT, typename Cb = CGAL::Triangulation_cell_base_3<GT>>
class Cell_base_without_hidden_points : public Cb {
 public:
  using Vertex_handle = typename Cb::Vertex_handle;
  using Cell_handle = typename Cb::Cell_handle;
  using Geom_traits = GT;
  using Point_3 = typename GT::Point_3;
  using Point = typename GT::Weighted_point_3;
  using Point_iterator = Point*;
  using Point_const_iterator = const Point*;

  template <typename TDS2>
  struct Rebind_TDS {
    using Cb2 = typename Cb::template Rebind_TDS<TDS2>::Other;
    using Other = Cell_base_without_hidden_points<GT, Cb2>;
  };

  using Cb::Cb;

  Point_iterator hidden_points_begin() { return nullptr; }
  Point_iterator hidden_points_end() { return nullptr; }
  Point_const_iterator hidden_points_begin() const { return nullptr; }
  Point_const_iterator hidden_points_end() const { return nullptr; }
  void hide_point(const Point&) {}
  void unhide_point(Point_iterator) {}
};

using Vb = CGAL::Triangulation_vertex_base_with_info_3<
    VertexInfo, K, CGAL::Regular_triangulation_vertex_base_3<K>>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<CellInfo, K,
                                                     Cell_base_without_hidden_points<K>>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using Regular = CGAL::Regular_triangulation_3<K, Tds>;
using Cell_handle = Regular::Cell_handle;
using Vertex_handle = Regular::Vertex_handle;

// Facets whose dual changed in the last batch, with clipped dual segments.
struct ChangedFacets {
  std::vector<std::int64_t> tri;  // k*3 sorted vertex ids
  std::vector<double> seg;        // k*6: start xyz, end xyz (canonical order)
  // Segment ends as indices into `ends` (u*3): a Voronoi vertex shared by
  // several segments appears once, so f is evaluated there once.
  std::vector<std::int64_t> end_index;  // k*2
  std::vector<double> ends;             // u*3
  // f at each end where a cell keeps it from an earlier chunk (NaN: unknown,
  // or a clipped end, which is no circumcentre).
  std::vector<double> end_f;            // u
  // The index of each end among the ends of the previous changed_facets
  // call, when it was one there too (-1 otherwise): that chunk may not be
  // updated yet, so its f is not kept, but the caller has it.
  std::vector<std::int64_t> end_prev;   // u
  std::vector<double> rho;              // k facet circumradii
  SegmentSamples samples;  // per facet, its apex the smallest-id vertex
  std::uint64_t chunk = 0;  // serial of the pending chunk (0: none), for
                            // RestrictedDelaunay::withdraw_chunk
};

// Voronoi facets dual to Delaunay edges, as CSR polygons (voronoi.cpp).
struct VoronoiFacets {
  std::vector<std::int64_t> offsets;  // m+1: polygon k is [offsets[k], offsets[k+1])
  std::vector<double> points;         // total*3 circumcentres, circulator order
  // total: index of the cell of each polygon vertex into a per-call numbering
  // of the distinct cells (so a cell's values can be computed once).
  std::vector<std::int64_t> cell;
  // total: polygon edge j runs from vertex j to vertex j+1 (cyclically); it is
  // dual to the Delaunay facet (p, q, third[j]); third is -1 for a dummy.
  std::vector<std::int64_t> third;
};

// A triangle set made one disk per vertex by relabelling Delaunay cells
// (star_relabel.cpp).
struct StarRelabel {
  std::vector<std::int64_t> faces;    // k*3, oriented outward
  std::vector<std::int64_t> flipped;  // c*4 sorted ids of each cell flipped
  bool timed_out = false;             // max_seconds passed: later vertices left as they were
};

// Throws std::invalid_argument unless 0 <= id < n (a sample id).
inline void check_sample_id(std::int64_t id, std::size_t n) {
  if (id < 0 || id >= static_cast<std::int64_t>(n))
    throw std::invalid_argument("vertex id " + std::to_string(id) + " out of range");
}

// The distinct cells around some samples (star_relabel.cpp).
struct StarCells {
  std::vector<std::int64_t> cells;  // c*4 sorted vertex ids, -1 for a dummy
  std::vector<double> centres;      // c*3 circumcentres
};

// Restricted facets, oriented outward, with their surface centres.
struct FacetList {
  std::vector<std::int64_t> tri;    // k*3
  std::vector<double> centre;       // k*3
  std::vector<std::uint8_t> flags;  // k labels (RESTRICTED | BAD | TOPO bits)
};

class RestrictedDelaunay {
 public:
  RestrictedDelaunay(const std::array<double, 3>& centre, double radius);

  // Insert n points (xyz, row-major) with weights w (n values >= 0; null: all
  // 0); returns one id per point.  A point that coincides with an existing
  // vertex of the same weight gets that vertex's id; a point of weight 0
  // that the balls hide (it lies where a ball has smaller power) gets -1 and
  // is not a vertex.  Throws std::invalid_argument for a point of positive
  // weight that would hide a vertex (lie on one, or cover one's power cell):
  // balls go in before the samples they must not hide.
  std::vector<std::int64_t> insert(const double* xyz, std::size_t n,
                                   const double* w = nullptr);

  // Facets of the cells created since the previous round whose clipped dual
  // meets the bounding ball, in chunks of about max_facets (0: all at once);
  // an empty result ends the round.  Their flags are cleared: update_facets
  // sets them, for the oldest chunk not yet updated (same order and count).
  // Several chunks may be handed out before the first is updated.  An
  // insert before the round is fully updated reports the round again.
  // Each segment comes with its samples for the crossing search.
  //
  // Exceptions (e.g. std::bad_alloc): changed_facets commits its progress
  // through the round only once the chunk is complete and queued, so after a
  // throw the next call hands out the same facets again (the cells it
  // gathered stay gathered, and flags it cleared stay cleared: both are
  // redone the same way).  update_facets checks and allocates before it
  // writes, so a throw leaves the chunk pending.  withdraw_chunk undoes a
  // call whose result never reached the caller.  restart_round always hands
  // out the whole round again.
  ChangedFacets changed_facets(std::size_t max_facets = 0,
                               const SegmentSampling& sampling = {});
  // end_f: null, or f at the chunk's u ends (as changed_facets numbered
  // them; n_ends must be u), kept in their cells for later chunks (NaN: not
  // kept).
  void update_facets(const std::uint8_t* flags, const double* centres,
                     std::size_t n, const double* end_f = nullptr,
                     std::size_t n_ends = 0);

  // Undoes the changed_facets call that returned chunk `serial`, if that
  // chunk is still the newest pending one (module.cpp: the result could not
  // be handed to Python), so the next call reports its facets again.
  void withdraw_chunk(std::uint64_t serial);

  // Forget the chunks handed out and not updated, and hand out the whole
  // current round again (after an interruption mid-round).
  void restart_round();

  // Restricted facets having any bit of `mask` (all restricted facets when
  // mask is 0), each once.  A mask of BAD and TOPO bits only reads the
  // facets marked so since the last full scan (marked_) when they are few:
  // late rounds then need not visit every cell.
  FacetList facets_with(std::uint8_t mask) const;

  // Restricted facets (as facets_with(0)) having a vertex among the m
  // sample ids, each once; throws std::invalid_argument for an id out of range.
  FacetList facets_around(const std::int64_t* ids, std::size_t m) const;

  // Ids of the samples whose restricted facets may have changed since the
  // last call (the vertices of every cell made since: a facet's status
  // changes only with one of its cells), ascending; clears the list.
  std::vector<std::int64_t> take_touched();

  // Each facet (sorted or not) as three vertex ids: is it a Delaunay facet?
  std::vector<std::uint8_t> is_facet(const std::int64_t* tri,
                                     std::size_t n) const;

  // Ids of the samples adjacent (by a Delaunay edge) to each given sample,
  // as CSR arrays.  Dummies are left out.
  void neighbours(const std::int64_t* ids, std::size_t n,
                  std::vector<std::int64_t>& offsets,
                  std::vector<std::int64_t>& adj) const;

  // Voronoi facets dual to the Delaunay edges (p, q) given as m id pairs
  // (p != q, both samples); throws std::invalid_argument for an id out of
  // range or a pair that is not a Delaunay edge.  Not const: it numbers the
  // cells through their end_idx/end_stamp fields and caches circumcentres.
  VoronoiFacets voronoi_facets(const std::int64_t* edges, std::size_t m);

  // The distinct finite cells incident to the k given samples, with their
  // circumcentres.  Throws std::invalid_argument for ids out of range.  Not
  // const: it caches circumcentres.
  StarCells star_cells(const std::int64_t* ids, std::size_t k);

  // Read faces (F, 3 sample ids, oriented outward) as the boundary of a
  // labelling of the Delaunay cells (inside: the faces' normals point away
  // from it), and at each given vertex (ascending) move one group of its
  // incident cells, joined through facets not in the set, to the other side
  // until two groups are left (one inside, one outside), so the faces around
  // it form one disk.  The group moved is the one whose largest cell cost
  // is least (then the smallest, then the first by cell ids); cost gives
  // each of c cells (4 ids each, any order) its cost, and a cell without
  // one (or with a dummy vertex, or a cost that is NaN or negative) is
  // never moved, so the vertex may keep more than two groups.  Each move
  // toggles the cells' four facets.  Faces come back in their order, the
  // removed ones dropped, then the added ones.  Throws
  // std::invalid_argument for ids out of range, a face repeating a vertex or
  // a face given twice.  Vertices go in id order; once max_seconds have
  // passed, the rest are left as they are (timed_out).
  StarRelabel relabel_stars(const std::int64_t* faces, std::size_t F,
                            const std::int64_t* ids, std::size_t k,
                            const std::int64_t* cells, const double* cost,
                            std::size_t c, double max_seconds) const;

  // Every Delaunay edge between samples (sorted id pairs, as delaunay_edges
  // gives them) and the bounding box of its Voronoi facet, 6 doubles per edge
  // (lo then hi): the extremes of the circumcentres of the cells around it;
  // and every sample's Voronoi cell box, as voronoi_cell_boxes gives it.
  // Not const: it caches circumcentres.
  void voronoi_boxes(std::vector<std::int64_t>& edges, std::vector<double>& facet_boxes,
                     std::vector<double>& cell_boxes);

  // Delaunay edges between samples, as sorted id pairs (p < q) in increasing
  // order: those of the cells incident to the given samples, or every such
  // edge when ids is null.  A Voronoi facet changes only when a cell around
  // its edge does, so the edges of the stars of a batch's new samples are
  // the facets that batch changed.
  std::vector<std::int64_t> delaunay_edges(const std::int64_t* ids,
                                           std::size_t n) const;

  // Bounding boxes of the Voronoi cells of the given samples (with the
  // dummies: inside the ball the same cells as without them), as 6 doubles
  // per sample (lo then hi): the extremes of the circumcentres of the cells
  // incident to each sample; +-inf if one is infinite.  Throws
  // std::invalid_argument for ids out of range.  Not const: it caches
  // circumcentres.
  std::vector<double> voronoi_cell_boxes(const std::int64_t* ids, std::size_t n);

  // Clip every dual segment to the axis-aligned box [lo, hi] as well as to
  // the bounding ball (a mesh with a boundary on the box faces).  Only before
  // the first insertion; throws std::invalid_argument for a non-finite box or
  // one with lo >= hi on some axis, std::logic_error after an insertion.
  void set_clip_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi);
  bool has_clip_box() const { return has_box_; }

  std::size_t number_of_samples() const { return samples_.size(); }
  // Facets whose new status changed_facets derived from a KNOWN old one
  // instead of handing them out, since construction.
  std::uint64_t reused_facets() const { return reused_; }

  // Clearing by the seeding grid (rdmesh.sampling.screen): f at the grid's
  // nodes, the local |grad f| estimates, and how they bound |grad f| along a
  // segment: scale x the estimate at its middle for segments up to reach
  // long, at most cap (cap alone for longer ones).  A facet whose segment
  // the node nearest its middle clears (GridField::clearing_values) is not
  // handed out: it is set KNOWN and not restricted at once, like a reused
  // one.  set_clearing_cap changes cap (a bound raised by what the
  // segments showed).
  void set_clearing(const GridField& f, const GridField& slopes, double scale, double reach,
                    double cap);
  void set_clearing_cap(double cap) { clear_cap_ = cap; }
  // A finer level of the clearing (FineField over set_clearing's grid, with
  // cap as its bounds' cap), for segments the grid did not clear; a new
  // set_clearing drops it.  Throws std::logic_error before set_clearing.
  void set_fine_clearing(int m, std::uint32_t threshold, double reach);
  FineField* fine_clearing() { return fine_.get(); }
  // Whether the clearing (grid, then its fine level) clears segment a -> b,
  // as for a facet's dual (an uncleared one counts a miss).
  bool grid_clears(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return clear_f_ && cleared_by_grid(a, b);
  }
  // Facets cleared so, since construction.
  std::uint64_t cleared_facets() const { return cleared_; }
  // Circumcentres computed exactly because the double one was not
  // equidistant from the cell's vertices (see circumcentre).
  std::uint64_t exact_circumcentres() const { return exact_circumcentres_; }
  std::size_t number_of_cells() const { return dt_.number_of_finite_cells(); }
  std::vector<double> samples() const;
  std::vector<double> weights() const;

  // Every facet whose clipped dual meets the bounding ball (no effect on the
  // rounds; fills the circumcentre cache); for checking the incremental
  // bookkeeping against a from-scratch pass.
  ChangedFacets all_facets();

  // Checks the Delaunay property and the symmetry of the facet flags;
  // throws std::runtime_error on failure.
  void check() const;

  // The lock every caller holds for each call (see the top of this file).
  std::mutex& mutex() const { return mutex_; }

 private:
  // Fills the cell's circumcentre cache on first use.
  const std::array<double, 3>& circumcentre(Cell_handle c);
  // Radius of the smallest sphere orthogonal to facet (c, i)'s three vertex
  // balls (its circumradius when the weights are 0); 0 when there is none.
  double facet_radius(Cell_handle c, int i) const;
  bool is_dummy(Vertex_handle v) const;
  bool clip(std::array<double, 3>& a, std::array<double, 3>& b) const;
  bool gather_more();
  bool reuse(Cell_handle c, int i, Cell_handle nb, int j, std::uint8_t was,
             std::int32_t centre, const std::array<double, 3>& a,
             const std::array<double, 3>& b);
  void mark_fresh(Cell_handle c);
  bool round_unfinished() const;
  void start_round();
  void reset_end_stamps();
  void compact_centres();

  Regular dt_;
  std::array<double, 3> c0_;
  double radius_;
  bool has_box_ = false;
  std::array<double, 3> box_lo_{}, box_hi_{};
  std::vector<Vertex_handle> samples_;
  std::vector<Vertex_handle> last_new_;
  // Chunks handed out and not yet updated, oldest first.  Both sides of each
  // facet, so update_facets need not look up the mirror index (a cache miss
  // per facet on large meshes).
  struct Side {
    Cell_handle c, nb;
    std::int8_t i, j, swapped;
  };
  struct Chunk {
    std::vector<Side> facets;
    std::vector<Cell_handle> end_cells;  // the cell of each end (null: clipped)
    std::size_t begin = 0;     // its first cell in fresh_
    std::uint64_t serial = 0;  // as ChangedFacets::chunk
  };
  std::deque<Chunk> pending_;
  std::uint64_t serial_ = 0;  // chunks handed out so far
  std::uint64_t reused_ = 0;  // see reused_facets()
  std::uint64_t cleared_ = 0;  // see cleared_facets()
  std::unique_ptr<GridField> clear_f_, clear_slopes_;
  std::unique_ptr<FineField> fine_;
  double clear_scale_ = 0.0, clear_reach_ = 0.0, clear_cap_ = 0.0;
  // Whether the grid clears segment a -> b (set_clearing).
  bool cleared_by_grid(const std::array<double, 3>& a, const std::array<double, 3>& b);
  std::uint64_t exact_circumcentres_ = 0;  // see exact_circumcentres()
  // Sorted vertex ids of facets given a BAD or TOPO label since the last
  // full scan of facets_with (which resets it to the labelled facets then),
  // so a superset of the labelled facets while marked_whole_; entries whose
  // facet is gone or relabelled are dropped when read.
  mutable std::vector<std::array<std::int64_t, 3>> marked_;
  // Per sample id: a vertex of a cell made since take_touched (sized in
  // changed_facets, before any cell is marked); touched_all_ when a cell's
  // vertex had no entry.
  std::vector<std::uint8_t> touched_;
  bool touched_all_ = false;
  mutable bool marked_whole_ = true;
  void mark(Cell_handle c, int i, std::uint8_t flags);
  void emit(FacetList& out, Cell_handle c, int i, std::uint8_t fl) const;
  FacetList facets_from_marked(std::uint8_t mask) const;
  mutable std::mutex mutex_;
  std::vector<Vertex_handle> round_vertices_;  // inserted before this round
  // Cells new in this round, gathered lazily (so the first chunk of a round
  // comes quickly): around round_vertices_ when they are few, otherwise by
  // a scan of all cells for those born since epoch round_from_ (faster than
  // visiting many vertex stars).
  std::vector<Cell_handle> fresh_;
  std::size_t cursor_ = 0;          // next cell of fresh_ to report
  std::size_t vertex_cursor_ = 0;   // next vertex whose cells to gather
  bool scan_ = false;
  bool gathered_all_ = true;
  Regular::Finite_cells_iterator scan_it_;
  std::int32_t epoch_ = 0;        // insertions so far
  std::int32_t report_from_ = 1;  // first epoch not handed out yet
  std::int32_t round_from_ = 1;   // ... as of this round's start
  // Surface centres of restricted facets (xyz); cells index into it.  Grows
  // by update_facets, compacted at the start of a round when mostly dead.
  std::vector<double> centres_;
  std::vector<Cell_handle> around_;  // scratch
  std::int32_t round_ = 0;
  std::int32_t call_ = 0;
  std::int32_t voronoi_call_ = 0;  // voronoi_facets calls (cell numbering)
  Vertex_handle hint_;
};

// Greedy independent set of balls (algorithm.md, batching rule): in order of
// decreasing radius (ties by lexicographic centre) accept a ball unless its
// centre lies in the closed ball of an already accepted one (decided
// exactly, whatever the magnitudes).  Returns the accepted indices in that
// order.  Throws std::invalid_argument for a non-finite centre or radius or
// a radius <= 0.
std::vector<std::int64_t> select_independent(const double* centres,
                                             const double* radii,
                                             std::size_t n);

// Test hook for the exception guarantees above: the n-th fault point from
// now throws std::bad_alloc (n <= 0: never).  Fault points: each facet that
// changed_facets appends or cell it gathers, each update_facets, and the
// conversion of changed_facets' result in module.cpp.
inline std::atomic<std::int64_t> fail_countdown_for_testing{0};
inline void fault_point_for_testing() {
  if (fail_countdown_for_testing.load(std::memory_order_relaxed) > 0 &&
      fail_countdown_for_testing.fetch_sub(1) == 1)
    throw std::bad_alloc();
}

}  // namespace rdmesh
