// PSLG preparation: input checks, duplicate merging, point-on-segment splits, overlap merging and
// crossing resolution (see pslg.hpp).
//
// Overlapping collinear segments need no code of their own: when every segment is split at every
// vertex lying in its interior, two segments that overlap are cut into the very same pieces along the
// overlap, and identical pieces are merged (keeping the lowest segment id). Crossings are resolved in
// rounds: the rounded crossing point bends both segments slightly, so the bent pieces are checked again
// (against everything) in the next round, until a round finds no crossing.
//
// Candidate pairs (segment/segment and point/segment) come from a uniform grid. A segment is registered
// in a superset of the cells it meets: cell boundaries are fixed doubles and a point's cell is found
// by exact comparisons with them, so only the segment's y over one column is computed inexactly, and
// that range is widened by a margin far above its rounding error.

#include "pslg.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <system_error>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "box.hpp"
#include "cdt/detail/predicates.hpp"
#include "cdt/detail/trace.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {
namespace {

using Kind = InvalidInputError::Kind;

/// Limits of crossing resolution. Each round only re-checks pieces bent in the previous one; inputs
/// settle in a few rounds, the repairs adding at most a few vertices per vertex of the first round. An
/// input beyond these limits is one where rounding keeps creating crossings faster than it resolves
/// them.
constexpr int kMaxRounds = 32;
constexpr std::size_t kRepairVerticesPerFirstVertex = 8;
constexpr std::size_t kRepairVerticesSlack = 1024;
/// The segment grid of the crossing resolution is sized again when the pieces outnumber the segments
/// it was sized for by more than this.
constexpr std::size_t kGridGrowth = 2;

std::string format_number(double v) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  return std::string(buffer.data(), result.ptr);
}

std::string format_point(const Point& p) {
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) about "(" + std::string when inlined.
  std::string text("(");
  text.append(format_number(p.x)).append(", ").append(format_number(p.y)).append(")");
  return text;
}

int orient(const Point& a, const Point& b, const Point& c) { return orient2d(a.x, a.y, b.x, b.y, c.x, c.y); }

/// The axis along which a non-degenerate segment a-b is longest: coordinates along it are strictly
/// monotone over the segment, so exact comparisons on it order points that lie on the segment.
bool x_is_dominant(const Point& a, const Point& b) { return std::abs(b.x - a.x) >= std::abs(b.y - a.y); }

/// True when p, known to be collinear with a-b, lies strictly between a and b.
bool strictly_between(const Point& a, const Point& b, const Point& p) {
  const bool use_x = x_is_dominant(a, b);
  const double pa = use_x ? a.x : a.y;
  const double pb = use_x ? b.x : b.y;
  const double pp = use_x ? p.x : p.y;
  return pa < pb ? (pa < pp && pp < pb) : (pb < pp && pp < pa);
}

// --- input checks ------------------------------------------------------------------------------------

bool point_is_valid(const Point& p) { return detail::point_is_valid(p.x, p.y); }

void validate_points(std::span<const Point> points, CpuExecutor& executor) {
  // Screened in parallel; the lowest invalid point is the one reported.
  auto first_invalid = static_cast<std::uint32_t>(points.size());
  executor.for_each(points.size(), [&](std::size_t i) {
    if (!point_is_valid(points[i])) atomic_min(&first_invalid, static_cast<std::uint32_t>(i));
  });
  if (first_invalid != points.size()) throw_invalid_point(points, first_invalid);
}

/// Returns the number of zero-length segments (a point to itself, or two points at one place): they
/// are ignored under CrossingSegments::resolve (the point is a vertex anyway) and an error under
/// CrossingSegments::reject.
std::size_t validate_segments(std::span<const Point> points, std::span<const Segment> segments,
                              CrossingSegments policy, CpuExecutor& executor) {
  // The zero-length segments, and the first segment that is an error (n when none): the error reported
  // is the lowest-numbered one, as a serial scan would find it.
  struct Scan {
    std::size_t zero_length = 0;
    std::size_t first_bad;
  };
  const std::size_t n = segments.size();
  const Scan scan = executor.reduce(
      n, Scan{0, n},
      [&](Scan& acc, std::size_t s) {
        if (acc.first_bad != n) return;
        const Segment& g = segments[s];
        if (g.a >= points.size() || g.b >= points.size()) {
          acc.first_bad = s;
        } else if (g.a == g.b || points[g.a] == points[g.b]) {
          ++acc.zero_length;
          if (policy != CrossingSegments::resolve) acc.first_bad = s;
        }
      },
      [](Scan& acc, const Scan& part) {
        acc.zero_length += part.zero_length;
        acc.first_bad = std::min(acc.first_bad, part.first_bad);
      });
  if (scan.first_bad == n) return scan.zero_length;
  throw_invalid_segment(points, segments, scan.first_bad);
}

} // namespace

void throw_invalid_point(std::span<const Point> points, std::size_t i) {
  const Point& p = points[i];
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
    throw InvalidInputError(Kind::non_finite_coordinate, i,
                            "point " + std::to_string(i) + " has a non-finite coordinate " + format_point(p));
  }
  if (std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate) {
    throw InvalidInputError(Kind::coordinate_out_of_range, i,
                            "point " + std::to_string(i) + " has a coordinate beyond +-" +
                                format_number(kMaxCoordinate) + " " + format_point(p) +
                                ": the exact predicates' products would overflow");
  }
  throw InvalidInputError(Kind::coordinate_out_of_range, i,
                          "point " + std::to_string(i) + " has a nonzero coordinate smaller than " +
                              format_number(kMinCoordinate) + " in magnitude " + format_point(p) +
                              ": the exact predicates' products would underflow (scale the input, or "
                              "write such coordinates as 0)");
}

void throw_invalid_segment(std::span<const Point> points, std::span<const Segment> segments, std::size_t s) {
  const Segment& g = segments[s];
  if (g.a >= points.size() || g.b >= points.size()) {
    throw InvalidInputError(Kind::index_out_of_range, s,
                            "segment " + std::to_string(s) + " (" + std::to_string(g.a) + ", " +
                                std::to_string(g.b) + ") refers to a point beyond the " +
                                std::to_string(points.size()) + " points given");
  }
  throw InvalidInputError(Kind::degenerate_segment, s,
                          "segment " + std::to_string(s) + " (" + std::to_string(g.a) + ", " +
                              std::to_string(g.b) + ") has zero length: both ends are at " +
                              format_point(points[g.a]));
}

