// Stage 4: topology-preserving polyline simplification. Greedy point removal in order of deviation
// (in the spirit of Visvalingam and Whyatt, "Line generalisation by repeated elimination of points",
// 1993, with the Hausdorff deviation from the original chain as the cost and a hard tolerance), where
// a removal is accepted only when the new segment meets no other segment and sweeps over no point,
// checked with exact orientation tests against the segments of a uniform grid.
#include "vectorize/simplify.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"

namespace vectorize {
namespace {

struct Vec {
  double x = 0.0;
  double y = 0.0;
  friend bool operator==(const Vec&, const Vec&) = default;
};

// Exact for any coordinates (orient2d's expansion fallback), so placed points off the pixel grid are
// tested as exactly as pixel centres. orient2d's own filter, with the same error bound, goes by the
// products' signs first; here one test on the magnitudes settles almost every call, without the
// branches on signs that the tests' unpredictable outcomes make costly.
int orient(const Vec& a, const Vec& b, const Vec& c) {
  const double left = (a.x - c.x) * (b.y - c.y);
  const double right = (a.y - c.y) * (b.x - c.x);
  const double det = left - right;
  if (std::abs(det) > cdt::detail::kOrientBound * (std::abs(left) + std::abs(right)))
    return (det > 0.0) - (det < 0.0);
  return cdt::detail::orient2d(a.x, a.y, b.x, b.y, c.x, c.y);
}

// p on the closed segment ab, given that a, b, p are collinear.
bool within_box(const Vec& a, const Vec& b, const Vec& p) {
  return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
         p.y <= std::max(a.y, b.y);
}

bool on_segment(const Vec& a, const Vec& b, const Vec& p) {
  return orient(a, b, p) == 0 && within_box(a, b, p);
}

// Closed segments ab and cd share at least one point.
bool segments_meet(const Vec& a, const Vec& b, const Vec& c, const Vec& d) {
  const int o1 = orient(a, b, c);
  const int o2 = orient(a, b, d);
  const int o3 = orient(c, d, a);
  const int o4 = orient(c, d, b);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && within_box(a, b, c)) || (o2 == 0 && within_box(a, b, d)) ||
         (o3 == 0 && within_box(c, d, a)) || (o4 == 0 && within_box(c, d, b));
}

// p in the closed triangle abc (which may be degenerate).
bool in_triangle(const Vec& a, const Vec& b, const Vec& c, const Vec& p) {
  const int o = orient(a, b, c);
  if (o == 0) return on_segment(a, b, p) || on_segment(b, c, p) || on_segment(a, c, p);
  const int s1 = orient(a, b, p);
  const int s2 = orient(b, c, p);
  const int s3 = orient(c, a, p);
  return s1 * o >= 0 && s2 * o >= 0 && s3 * o >= 0;
}

// Squared distance from p to the segment ab; exactly 0 for a point on it when the coordinates are pixel
// centres (the cross product of small half-integers is exact), so that tolerance 0 removes the middle
// points of straight runs. Squared, so that no square root is taken: costs are only compared, with
// each other and with the tolerance.
double squared_distance_to_segment(const Vec& a, const Vec& b, const Vec& p) {
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const double ax = p.x - a.x;
  const double ay = p.y - a.y;
  if (ax * dx + ay * dy <= 0.0) return ax * ax + ay * ay;
  const double bx = p.x - b.x;
  const double by = p.y - b.y;
  if (bx * dx + by * dy >= 0.0) return bx * bx + by * by;
  const double cross = dx * ay - dy * ax;
  return cross * cross / (dx * dx + dy * dy);
}

// Whether the segment ab passes through the interior of the unit square of pixel (x, y) (touching
// its boundary does not count): the part of ab inside the open square, clipped parametrically, has
// positive length.
bool crosses_square(const Vec& a, const Vec& b, int x, int y) {
  double t0 = 0.0;
  double t1 = 1.0;
  const auto clip = [&](double start, double delta, double lo, double hi) {
    if (delta == 0.0) return lo < start && start < hi;
    double enter = (lo - start) / delta;
    double leave = (hi - start) / delta;
    if (enter > leave) std::swap(enter, leave);
    t0 = std::max(t0, enter);
    t1 = std::min(t1, leave);
    return t0 < t1;
  };
  return clip(a.x, b.x - a.x, x, x + 1.0) && clip(a.y, b.y - a.y, y, y + 1.0);
}

struct Segment {
  Vec a;
  Vec b;
};

// An axis-aligned box, closed.
struct Box {
  double x0;
  double x1;
  double y0;
  double y1;
};

// A float no larger (lower) or no smaller (upper) than the double: boxes rounded outwards stay
// conservative filters.
float round_down(double v) {
  const auto f = static_cast<float>(v);
  return static_cast<double>(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float round_up(double v) {
  const auto f = static_cast<float>(v);
  return static_cast<double>(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// Uniform grid of segment ids. A segment is entered in every cell its (slightly widened) extent meets
// row by row, so two segments that meet share a cell. Dead ids are dropped lazily while querying.
// Each entry carries the segment's bounding box rounded outwards to floats: most entries of the cells
// a query meets lie clear of its box and are dismissed from the cell's own memory, without touching
// the segment. Whether a segment is alive is kept in a byte array apart, which stays in cache.
class SegmentGrid {
public:
  SegmentGrid(Vec lo, Vec hi, double cell) : lo_(lo), cell_(cell), inverse_cell_(1.0 / cell) {
    nx_ = static_cast<int>(std::floor((hi.x - lo.x) / cell)) + 1;
    ny_ = static_cast<int>(std::floor((hi.y - lo.y) / cell)) + 1;
    cells_.resize(static_cast<std::size_t>(nx_) * ny_);
  }

  void insert(std::uint32_t id, const Vec& a, const Vec& b) {
    const Entry entry{id, round_down(std::min(a.x, b.x)), round_up(std::max(a.x, b.x)),
                      round_down(std::min(a.y, b.y)), round_up(std::max(a.y, b.y))};
    const std::array<Vec, 3> poly = {a, b, b};
    for_cells(poly, 2, [&](Cell& cell) {
      if (cell.size == cell.capacity) grow(cell);
      cell.data[cell.size++] = entry;
    });
  }

  // Calls f(id) once for every live segment in the cells met by the polygon (2 or 3 points, convex)
  // whose bounding box meets `box`. The box test dismisses most segments, so it comes before the
  // check for one seen in an earlier cell. Whether an entry is alive and whether it meets the box
  // vary unpredictably from one entry to the next: the cells are scanned without branching on them,
  // live entries moved up over dead ones and the ids of those that meet the box gathered, and only
  // then is f called.
  template <class F>
  void query(const std::array<Vec, 3>& poly, int n, const Box& box, std::size_t num_segments,
             const std::vector<std::uint8_t>& alive, F&& f) {
    ++stamp_;
    if (seen_.size() < num_segments) seen_.resize(num_segments * 2, 0);
    std::size_t num_hits = 0;
    for_cells(poly, n, [&](Cell& cell) {
      if (hits_.size() < num_hits + cell.size) hits_.resize(2 * (num_hits + cell.size));
      std::uint32_t kept = 0;
      for (std::uint32_t i = 0; i < cell.size; ++i) {
        const Entry e = cell.data[i];
        const bool live = alive[e.id] != 0;
        cell.data[kept] = e;
        kept += live;
        const bool meets = (e.x1 >= box.x0) & (e.x0 <= box.x1) & (e.y1 >= box.y0) & (e.y0 <= box.y1);
        hits_[num_hits] = e.id;
        num_hits += live & meets;
      }
      cell.size = kept;
    });
    for (std::size_t i = 0; i < num_hits; ++i) {
      const std::uint32_t id = hits_[i];
      if (seen_[id] == stamp_) continue;
      seen_[id] = stamp_;
      f(id);
    }
  }

private:
  struct Entry {
    std::uint32_t id;
    float x0; // bounding box, rounded outwards
    float x1;
    float y0;
    float y1;
  };

  // A cell's entries, in blocks of memory shared by the cells: an image's grid has thousands of cells,
  // and an allocation for each made the allocator a noticeable part of the stage.
  struct Cell {
    Entry* data = nullptr;
    std::uint32_t size = 0;
    std::uint32_t capacity = 0;
  };

  // Room for what a cell typically holds at first, then twice as much each time it is full (the room
  // it leaves is not reused: the grid lives for one simplification).
  void grow(Cell& cell) {
    const std::uint32_t capacity = cell.capacity == 0 ? 8 : 2 * cell.capacity;
    if (block_left_ < capacity) {
      const std::size_t size = std::max<std::size_t>(capacity, kBlockEntries);
      blocks_.push_back(std::make_unique_for_overwrite<Entry[]>(size));
      block_next_ = blocks_.back().get();
      block_left_ = size;
    }
    std::copy_n(cell.data, cell.size, block_next_);
    cell.data = block_next_;
    cell.capacity = capacity;
    block_next_ += capacity;
    block_left_ -= capacity;
  }

  int col(double x) const {
    return std::clamp(static_cast<int>(std::floor((x - lo_.x) * inverse_cell_)), 0, nx_ - 1);
  }
  int row(double y) const {
    return std::clamp(static_cast<int>(std::floor((y - lo_.y) * inverse_cell_)), 0, ny_ - 1);
  }

  template <class F>
  void for_cells(const std::array<Vec, 3>& poly, int n, F&& f) {
    const double margin = 1e-3 * cell_;
    double ymin = poly[0].y;
    double ymax = poly[0].y;
    for (int i = 1; i < n; ++i) {
      ymin = std::min(ymin, poly[i].y);
      ymax = std::max(ymax, poly[i].y);
    }
    const int r0 = row(ymin - margin);
    const int r1 = row(ymax + margin);
    if (r0 == r1) { // most polygons of image chains lie within one row: its cells are their extent's
      double xmin = poly[0].x;
      double xmax = poly[0].x;
      for (int i = 1; i < n; ++i) {
        xmin = std::min(xmin, poly[i].x);
        xmax = std::max(xmax, poly[i].x);
      }
      const int c1 = col(xmax + margin);
      for (int c = col(xmin - margin); c <= c1; ++c) f(cells_[static_cast<std::size_t>(r0) * nx_ + c]);
      return;
    }
    for (int r = r0; r <= r1; ++r) {
      const double band_lo = std::max(ymin, lo_.y + r * cell_ - margin);
      const double band_hi = std::min(ymax, lo_.y + (r + 1) * cell_ + margin);
      double xmin = std::numeric_limits<double>::infinity();
      double xmax = -xmin;
      for (int i = 0; i < n; ++i) {
        const Vec& p = poly[i];
        const Vec& q = poly[(i + 1) % n];
        const double ey_lo = std::min(p.y, q.y);
        const double ey_hi = std::max(p.y, q.y);
        if (ey_hi < band_lo || ey_lo > band_hi) continue;
        if (p.y == q.y) {
          xmin = std::min({xmin, p.x, q.x});
          xmax = std::max({xmax, p.x, q.x});
          continue;
        }
        for (const double y : {std::max(ey_lo, band_lo), std::min(ey_hi, band_hi)}) {
          const double x = p.x + (q.x - p.x) * (y - p.y) / (q.y - p.y);
          xmin = std::min(xmin, x);
          xmax = std::max(xmax, x);
        }
      }
      if (xmin > xmax) continue;
      const int c0 = col(xmin - margin);
      const int c1 = col(xmax + margin);
      for (int c = c0; c <= c1; ++c) f(cells_[static_cast<std::size_t>(r) * nx_ + c]);
    }
  }

  Vec lo_;
  double cell_;
  double inverse_cell_;
  int nx_ = 1;
  int ny_ = 1;
  static constexpr std::size_t kBlockEntries = 4096;
  std::vector<Cell> cells_;
  std::vector<std::unique_ptr<Entry[]>> blocks_;
  Entry* block_next_ = nullptr;
  std::size_t block_left_ = 0;
  std::vector<std::uint32_t> seen_;
  std::vector<std::uint32_t> hits_;
  std::uint32_t stamp_ = 0;
};

// A chain's point arrays are parts of arrays shared by all the chains (see ChainArrays): an image has
// thousands of chains, and arrays of their own made the allocator a noticeable part of the stage.
struct ChainState {
  // What is known of each point besides where it is: the linked list of live points and more.
  struct Link {
    int prev;
    int next;
    std::uint32_t segment_from; // id of the live segment from the point to next
    std::uint32_t version;
    std::uint8_t alive;
    std::uint8_t outline; // 1 where the point is on a shape's outline (Placement::outline)
  };
  std::span<PixelPoint> pixels; // the original points, consecutive duplicates dropped
  std::span<Vec> points;        // where they are placed
  std::span<Link> link;         // one entry per point
  bool closed = false;
  int num_alive = 0;
  int min_alive = 2;
};

// The arrays that the chains' points are parts of, one entry per input point.
struct ChainArrays {
  explicit ChainArrays(std::size_t size) : pixels(size), points(size), link(size) {}
  std::vector<PixelPoint> pixels;
  std::vector<Vec> points;
  std::vector<ChainState::Link> link;
};

// A point to try removing, ordered by cost, ties in input order so that the result is deterministic.
// The order is two integer keys (a cost is finite and >= 0, so its bits order as the number does),
// compared without branches: the queue's comparisons are much of the simplification's time.
struct Candidate {
  Candidate(double cost, std::uint32_t chain, std::uint32_t vertex, std::uint32_t at_version)
      : cost_bits(std::bit_cast<std::uint64_t>(cost)),
        place(static_cast<std::uint64_t>(chain) << 32 | vertex), version(at_version) {}
  std::uint32_t chain() const { return static_cast<std::uint32_t>(place >> 32); }
  std::uint32_t vertex() const { return static_cast<std::uint32_t>(place); }
  // A min-heap: the "largest" candidate is the cheapest.
  bool operator<(const Candidate& o) const {
    return (cost_bits > o.cost_bits) | ((cost_bits == o.cost_bits) & (place > o.place));
  }

  std::uint64_t cost_bits;
  std::uint64_t place; // chain << 32 | vertex
  std::uint32_t version;
};

// The candidates of a pass, cheapest first. Most are evaluated once, when the pass starts, and taken
// once: those are sorted, which costs much less than a heap's pushes and pops, and only those
// evaluated again after a removal go into a heap, much smaller. The next candidate is the cheaper of
// the two fronts.
class CandidateQueue {
public:
  bool empty() const { return next_ == sorted_.size() && heap_.empty(); }
  const Candidate& top() const { return from_sorted() ? sorted_[next_] : heap_.front(); }

  // Candidates of the start of the pass, taken in before sort().
  void add(const Candidate& c) { sorted_.push_back(c); }
  void sort() {
    std::sort(sorted_.begin(), sorted_.end(), [](const Candidate& a, const Candidate& b) { return b < a; });
  }

  void push(const Candidate& c) {
    heap_.push_back(c);
    std::push_heap(heap_.begin(), heap_.end());
  }

  void pop() {
    if (from_sorted()) {
      ++next_;
    } else {
      std::pop_heap(heap_.begin(), heap_.end());
      heap_.pop_back();
    }
  }

private:
  bool from_sorted() const {
    return next_ < sorted_.size() && (heap_.empty() || heap_.front() < sorted_[next_]);
  }

  std::vector<Candidate> sorted_;
  std::size_t next_ = 0;
  std::vector<Candidate> heap_; // a max-heap of Candidate's order: the cheapest on top
};

constexpr std::uint32_t kNoSegment = std::numeric_limits<std::uint32_t>::max();

// A chain's points where they are placed, all alive and linked in order, in the arrays from `first`
// on.
ChainState place_chain(const Chain& chain, const PointPlacement& placement, ChainArrays& arrays,
                       std::size_t first) {
  ChainState s;
  s.closed = chain.closed;
  PixelPoint* pixels = arrays.pixels.data() + first;
  Vec* points = arrays.points.data() + first;
  ChainState::Link* link = arrays.link.data() + first;
  std::size_t size = 0;
  // Without a no-shape pixel every point is its pixel's centre (PointPlacement::place).
  const bool centres = !placement.any_no_shape();
  for (const PixelPoint& p : chain.points) {
    if (size != 0 && pixels[size - 1] == p) continue;
    const Placement placed = centres ? Placement{{p.x + 0.5, p.y + 0.5}, {}, false} : placement.place(p);
    pixels[size] = p;
    points[size] = {placed.at.x, placed.at.y};
    link[size] = {0, 0, kNoSegment, 0, 1, static_cast<std::uint8_t>(placed.outline ? 1 : 0)};
    ++size;
  }
  if (s.closed && size > 1 && pixels[0] == pixels[size - 1]) --size;
  s.pixels = {pixels, size};
  s.points = {points, size};
  s.link = {link, size};
  const int n = static_cast<int>(s.points.size());
  s.num_alive = n;
  s.min_alive = s.closed ? 3 : (n > 1 && s.points.front() == s.points.back() ? 4 : 2);
  for (int i = 0; i < n; ++i) {
    s.link[i].prev = s.closed ? (i + n - 1) % n : i - 1;
    s.link[i].next = s.closed ? (i + 1) % n : i + 1;
  }
  return s;
}

// Removes the middle points of exactly straight runs before the greedy removal, where that changes
// nothing it would check: when every point sits at its pixel centre and consecutive points are
// 8-adjacent (so that a segment between them passes through no other centre), a point v strictly
// between its collinear neighbours u and w can go if
// - its pixel is no other chain point's (no segment of another chain ends on u-w),
// - neither of its two steps is a diagonal crossed by the other diagonal of its 2 x 2 block (the only
//   way two such segments meet away from their ends; both other pixels in use stands for it), and
// - it is not on a shape's outline (whose solid pixels the greedy pass keeps clear of),
// because u-w then covers exactly the points u-v and v-w covered: nothing is touched or swept, the
// deviation is zero. The greedy pass would remove these first too (cost zero), each at the price of a
// grid query and two queue entries; pixel chains from an image are about half such points.
void drop_straight_run_points(std::vector<ChainState>& states) {
  int x0 = std::numeric_limits<int>::max();
  int y0 = x0;
  int x1 = std::numeric_limits<int>::min();
  int y1 = x1;
  for (const ChainState& s : states) {
    const auto n = s.pixels.size();
    for (std::size_t i = 0; i < n; ++i) {
      const PixelPoint p = s.pixels[i];
      if (s.points[i] != Vec{p.x + 0.5, p.y + 0.5}) return;
      if (i + 1 < n || s.closed) {
        const PixelPoint q = s.pixels[i + 1 < n ? i + 1 : 0];
        if (std::abs(std::int64_t{q.x} - p.x) > 1 || std::abs(std::int64_t{q.y} - p.y) > 1) return;
      }
      x0 = std::min(x0, p.x);
      y0 = std::min(y0, p.y);
      x1 = std::max(x1, p.x);
      y1 = std::max(y1, p.y);
    }
  }
  if (x0 > x1) return;
  constexpr std::size_t kMaxTable = std::size_t{1} << 30; // far-flung input: no pixel table
  const auto width = static_cast<std::size_t>(std::int64_t{x1} - x0 + 1);
  const auto height = static_cast<std::size_t>(std::int64_t{y1} - y0 + 1);
  if (width > kMaxTable || height > kMaxTable || width * height > kMaxTable) return;
  std::vector<std::uint8_t> uses(width * height, 0); // 0, 1, or 2 for more
  const auto index = [&](PixelPoint p) {
    return static_cast<std::size_t>(std::int64_t{p.y} - y0) * width +
           static_cast<std::size_t>(std::int64_t{p.x} - x0);
  };
  for (const ChainState& s : states)
    for (const PixelPoint& p : s.pixels)
      uses[index(p)] = static_cast<std::uint8_t>(std::min(2, uses[index(p)] + 1));
  // Whether the step p -> q (8-adjacent) is a diagonal whose block's other two pixels are both in use.
  const auto maybe_crossed = [&](PixelPoint p, PixelPoint q) {
    return p.x != q.x && p.y != q.y && uses[index({q.x, p.y})] != 0 && uses[index({p.x, q.y})] != 0;
  };

  for (ChainState& s : states) {
    const int n = static_cast<int>(s.points.size());
    for (int v = 0; v < n; ++v) {
      if (s.num_alive <= s.min_alive) break;
      if (s.closed ? n < 3 : v == 0 || v + 1 == n) continue;
      if (uses[index(s.pixels[v])] != 1 || s.link[v].outline != 0) continue;
      // v's own steps; those of the points removed before it between u and w were checked with them.
      const PixelPoint before = s.pixels[v == 0 ? n - 1 : v - 1];
      const PixelPoint after = s.pixels[v + 1 == n ? 0 : v + 1];
      if (maybe_crossed(before, s.pixels[v]) || maybe_crossed(s.pixels[v], after)) continue;
      const int u = s.link[v].prev;
      const int w = s.link[v].next;
      if (s.pixels[u] == s.pixels[w]) continue;
      const Vec& a = s.points[u];
      const Vec& b = s.points[v];
      const Vec& c = s.points[w];
      if (orient(a, b, c) != 0 || (b.x - a.x) * (c.x - b.x) + (b.y - a.y) * (c.y - b.y) <= 0.0) continue;
      s.link[v].alive = 0;
      --s.num_alive;
      s.link[u].next = w;
      s.link[w].prev = u;
    }
  }
}

// Calls f(i) for each live point i of the chain that starts a live segment (to next[i]).
template <class F>
void for_each_segment_start(const ChainState& s, F&& f) {
  const int n = static_cast<int>(s.points.size());
  if (s.closed ? n < 3 : n < 2) return;
  for (int i = 0; i < n; ++i)
    if (s.link[i].alive && (s.closed || s.link[i].next < n)) f(i);
}

// Simplifies some chains (its own: no other simplifier touches them meanwhile) around others that
// stay as they are (fixed: read only, so simplifiers with disjoint own chains may run at once). With
// `adoptable`, the fixed chains' segments are linked to their points as the own chains' are, so that
// a later run() may take some of them as its own (no other simplifier may read them then).
class Simplifier {
public:
  Simplifier(std::vector<ChainState>& states, const std::vector<std::uint32_t>& own,
             const std::vector<std::uint32_t>& fixed, double tolerance, const PointPlacement& placement,
             bool adoptable = false)
      : tolerance_(tolerance), squared_tolerance_(tolerance * tolerance), placement_(placement),
        states_(states), own_(&own) {
    Vec lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    Vec hi{-lo.x, -lo.y};
    for (const auto* list : {&own, &fixed})
      for (const std::uint32_t c : *list)
        for (const Vec& v : states_[c].points) {
          lo = {std::min(lo.x, v.x), std::min(lo.y, v.y)};
          hi = {std::max(hi.x, v.x), std::max(hi.y, v.y)};
        }
    if (!(lo.x <= hi.x)) lo = hi = Vec{};
    // Cells of a few pixels suit image chains; the cap keeps sparse, far-flung input from allocating a
    // huge grid.
    const double extent = std::max(hi.x - lo.x, hi.y - lo.y);
    const double cell = std::max({8.0, 2.0 * tolerance_, extent / 2048.0});
    grid_.emplace(lo, hi, cell);

    for (const std::uint32_t c : own) {
      ChainState& s = states_[c];
      for_each_segment_start(
          s, [&](int i) { s.link[i].segment_from = add_segment(s.points[i], s.points[s.link[i].next]); });
    }
    for (const std::uint32_t c : fixed) {
      ChainState& s = states_[c];
      for_each_segment_start(s, [&](int i) {
        const std::uint32_t id = add_segment(s.points[i], s.points[s.link[i].next]);
        if (adoptable) s.link[i].segment_from = id;
      });
    }
  }

  // Simplifies `chains` (fixed ones of an adoptable simplifier, or its own) around all the others, as
  // a simplifier with them as its own and the others as fixed would: the same removals.
  void run(const std::vector<std::uint32_t>& chains) {
    own_ = &chains;
    run();
  }

  void run() {
    // Removing a point can unblock another (a point that stood in a triangle is gone), so passes repeat
    // while they make progress; each pass is near-linear. At the end of a pass every live point's last
    // evaluation saw its current neighbours, so the candidates of the next pass are exactly the points
    // that were blocked: only they are evaluated again.
    std::vector<Candidate> blocked;
    for (int pass = 0; pass < 8; ++pass) {
      CandidateQueue queue;
      if (pass == 0) {
        for (const std::uint32_t c : *own_)
          for (int v = 0; v < static_cast<int>(states_[c].points.size()); ++v) push(queue, c, v, true);
      } else {
        for (const Candidate& b : blocked) push(queue, b.chain(), static_cast<int>(b.vertex()), true);
      }
      queue.sort();
      blocked.clear();
      std::size_t removed = 0;
      while (!queue.empty()) {
        const Candidate cand = queue.top();
        queue.pop();
        if (!queue.empty()) { // the next candidate's links, fetched while this one is checked
          const Candidate& next = queue.top();
          __builtin_prefetch(states_[next.chain()].link.data() + next.vertex());
        }
        ChainState& s = states_[cand.chain()];
        const int v = static_cast<int>(cand.vertex());
        if (!s.link[v].alive || s.link[v].version != cand.version || s.num_alive <= s.min_alive) continue;
        if (!removable(s, v)) {
          blocked.push_back(cand);
          continue;
        }
        remove(s, v);
        ++removed;
        push(queue, cand.chain(), s.link[v].prev);
        push(queue, cand.chain(), s.link[v].next);
      }
      if (blocked.empty() || removed == 0) break;
    }
  }

private:
  std::uint32_t add_segment(const Vec& a, const Vec& b) {
    const auto id = static_cast<std::uint32_t>(segments_.size());
    segments_.push_back({a, b});
    segment_alive_.push_back(1);
    grid_->insert(id, a, b);
    return id;
  }

  bool interior(const ChainState& s, int v) const {
    if (s.closed) return s.points.size() >= 3;
    return v > 0 && v + 1 < static_cast<int>(s.points.size());
  }

  // The largest squared distance of the original points from u to w (exclusive) to the segment uw;
  // infinity when uw would cut into a solid pixel next to an outline point it replaces. Stops at the
  // first point farther than the tolerance: such a cost is only ever rejected.
  double squared_deviation(const ChainState& s, int u, int w) const {
    const int n = static_cast<int>(s.points.size());
    const Vec& a = s.points[u];
    const Vec& b = s.points[w];
    double worst = 0.0;
    for (int i = u + 1 == n ? 0 : u + 1; i != w; i = i + 1 == n ? 0 : i + 1) {
      worst = std::max(worst, squared_distance_to_segment(a, b, s.points[i]));
      if (worst > squared_tolerance_) return worst;
      if (!s.link[i].outline) continue;
      // The segment stays within the tolerance of the point, so the solid pixels it could cut into
      // are the point's own and its neighbours.
      const PixelPoint p = s.pixels[i];
      for (int y = p.y - 1; y <= p.y + 1; ++y)
        for (int x = p.x - 1; x <= p.x + 1; ++x)
          if (placement_.solid({x, y}) && crosses_square(a, b, x, y))
            return std::numeric_limits<double>::infinity();
    }
    return worst;
  }

  // `at_start`: the candidate is one of those the pass starts with (see CandidateQueue).
  void push(CandidateQueue& queue, std::uint32_t c, int v, bool at_start = false) {
    const ChainState& s = states_[c];
    if (!s.link[v].alive || !interior(s, v) || s.num_alive <= s.min_alive) return;
    const int u = s.link[v].prev;
    const int w = s.link[v].next;
    if (s.pixels[u] == s.pixels[w]) return;
    const double cost = squared_deviation(s, u, w);
    if (cost > squared_tolerance_) return;
    const Candidate cand(cost, c, static_cast<std::uint32_t>(v), s.link[v].version);
    if (at_start)
      queue.add(cand);
    else
      queue.push(cand);
  }

  // Whether replacing u-v-w by u-w creates no contact with another segment and sweeps over no point.
  bool removable(const ChainState& s, int v) {
    const int u = s.link[v].prev;
    const int w = s.link[v].next;
    const Vec& pu = s.points[u];
    const Vec& pv = s.points[v];
    const Vec& pw = s.points[w];
    const std::uint32_t skip_a = s.link[u].segment_from;
    const std::uint32_t skip_b = s.link[v].segment_from;
    // Most segments of the cells lie clear of the triangle's bounding box: they can neither meet uw
    // nor have an end inside the triangle, and are dismissed without an orientation test.
    const Box box{std::min({pu.x, pv.x, pw.x}), std::max({pu.x, pv.x, pw.x}), std::min({pu.y, pv.y, pw.y}),
                  std::max({pu.y, pv.y, pw.y})};
    bool ok = true;
    grid_->query({pu, pv, pw}, 3, box, segments_.size(), segment_alive_, [&](std::uint32_t id) {
      if (!ok || id == skip_a || id == skip_b) return;
      const Segment& t = segments_[id];
      const bool a_shared = t.a == pu || t.a == pw;
      const bool b_shared = t.b == pu || t.b == pw;
      if (a_shared && b_shared) {
        ok = false; // the same segment twice, or a zero-length one at an end
      } else if (a_shared || b_shared) {
        const Vec& p = a_shared ? t.a : t.b;
        const Vec& r = a_shared ? t.b : t.a;
        const Vec& q = p == pu ? pw : pu;
        const bool overlap =
            orient(p, q, r) == 0 && (q.x - p.x) * (r.x - p.x) + (q.y - p.y) * (r.y - p.y) > 0.0;
        if (overlap || in_triangle(pu, pv, pw, r)) ok = false;
      } else if (segments_meet(pu, pw, t.a, t.b) || in_triangle(pu, pv, pw, t.a) ||
                 in_triangle(pu, pv, pw, t.b)) {
        ok = false;
      }
    });
    return ok;
  }

  void remove(ChainState& s, int v) {
    const int u = s.link[v].prev;
    const int w = s.link[v].next;
    segment_alive_[s.link[u].segment_from] = 0;
    segment_alive_[s.link[v].segment_from] = 0;
    s.link[v].segment_from = kNoSegment;
    s.link[u].segment_from = add_segment(s.points[u], s.points[w]);
    s.link[v].alive = 0;
    --s.num_alive;
    s.link[u].next = w;
    s.link[w].prev = u;
    ++s.link[u].version;
    ++s.link[w].version;
  }

  double tolerance_;
  double squared_tolerance_;
  PointPlacement placement_;
  std::vector<ChainState>& states_;
  const std::vector<std::uint32_t>* own_;
  std::vector<Segment> segments_;
  std::vector<std::uint8_t> segment_alive_; // by segment id
  std::optional<SegmentGrid> grid_;
};

// Splits the chains at the median x of their points: those wholly left of it, those wholly right, and
// those across it. Every segment of a simplified chain lies within the bounding box of the chain's
// points, so the left and the right chains never meet: they are simplified apart (at once, given two
// threads), each around the crossing chains as they are; then the crossing chains around both
// results. The outcome is the same for any number of threads.
std::array<std::vector<std::uint32_t>, 3> split_at_median(const std::vector<ChainState>& states) {
  std::vector<double> xs;
  for (const ChainState& s : states)
    for (const Vec& v : s.points) xs.push_back(v.x);
  std::array<std::vector<std::uint32_t>, 3> parts; // left, right, across
  if (xs.empty()) return parts;
  const auto middle = xs.begin() + static_cast<std::ptrdiff_t>(xs.size() / 2);
  std::nth_element(xs.begin(), middle, xs.end());
  const double split = *middle;
  for (std::uint32_t c = 0; c < states.size(); ++c) {
    double x0 = std::numeric_limits<double>::infinity();
    double x1 = -x0;
    for (const Vec& v : states[c].points) {
      x0 = std::min(x0, v.x);
      x1 = std::max(x1, v.x);
    }
    parts[x1 < split ? 0 : x0 > split ? 1 : 2].push_back(c);
  }
  return parts;
}

} // namespace

std::vector<Polyline> simplify_chains(const std::vector<Chain>& chains, double tolerance_px,
                                      const PointPlacement& placement, unsigned threads) {
  if (!(tolerance_px >= 0.0) || !std::isfinite(tolerance_px))
    throw std::invalid_argument("simplify_chains: tolerance_px must be finite and >= 0");
  std::vector<ChainState> states;
  states.reserve(chains.size());
  std::size_t num_points = 0;
  for (const Chain& chain : chains) num_points += chain.points.size();
  ChainArrays arrays(num_points);
  std::size_t first = 0;
  for (const Chain& chain : chains) {
    states.push_back(place_chain(chain, placement, arrays, first));
    first += states.back().points.size();
  }
  drop_straight_run_points(states);

  const auto [left, right, across] = split_at_median(states);
  const auto simplify = [&](const std::vector<std::uint32_t>& own, const std::vector<std::uint32_t>& fixed) {
    if (own.empty()) return;
    Simplifier simplifier(states, own, fixed, tolerance_px, placement);
    simplifier.run();
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::uint32_t> sides = left;
  sides.insert(sides.end(), right.begin(), right.end());
  if (threads < 2 || left.empty() || right.empty()) {
    // The left and the right chains never meet, so one pass over both around the crossing chains makes
    // the removals that a pass over each would; the crossing chains are then simplified around the
    // result in the same grid, whose segments they already are.
    Simplifier simplifier(states, sides, across, tolerance_px, placement, true);
    simplifier.run();
    if (!across.empty()) simplifier.run(across);
  } else {
    // The two sides on two threads, then the crossing chains around them. The worker is joined
    // whichever side fails (memory running out, say): a thread destroyed unjoined ends the process.
    std::exception_ptr failure, own_failure;
    std::thread worker([&] {
      try {
        simplify(right, across);
      } catch (...) {
        failure = std::current_exception();
      }
    });
    try {
      simplify(left, across);
    } catch (...) {
      own_failure = std::current_exception();
    }
    worker.join();
    if (own_failure) std::rethrow_exception(own_failure);
    if (failure) std::rethrow_exception(failure);
    simplify(across, sides);
  }

  std::vector<Polyline> out(states.size());
  for (std::size_t c = 0; c < states.size(); ++c) {
    const ChainState& s = states[c];
    out[c].closed = s.closed;
    out[c].points.reserve(static_cast<std::size_t>(s.num_alive));
    for (std::size_t i = 0; i < s.points.size(); ++i)
      if (s.link[i].alive) out[c].points.push_back(s.pixels[i]);
  }
  return out;
}

} // namespace vectorize