namespace {

// --- duplicates --------------------------------------------------------------------------------------

/// Per point, its representative: the lowest index with identical coordinates (-0 and +0 are equal).
IndexArray merge_duplicates(std::span<const Point> points, CpuExecutor& executor) {
  // Identical points only need to meet, not to be ordered: a stable radix sort by a hash of the
  // coordinates brings them together in linear time (a comparison sort of the coordinates took most of
  // the preparation of a million points), in index order within each run of equal hashes. 32 bits of
  // hash are plenty to keep runs short.
  const std::size_t n = points.size();
  std::vector<std::uint32_t> hash(n);
  std::vector<std::uint32_t> order(n);
  executor.for_each(n, [&](std::size_t i) {
    hash[i] = static_cast<std::uint32_t>(point_hash(points[i].x, points[i].y));
    order[i] = static_cast<std::uint32_t>(i);
  });
  executor.sort_pairs_by_key(hash, order, 32);
  // Within a run of equal hashes the first point with given coordinates has the lowest index of them
  // (runs are in index order): the representative. A run holds one point's copies unless hashes
  // collide, so each point is compared with one or two representatives of its run, however many
  // copies the run holds. Most runs are a single point, its own representative: only the heads of
  // longer runs do any work.
  IndexArray duplicate_of(n);
  executor.for_each(n, [&](std::size_t i) { duplicate_of[i] = static_cast<std::uint32_t>(i); });
  executor.for_each(n, [&](std::size_t head) {
    if (head > 0 && hash[head] == hash[head - 1]) return;      // inside a run
    if (head + 1 == n || hash[head + 1] != hash[head]) return; // a run of one
    thread_local std::vector<std::uint32_t> representatives;   // one per distinct point of the run
    representatives.clear();
    for (std::size_t k = head; k < n && hash[k] == hash[head]; ++k) {
      const std::uint32_t i = order[k];
      std::uint32_t representative = i;
      for (const std::uint32_t c : representatives) {
        if (points[c].x == points[i].x && points[c].y == points[i].y) {
          representative = c;
          break;
        }
      }
      if (representative == i) representatives.push_back(i);
      duplicate_of[i] = representative;
    }
  });
  return duplicate_of;
}

/// representative(k) is the k-th of `count` distinct points.
template <class Representative>
void check_dimension(std::span<const Point> points, std::size_t count, Representative representative) {
  if (count < 3) {
    throw InvalidInputError(Kind::too_few_points, count,
                            "only " + std::to_string(count) + " distinct points: a triangulation needs 3");
  }
  const Point& a = points[representative(0)];
  const Point& b = points[representative(1)];
  for (std::size_t k = 0; k < count; ++k) {
    if (orient(a, b, points[representative(k)]) != 0) return;
  }
  throw InvalidInputError(Kind::all_collinear, count,
                          "all " + std::to_string(count) +
                              " distinct points are collinear: there is no triangle");
}

/// check_dimension of the `count` distinct points among `points`, without their list: the first point
/// and the first one unlike it stand for the first two sites, and every point is on the line through
/// them exactly when every distinct one is.
void check_dimension_of_points(std::span<const Point> points, std::size_t count) {
  if (count >= 3) {
    std::size_t second = 1;
    while (points[second] == points[0]) ++second; // count >= 2: a point unlike the first exists
    for (const Point& p : points)
      if (orient(points[0], points[second], p) != 0) return;
  }
  check_dimension(points, count, [](std::size_t k) { return k; }); // throws the same errors
}

// --- working segments --------------------------------------------------------------------------------

/// A segment during preparation: input segments first, then the pieces bent at crossing points.
struct WorkSegment {
  std::uint32_t a;
  std::uint32_t b;
  std::uint32_t label; // lowest input segment id covering it
  bool dirty;          // to be checked against every segment and site in the coming round
  bool snapped;        // bent through a snapped site in this round, after its sites were checked
};

/// Sorts vertices along segment a -> b: by the dominant coordinate, then the other one. Exact for
/// vertices on the segment; for rounded crossing points it still gives a monotone order, so the bent
/// polyline never folds back.
struct AlongSegment {
  const PointArray* vertices;
  bool use_x;
  bool ascending;
  bool ascending_other;
  AlongSegment(const PointArray& v, const Point& a, const Point& b)
      : vertices(&v), use_x(x_is_dominant(a, b)), ascending(use_x ? a.x < b.x : a.y < b.y),
        ascending_other(use_x ? a.y <= b.y : a.x <= b.x) {}
  bool operator()(std::uint32_t i, std::uint32_t j) const {
    const Point& p = (*vertices)[i];
    const Point& q = (*vertices)[j];
    const double pk = use_x ? p.x : p.y;
    const double qk = use_x ? q.x : q.y;
    if (pk != qk) return ascending ? pk < qk : pk > qk;
    const double po = use_x ? p.y : p.x;
    const double qo = use_x ? q.y : q.x;
    if (po != qo) return ascending_other ? po < qo : po > qo;
    return i < j;
  }
};

/// Per segment: the vertices to split it at, in a compressed row layout.
struct SplitLists {
  std::vector<std::size_t> start; // segment s owns vertex[start[s] .. start[s + 1])
  std::vector<std::uint32_t> vertex;
  std::span<const std::uint32_t> of(std::size_t s) const {
    return {vertex.data() + start[s], vertex.data() + start[s + 1]};
  }
};

// --- the grid ----------------------------------------------------------------------------------------

/// Per key c in [0, num_keys], the position of the first of `sorted` (increasing) that is >= c: the
/// row starts of a compressed layout whose entries were sorted by their row.
std::vector<std::size_t> run_starts(const std::vector<std::uint32_t>& sorted, std::size_t num_keys,
                                    CpuExecutor& executor) {
  std::vector<std::size_t> start(num_keys + 1);
  const std::size_t n = sorted.size();
  // Each key's start is written once: by the entry where the keys step past it, or at the end.
  executor.for_each(n + 1, [&](std::size_t k) {
    const std::size_t from = k == 0 ? 0 : std::size_t{sorted[k - 1]} + 1;
    const std::size_t to = k == n ? num_keys : std::size_t{sorted[k]};
    for (std::size_t c = from; c <= to; ++c) start[c] = k;
  });
  return start;
}

/// Groups (segment, vertex) pairs by segment and sorts each group along its segment.
SplitLists group_splits(const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
                        const std::vector<WorkSegment>& segs, const PointArray& vertices,
                        CpuExecutor& executor) {
  std::vector<std::uint32_t> segment(pairs.size());
  SplitLists lists;
  lists.vertex.resize(pairs.size());
  for (std::size_t k = 0; k < pairs.size(); ++k) std::tie(segment[k], lists.vertex[k]) = pairs[k];
  executor.sort_pairs_by_key(segment, lists.vertex, bits_below(segs.size()));
  lists.start = run_starts(segment, segs.size(), executor);
  const std::vector<std::uint32_t> first =
      executor.compact(segment.size(), [&](std::size_t k) { return k == 0 || segment[k] != segment[k - 1]; });
  executor.for_each(first.size(), [&](std::size_t r) {
    const std::uint32_t s = segment[first[r]];
    if (lists.start[s + 1] - lists.start[s] < 2) return;
    const AlongSegment along(vertices, vertices[segs[s].a], vertices[segs[s].b]);
    std::sort(lists.vertex.begin() + static_cast<std::ptrdiff_t>(lists.start[s]),
              lists.vertex.begin() + static_cast<std::ptrdiff_t>(lists.start[s + 1]), along);
  });
  return lists;
}

/// The endpoints of each working segment, copied in segment order: the hot loops read them in sequence
/// instead of chasing vertex indices across memory.
using Ends = std::vector<std::array<Point, 2>>;

Ends endpoints(const std::vector<WorkSegment>& segs, const PointArray& vertices, CpuExecutor& executor) {
  Ends ends(segs.size());
  executor.for_each(segs.size(), [&](std::size_t k) {
    ends[k] = {vertices[segs[k].a], vertices[segs[k].b]};
  });
  return ends;
}

/// The largest coordinate magnitude in the box: the scale of the rounding errors of coordinates.
double magnitude(const Box& box) {
  return std::max({std::abs(box.min_x), std::abs(box.max_x), std::abs(box.min_y), std::abs(box.max_y)});
}

/// A uniform grid over the sites' bounding box; cells list the segments that may meet them.
class SegmentGrid {
public:
  SegmentGrid(const Box& box, std::size_t num_segments) : min_x_(box.min_x), min_y_(box.min_y) {
    const double width = box.max_x - box.min_x;
    const double height = box.max_y - box.min_y;
    // About four cells per segment (clustered data such as coastlines crowds many segments into the
    // cells of a uniform grid), but never more cells along a side than that, so that a very thin box
    // cannot ask for an absurd number of cells.
    // At most 2^30 cells in the target, so that cell indices (at most 3 target + 1 of them) fit 32 bits.
    const double target = std::min(4.0 * static_cast<double>(std::max<std::size_t>(num_segments, 1)),
                                   static_cast<double>(std::uint32_t{1} << 30));
    size_ = std::max({std::sqrt(width * height / target), width / target, height / target});
    if (!(size_ > 0.0)) size_ = 1.0;
    nx_ = static_cast<std::uint32_t>(std::min(target, std::floor(width / size_)) + 1.0);
    ny_ = static_cast<std::uint32_t>(std::min(target, std::floor(height / size_)) + 1.0);
    // The y of a segment over a column is computed with an error of a few ulps of the coordinates.
    margin_ = std::max(1e-12 * magnitude(box), std::numeric_limits<double>::min());
  }

  /// Registers every segment in the cells it may meet; each cell lists its segments in increasing
  /// order. (cell, segment) pairs are written in segment order and sorted stably by cell.
  void build(const Ends& ends, CpuExecutor& executor) {
    std::vector<std::size_t> at(ends.size());
    executor.for_each(ends.size(), [&](std::size_t k) {
      std::size_t count = 0;
      for_each_cell(ends[k][0], ends[k][1], [&](std::size_t) { ++count; });
      at[k] = count;
    });
    const std::size_t total = executor.exclusive_scan(at);
    std::vector<std::uint32_t> cell(total);
    items_.resize(total);
    executor.for_each(ends.size(), [&](std::size_t k) {
      std::size_t slot = at[k];
      for_each_cell(ends[k][0], ends[k][1], [&](std::size_t c) {
        cell[slot] = static_cast<std::uint32_t>(c);
        items_[slot++] = static_cast<std::uint32_t>(k);
      });
    });
    executor.sort_pairs_by_key(cell, items_, bits_below(num_cells()));
    start_ = run_starts(cell, num_cells(), executor);
  }

  std::size_t num_cells() const { return static_cast<std::size_t>(nx_) * ny_; }

  std::size_t cell_of(const Point& p) const {
    return static_cast<std::size_t>(row_of(p.y)) * nx_ + column_of(p.x);
  }

  std::span<const std::uint32_t> segments_in(std::size_t cell) const {
    return {items_.data() + start_[cell], items_.data() + start_[cell + 1]};
  }

  /// Calls f(cell) for each cell meeting the box [x0, x1] x [y0, y1], unless there are more than
  /// max_cells of them; returns whether it did.
  template <class F>
  bool for_each_cell_in_box(double x0, double y0, double x1, double y1, std::size_t max_cells, F&& f) const {
    const std::uint32_t c0 = column_of(x0);
    const std::uint32_t c1 = column_of(x1);
    const std::uint32_t r0 = row_of(y0);
    const std::uint32_t r1 = row_of(y1);
    if (static_cast<std::size_t>(c1 - c0 + 1) * (r1 - r0 + 1) > max_cells) return false;
    for (std::uint32_t r = r0; r <= r1; ++r) {
      for (std::uint32_t c = c0; c <= c1; ++c) f(static_cast<std::size_t>(r) * nx_ + c);
    }
    return true;
  }

  /// Calls f(cell) once for each cell of a superset of the cells that segment a-b meets.
  template <class F>
  void for_each_cell(const Point& a, const Point& b, F&& f) const {
    const std::uint32_t c0 = column_of(std::min(a.x, b.x));
    const std::uint32_t c1 = column_of(std::max(a.x, b.x));
    const std::uint32_t r0 = row_of(std::min(a.y, b.y));
    const std::uint32_t r1 = row_of(std::max(a.y, b.y));
    const std::size_t box_cells = static_cast<std::size_t>(c1 - c0 + 1) * (r1 - r0 + 1);
    if (box_cells <= 4 || c0 == c1 || r0 == r1) {
      for (std::uint32_t r = r0; r <= r1; ++r) {
        for (std::uint32_t c = c0; c <= c1; ++c) f(static_cast<std::size_t>(r) * nx_ + c);
      }
      return;
    }
    // Walk the columns (or rows) along the dominant axis; in each, the segment's extent across is a
    // short interval, widened by the margin.
    const bool along_x = x_is_dominant(a, b);
    const Point& p = along_x ? (a.x < b.x ? a : b) : (a.y < b.y ? a : b);
    const Point& q = &p == &a ? b : a;
    if (along_x) {
      const double slope = (q.y - p.y) / (q.x - p.x);
      for (std::uint32_t c = c0; c <= c1; ++c) {
        const double lo = std::max(boundary_x(c), p.x);
        const double hi = c + 1 < nx_ ? std::min(boundary_x(c + 1), q.x) : q.x;
        const double y_lo = p.y + (lo - p.x) * slope;
        const double y_hi = p.y + (hi - p.x) * slope;
        const std::uint32_t from = std::max(r0, row_of(std::min(y_lo, y_hi) - margin_));
        const std::uint32_t to = std::min(r1, row_of(std::max(y_lo, y_hi) + margin_));
        for (std::uint32_t r = from; r <= to; ++r) f(static_cast<std::size_t>(r) * nx_ + c);
      }
    } else {
      const double slope = (q.x - p.x) / (q.y - p.y);
      for (std::uint32_t r = r0; r <= r1; ++r) {
        const double lo = std::max(boundary_y(r), p.y);
        const double hi = r + 1 < ny_ ? std::min(boundary_y(r + 1), q.y) : q.y;
        const double x_lo = p.x + (lo - p.y) * slope;
        const double x_hi = p.x + (hi - p.y) * slope;
        const std::uint32_t from = std::max(c0, column_of(std::min(x_lo, x_hi) - margin_));
        const std::uint32_t to = std::min(c1, column_of(std::max(x_lo, x_hi) + margin_));
        for (std::uint32_t c = from; c <= to; ++c) f(static_cast<std::size_t>(r) * nx_ + c);
      }
    }
  }

private:
  /// Cell k spans [boundary(k), boundary(k + 1)) along an axis. These doubles *are* the cells: whatever
  /// their rounding, they increase with k, and cell indices are found by comparing with them.
  static double boundary(double origin, double size, std::uint32_t k) {
    return origin + static_cast<double>(k) * size;
  }
  /// The cell index of a coordinate: the estimate by division is corrected by exact comparisons.
  static std::uint32_t index_of(double v, double origin, double size, std::uint32_t count) {
    const double estimate = std::floor((v - origin) / size);
    std::uint32_t k = 0;
    if (estimate >= static_cast<double>(count - 1)) {
      k = count - 1;
    } else if (estimate > 0.0) {
      k = static_cast<std::uint32_t>(estimate);
    }
    while (k > 0 && v < boundary(origin, size, k)) --k;
    while (k + 1 < count && v >= boundary(origin, size, k + 1)) ++k;
    return k;
  }
  double boundary_x(std::uint32_t c) const { return boundary(min_x_, size_, c); }
  double boundary_y(std::uint32_t r) const { return boundary(min_y_, size_, r); }
  std::uint32_t column_of(double x) const { return index_of(x, min_x_, size_, nx_); }
  std::uint32_t row_of(double y) const { return index_of(y, min_y_, size_, ny_); }

  double min_x_;
  double min_y_;
  double size_ = 1.0;
  double margin_ = 0.0;
  std::uint32_t nx_ = 1;
  std::uint32_t ny_ = 1;
  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> items_;
};

// --- point on segment --------------------------------------------------------------------------------

/// The sites of each grid cell with their coordinates, so that a cell's tests read contiguous memory.
struct SiteCells {
  std::vector<std::size_t> start; // cell c holds entries start[c] .. start[c + 1], by increasing x
  std::vector<std::uint32_t> id;
  std::vector<Point> point;
};

SiteCells bucket_sites(const SegmentGrid& grid, const PointArray& vertices, const IndexArray& sites,
                       CpuExecutor& executor) {
  SiteCells cells;
  std::vector<std::uint32_t> cell(sites.size());
  cells.id.assign(sites.begin(), sites.end());
  executor.for_each(sites.size(), [&](std::size_t k) {
    cell[k] = static_cast<std::uint32_t>(grid.cell_of(vertices[sites[k]]));
  });
  executor.sort_pairs_by_key(cell, cells.id, bits_below(grid.num_cells()));
  cells.start = run_starts(cell, grid.num_cells(), executor);
  cells.point.resize(sites.size());
  executor.for_each(sites.size(), [&](std::size_t k) { cells.point[k] = vertices[cells.id[k]]; });
  // By x within each cell, so that a segment short against the cell (clustered data crowd many sites
  // into one cell) tests only the sites in its x-range. Ties by id: the order is the same for any
  // thread count.
  executor.for_each_costly(grid.num_cells(), [&](std::size_t c) {
    const std::size_t begin = cells.start[c];
    const std::size_t end = cells.start[c + 1];
    if (end - begin < 2) return;
    thread_local std::vector<std::pair<Point, std::uint32_t>> entries;
    entries.resize(end - begin);
    for (std::size_t k = begin; k < end; ++k) entries[k - begin] = {cells.point[k], cells.id[k]};
    std::sort(entries.begin(), entries.end(), [](const auto& p, const auto& q) {
      return p.first.x != q.first.x ? p.first.x < q.first.x : p.second < q.second;
    });
    for (std::size_t k = begin; k < end; ++k) {
      cells.point[k] = entries[k - begin].first;
      cells.id[k] = entries[k - begin].second;
    }
  });
  return cells;
}

/// Adds sites to cells built by bucket_sites (the vertices a repair round added: few), giving what
/// bucket_sites would give for all of them, without bucketing the others again.
void add_sites(SiteCells& cells, const SegmentGrid& grid, const PointArray& vertices,
               std::span<const std::uint32_t> added, CpuExecutor& executor) {
  if (added.empty()) return;
  struct Entry {
    std::size_t cell;
    Point point;
    std::uint32_t id;
  };
  std::vector<Entry> fresh(added.size());
  for (std::size_t k = 0; k < added.size(); ++k) {
    fresh[k] = {grid.cell_of(vertices[added[k]]), vertices[added[k]], added[k]};
  }
  const auto before = [](const Point& p, std::uint32_t i, const Point& q, std::uint32_t j) {
    return p.x != q.x ? p.x < q.x : i < j;
  };
  std::sort(fresh.begin(), fresh.end(), [&](const Entry& e, const Entry& f) {
    return e.cell != f.cell ? e.cell < f.cell : before(e.point, e.id, f.point, f.id);
  });
  // Each entry's place among the old ones: in its cell, by x then id.
  std::vector<std::size_t> place(fresh.size());
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const Entry& e = fresh[k];
    std::size_t at = cells.start[e.cell];
    while (at < cells.start[e.cell + 1] && before(cells.point[at], cells.id[at], e.point, e.id)) ++at;
    place[k] = at;
  }
  // Every cell's start moves by the number of new entries in earlier cells: parts of the cells, each
  // walking the sorted entries from where its first cell stands.
  const std::size_t num_starts = cells.start.size();
  const std::size_t parts = std::min<std::size_t>(num_starts, 4 * std::size_t{executor.threads()});
  executor.for_each_part(parts, [&](std::size_t part) {
    const std::size_t first = num_starts * part / parts;
    const std::size_t last = num_starts * (part + 1) / parts;
    std::size_t k = static_cast<std::size_t>(
        std::partition_point(fresh.begin(), fresh.end(), [&](const Entry& e) { return e.cell < first; }) -
        fresh.begin());
    for (std::size_t c = first; c < last; ++c) {
      while (k < fresh.size() && fresh[k].cell < c) ++k;
      cells.start[c] += k;
    }
  });
  std::vector<std::uint32_t> id;
  std::vector<Point> point;
  id.reserve(cells.id.size() + fresh.size());
  point.reserve(cells.point.size() + fresh.size());
  std::size_t copied = 0;
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    id.insert(id.end(), cells.id.begin() + static_cast<std::ptrdiff_t>(copied),
              cells.id.begin() + static_cast<std::ptrdiff_t>(place[k]));
    point.insert(point.end(), cells.point.begin() + static_cast<std::ptrdiff_t>(copied),
                 cells.point.begin() + static_cast<std::ptrdiff_t>(place[k]));
    copied = place[k];
    id.push_back(fresh[k].id);
    point.push_back(fresh[k].point);
  }
  id.insert(id.end(), cells.id.begin() + static_cast<std::ptrdiff_t>(copied), cells.id.end());
  point.insert(point.end(), cells.point.begin() + static_cast<std::ptrdiff_t>(copied), cells.point.end());
  cells.id = std::move(id);
  cells.point = std::move(point);
}

/// The vertices to split the segments at, and per segment whether any of them was snapped (lies off
/// the segment, so that its pieces are bent).
struct PointSplits {
  SplitLists lists;
  std::vector<std::uint8_t> snapped;
  bool any_snapped = false;
};

/// True when p lies within `tolerance` of the line through a and b (an estimate, not a decision: the
/// pieces bent through p are checked exactly afterwards).
bool near_line(const Point& a, const Point& b, const Point& p, double tolerance) {
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  return std::abs(dx * (p.y - a.y) - dy * (p.x - a.x)) <= tolerance * std::max(std::abs(dx), std::abs(dy));
}

/// Every site that lies in the interior of a segment, as split lists sorted along each segment. Only
/// pairs not settled in an earlier round are tested: a dirty segment against every site, a new vertex
/// (id >= first_new) against every segment. A site lies in exactly one cell, so no pair is seen twice.
///
/// With a positive snap tolerance (repair rounds only), a new vertex that lies within it of a segment's
/// interior splits the segment too, bending it through the vertex: segments that pass a hair away from
/// a crossing vertex would otherwise cross its bent pieces again and again. Only vertices new in this
/// round snap, so each vertex snaps in one round at most and snapping cannot go back and forth.
PointSplits find_points_on_segments(const SegmentGrid& grid, const SiteCells& site_cells, const Ends& ends,
                                    const std::vector<WorkSegment>& segs, const PointArray& vertices,
                                    std::uint32_t first_new, double snap_tolerance, CpuExecutor& executor) {
  PointSplits splits;
  splits.snapped.assign(segs.size(), 0);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> hits;
  // Calls hit(s, v, snapped) for every split found in cell c, in a fixed order.
  const auto scan_cell = [&](std::size_t c, auto&& hit) {
    const std::size_t begin = site_cells.start[c];
    const std::size_t end = site_cells.start[c + 1];
    if (begin == end) return;
    const Point* first = site_cells.point.data() + begin;
    const Point* last = site_cells.point.data() + end;
    bool any_new = false;
    for (std::size_t k = begin; k < end && !any_new; ++k) any_new = site_cells.id[k] >= first_new;
    for (std::uint32_t s : grid.segments_in(c)) {
      const WorkSegment& g = segs[s];
      if (!g.dirty && !any_new) continue; // every pair of this cell was settled in an earlier round
      const auto& [a, b] = ends[s];
      // A site on the segment lies in its x-range; a site snapped to it within the tolerance of it (twice
      // the tolerance covers the rounding of near_line's estimate).
      const double lo = std::min(a.x, b.x) - 2.0 * snap_tolerance;
      const double hi = std::max(a.x, b.x) + 2.0 * snap_tolerance;
      const Point* from = std::lower_bound(first, last, lo, [](const Point& p, double x) { return p.x < x; });
      for (std::size_t k = begin + static_cast<std::size_t>(from - first); k < end; ++k) {
        if (site_cells.point[k].x > hi) break;
        const std::uint32_t v = site_cells.id[k];
        if ((!g.dirty && v < first_new) || v == g.a || v == g.b) continue;
        const Point& p = site_cells.point[k];
        if (!strictly_between(a, b, p)) continue;
        if (orient(a, b, p) == 0) {
          hit(s, v, false);
        } else if (v >= first_new && snap_tolerance > 0.0 && near_line(a, b, p, snap_tolerance)) {
          hit(s, v, true);
        }
      }
    }
  };
  // Splits are rare on most inputs but not on all (a lattice's segments pass through many sites): the
  // cells count theirs in parallel, then each cell with any scans again into its own stretch of the
  // list, in cell order, so the lists come out the same for any thread count.
  const std::size_t num_cells = grid.num_cells();
  std::vector<std::size_t> offset(num_cells + 1, 0);
  executor.for_each_costly(num_cells, [&](std::size_t c) {
    std::size_t count = 0;
    scan_cell(c, [&](std::uint32_t, std::uint32_t, bool) { ++count; });
    offset[c] = count;
  });
  hits.resize(executor.exclusive_scan(offset));
  std::vector<std::uint8_t> hit_snapped(hits.size(), 0);
  executor.for_each_costly(num_cells, [&](std::size_t c) {
    std::size_t at = offset[c];
    if (at == offset[c + 1]) return;
    scan_cell(c, [&](std::uint32_t s, std::uint32_t v, bool snapped) {
      hits[at] = {s, v};
      hit_snapped[at] = snapped ? 1 : 0;
      ++at;
    });
  });
  for (std::size_t k = 0; k < hits.size(); ++k) {
    if (hit_snapped[k] == 0) continue;
    splits.snapped[hits[k].first] = 1;
    splits.any_snapped = true;
  }
  splits.lists = group_splits(hits, segs, vertices, executor);
  return splits;
}

// --- crossings ---------------------------------------------------------------------------------------

/// True when segments i and j cross at a single point interior to both (touching and collinear
/// overlap are no crossings: splitting at vertices handles them).
bool properly_cross(const std::array<Point, 2>& i, const std::array<Point, 2>& j) {
  const auto& [a, b] = i;
  const auto& [c, d] = j;
  const int oc = orient(a, b, c);
  const int od = orient(a, b, d);
  if (oc == 0 || od == 0 || oc == od) return false;
  const int oa = orient(c, d, a);
  const int ob = orient(c, d, b);
  return oa != 0 && ob != 0 && oa != ob;
}

/// All pairs of segments that properly cross, as index pairs (lower first). Each candidate pair of the
/// grid is tested once, and only when one of the two is dirty. every_segment_dirty (the first round)
/// picks the screen that suits it.
std::vector<std::pair<std::uint32_t, std::uint32_t>> find_crossings(const SegmentGrid& grid, const Ends& ends,
                                                                    const std::vector<WorkSegment>& segs,
                                                                    bool every_segment_dirty,
                                                                    CpuExecutor& executor) {
  // Disjoint bounding boxes rule a crossing out with four comparisons; in crowded cells (coastlines) most
  // candidate pairs are far apart within the cell.
  const auto boxes_meet = [&](std::uint32_t i, std::uint32_t j) {
    const auto& [a, b] = ends[i];
    const auto& [c, d] = ends[j];
    return std::max(c.x, d.x) >= std::min(a.x, b.x) && std::min(c.x, d.x) <= std::max(a.x, b.x) &&
           std::max(c.y, d.y) >= std::min(a.y, b.y) && std::min(c.y, d.y) <= std::max(a.y, b.y);
  };
  // Crossings are rare: segments are screened in parallel (a pair met in two cells is simply tested
  // twice) for the lower segments of crossing pairs, and the few found are listed again in order, so the
  // list is the same for any thread count.
  std::vector<std::uint32_t> crossing;
  if (every_segment_dirty) {
    // Each segment screens the pairs with the higher segments of its cells (cells list their segments
    // in increasing order).
    // (Flagged first, in small chunks: in crowded cells a segment screens hundreds of pairs.)
    std::vector<std::uint8_t> found(segs.size());
    executor.for_each_costly(segs.size(), [&](std::size_t k) {
      const auto i = static_cast<std::uint32_t>(k);
      bool any = false;
      grid.for_each_cell(ends[i][0], ends[i][1], [&](std::size_t cell) {
        const std::span<const std::uint32_t> in_cell = grid.segments_in(cell);
        for (auto it = std::upper_bound(in_cell.begin(), in_cell.end(), i); it != in_cell.end() && !any; ++it)
          any = boxes_meet(i, *it) && properly_cross(ends[i], ends[*it]);
      });
      found[k] = any ? 1 : 0;
    });
    crossing = executor.compact(segs.size(), [&](std::size_t k) { return found[k] != 0; });
  } else {
    // A repair round: only the few dirty segments screen, marking the lower segment of each crossing,
    // so the screen costs what they meet rather than a pass over every cell's pairs. A pair of dirty
    // segments is screened from its lower side.
    const std::vector<std::uint32_t> dirty_ids =
        executor.compact(segs.size(), [&](std::size_t k) { return segs[k].dirty; });
    std::vector<std::uint8_t> marked(segs.size(), 0);
    executor.for_each(dirty_ids.size(), [&](std::size_t k) {
      const std::uint32_t d = dirty_ids[k];
      grid.for_each_cell(ends[d][0], ends[d][1], [&](std::size_t cell) {
        for (const std::uint32_t e : grid.segments_in(cell)) {
          if (e == d || (e < d && segs[e].dirty) || !boxes_meet(d, e)) continue;
          if (properly_cross(ends[d], ends[e]))
            std::atomic_ref<std::uint8_t>(marked[std::min(d, e)]).store(1, std::memory_order_relaxed);
        }
      });
    });
    crossing = executor.compact(segs.size(), [&](std::size_t k) { return marked[k] != 0; });
  }
  // The pairs of each lower segment i, its partners j in the order its cells first meet them (a pair
  // met in two cells is listed once): found in parallel, then joined in the order of i.
  const auto partners_of = [&](std::uint32_t i, std::vector<std::uint32_t>& js) {
    const bool dirty = segs[i].dirty;
    grid.for_each_cell(ends[i][0], ends[i][1], [&](std::size_t cell) {
      for (const std::uint32_t j : grid.segments_in(cell)) {
        if (j <= i || (!dirty && !segs[j].dirty)) continue;
        if (!boxes_meet(i, j) || !properly_cross(ends[i], ends[j])) continue;
        if (std::find(js.begin(), js.end(), j) == js.end()) js.push_back(j);
      }
    });
  };
  std::vector<std::vector<std::uint32_t>> partners(crossing.size());
  std::vector<std::size_t> first(crossing.size() + 1, 0);
  executor.for_each(crossing.size(), [&](std::size_t k) {
    partners_of(crossing[k], partners[k]);
    first[k] = partners[k].size();
  });
  std::vector<std::pair<std::uint32_t, std::uint32_t>> crossings(executor.exclusive_scan(first));
  executor.for_each(crossing.size(), [&](std::size_t k) {
    for (std::size_t m = 0; m < partners[k].size(); ++m)
      crossings[first[k] + m] = {crossing[k], partners[k][m]};
  });
  return crossings;
}

[[noreturn]] void throw_not_converging(const std::string& where, int rounds) {
  throw SplitNotConvergingError(
      "crossing segments: resolution did not converge after " + std::to_string(rounds) +
      " rounds: rounding the crossing points keeps creating new crossings" + where +
      "; the input has segments that nearly overlap at the limit of double precision");
}

[[noreturn]] void reject_crossing(const std::vector<std::pair<std::uint32_t, std::uint32_t>>& crossings,
                                  const std::vector<WorkSegment>& segs) {
  std::pair<std::uint32_t, std::uint32_t> lowest{std::numeric_limits<std::uint32_t>::max(), 0};
  for (const auto& [i, j] : crossings) {
    const auto pair = std::minmax(segs[i].label, segs[j].label);
    lowest = std::min(lowest, std::pair<std::uint32_t, std::uint32_t>(pair.first, pair.second));
  }
  throw CrossingSegmentsError(lowest.first, lowest.second,
                              "segments " + std::to_string(lowest.first) + " and " +
                                  std::to_string(lowest.second) +
                                  " cross in their interiors (crossing policy: reject)");
}

/// (b - a) x (d - c), evaluated exactly and rounded once at the end (the expansion's components summed
/// smallest first), so that it keeps its relative accuracy when the two directions are nearly parallel.
double cross_of_differences(const Point& a, const Point& b, const Point& c, const Point& d) {
  const Expansion<2> ux = exact_diff(b.x, a.x);
  const Expansion<2> uy = exact_diff(b.y, a.y);
  const Expansion<2> vx = exact_diff(d.x, c.x);
  const Expansion<2> vy = exact_diff(d.y, c.y);
  Expansion<8> left;
  Expansion<8> right;
  expansion_product(ux, vy, left);
  expansion_product(uy, vx, right);
  Expansion<16> det;
  expansion_sum(left, negated(right), det);
  double sum = 0.0;
  for (int k = 0; k < det.n; ++k) sum += det.t[k];
  return sum;
}

/// The crossing point of two segments known to cross, rounded to doubles.
///
/// The parameter along one segment is a ratio of two cross products, both evaluated exactly before
/// rounding, so it is accurate even for nearly parallel segments (where the plain double formula can
/// be off by the whole segment). The point is then stepped from the nearer end of the shorter
/// segment, which keeps the absolute error to a few ulps of that short step, and clamped into both
/// bounding boxes, where the exact point lies. A far-off point would bend the pieces across
/// neighbouring segments, and the repair rounds would snowball.
Point crossing_point(const Point& a, const Point& b, const Point& c, const Point& d) {
  const auto length2 = [](const Point& p, const Point& q) {
    return (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y);
  };
  const bool first_shorter = length2(a, b) <= length2(c, d);
  const Point& p0 = first_shorter ? a : c;
  const Point& p1 = first_shorter ? b : d;
  const Point& q0 = first_shorter ? c : a;
  const Point& q1 = first_shorter ? d : b;
  double t = cross_of_differences(p0, q0, q0, q1) / cross_of_differences(p0, p1, q0, q1);
  if (!std::isfinite(t)) t = 0.5;
  t = std::clamp(t, 0.0, 1.0);
  Point x = t <= 0.5 ? Point{p0.x + t * (p1.x - p0.x), p0.y + t * (p1.y - p0.y)}
                     : Point{p1.x + (t - 1.0) * (p1.x - p0.x), p1.y + (t - 1.0) * (p1.y - p0.y)};
  const double lo_x = std::max(std::min(a.x, b.x), std::min(c.x, d.x));
  const double hi_x = std::min(std::max(a.x, b.x), std::max(c.x, d.x));
  const double lo_y = std::max(std::min(a.y, b.y), std::min(c.y, d.y));
  const double hi_y = std::min(std::max(a.y, b.y), std::max(c.y, d.y));
  // + 0.0 turns -0 into +0, so that equal points have equal bits.
  x.x = std::clamp(x.x, lo_x, hi_x) + 0.0;
  x.y = std::clamp(x.y, lo_y, hi_y) + 0.0;
  return x;
}

/// Chooses the vertices for the rounded crossing points of a round.
///
/// An input point at exactly that place is reused, and so is an added vertex within a tolerance of a
/// few ulps of the largest coordinate (the nearest one, the lowest id among the nearest), so that
/// rounded crossing points of segments that overlap to within rounding error (a shared border
/// digitised twice) gather on few vertices. The tolerance is far below any feature the input can
/// resolve. Input points are only reused exactly: a segment may bend through an added vertex, never
/// through an input point that is not on it.
///
/// The points are taken in order, each seeing the vertices the earlier ones added. Most points have no
/// other point of their round within the tolerance: their choice depends only on the vertices of earlier
/// rounds and is made in parallel; only the crowded ones are chosen one by one.
class VertexChooser {
public:
  VertexChooser(double tolerance, std::size_t num_points)
      : tolerance_(std::max(tolerance, std::numeric_limits<double>::min())), num_points_(num_points) {}

  /// The vertex of each point of `at`; new ones are appended to vertices and sites.
  std::vector<std::uint32_t> choose(std::span<const Point> at, const SegmentGrid& grid,
                                    const SiteCells& site_cells, PointArray& vertices, IndexArray& sites,
                                    CpuExecutor& executor) {
    const std::size_t n = at.size();
    // This round's points by bucket, to find the crowded ones.
    std::vector<Keyed> round(n);
    executor.for_each(n, [&](std::size_t k) { round[k] = {key_of(at[k]), static_cast<std::uint32_t>(k)}; });
    executor.sort(
        round, [](const Keyed& p, const Keyed& q) { return p.key != q.key ? p.key < q.key : p.id < q.id; });
    std::vector<Choice> earlier(n);
    std::vector<std::uint8_t> crowded(n, 0);
    executor.for_each(n, [&](std::size_t k) {
      earlier[k] = nearest_earlier(at[k], grid, site_cells, vertices);
      for_each_near(round, key_of(at[k]), [&](std::uint32_t j) {
        if (j != k && distance(at[j], at[k]) <= tolerance_) crowded[k] = 1;
      });
    });
    // In order: a point alone in its neighbourhood takes what earlier rounds left or a new vertex; a
    // crowded one also sees the vertices added by the crowded points before it.
    std::vector<std::uint32_t> chosen(n);
    std::unordered_multimap<Key, std::uint32_t, KeyHash> fresh; // the crowded points' new vertices
    const std::size_t first_new = vertices.size();
    for (std::size_t k = 0; k < n; ++k) {
      Choice best = earlier[k];
      const Key key = key_of(at[k]);
      if (crowded[k] != 0 && !best.final) {
        for (std::int64_t dy = -1; dy <= 1; ++dy) {
          for (std::int64_t dx = -1; dx <= 1; ++dx) {
            const auto [first, last] = fresh.equal_range(Key{key.x + dx, key.y + dy});
            for (auto it = first; it != last; ++it)
              consider(best, it->second, distance(vertices[it->second], at[k]));
          }
        }
      }
      if (best.vertex == kNone) {
        if (vertices.size() >= std::numeric_limits<std::uint32_t>::max()) {
          throw Error("crossing resolution needs more than 2^32 - 1 vertices");
        }
        best.vertex = static_cast<std::uint32_t>(vertices.size());
        vertices.push_back(at[k]);
        sites.push_back(best.vertex);
        if (crowded[k] != 0) fresh.emplace(key, best.vertex);
      }
      chosen[k] = best.vertex;
    }
    // This round's vertices join the earlier ones, by key.
    const std::size_t old = added_.size();
    added_.resize(old + vertices.size() - first_new);
    executor.for_each(vertices.size() - first_new, [&](std::size_t k) {
      const auto v = static_cast<std::uint32_t>(first_new + k);
      added_[old + k] = {key_of(vertices[v]), v};
    });
    executor.sort(
        added_, [](const Keyed& p, const Keyed& q) { return p.key != q.key ? p.key < q.key : p.id < q.id; });
    return chosen;
  }

private:
  /// Buckets of side `tolerance_`: a point within the tolerance of p lies in one of the 3 x 3 buckets
  /// around p's.
  struct Key {
    std::int64_t x;
    std::int64_t y;
    friend auto operator<=>(const Key&, const Key&) = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const noexcept {
      const auto hx = std::hash<std::int64_t>{}(k.x);
      return hx ^ (std::hash<std::int64_t>{}(k.y) + 0x9E3779B97F4A7C15ull + (hx << 6) + (hx >> 2));
    }
  };
  struct Keyed {
    Key key;
    std::uint32_t id;
  };
  struct Choice {
    std::uint32_t vertex = kNone;
    double distance = 0.0;
    bool final = false; // an exact input point found without the neighbourhood's scan
  };

  Key key_of(const Point& p) const {
    return {static_cast<std::int64_t>(std::floor(p.x / tolerance_)),
            static_cast<std::int64_t>(std::floor(p.y / tolerance_))};
  }
  static double distance(const Point& p, const Point& q) {
    return std::max(std::abs(q.x - p.x), std::abs(q.y - p.y));
  }
  void consider(Choice& best, std::uint32_t v, double distance) const {
    if (v < num_points_ && distance != 0.0) return;
    if (distance > tolerance_) return;
    if (best.vertex == kNone || distance < best.distance || (distance == best.distance && v < best.vertex)) {
      best.vertex = v;
      best.distance = distance;
    }
  }
  /// Calls f(id) for each entry of `sorted` in the 3 x 3 buckets around `key`.
  template <class F>
  static void for_each_near(const std::vector<Keyed>& sorted, const Key& key, F&& f) {
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      const Key low{key.x + dx, key.y - 1};
      auto it = std::lower_bound(sorted.begin(), sorted.end(), low,
                                 [](const Keyed& e, const Key& k) { return e.key < k; });
      for (; it != sorted.end() && it->key.x == low.x && it->key.y <= key.y + 1; ++it) f(it->id);
    }
  }
  /// The choice among the vertices of earlier rounds: the site cells hold them all (and the input
  /// points); should the neighbourhood span too many cells, only an exact input point of p's cell and
  /// the added vertices by key are looked at.
  Choice nearest_earlier(const Point& p, const SegmentGrid& grid, const SiteCells& site_cells,
                         const PointArray& vertices) const {
    Choice best;
    // Cells are far larger than the tolerance except in inputs at the limit of double precision, where
    // scanning a huge box would cost more than an extra vertex.
    const bool scanned = grid.for_each_cell_in_box(
        p.x - tolerance_, p.y - tolerance_, p.x + tolerance_, p.y + tolerance_, 9, [&](std::size_t cell) {
          for (std::size_t k = site_cells.start[cell]; k < site_cells.start[cell + 1]; ++k) {
            consider(best, site_cells.id[k], distance(site_cells.point[k], p));
          }
        });
    if (scanned) return best; // the cells hold every earlier round's vertex too (they are sites)
    const std::size_t cell = grid.cell_of(p);
    for (std::size_t k = site_cells.start[cell]; k < site_cells.start[cell + 1]; ++k) {
      if (site_cells.point[k] == p) return {site_cells.id[k], 0.0, true};
    }
    for_each_near(added_, key_of(p), [&](std::uint32_t v) { consider(best, v, distance(vertices[v], p)); });
    return best;
  }

  double tolerance_;
  std::size_t num_points_;
  std::vector<Keyed> added_; // the vertices of earlier rounds, by key
};

// --- pieces ------------------------------------------------------------------------------------------

enum class CutAt {
  sites,     ///< vertices on (or snapped to) the segments, found before this round's crossing tests
  crossings, ///< rounded crossing points, after this round's tests
};

/// The positions of segs ordered by (a, b), ties in their given order: stable radix sorts by b, then
/// by a.
std::vector<std::uint32_t> order_by_ends(const std::vector<WorkSegment>& segs, std::size_t num_vertices,
                                         CpuExecutor& executor) {
  const int bits = bits_below(num_vertices);
  std::vector<std::uint32_t> key(segs.size());
  std::vector<std::uint32_t> order(segs.size());
  executor.for_each(segs.size(), [&](std::size_t k) {
    key[k] = segs[k].b;
    order[k] = static_cast<std::uint32_t>(k);
  });
  executor.sort_pairs_by_key(key, order, bits);
  executor.for_each(segs.size(), [&](std::size_t k) { key[k] = segs[order[k]].a; });
  executor.sort_pairs_by_key(key, order, bits);
  return order;
}

/// Calls piece(k, piece) for the pieces of segment g cut at `at_vertices` (sorted along it), in order;
/// returns their number. A cut at an end of its own segment (a crossing point rounded onto it) is no
/// cut. is_bent says that g was bent by its cuts (snapped sites or crossings).
///
/// Dirty pieces are tested against everything in the coming round. Exact cuts at sites give parts of
/// the segment, which inherit what was already checked of it. After the crossing tests, pieces are
/// clean unless bent by a crossing now, or by a snap earlier in this round (their sites are unchecked).
template <class Piece>
std::size_t for_each_piece(const WorkSegment& g, std::span<const std::uint32_t> at_vertices, bool is_bent,
                           CutAt at, Piece&& piece) {
  const bool dirty = at == CutAt::sites ? g.dirty || is_bent : is_bent || g.snapped;
  const bool snapped = at == CutAt::sites && is_bent;
  std::uint32_t from = g.a;
  std::size_t count = 0;
  std::uint32_t last = std::numeric_limits<std::uint32_t>::max();
  for (const std::uint32_t v : at_vertices) {
    if (v == last || v == g.a || v == g.b) continue; // repeated, or rounded onto an end of its own
    last = v;
    piece(count++, WorkSegment{std::min(from, v), std::max(from, v), g.label, dirty, snapped});
    from = v;
  }
  piece(count++, WorkSegment{std::min(from, g.b), std::max(from, g.b), g.label, dirty, snapped});
  return count;
}

/// Pieces sorted by (a, b, label) with identical ones merged into the first of their run (the lowest
/// label), dirty or snapped if any is.
std::vector<WorkSegment> merge_identical(const std::vector<WorkSegment>& pieces, CpuExecutor& executor) {
  const std::size_t total = pieces.size();
  const std::vector<std::uint32_t> heads = executor.compact(total, [&](std::size_t k) {
    return k == 0 || pieces[k].a != pieces[k - 1].a || pieces[k].b != pieces[k - 1].b;
  });
  std::vector<WorkSegment> merged(heads.size());
  executor.for_each(heads.size(), [&](std::size_t r) {
    const std::size_t end = r + 1 < heads.size() ? heads[r + 1] : total;
    WorkSegment p = pieces[heads[r]];
    for (std::size_t k = heads[r] + 1; k < end; ++k) {
      p.dirty = p.dirty || pieces[k].dirty;
      p.snapped = p.snapped || pieces[k].snapped;
    }
    merged[r] = p;
  });
  return merged;
}

/// Cuts every segment at its cut vertices (for_each_piece) and merges identical pieces, keeping the
/// lowest label. bent[s] says that segment s was bent by its cuts.
std::vector<WorkSegment> cut_segments(const std::vector<WorkSegment>& segs, const SplitLists& cuts,
                                      const std::vector<std::uint8_t>& bent, CutAt at,
                                      CpuExecutor& executor) {
  const auto pieces_of = [&](std::size_t s, auto&& piece) {
    return for_each_piece(segs[s], cuts.of(s), bent[s] != 0, at, piece);
  };
  std::vector<std::size_t> first(segs.size());
  executor.for_each(segs.size(), [&](std::size_t s) { first[s] = pieces_of(s, [](std::size_t, auto&&) {}); });
  const std::size_t total = executor.exclusive_scan(first);
  std::vector<WorkSegment> pieces(total);
  executor.for_each(segs.size(), [&](std::size_t s) {
    pieces_of(s, [&](std::size_t k, const WorkSegment& p) { pieces[first[s] + k] = p; });
  });
  executor.sort(pieces, [](const WorkSegment& p, const WorkSegment& q) {
    if (p.a != q.a) return p.a < q.a;
    if (p.b != q.b) return p.b < q.b;
    return p.label < q.label;
  });
  return merge_identical(pieces, executor);
}

/// cut_segments at crossings when few segments are cut, for segments in spatial order (order_spatially:
/// by the grid cell of a, then a, then b, each pair once): the same merged pieces, already in that
/// order, without sorting them all again. The pieces of the cut segments are sorted alone and put in
/// their places; an uncut segment equal to one of them absorbs it (lowest label, flags of either).
std::vector<WorkSegment> cut_few_segments(const std::vector<WorkSegment>& segs, const SplitLists& cuts,
                                          const std::vector<std::uint8_t>& bent, const SegmentGrid& grid,
                                          const PointArray& vertices, CpuExecutor& executor) {
  // A piece's place: the grid cell of its first end, then its ends.
  struct Place {
    std::size_t cell;
    std::uint32_t a, b;
    auto operator<=>(const Place&) const = default;
  };
  const auto place_of = [&](const WorkSegment& p) { return Place{grid.cell_of(vertices[p.a]), p.a, p.b}; };
  const std::vector<std::uint32_t> cut = executor.compact(
      segs.size(), [&](std::size_t s) { return cuts.start[s + 1] > cuts.start[s] || bent[s] != 0; });
  // The pieces of the cut segments, as cut_segments makes them, with their places among segs.
  struct Fresh {
    Place place;
    WorkSegment piece;
  };
  // Counted, then made into each segment's own stretch (in parallel: "few" can be a million).
  std::vector<std::size_t> first(cut.size() + 1, 0);
  const auto pieces_of = [&](std::size_t k, auto&& f) {
    const std::uint32_t s = cut[k];
    return for_each_piece(segs[s], cuts.of(s), bent[s] != 0, CutAt::crossings, f);
  };
  executor.for_each(cut.size(),
                    [&](std::size_t k) { first[k] = pieces_of(k, [](std::size_t, const WorkSegment&) {}); });
  std::vector<Fresh> fresh(executor.exclusive_scan(first));
  executor.for_each(cut.size(), [&](std::size_t k) {
    pieces_of(k, [&](std::size_t i, const WorkSegment& p) { fresh[first[k] + i] = {place_of(p), p}; });
  });
  executor.sort(fresh, [](const Fresh& p, const Fresh& q) {
    return p.place != q.place ? p.place < q.place : p.piece.label < q.piece.label;
  });
  // Merge equal pieces among themselves (into the lowest label, flags of any).
  std::vector<Fresh> unique;
  for (const Fresh& p : fresh) {
    if (!unique.empty() && unique.back().place == p.place) {
      unique.back().piece.dirty = unique.back().piece.dirty || p.piece.dirty;
      unique.back().piece.snapped = unique.back().piece.snapped || p.piece.snapped;
    } else {
      unique.push_back(p);
    }
  }
  // The uncut segments keep their order. After the crossing tests, they are clean unless bent by a
  // snap in this round.
  std::vector<std::uint8_t> is_cut(segs.size(), 0);
  executor.for_each(cut.size(), [&](std::size_t k) { is_cut[cut[k]] = 1; });
  const std::vector<std::uint32_t> kept =
      executor.compact(segs.size(), [&](std::size_t s) { return is_cut[s] == 0; });
  std::vector<WorkSegment> rest(kept.size());
  executor.for_each(kept.size(), [&](std::size_t k) {
    rest[k] = segs[kept[k]];
    rest[k].dirty = rest[k].snapped;
    rest[k].snapped = false;
  });
  // Each new piece goes before the first uncut segment not below it, or into it when equal: both
  // lists in order, merged in one pass.
  std::vector<WorkSegment> out;
  out.reserve(rest.size() + unique.size());
  std::size_t r = 0;
  for (const Fresh& f : unique) {
    while (r < rest.size() && place_of(rest[r]) < f.place) out.push_back(rest[r++]);
    const WorkSegment& p = f.piece;
    if (r < rest.size() && rest[r].a == p.a && rest[r].b == p.b) {
      rest[r].label = std::min(rest[r].label, p.label);
      rest[r].dirty = rest[r].dirty || p.dirty;
      rest[r].snapped = rest[r].snapped || p.snapped;
    } else {
      out.push_back(p);
    }
  }
  out.insert(out.end(), rest.begin() + static_cast<std::ptrdiff_t>(r), rest.end());
  return out;
}

/// The input segments between representatives, each vertex pair once (lowest segment id), all dirty.
std::vector<WorkSegment> initial_segments(std::span<const Segment> segments, const IndexArray& duplicate_of,
                                          CpuExecutor& executor) {
  // Zero-length segments were validated and are ignored.
  const std::vector<std::uint32_t> kept = executor.compact(segments.size(), [&](std::size_t s) {
    return duplicate_of[segments[s].a] != duplicate_of[segments[s].b];
  });
  std::vector<WorkSegment> segs(kept.size());
  executor.for_each(kept.size(), [&](std::size_t k) {
    const std::uint32_t a = duplicate_of[segments[kept[k]].a];
    const std::uint32_t b = duplicate_of[segments[kept[k]].b];
    segs[k] = {std::min(a, b), std::max(a, b), kept[k], true, false};
  });
  // Ordered by (a, b, label) as cut_segments orders its pieces, by radix passes rather than a
  // comparison sort: the segments come in label order, and order_by_ends keeps ties in order.
  const std::vector<std::uint32_t> order = order_by_ends(segs, duplicate_of.size(), executor);
  std::vector<WorkSegment> sorted(segs.size());
  executor.for_each(segs.size(), [&](std::size_t k) { sorted[k] = segs[order[k]]; });
  return merge_identical(sorted, executor);
}

/// Orders segments by the grid cell of their first end, so that segments met together in the grid
/// are also near each other in memory.
void order_spatially(std::vector<WorkSegment>& segs, const PointArray& vertices, const SegmentGrid& grid,
                     CpuExecutor& executor) {
  std::vector<std::uint32_t> cell(segs.size());
  std::vector<std::uint32_t> order(segs.size());
  executor.for_each(segs.size(), [&](std::size_t k) {
    cell[k] = static_cast<std::uint32_t>(grid.cell_of(vertices[segs[k].a]));
    order[k] = static_cast<std::uint32_t>(k);
  });
  executor.sort_pairs_by_key(cell, order, bits_below(grid.num_cells()));
  std::vector<WorkSegment> sorted(segs.size());
  executor.for_each(segs.size(), [&](std::size_t k) { sorted[k] = segs[order[k]]; });
  segs = std::move(sorted);
}

Box bounding_box(const PointArray& vertices, const IndexArray& sites, CpuExecutor& executor) {
  return box_of_points(
      sites.size(), [&](std::size_t k) -> const Point& { return vertices[sites[k]]; }, executor);
}

/// Splits segs (all dirty) in rounds until no two pieces cross or overlap and no site of `sites` lies
/// in a piece's interior (see prepare_pslg); vertices added at crossings are appended to `vertices`
/// and `sites`. Returns the pieces sorted by (a, b). box holds every site; the snap tolerance is given
/// by the caller, so that a subset of the input is treated exactly as the whole would be.
PieceArray resolve(std::vector<WorkSegment> segs, PointArray& vertices, IndexArray& sites,
                   std::size_t num_points, const Box& box, double snap_tolerance, CrossingSegments policy,
                   CpuExecutor& executor) {
  StepTrace trace("prepare");
  SegmentGrid grid(box, segs.size());
  std::size_t grid_segments = segs.size(); // the number of segments the grid was sized for
  VertexChooser chooser(snap_tolerance, num_points);
  // Each round: split at the vertices on the segments (and, in repair rounds, snap new vertices into
  // segments passing within the tolerance), then bend crossing pieces through their rounded crossing
  // points. Pairs settled in an earlier round are not tested again (see WorkSegment::dirty).
  std::uint32_t first_new = 0;
  std::size_t first_round_vertices = 0;
  bool spatial_order = false; // segs in order_spatially's order already
  SiteCells site_cells;       // sites[0, bucketed) by cell
  std::size_t bucketed = 0;
  for (int round = 0; round < kMaxRounds; ++round) {
    // Many crossings cut the segments into many more pieces, which would crowd the cells sized for the
    // segments (every dirty piece tests the pieces of its cells): the grid grows with them.
    const bool regrown = segs.size() > kGridGrowth * grid_segments;
    if (regrown) {
      grid = SegmentGrid(box, segs.size() / 4);
      grid_segments = segs.size();
      spatial_order = false;
    }
    if (!spatial_order) order_spatially(segs, vertices, grid, executor);
    trace.mark("segments ordered");
    Ends ends = endpoints(segs, vertices, executor);
    grid.build(ends, executor);
    trace.mark("segment grid");
    if (round == 0 || regrown) {
      site_cells = bucket_sites(grid, vertices, sites, executor);
    } else {
      add_sites(site_cells, grid, vertices, std::span(sites).subspan(bucketed), executor);
    }
    bucketed = sites.size();
    trace.mark("sites bucketed");
    // The first round is exact: snapping is only for repairing what rounding did.
    const PointSplits on_segment = find_points_on_segments(grid, site_cells, ends, segs, vertices, first_new,
                                                           round == 0 ? 0.0 : snap_tolerance, executor);
    trace.mark("points on segments");
    if (!on_segment.lists.vertex.empty()) {
      segs = cut_segments(segs, on_segment.lists, on_segment.snapped, CutAt::sites, executor);
      order_spatially(segs, vertices, grid, executor);
      ends = endpoints(segs, vertices, executor);
      grid.build(ends, executor);
      trace.mark("cut at sites");
    }
    const auto crossings = find_crossings(grid, ends, segs, round == 0, executor);
    trace.mark("crossings");
    trace.count("crossings", crossings.size());
    if (crossings.empty() && !on_segment.any_snapped) {
      const std::vector<std::uint32_t> order = order_by_ends(segs, vertices.size(), executor);
      PieceArray pieces(segs.size());
      executor.for_each(segs.size(), [&](std::size_t k) {
        const WorkSegment& p = segs[order[k]];
        pieces[k] = {p.a, p.b, p.label};
      });
      trace.mark("pieces");
      return pieces;
    }
    if (policy == CrossingSegments::reject && !crossings.empty()) reject_crossing(crossings, segs);

    first_new = static_cast<std::uint32_t>(vertices.size());
    // The rounded crossing points (exact arithmetic, in parallel) and their vertices.
    std::vector<Point> at(crossings.size());
    executor.for_each(crossings.size(), [&](std::size_t k) {
      const auto& [i, j] = crossings[k];
      at[k] =
          crossing_point(vertices[segs[i].a], vertices[segs[i].b], vertices[segs[j].a], vertices[segs[j].b]);
    });
    const std::vector<std::uint32_t> chosen = chooser.choose(at, grid, site_cells, vertices, sites, executor);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> cuts(2 * crossings.size());
    executor.for_each(crossings.size(), [&](std::size_t k) {
      cuts[2 * k] = {crossings[k].first, chosen[k]};
      cuts[2 * k + 1] = {crossings[k].second, chosen[k]};
    });
    trace.mark("crossing vertices");
    if (round == 0) first_round_vertices = vertices.size() - num_points;
    const std::size_t repair_vertices = vertices.size() - num_points - first_round_vertices;
    if (repair_vertices > kRepairVerticesPerFirstVertex * first_round_vertices + kRepairVerticesSlack ||
        round + 1 == kMaxRounds) {
      std::string where;
      if (!crossings.empty()) {
        where.append(" (segments ").append(std::to_string(segs[crossings.front().first].label));
        where.append(" and ").append(std::to_string(segs[crossings.front().second].label));
        where.append(" near ").append(format_point(vertices[cuts.front().second])).append(")");
      }
      throw_not_converging(where, round + 1);
    }
    // Without crossings this only turns this round's snapped pieces from "snapped" into "dirty".
    std::vector<std::uint8_t> bent(segs.size(), 0);
    for (const auto& [i, j] : crossings) bent[i] = bent[j] = 1;
    const SplitLists crossing_cuts = group_splits(cuts, segs, vertices, executor);
    // Crossings are rare in most inputs: when few segments are cut, their pieces are put in their
    // places apart, and the rest keep their order (so the next round need not order them again).
    spatial_order = 8 * cuts.size() < segs.size();
    segs = spatial_order ? cut_few_segments(segs, crossing_cuts, bent, grid, vertices, executor)
                         : cut_segments(segs, crossing_cuts, bent, CutAt::crossings, executor);
    trace.mark("pieces cut");
  }
  throw Error("crossing segments: resolution did not converge"); // not reached: the loop throws first
}

/// Rounding a crossing point moves it by an ulp or two of the largest coordinate; snapping works at a
/// few times that.
double snap_tolerance_of(double magnitude) { return 16.0 * kEpsilon * magnitude; }
double snap_tolerance_of(const Box& box) { return snap_tolerance_of(magnitude(box)); }

} // namespace

PreparedPslg prepare_pslg(std::span<const Point> points, std::span<const Segment> segments,
                          CrossingSegments policy) {
  CpuExecutor serial(1);
  return prepare_pslg(points, segments, policy, serial);
}

PreparedPslg prepare_pslg(std::span<const Point> points, std::span<const Segment> segments,
                          CrossingSegments policy, CpuExecutor& executor) {
  PreparedPslg out = merge_input(points, segments, policy, executor);
  split_pieces(out, policy, executor);
  return out;
}

PreparedPslg merge_input(std::span<const Point> points, std::span<const Segment> segments,
                         CrossingSegments policy, CpuExecutor& executor, const InputMerge& merge) {
  if (points.size() >= std::numeric_limits<std::uint32_t>::max() ||
      segments.size() >= std::numeric_limits<std::uint32_t>::max()) {
    throw Error("more than 2^32 - 2 points or segments");
  }
  StepTrace trace("prepare");
  PreparedPslg out;
  if (merge) {
    out.zero_length_segments = merge(out.duplicate_of, out.sites, out.pieces, out.identity_maps_unwritten);
    trace.mark("validated, duplicates, sites, pieces");
  } else {
    validate_points(points, executor);
    out.zero_length_segments = validate_segments(points, segments, policy, executor);
    trace.mark("validated");
    out.duplicate_of = merge_duplicates(points, executor);
    trace.mark("duplicates");
    // With room for the vertices the split adds: a full array would be copied for the first of them.
    out.sites = executor.compact<IndexArray>(
        points.size(), [&](std::size_t i) { return out.duplicate_of[i] == i; }, vertex_room(points.size()));
  }
  if (merge) {
    // The merge may still be filling the maps: the points themselves are looked at.
    check_dimension_of_points(points, out.sites.size());
  } else {
    check_dimension(points, out.sites.size(), [&](std::size_t k) { return out.sites[k]; });
  }
  // Room for the vertices that crossings may add: growing the array would copy every point (30 MB for
  // the coastlines) for the first of them. The elements are left unwritten by resize; the copy is made
  // in parallel here, or by the caller when the merge was done elsewhere.
  out.vertices.reserve(vertex_room(points.size()));
  out.vertices.resize(points.size());
  if (!merge) {
    executor.for_each(points.size(), [&](std::size_t k) { out.vertices[k] = points[k]; });
    trace.mark("sites");
    const std::vector<WorkSegment> segs = initial_segments(segments, out.duplicate_of, executor);
    out.pieces.reserve(piece_room(segs.size()));
    out.pieces.resize(segs.size());
    executor.for_each(segs.size(), [&](std::size_t k) {
      out.pieces[k] = {segs[k].a, segs[k].b, segs[k].label};
    });
    trace.mark("initial segments");
  }
  return out;
}

void copy_points(std::span<const Point> points, PointArray& vertices) {
  std::copy(points.begin(), points.end(), vertices.begin());
}

void write_identity_maps(PreparedPslg& pslg) {
  std::iota(pslg.duplicate_of.begin(), pslg.duplicate_of.end(), std::uint32_t{0});
  std::iota(pslg.sites.begin(), pslg.sites.end(), std::uint32_t{0});
}

void split_pieces(PreparedPslg& pslg, CrossingSegments policy, CpuExecutor& executor) {
  if (pslg.pieces.empty()) return;
  std::vector<WorkSegment> segs(pslg.pieces.size());
  executor.for_each(segs.size(), [&](std::size_t k) {
    segs[k] = {pslg.pieces[k].a, pslg.pieces[k].b, pslg.pieces[k].segment, true, false};
  });
  // Crossing points are clamped into their segments' boxes, so this box holds every vertex to come.
  const Box box = bounding_box(pslg.vertices, pslg.sites, executor);
  pslg.pieces = resolve(std::move(segs), pslg.vertices, pslg.sites, pslg.duplicate_of.size(), box,
                        snap_tolerance_of(box), policy, executor);
}

namespace {

/// Pieces [from, from + count) of an array going to [to, to + count).
struct Run {
  std::size_t from, to, count;
};

/// Moves the chunks of `pieces` (runs whose sources are disjoint, as are their destinations, none
/// moving farther than `reach`) within the array, the chunks spread over for_parts(n, f) (f(k) for every
/// k in [0, n), in parallel), and leaves it with `size` pieces (at most its capacity). A chunk's
/// destination can overlap another chunk's source only within `reach` of that source's ends (it lies
/// within reach of its own source, which is disjoint from the other), so each chunk first sets aside
/// its first and last `reach` pieces, and after a barrier moves the rest itself (memmove order:
/// nothing else writes there) and writes the set-aside ones. (A new array instead: 21 MB of fresh
/// pages for the coastlines' pieces, or memory touched beforehand.)
template <class ForParts>
void move_in_place(PieceArray& pieces, const std::vector<PieceRun>& chunks, std::size_t reach,
                   std::size_t size, ForParts&& for_parts) {
  std::vector<std::size_t> aside_at(chunks.size() + 1, 0);
  for (std::size_t k = 0; k < chunks.size(); ++k)
    aside_at[k + 1] = aside_at[k] + std::min<std::size_t>(chunks[k].count, 2 * reach);
  std::vector<ConstraintPiece> aside(aside_at.back());
  // The ends of each chunk: its first `head` pieces and its last `tail`, all of it when short.
  const auto ends = [&](const PieceRun& c) {
    const std::size_t head = std::min<std::size_t>(c.count, reach);
    return std::pair{head, std::min(c.count - head, reach)};
  };
  for_parts(chunks.size(), [&](std::size_t k) {
    const PieceRun& c = chunks[k];
    const auto [head, tail] = ends(c);
    const ConstraintPiece* from = pieces.data() + c.from;
    std::copy_n(from, head, aside.begin() + static_cast<std::ptrdiff_t>(aside_at[k]));
    std::copy_n(from + c.count - tail, tail, aside.begin() + static_cast<std::ptrdiff_t>(aside_at[k] + head));
  });
  if (size > pieces.size()) pieces.resize(size); // within the capacity: nothing moves, nothing is written
  for_parts(chunks.size(), [&](std::size_t k) {
    const PieceRun& c = chunks[k];
    const auto [head, tail] = ends(c);
    ConstraintPiece* data = pieces.data();
    const std::size_t middle = c.count - head - tail;
    if (middle > 0) std::memmove(data + c.to + head, data + c.from + head, middle * sizeof(ConstraintPiece));
    std::copy_n(aside.begin() + static_cast<std::ptrdiff_t>(aside_at[k]), head, data + c.to);
    std::copy_n(aside.begin() + static_cast<std::ptrdiff_t>(aside_at[k] + head), tail,
                data + c.to + c.count - tail);
  });
  pieces.resize(size);
}

/// PieceMove's work, its chunks spread over for_parts as in move_in_place.
template <class ForParts>
void move_pieces(PieceArray& pieces, const PieceMove& move, ForParts&& for_parts) {
  if (move.in_place) {
    move_in_place(pieces, move.chunks, move.reach, move.size, for_parts);
  } else {
    PieceArray merged;
    merged.reserve(std::max(pieces.capacity(), piece_room(move.size)));
    merged.resize(move.size);
    for_parts(move.chunks.size(), [&](std::size_t k) {
      const PieceRun& c = move.chunks[k];
      std::copy_n(pieces.begin() + static_cast<std::ptrdiff_t>(c.from), c.count,
                  merged.begin() + static_cast<std::ptrdiff_t>(c.to));
    });
    pieces = std::move(merged);
  }
  for (std::size_t k = 0; k < move.inserted.size(); ++k) pieces[move.inserted_at[k]] = move.inserted[k];
}

} // namespace

bool split_pieces(PreparedPslg& pslg, std::span<const std::uint32_t> suspect_pieces,
                  std::span<const std::uint32_t> suspect_sites, CrossingSegments policy,
                  CpuExecutor& executor, double sites_magnitude, std::vector<std::uint32_t>* new_pieces,
                  PieceMoves* moves, PieceMove* later) {
  if (new_pieces != nullptr) new_pieces->clear();
  if (moves != nullptr) *moves = {};
  if (later != nullptr) *later = {};
  if (suspect_pieces.empty()) return false;
  StepTrace trace("split");
  trace.count("suspect pieces", suspect_pieces.size());
  trace.count("suspect sites", suspect_sites.size());
  // The tolerance of the whole input, so that the suspects are treated as they would be with it.
  const double tolerance = sites_magnitude >= 0.0
                               ? snap_tolerance_of(sites_magnitude)
                               : snap_tolerance_of(bounding_box(pslg.vertices, pslg.sites, executor));
  trace.mark("tolerance");
  std::vector<WorkSegment> segs(suspect_pieces.size());
  executor.for_each(segs.size(), [&](std::size_t k) {
    const ConstraintPiece& p = pslg.pieces[suspect_pieces[k]];
    segs[k] = {p.a, p.b, p.segment, true, false};
  });
  IndexArray sites(suspect_sites.begin(), suspect_sites.end());
  trace.mark("suspects listed");
  const std::size_t first_added = pslg.vertices.size();
  const PieceArray resolved =
      resolve(std::move(segs), pslg.vertices, sites, pslg.duplicate_of.size(),
              bounding_box(pslg.vertices, sites, executor), tolerance, policy, executor);
  for (std::size_t v = first_added; v < pslg.vertices.size(); ++v)
    pslg.sites.push_back(static_cast<std::uint32_t>(v));
  trace.mark("suspects resolved");
  // The others are unchanged; both lists are sorted by (a, b). A resolved piece identical to a piece
  // of the list merges into it (the lowest segment id), a suspect included: most suspects come back
  // as they were, and keep their places. The new pieces (few) find their places by binary search,
  // the suspects that did not come back leave, and the array is changed in place: the runs of kept
  // pieces between those places move by how many pieces came and went before them, most of them not
  // at all. (A merge into a fresh array wrote every piece, 21 MB for the coastlines, into fresh pages.)
  const auto before = [](const ConstraintPiece& p, const ConstraintPiece& q) {
    return p.a != q.a ? p.a < q.a : p.b < q.b;
  };
  const auto same = [](const ConstraintPiece& p, const ConstraintPiece& q) {
    return p.a == q.a && p.b == q.b;
  };
  std::vector<std::uint32_t> suspects(suspect_pieces.begin(), suspect_pieces.end());
  if (!std::is_sorted(suspects.begin(), suspects.end())) executor.sort(suspects, std::less<>());
  // Each resolved piece's place among all, and whether the piece there is identical (searched in
  // parallel: on a lattice with random segments most pieces are suspects). The suspects' own pieces are
  // in order too and bound each search: a piece that came back as it was is found among them alone, a
  // new one between the two suspects around it (a search over all pieces missed the cache at nearly
  // every step).
  std::vector<ConstraintPiece> suspect_piece(suspects.size());
  executor.for_each(suspects.size(), [&](std::size_t i) { suspect_piece[i] = pslg.pieces[suspects[i]]; });
  std::vector<std::size_t> at_of(resolved.size());
  std::vector<std::uint8_t> hit(resolved.size());
  executor.for_each_costly(resolved.size(), [&](std::size_t k) {
    const ConstraintPiece& q = resolved[k];
    const auto i = static_cast<std::size_t>(
        std::lower_bound(suspect_piece.begin(), suspect_piece.end(), q, before) - suspect_piece.begin());
    if (i < suspects.size() && same(suspect_piece[i], q)) {
      at_of[k] = suspects[i];
      hit[k] = 1;
      return;
    }
    const std::size_t lo = i == 0 ? 0 : std::size_t{suspects[i - 1]} + 1;
    const std::size_t hi = i == suspects.size() ? pslg.pieces.size() : std::size_t{suspects[i]};
    const auto at = static_cast<std::size_t>(
        std::lower_bound(pslg.pieces.begin() + static_cast<std::ptrdiff_t>(lo),
                         pslg.pieces.begin() + static_cast<std::ptrdiff_t>(hi), q, before) -
        pslg.pieces.begin());
    at_of[k] = at;
    hit[k] = at < pslg.pieces.size() && same(pslg.pieces[at], q);
  });
  std::vector<std::uint8_t> stays(suspects.size(), 0); // a suspect that came back
  PieceArray inserted;                                 // resolved pieces that are new, with their places:
  std::vector<std::size_t> place;                      // the index in pslg.pieces each goes before
  for (std::size_t k = 0; k < resolved.size(); ++k) {
    const ConstraintPiece& q = resolved[k];
    if (!inserted.empty() && same(inserted.back(), q)) {
      inserted.back().segment = std::min(inserted.back().segment, q.segment);
    } else if (hit[k] != 0) {
      ConstraintPiece& there = pslg.pieces[at_of[k]];
      const auto it = std::lower_bound(suspects.begin(), suspects.end(), at_of[k]);
      if (it != suspects.end() && *it == at_of[k] && stays[it - suspects.begin()] == 0) {
        stays[it - suspects.begin()] = 1; // a suspect's own id is not kept unless it came back
        there.segment = q.segment;
      } else {
        there.segment = std::min(there.segment, q.segment);
      }
    } else {
      inserted.push_back(q);
      place.push_back(at_of[k]);
    }
  }
  // Every suspect came back as it was (no crossing, no site on it: the common case): the array stays.
  if (inserted.empty() && std::all_of(stays.begin(), stays.end(), [](std::uint8_t k) { return k != 0; })) {
    trace.mark("pieces kept");
    return false;
  }
  // Walking the leaving suspects and the places in order: runs of kept pieces (source, destination,
  // length) and the inserted pieces' destinations.
  std::vector<Run> runs;
  std::vector<std::size_t> inserted_at(inserted.size());
  std::size_t from = 0, to = 0, s = 0, j = 0;
  const auto copy_until = [&](std::size_t stop) {
    if (from < stop) runs.push_back({from, to, stop - from});
    to += stop - from;
    from = stop;
  };
  while (s < suspects.size() || j < inserted.size()) {
    if (s < suspects.size() && stays[s] != 0) {
      ++s;
    } else if (j < inserted.size() && (s == suspects.size() || place[j] <= suspects[s])) {
      copy_until(place[j]);
      inserted_at[j++] = to++;
    } else {
      copy_until(suspects[s]);
      from = suspects[s++] + 1;
    }
  }
  copy_until(pslg.pieces.size());
  // The runs move in place, cut into chunks moved in parallel, when the array's room holds the new
  // count and the runs move by little against a chunk (the coastlines' split: 1.8 million pieces, the
  // farthest run 96 places); else they are copied into a new array, which keeps the old one's room.
  PieceMove move;
  for (const Run& r : runs) move.reach = std::max(move.reach, r.to > r.from ? r.to - r.from : r.from - r.to);
  constexpr std::size_t kChunk = std::size_t{1} << 14;
  move.size = to;
  move.in_place = to <= pslg.pieces.capacity() && move.reach * 8 <= kChunk;
  for (const Run& r : runs) {
    if (move.in_place && r.from == r.to) continue; // there already, and nothing else is written there
    for (std::size_t done = 0; done < r.count; done += kChunk)
      move.chunks.push_back({static_cast<std::uint32_t>(r.from + done),
                             static_cast<std::uint32_t>(r.to + done),
                             static_cast<std::uint32_t>(std::min(kChunk, r.count - done))});
  }
  move.inserted.assign(inserted.begin(), inserted.end());
  move.inserted_at.reserve(inserted_at.size());
  for (const std::size_t at : inserted_at) move.inserted_at.push_back(static_cast<std::uint32_t>(at));
  if (new_pieces != nullptr)
    new_pieces->insert(new_pieces->end(), move.inserted_at.begin(), move.inserted_at.end());
  if (moves != nullptr) {
    for (const Run& r : runs)
      moves->runs.push_back({static_cast<std::uint32_t>(r.from), static_cast<std::uint32_t>(r.to),
                             static_cast<std::uint32_t>(r.count)});
    // The pieces from the suspects with their new places, read before anything moves.
    std::vector<std::pair<std::uint32_t, ConstraintPiece>> from_suspects;
    for (std::size_t k = 0; k < inserted.size(); ++k)
      from_suspects.push_back({move.inserted_at[k], inserted[k]});
    for (std::size_t i = 0; i < suspects.size(); ++i)
      if (stays[i] != 0)
        from_suspects.push_back({moved_piece(moves->runs, suspects[i]), pslg.pieces[suspects[i]]});
    std::sort(from_suspects.begin(), from_suspects.end(),
              [](const auto& p, const auto& q) { return p.first < q.first; });
    for (const auto& [at, piece] : from_suspects) {
      moves->from_suspects.push_back(at);
      moves->suspect_pieces.push_back(piece);
    }
    moves->came = move.inserted;
  }
  if (later != nullptr) {
    *later = std::move(move);
    later->pending = true;
    trace.mark("pieces' move planned");
    return true;
  }
  move_pieces(pslg.pieces, move, [&](std::size_t n, auto&& f) { executor.for_each_part(n, f); });
  trace.mark("pieces merged");
  return true;
}

void apply_piece_move(PieceArray& pieces, PieceMove& move, unsigned threads) {
  if (!move.pending) return;
  // f(k) for k in [0, n), handed out one at a time to this thread and up to threads - 1 helpers.
  const auto for_parts = [threads](std::size_t n, auto&& f) {
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
      for (std::size_t k = next.fetch_add(1); k < n; k = next.fetch_add(1)) f(k);
    };
    std::vector<std::thread> helpers;
    for (unsigned t = 1; t < threads && t < n; ++t) {
      try {
        helpers.emplace_back(work);
      } catch (const std::system_error&) {
        break; // no thread to be had: the others do its share
      }
    }
    work();
    for (std::thread& helper : helpers) helper.join();
  };
  move_pieces(pieces, move, for_parts);
  move.pending = false;
}

} // namespace cdt::detail
