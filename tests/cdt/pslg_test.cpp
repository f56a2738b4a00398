// Tests of prepare_pslg(): input errors with their ids, duplicate merging, splitting at points on
// segments, overlap merging, crossing resolution and rejection. Results are checked for the property
// the triangulator relies on, exactly: no two pieces cross or overlap and no site lies inside a piece.
#include "pslg.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <tuple>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/io.hpp"
#include "executor/cpu_executor.hpp"
#include "pslg_generators.hpp"

#ifndef TRIXEL_TEST_DATA_DIR
#error "TRIXEL_TEST_DATA_DIR must name the tests/data folder"
#endif

namespace {

using cdt::CrossingSegments;
using cdt::Point;
using cdt::Segment;
using cdt::detail::ConstraintPiece;
using cdt::detail::CpuExecutor;
using cdt::detail::prepare_pslg;
using cdt::detail::PreparedPslg;
using Kind = cdt::InvalidInputError::Kind;

int orient(const Point& a, const Point& b, const Point& c) {
  return cdt::detail::orient2d(a.x, a.y, b.x, b.y, c.x, c.y);
}

bool strictly_inside(const Point& a, const Point& b, const Point& p) {
  if (orient(a, b, p) != 0) return false;
  if (a.x != b.x) return std::min(a.x, b.x) < p.x && p.x < std::max(a.x, b.x);
  return std::min(a.y, b.y) < p.y && p.y < std::max(a.y, b.y);
}

/// Exact check of the output contract; returns the first problem or "" when there is none. Candidate
/// pairs come from a uniform grid over bounding boxes (each pair tested in one cell only: the one
/// holding the lower-left corner of the boxes' intersection), so it also runs on large outputs.
std::string contract_violation(const PreparedPslg& out) {
  const auto& v = out.vertices;
  for (std::size_t k = 1; k < out.sites.size(); ++k) {
    if (out.sites[k - 1] >= out.sites[k]) return "sites not increasing";
  }
  std::vector<std::uint8_t> is_site(v.size(), 0);
  for (std::uint32_t s : out.sites) is_site[s] = 1;
  for (std::size_t k = 0; k < out.pieces.size(); ++k) {
    const ConstraintPiece& p = out.pieces[k];
    if (p.a >= p.b || p.b >= v.size()) return "piece " + std::to_string(k) + " has bad indices";
    if (is_site[p.a] == 0 || is_site[p.b] == 0) return "piece " + std::to_string(k) + " ends at a non-site";
    if (k > 0 && (out.pieces[k - 1].a > p.a || (out.pieces[k - 1].a == p.a && out.pieces[k - 1].b >= p.b))) {
      return "pieces not sorted and unique at " + std::to_string(k);
    }
  }
  struct Box {
    double x0, y0, x1, y1;
  };
  std::vector<Box> boxes;
  for (const ConstraintPiece& p : out.pieces) {
    boxes.push_back({std::min(v[p.a].x, v[p.b].x), std::min(v[p.a].y, v[p.b].y), std::max(v[p.a].x, v[p.b].x),
                     std::max(v[p.a].y, v[p.b].y)});
  }
  double x0 = v[out.sites[0]].x, y0 = v[out.sites[0]].y, x1 = x0, y1 = y0;
  for (std::uint32_t s : out.sites) {
    x0 = std::min(x0, v[s].x), y0 = std::min(y0, v[s].y), x1 = std::max(x1, v[s].x),
    y1 = std::max(y1, v[s].y);
  }
  const int side =
      static_cast<int>(std::clamp(std::sqrt(static_cast<double>(out.pieces.size())), 1.0, 1024.0));
  // Cell indices are monotone in the coordinate, which is all the pair dedupe below needs.
  const auto cx = [&](double x) {
    return std::clamp(static_cast<int>((x - x0) / (x1 - x0) * side), 0, side - 1);
  };
  const auto cy = [&](double y) {
    return std::clamp(static_cast<int>((y - y0) / (y1 - y0) * side), 0, side - 1);
  };
  std::vector<std::vector<std::uint32_t>> cells(static_cast<std::size_t>(side) * side);
  for (std::uint32_t k = 0; k < boxes.size(); ++k) {
    for (int y = cy(boxes[k].y0); y <= cy(boxes[k].y1); ++y) {
      for (int x = cx(boxes[k].x0); x <= cx(boxes[k].x1); ++x) cells[y * side + x].push_back(k);
    }
  }
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const auto& list = cells[y * side + x];
      for (std::size_t i = 0; i < list.size(); ++i) {
        for (std::size_t j = i + 1; j < list.size(); ++j) {
          const Box &bp = boxes[list[i]], &bq = boxes[list[j]];
          const double lx = std::max(bp.x0, bq.x0), ly = std::max(bp.y0, bq.y0);
          if (lx > std::min(bp.x1, bq.x1) || ly > std::min(bp.y1, bq.y1)) continue;
          if (cx(lx) != x || cy(ly) != y) continue; // tested in another cell
          const ConstraintPiece &p = out.pieces[list[i]], &q = out.pieces[list[j]];
          const Point &a = v[p.a], &b = v[p.b], &c = v[q.a], &d = v[q.b];
          const int oc = orient(a, b, c), od = orient(a, b, d), oa = orient(c, d, a), ob = orient(c, d, b);
          const std::string pair = std::to_string(list[i]) + " and " + std::to_string(list[j]);
          if (oc * od < 0 && oa * ob < 0) return "pieces " + pair + " cross";
          if (oc == 0 && od == 0 &&
              (strictly_inside(a, b, c) || strictly_inside(a, b, d) || strictly_inside(c, d, a) ||
               strictly_inside(c, d, b) || (p.a == q.a && p.b == q.b))) {
            return "pieces " + pair + " overlap";
          }
        }
      }
    }
  }
  for (std::uint32_t s : out.sites) {
    for (std::uint32_t k : cells[cy(v[s].y) * side + cx(v[s].x)]) {
      const ConstraintPiece& p = out.pieces[k];
      if (strictly_inside(v[p.a], v[p.b], v[s])) {
        return "site " + std::to_string(s) + " lies inside piece " + std::to_string(k);
      }
    }
  }
  return "";
}

/// Whether every input segment's representatives are joined by a path of pieces (bent pieces included).
bool segments_connected(const PreparedPslg& out, const std::vector<Segment>& segments) {
  std::vector<std::uint32_t> parent(out.vertices.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const std::function<std::uint32_t(std::uint32_t)> find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const ConstraintPiece& p : out.pieces) parent[find(p.a)] = find(p.b);
  for (const Segment& s : segments) {
    if (find(out.duplicate_of[s.a]) != find(out.duplicate_of[s.b])) return false;
  }
  return true;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> piece_pairs_of(const cdt::detail::PieceArray& pieces) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (const ConstraintPiece& p : pieces) pairs.emplace_back(p.a, p.b);
  return pairs;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> piece_pairs(const PreparedPslg& out) {
  return piece_pairs_of(out.pieces);
}

std::vector<std::uint32_t> piece_labels(const PreparedPslg& out) {
  std::vector<std::uint32_t> labels;
  for (const ConstraintPiece& p : out.pieces) labels.push_back(p.segment);
  return labels;
}

/// Runs prepare_pslg expecting InvalidInputError; returns it for inspection.
cdt::InvalidInputError invalid_input(const std::vector<Point>& points, const std::vector<Segment>& segments,
                                     CrossingSegments policy = CrossingSegments::resolve) {
  try {
    prepare_pslg(points, segments, policy);
  } catch (const cdt::InvalidInputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InvalidInputError";
  return cdt::InvalidInputError(Kind::too_few_points, 0, "");
}

const std::vector<Point> kTriangle{{0, 0}, {1, 0}, {0, 1}};

/// What expect_suspects_split_as_all saw.
struct SuspectSplit {
  std::size_t cut = 0;               ///< pieces the whole split cuts
  std::size_t longest_whole_run = 0; ///< the longest run of pieces it keeps, between cut ones
  bool in_place = false;             ///< the split with room moved the pieces within their array
};

/// Splits every piece of the PSLG, and separately only the suspects (each piece the whole split cuts,
/// and about one in `share` of the others, drawn by rng), and expects the same pieces: compared by
/// coordinates, because crossing vertices are numbered in the order each split meets them; the list
/// sorted by (a, b) and without repeats, as the triangulation expects.
SuspectSplit expect_suspects_split_as_all(const std::vector<Point>& points,
                                          const std::vector<Segment>& segments, trixel_gen::Random& rng,
                                          int share) {
  CpuExecutor executor(2);
  PreparedPslg all = cdt::detail::merge_input(points, segments, CrossingSegments::resolve, executor);
  PreparedPslg some = all;
  cdt::detail::split_pieces(all, CrossingSegments::resolve, executor);
  const auto kept = piece_pairs(all);
  SuspectSplit seen;
  std::vector<std::uint32_t> suspects;
  std::size_t run = 0;
  for (std::uint32_t k = 0; k < some.pieces.size(); ++k) {
    const std::pair<std::uint32_t, std::uint32_t> ab{some.pieces[k].a, some.pieces[k].b};
    const bool whole = std::binary_search(kept.begin(), kept.end(), ab);
    seen.cut += whole ? 0 : 1;
    run = whole ? run + 1 : 0;
    seen.longest_whole_run = std::max(seen.longest_whole_run, run);
    if (!whole || rng.range(0, share - 1) == 0) suspects.push_back(k);
  }
  EXPECT_LT(suspects.size(), some.pieces.size());
  const std::vector<std::uint32_t> sites(some.sites.begin(), some.sites.end());
  const auto before = piece_pairs(some);
  // The same split with room in the array (as the preparation leaves it): the pieces move within it
  // when few came or went, else into a new array; the same pieces and labels either way. Without room
  // (a copy's capacity is its size, unless more went than came) they go into a new array.
  PreparedPslg roomy = some;
  roomy.pieces.reserve(cdt::detail::piece_room(roomy.pieces.size()));
  // The same split with the move left for later, then done on three threads of its own.
  PreparedPslg later = roomy;
  const cdt::detail::ConstraintPiece* roomy_memory = roomy.pieces.data();
  EXPECT_TRUE(cdt::detail::split_pieces(roomy, suspects, sites, CrossingSegments::resolve, executor));
  seen.in_place = roomy.pieces.data() == roomy_memory;
  std::vector<std::uint32_t> new_pieces{7}; // replaced
  cdt::detail::PieceMoves moves;
  moves.from_suspects = {3}; // replaced
  EXPECT_TRUE(cdt::detail::split_pieces(some, suspects, sites, CrossingSegments::resolve, executor, -1.0,
                                        &new_pieces, &moves));
  EXPECT_EQ(piece_pairs(roomy), piece_pairs(some));
  EXPECT_EQ(piece_labels(roomy), piece_labels(some));
  {
    const auto later_before = piece_pairs(later);
    std::vector<std::uint32_t> later_new;
    cdt::detail::PieceMoves later_moves;
    cdt::detail::PieceMove move;
    EXPECT_TRUE(cdt::detail::split_pieces(later, suspects, sites, CrossingSegments::resolve, executor, -1.0,
                                          &later_new, &later_moves, &move));
    EXPECT_TRUE(move.pending);
    EXPECT_EQ(piece_pairs(later), later_before) << "the pieces moved before apply_piece_move";
    EXPECT_EQ(later_new, new_pieces);
    EXPECT_EQ(later_moves.from_suspects, moves.from_suspects);
    // What the moved array will hold at those places, known before the move.
    const auto same_piece = [](const cdt::detail::ConstraintPiece& p, const cdt::detail::ConstraintPiece& q) {
      return p.a == q.a && p.b == q.b && p.segment == q.segment;
    };
    EXPECT_EQ(later_moves.suspect_pieces.size(), moves.from_suspects.size());
    for (std::size_t k = 0; k < later_moves.suspect_pieces.size() && k < moves.from_suspects.size(); ++k)
      EXPECT_TRUE(same_piece(later_moves.suspect_pieces[k], some.pieces[moves.from_suspects[k]])) << k;
    EXPECT_EQ(later_moves.came.size(), new_pieces.size());
    for (std::size_t k = 0; k < later_moves.came.size() && k < new_pieces.size(); ++k)
      EXPECT_TRUE(same_piece(later_moves.came[k], some.pieces[new_pieces[k]])) << k;
    cdt::detail::apply_piece_move(later.pieces, move, 3);
    EXPECT_FALSE(move.pending);
    EXPECT_EQ(piece_pairs(later), piece_pairs(roomy));
    EXPECT_EQ(piece_labels(later), piece_labels(roomy));
    EXPECT_EQ(later.vertices.size(), roomy.vertices.size());
  }
  EXPECT_EQ(some.vertices.size(), all.vertices.size());
  // The moves: every piece that was no suspect went to a place of its own holding the same piece, and
  // the pieces made from the suspects fill exactly the other places.
  std::vector<int> filled(some.pieces.size(), 0);
  for (std::uint32_t k = 0, s = 0; k < before.size(); ++k) {
    const bool suspect = s < suspects.size() && suspects[s] == k;
    s += suspect ? 1 : 0;
    const std::uint32_t to = cdt::detail::moved_piece(moves.runs, k);
    if (suspect) continue;
    EXPECT_LT(to, some.pieces.size()) << "piece " << k;
    if (to >= some.pieces.size()) continue;
    EXPECT_EQ((std::pair{some.pieces[to].a, some.pieces[to].b}), before[k]) << "piece " << k;
    ++filled[to];
  }
  EXPECT_TRUE(std::is_sorted(moves.from_suspects.begin(), moves.from_suspects.end()));
  for (const std::uint32_t k : moves.from_suspects) {
    EXPECT_LT(k, some.pieces.size());
    if (k < some.pieces.size()) ++filled[k];
  }
  EXPECT_EQ(std::count(filled.begin(), filled.end(), 1), static_cast<std::ptrdiff_t>(filled.size()));
  // The pieces that came: the ones not in the list before, in increasing order.
  std::vector<std::uint32_t> came;
  for (std::uint32_t k = 0; k < some.pieces.size(); ++k)
    if (!std::binary_search(before.begin(), before.end(), std::pair{some.pieces[k].a, some.pieces[k].b}))
      came.push_back(k);
  EXPECT_FALSE(came.empty());
  EXPECT_EQ(new_pieces, came);
  const auto by_coordinates = [](const PreparedPslg& out) {
    std::vector<std::tuple<double, double, double, double, std::uint32_t>> list;
    for (const auto& piece : out.pieces) {
      Point a = out.vertices[piece.a], b = out.vertices[piece.b];
      if (std::tie(b.x, b.y) < std::tie(a.x, a.y)) std::swap(a, b);
      list.emplace_back(a.x, a.y, b.x, b.y, piece.segment);
    }
    std::sort(list.begin(), list.end());
    return list;
  };
  EXPECT_EQ(by_coordinates(some), by_coordinates(all));
  const auto pairs = piece_pairs(some);
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));
  EXPECT_EQ(std::adjacent_find(pairs.begin(), pairs.end()), pairs.end());
  return seen;
}

// The property tests below are only as good as this checker: it must see each kind of violation.
TEST(PslgChecker, SeesCrossingsOverlapsAndSitesInsidePieces) {
  PreparedPslg out;
  out.vertices = {{0, 0}, {2, 2}, {0, 2}, {2, 0}, {1, 1}, {3, 3}};
  out.sites = {0, 1, 2, 3, 5};
  out.pieces = {{0, 1, 0}, {2, 3, 1}};
  EXPECT_NE(contract_violation(out).find("cross"), std::string::npos);
  out.pieces = {{0, 1, 0}, {0, 5, 1}};
  EXPECT_NE(contract_violation(out).find("overlap"), std::string::npos);
  out.pieces = {{0, 5, 0}};
  out.sites = {0, 1, 5};
  EXPECT_NE(contract_violation(out).find("site 1 lies inside piece 0"), std::string::npos);
  out.pieces = {{0, 1, 0}, {1, 5, 0}};
  EXPECT_EQ(contract_violation(out), "");
}

// --- errors ------------------------------------------------------------------------------------------

TEST(PslgErrors, NonFiniteCoordinateNamesThePoint) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto e = invalid_input({{0, 0}, {1, 0}, {nan, 2}}, {});
  EXPECT_EQ(e.kind(), Kind::non_finite_coordinate);
  EXPECT_EQ(e.item(), 2u);
  EXPECT_NE(std::string(e.what()).find("point 2 has a non-finite coordinate (nan, 2)"), std::string::npos)
      << e.what();
  const auto f = invalid_input({{0, 0}, {0, -inf}, {1, 2}}, {});
  EXPECT_EQ(f.kind(), Kind::non_finite_coordinate);
  EXPECT_EQ(f.item(), 1u);
}

// Beyond the limit the fourth powers in incircle would overflow and the exact predicates lie.
TEST(PslgErrors, HugeCoordinateIsOutOfRange) {
  const auto e = invalid_input({{0, 0}, {1, 0}, {0, 1}, {-2e60, 5}}, {});
  EXPECT_EQ(e.kind(), Kind::coordinate_out_of_range);
  EXPECT_EQ(e.item(), 3u);
  EXPECT_NE(std::string(e.what()).find("overflow"), std::string::npos) << e.what();
  EXPECT_NO_THROW(
      prepare_pslg(std::vector<Point>{{0, 0}, {1e60, 0}, {0, -1e60}}, {}, CrossingSegments::resolve));
}

// Below the limit (other than 0) the predicates' products underflow: three points at 0 and 1e-300 were
// found collinear, subnormal coordinates beside ordinary ones broke the mesh.
TEST(PslgErrors, TinyNonzeroCoordinateIsOutOfRange) {
  const auto e = invalid_input({{0, 0}, {1e-300, 0}, {0, 1e-300}}, {});
  EXPECT_EQ(e.kind(), Kind::coordinate_out_of_range);
  EXPECT_EQ(e.item(), 1u);
  EXPECT_NE(std::string(e.what()).find("underflow"), std::string::npos) << e.what();
  const auto f =
      invalid_input({{0, 0}, {1, 0}, {0, 1}, {0.5, -std::numeric_limits<double>::denorm_min()}}, {});
  EXPECT_EQ(f.kind(), Kind::coordinate_out_of_range);
  EXPECT_EQ(f.item(), 3u);
  EXPECT_NO_THROW(
      prepare_pslg(std::vector<Point>{{0, -0.0}, {1e-60, 0}, {0, -1e-60}}, {}, CrossingSegments::resolve));
}

TEST(PslgErrors, SegmentIndexOutOfRangeNamesTheSegment) {
  const auto e = invalid_input(kTriangle, {{0, 1}, {1, 2}, {2, 3}});
  EXPECT_EQ(e.kind(), Kind::index_out_of_range);
  EXPECT_EQ(e.item(), 2u);
  EXPECT_NE(std::string(e.what()).find("segment 2"), std::string::npos) << e.what();
}

TEST(PslgErrors, ZeroLengthSegmentsAreRejectedUnderRejectAndNamed) {
  const auto same_index = invalid_input(kTriangle, {{0, 1}, {2, 2}}, CrossingSegments::reject);
  EXPECT_EQ(same_index.kind(), Kind::degenerate_segment);
  EXPECT_EQ(same_index.item(), 1u);
  // Different indices, identical coordinates: zero length all the same.
  const auto same_place =
      invalid_input({{0, 0}, {1, 0}, {0, 1}, {1, 0}}, {{0, 2}, {1, 2}, {3, 1}}, CrossingSegments::reject);
  EXPECT_EQ(same_place.kind(), Kind::degenerate_segment);
  EXPECT_EQ(same_place.item(), 2u);
}

TEST(PslgErrors, TheLowestNumberedBadSegmentIsNamedWhateverTheThreads) {
  // Segments are checked in parts on several threads; the error must still be the first in order.
  std::vector<Point> points;
  std::vector<Segment> segments;
  for (std::uint32_t k = 0; k < 600; ++k)
    points.push_back({static_cast<double>(k), static_cast<double>(k * k % 7)});
  for (std::uint32_t k = 0; k + 1 < 600; ++k) segments.push_back({k, k + 1});
  segments[100] = {5, 5};    // zero length: an error only under reject
  segments[300] = {7, 9000}; // out of range
  segments[450] = {8, 8};    // zero length
  segments[580] = {9000, 3}; // out of range
  for (const unsigned threads : {1u, 3u}) {
    CpuExecutor executor(threads);
    for (const CrossingSegments policy : {CrossingSegments::resolve, CrossingSegments::reject}) {
      try {
        prepare_pslg(points, segments, policy, executor);
        ADD_FAILURE() << "no error with " << threads << " threads";
      } catch (const cdt::InvalidInputError& e) {
        const bool reject = policy == CrossingSegments::reject;
        EXPECT_EQ(e.kind(), reject ? Kind::degenerate_segment : Kind::index_out_of_range) << threads;
        EXPECT_EQ(e.item(), reject ? 100u : 300u) << threads;
      }
    }
  }
}

TEST(Pslg, ZeroLengthSegmentsAreIgnoredAndCountedUnderResolve) {
  const std::vector<Point> points{{0, 0}, {1, 0}, {0, 1}, {1, 0}};
  const std::vector<Segment> segments{{0, 2}, {2, 2}, {3, 1}};
  const PreparedPslg out = prepare_pslg(points, segments, CrossingSegments::resolve);
  EXPECT_EQ(out.zero_length_segments, 2u);
  ASSERT_EQ(out.pieces.size(), 1u);
  EXPECT_EQ(out.pieces[0].a, 0u);
  EXPECT_EQ(out.pieces[0].b, 2u);
  EXPECT_EQ(out.pieces[0].segment, 0u);
}

TEST(PslgErrors, TooFewDistinctPoints) {
  EXPECT_EQ(invalid_input({}, {}).kind(), Kind::too_few_points);
  EXPECT_EQ(invalid_input({{0, 0}, {1, 1}}, {}).kind(), Kind::too_few_points);
  const auto e = invalid_input({{0, 0}, {1, 1}, {0, 0}, {1, 1}}, {{0, 1}});
  EXPECT_EQ(e.kind(), Kind::too_few_points);
  EXPECT_EQ(e.item(), 2u); // the number of distinct points
}

TEST(PslgErrors, AllCollinear) {
  const auto e = invalid_input({{0, 0}, {1, 1}, {2, 2}, {0, 0}, {-5, -5}}, {{0, 2}});
  EXPECT_EQ(e.kind(), Kind::all_collinear);
  EXPECT_EQ(e.item(), 4u); // the number of distinct points
}

// --- duplicates --------------------------------------------------------------------------------------

TEST(PslgDuplicates, MergedIntoTheLowestIndex) {
  const std::vector<Point> p{{1, 0}, {0, 0}, {0, 1}, {0, 0}, {1, 0}, {0, 0}, {-0.0, 1}};
  const PreparedPslg out = prepare_pslg(p, {}, CrossingSegments::resolve);
  EXPECT_EQ(out.duplicate_of, (cdt::IndexArray{0, 1, 2, 1, 0, 1, 2}));
  EXPECT_EQ(out.sites, (cdt::IndexArray{0, 1, 2}));
  ASSERT_EQ(out.vertices.size(), p.size());
  EXPECT_TRUE(std::equal(p.begin(), p.end(), out.vertices.begin()));
  EXPECT_TRUE(out.pieces.empty());
}

TEST(PslgDuplicates, SegmentsBetweenDuplicatesKeptOnceWithLowestId) {
  const std::vector<Point> p{{0, 0}, {1, 0}, {0, 1}, {0, 0}, {1, 0}};
  const std::vector<Segment> s{{2, 0}, {4, 3}, {1, 0}, {0, 1}, {3, 2}};
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 1}, {0, 2}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{1, 0}));
}

// --- points on segments and overlaps -----------------------------------------------------------------

TEST(PslgSplit, PointsOnASegmentSplitItInOrder) {
  const std::vector<Point> p{{0, 0}, {4, 2}, {3, 1.5}, {1, 0.5}, {2, 1}, {2, 0}, {0, 5}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{1, 0}}, CrossingSegments::resolve);
  EXPECT_EQ(piece_pairs(out),
            (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 3}, {1, 2}, {2, 4}, {3, 4}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{0, 0, 0, 0}));
  EXPECT_EQ(contract_violation(out), "");
}

// A point a hair off the segment must not split it: the decision is exact.
TEST(PslgSplit, PointJustOffTheSegmentDoesNotSplit) {
  const std::vector<Point> p{{0, 0}, {3, 3}, {1, std::nextafter(1.0, 2.0)}, {0, 3}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{0, 1}}, CrossingSegments::resolve);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 1}}));
}

TEST(PslgSplit, TJunctionSplitsTheCrossbarOnly) {
  const std::vector<Point> p{{0, 0}, {4, 0}, {2, 0}, {2, 3}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{0, 1}, {3, 2}}, CrossingSegments::reject);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 2}, {1, 2}, {2, 3}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{0, 0, 1}));
  EXPECT_EQ(out.vertices.size(), 4u);
}

// Splitting only the suspects (the pieces with a site inside them) gives what splitting all gives: the
// others kept, the suspects' parts placed among them, and a part identical to a kept piece merged into
// it with the lowest segment id. Segments along the rows of a lattice overlap and pass through points
// everywhere, but never cross.
TEST(PslgSplit, SuspectsAloneAsAll) {
  trixel_gen::Random rng(5);
  constexpr int kSide = 12;
  std::vector<Point> points;
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) points.push_back({double(x), double(y)});
  std::vector<Segment> segments;
  for (int k = 0; k < 300; ++k) {
    const auto y = static_cast<std::uint32_t>(rng.range(0, kSide - 1));
    const auto x0 = static_cast<std::uint32_t>(rng.range(0, kSide - 1));
    const auto x1 = static_cast<std::uint32_t>(rng.range(0, kSide - 1));
    if (x0 != x1) segments.push_back({y * kSide + x0, y * kSide + x1});
  }
  CpuExecutor executor(2);
  PreparedPslg all = cdt::detail::merge_input(points, segments, CrossingSegments::reject, executor);
  PreparedPslg some = all;
  std::vector<std::uint32_t> suspects;
  for (std::uint32_t k = 0; k < some.pieces.size(); ++k) {
    const Point& a = some.vertices[some.pieces[k].a];
    const Point& b = some.vertices[some.pieces[k].b];
    if (std::abs(a.x - b.x) > 1) suspects.push_back(k);
  }
  ASSERT_GT(suspects.size(), 10u);
  ASSERT_LT(suspects.size(), some.pieces.size());
  const std::vector<std::uint32_t> sites(some.sites.begin(), some.sites.end());
  cdt::detail::split_pieces(all, CrossingSegments::reject, executor);
  // The overlapping pieces are cut at the sites on them: the list changes.
  EXPECT_TRUE(cdt::detail::split_pieces(some, suspects, sites, CrossingSegments::reject, executor));
  EXPECT_EQ(piece_pairs(some), piece_pairs(all));
  EXPECT_EQ(piece_labels(some), piece_labels(all));
  EXPECT_EQ(some.vertices.size(), all.vertices.size());
}

// Suspects that come back as they were keep their places, the cut ones leave, and their parts are put
// among the rest in place (moved left where more left than came before them, right where more came):
// the same pieces as splitting all. Random segments, many crossing; the suspects are every cut piece
// and a share of the others.
TEST(PslgSplit, SuspectsThatComeBackKeepTheirPlaces) {
  for (const std::uint64_t seed : {11u, 12u, 13u}) {
    trixel_gen::Random rng(seed);
    std::vector<Point> points;
    for (int k = 0; k < 400; k += 2) { // short segments, most of them crossing nothing
      const Point p{rng.unit() * 100, rng.unit() * 100};
      points.push_back(p);
      points.push_back({p.x + rng.unit() * 3, p.y + rng.unit() * 3});
    }
    std::vector<Segment> segments;
    for (std::uint32_t k = 0; k + 1 < 400; k += 2) {
      const bool long_one = k % 40 == 0; // a few long segments cross many short ones
      const std::uint32_t b = long_one ? static_cast<std::uint32_t>(rng.range(0, 399)) : k + 1;
      if (b != k) segments.push_back({k, b});
    }
    SCOPED_TRACE("seed " + std::to_string(seed));
    const SuspectSplit seen = expect_suspects_split_as_all(points, segments, rng, 3);
    EXPECT_GT(seen.cut, 5u);
    EXPECT_TRUE(seen.in_place);
  }
}

// The pieces between the suspects move within the list in long runs (longer than the parallel moves'
// chunks) and both ways: a long segment at the start of the id range, over a chain of pieces that split
// it, leaves without a new piece (the run after it moves left), and crossings add pieces (the runs
// after them move right): across the last hundredth of the pieces, or across the first, so that the long
// run moves right. Points in x order, so that ids follow the places.
TEST(PslgSplit, SuspectsAmongLongRunsMoveBothWays) {
  for (const double crossed_from : {990.0, 0.0}) {
    SCOPED_TRACE("crossings from x = " + std::to_string(crossed_from));
    trixel_gen::Random rng(31);
    constexpr std::uint32_t kShort = 40000;
    std::vector<Point> points;
    std::vector<Segment> segments;
    // The chain 0-1-2-3-4 on the line y = -10 and the long segment 0-4 over it.
    for (std::uint32_t k = 0; k < 5; ++k) points.push_back({double(k), -10.0});
    for (std::uint32_t k = 0; k < 4; ++k) segments.push_back({k, k + 1});
    segments.push_back({0, 4});
    // Short steep segments left to right, apart in x (none crosses another).
    for (std::uint32_t k = 0; k < kShort; ++k) {
      const double x = 1000.0 * k / kShort;
      const double y = rng.unit() * 100;
      const auto a = static_cast<std::uint32_t>(points.size());
      points.push_back({x, y});
      points.push_back({x + 0.005, y + 10});
      segments.push_back({a, a + 1});
    }
    // Two flat segments across a hundredth of them.
    for (const double y : {30.0, 70.0}) {
      const auto a = static_cast<std::uint32_t>(points.size());
      points.push_back({crossed_from + 0.001, y});
      points.push_back({crossed_from + 10.5, y + 0.3});
      segments.push_back({a, a + 1});
    }
    const SuspectSplit seen = expect_suspects_split_as_all(points, segments, rng, 10);
    EXPECT_GT(seen.cut, 5u);
    // A run of kept pieces longer than a chunk of the parallel moves (2^14 pieces), moved in place.
    EXPECT_GT(seen.longest_whole_run, std::size_t{1} << 15);
    EXPECT_TRUE(seen.in_place);
  }
}

// Suspects of a list split already all come back as they were: split_pieces says nothing changed and
// the list is the same, piece for piece.
TEST(PslgSplit, SuspectsThatAllComeBackLeaveTheList) {
  trixel_gen::Random rng(21);
  std::vector<Point> points;
  for (int k = 0; k < 600; ++k) points.push_back({rng.unit() * 100, rng.unit() * 100});
  std::vector<Segment> segments;
  for (int k = 0; k < 200; ++k) {
    const auto a = static_cast<std::uint32_t>(rng.range(0, 599));
    const auto b = static_cast<std::uint32_t>(rng.range(0, 599));
    if (a != b) segments.push_back({a, b});
  }
  CpuExecutor executor(2);
  PreparedPslg split = cdt::detail::merge_input(points, segments, CrossingSegments::resolve, executor);
  cdt::detail::split_pieces(split, CrossingSegments::resolve, executor);
  ASSERT_GT(split.vertices.size(), points.size()) << "the segments should cross";
  const auto pairs = piece_pairs(split);
  const auto labels = piece_labels(split);
  const std::size_t vertices = split.vertices.size();
  std::vector<std::uint32_t> suspects;
  for (std::uint32_t k = 0; k < split.pieces.size(); k += 3) suspects.push_back(k);
  const std::vector<std::uint32_t> sites(split.sites.begin(), split.sites.end());
  std::vector<std::uint32_t> new_pieces{7}; // emptied
  EXPECT_FALSE(cdt::detail::split_pieces(split, suspects, sites, CrossingSegments::resolve, executor, -1.0,
                                         &new_pieces));
  EXPECT_TRUE(new_pieces.empty());
  EXPECT_EQ(piece_pairs(split), pairs);
  EXPECT_EQ(piece_labels(split), labels);
  EXPECT_EQ(split.vertices.size(), vertices);
}

TEST(PslgOverlap, PartialOverlapIsMergedWithLowestIds) {
  //  0 ----- 2 ===== 1 ----- 3      segment 1: 0-1, segment 0: 2-3
  const std::vector<Point> p{{0, 0}, {3, 0}, {1, 0}, {5, 0}, {0, 1}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{2, 3}, {0, 1}}, CrossingSegments::reject);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 2}, {1, 2}, {1, 3}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{1, 0, 0}));
  EXPECT_EQ(contract_violation(out), "");
}

TEST(PslgOverlap, ContainedSegmentKeepsItsLowerId) {
  const std::vector<Point> p{{0, 0}, {0, 5}, {0, 1}, {0, 3}, {1, 1}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{3, 2}, {1, 0}}, CrossingSegments::reject);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 2}, {1, 3}, {2, 3}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{1, 1, 0}));
}

TEST(PslgOverlap, ChainUnderALongSegmentKeepsTheChainIds) {
  const std::vector<Point> p{{0, 0}, {1, 1}, {2, 2}, {3, 3}, {0, 1}};
  const std::vector<Segment> s{{3, 0}, {0, 1}, {1, 2}, {2, 3}, {1, 3}};
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::reject);
  EXPECT_EQ(piece_pairs(out), (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 1}, {1, 2}, {2, 3}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{0, 0, 0}));
  // Without the long one, each piece is its own segment.
  const PreparedPslg chain =
      prepare_pslg(p, std::vector<Segment>{{0, 1}, {1, 2}, {2, 3}}, CrossingSegments::reject);
  EXPECT_EQ(piece_labels(chain), (std::vector<std::uint32_t>{0, 1, 2}));
}

// --- crossings ---------------------------------------------------------------------------------------

TEST(PslgCrossing, XIsResolvedIntoFourPiecesAndOneVertex) {
  const std::vector<Point> p{{0, 0}, {2, 2}, {0, 2}, {2, 0}};
  const PreparedPslg out = prepare_pslg(p, std::vector<Segment>{{0, 1}, {2, 3}}, CrossingSegments::resolve);
  ASSERT_EQ(out.vertices.size(), 5u);
  EXPECT_EQ(out.vertices[4], (Point{1, 1}));
  EXPECT_EQ(out.sites, (cdt::IndexArray{0, 1, 2, 3, 4}));
  EXPECT_EQ(piece_pairs(out),
            (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 4}, {1, 4}, {2, 4}, {3, 4}}));
  EXPECT_EQ(piece_labels(out), (std::vector<std::uint32_t>{0, 0, 1, 1}));
}

TEST(PslgCrossing, RejectedWithBothIdsLowerFirst) {
  const std::vector<Point> p{{0, 0}, {2, 2}, {0, 2}, {2, 0}, {5, 5}};
  const std::vector<Segment> s{{4, 2}, {2, 3}, {4, 3}, {1, 0}};
  try {
    prepare_pslg(p, s, CrossingSegments::reject);
    FAIL() << "no CrossingSegmentsError";
  } catch (const cdt::CrossingSegmentsError& e) {
    EXPECT_EQ(e.first(), 1u);
    EXPECT_EQ(e.second(), 3u);
    EXPECT_NE(std::string(e.what()).find("segments 1 and 3"), std::string::npos) << e.what();
  }
}

// Two segments crossing exactly at an input point need no new vertex, so reject does not object.
TEST(PslgCrossing, CrossingAtAnInputPointIsASplitNotACrossing) {
  const std::vector<Point> p{{0, 0}, {2, 2}, {0, 2}, {2, 0}, {1, 1}};
  const std::vector<Segment> s{{0, 1}, {2, 3}};
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::reject);
  EXPECT_EQ(out.vertices.size(), 5u);
  EXPECT_EQ(piece_pairs(out),
            (std::vector<std::pair<std::uint32_t, std::uint32_t>>{{0, 4}, {1, 4}, {2, 4}, {3, 4}}));
}

// The crossing point (1/3, 1/3) is not a double: the rounded vertex bends both segments slightly.
TEST(PslgCrossing, InexactCrossingPointStillGivesValidPieces) {
  const std::vector<Point> p{{0, 0}, {1, 1}, {0, 0.5}, {1, 0}};
  const std::vector<Segment> s{{0, 1}, {2, 3}};
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
  ASSERT_EQ(out.vertices.size(), 5u);
  EXPECT_NEAR(out.vertices[4].x, 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(out.vertices[4].y, 1.0 / 3.0, 1e-15);
  EXPECT_EQ(out.pieces.size(), 4u);
  EXPECT_EQ(contract_violation(out), "");
}

/// Adds n segments through `centre` (diameters of the circle of that radius, at angles not quite
/// regular): their crossings all lie at the centre, and their rounded crossing points near it.
void add_star(trixel_gen::Pslg& in, int n, const Point& centre, double radius) {
  for (int k = 0; k < n; ++k) {
    const double angle = 3.141592653589793 * (k + 0.37) / n;
    const auto a = static_cast<std::uint32_t>(in.points.size());
    in.points.push_back({centre.x + radius * std::cos(angle), centre.y + radius * std::sin(angle)});
    in.points.push_back({centre.x - radius * std::cos(angle), centre.y - radius * std::sin(angle)});
    in.segments.push_back({a, a + 1});
  }
}

// Several segments crossing at (nearly) one point: the rounded crossings create new crossings between
// the bent pieces, which later rounds must resolve.
TEST(PslgCrossing, ManySegmentsThroughOnePointConverge) {
  trixel_gen::Pslg in;
  add_star(in, 40, {0.3, 0.1}, 1.0);
  const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::resolve);
  EXPECT_GT(out.vertices.size(), in.points.size());
  EXPECT_EQ(contract_violation(out), "");
  EXPECT_TRUE(segments_connected(out, in.segments));
}

TEST(PslgCrossing, NearlyParallelCrossingConverges) {
  const std::vector<Point> p{{0, 0}, {1e6, 1}, {0, 1e-9}, {1e6, 1 - 1e-9}, {3, 7}};
  const std::vector<Segment> s{{0, 1}, {2, 3}};
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
  EXPECT_EQ(contract_violation(out), "");
  EXPECT_TRUE(segments_connected(out, s));
}

// Segments that overlap to within rounding error (points on one line, 1e9 from the origin, where an
// ulp is 1e-7): every rounded crossing point lands a hair off the other segments, which cross its bent
// pieces again. Without snapping new vertices into segments this snowballed (tripling each round).
TEST(PslgCrossing, SegmentsOverlappingWithinRoundingErrorConverge) {
  trixel_gen::Random rng(7);
  std::vector<Point> p;
  for (int k = 0; k < 200; ++k) {
    const double t = rng.unit();
    p.push_back({1e9 + t, 1e9 + 0.3 * t + 1e-12 * rng.unit()});
  }
  p.push_back({1e9, 1e9 + 1});
  std::vector<Segment> s;
  while (s.size() < 30) {
    const auto a = static_cast<std::uint32_t>(rng.next() % 200);
    const auto b = static_cast<std::uint32_t>(rng.next() % 200);
    if (!(p[a] == p[b])) s.push_back({a, b});
  }
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
  EXPECT_EQ(contract_violation(out), "");
  EXPECT_TRUE(segments_connected(out, s));
  EXPECT_LT(out.vertices.size(), 20 * p.size());
}

// Cutting a few crossing segments among many puts their pieces into place without sorting every
// segment again: here a small star of segments crossing near one point, among thousands of segments
// that do not cross, takes that path.
TEST(PslgCrossing, FewCrossingsAmongManySegmentsConverge) {
  trixel_gen::Pslg in = trixel_gen::synthetic_pslg(20000, 4000, trixel_gen::Distribution::uniform, 5);
  add_star(in, 8, {0.5, 0.5}, 0.01);
  const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::resolve);
  EXPECT_GT(out.vertices.size(), in.points.size());
  EXPECT_EQ(contract_violation(out), "");
  EXPECT_TRUE(segments_connected(out, in.segments));
}

// The crossing vertices are chosen in parallel where no other crossing point of the round lies within
// the tolerance, one by one where some do: the same vertices and pieces for any thread count. Crossings
// gathering on one point (crowded), segments overlapping within rounding (crowded, snapped), and
// thousands of crossings cutting the segments into many more pieces (the segment grid grows).
TEST(PslgCrossing, SameVerticesAndPiecesForAnyThreadCount) {
  std::vector<trixel_gen::Pslg> inputs(3);
  add_star(inputs[0], 40, {0.3, 0.1}, 1.0);
  trixel_gen::Random rng(11);
  for (int k = 0; k < 200; ++k) {
    const double t = rng.unit();
    inputs[1].points.push_back({1e9 + t, 1e9 + 0.3 * t + 1e-12 * rng.unit()});
  }
  inputs[1].points.push_back({1e9, 1e9 + 1});
  while (inputs[1].segments.size() < 30) {
    const auto a = static_cast<std::uint32_t>(rng.next() % 200);
    const auto b = static_cast<std::uint32_t>(rng.next() % 200);
    if (!(inputs[1].points[a] == inputs[1].points[b])) inputs[1].segments.push_back({a, b});
  }
  for (std::uint32_t k = 0; k < 400; ++k) {
    inputs[2].points.push_back({rng.unit(), rng.unit()});
    inputs[2].points.push_back({rng.unit(), rng.unit()});
    inputs[2].segments.push_back({2 * k, 2 * k + 1});
  }
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const trixel_gen::Pslg& in = inputs[i];
    CpuExecutor one(1);
    CpuExecutor three(3);
    const PreparedPslg a = prepare_pslg(in.points, in.segments, CrossingSegments::resolve, one);
    const PreparedPslg b = prepare_pslg(in.points, in.segments, CrossingSegments::resolve, three);
    EXPECT_GT(a.vertices.size(), in.points.size()) << "input " << i;
    EXPECT_EQ(contract_violation(a), "") << "input " << i;
    EXPECT_TRUE(segments_connected(a, in.segments)) << "input " << i;
    EXPECT_EQ(a.vertices, b.vertices) << "input " << i;
    EXPECT_EQ(piece_pairs(a), piece_pairs(b)) << "input " << i;
    EXPECT_EQ(piece_labels(a), piece_labels(b)) << "input " << i;
  }
  // 400 segments across the square cross about 19,000 times: the pieces outnumber the segments nearly
  // 100 to 1.
  EXPECT_GT(prepare_pslg(inputs[2].points, inputs[2].segments, CrossingSegments::resolve).pieces.size(),
            90 * inputs[2].segments.size());
}

// Crossing points within the tolerance of each other share a vertex: 40 segments through one point
// cross 780 times, and their rounded crossing points gather on a few vertices.
TEST(PslgCrossing, CrossingPointsWithinTheToleranceShareAVertex) {
  trixel_gen::Pslg in;
  add_star(in, 40, {0.3, 0.1}, 1.0);
  for (const unsigned threads : {1u, 3u}) {
    CpuExecutor executor(threads);
    const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::resolve, executor);
    EXPECT_GT(out.vertices.size(), in.points.size());
    EXPECT_LE(out.vertices.size(), in.points.size() + 8) << "threads " << threads;
  }
}

// --- property tests ----------------------------------------------------------------------------------

/// Random segments on a k x k lattice: many collinear overlaps, points on segments, and crossings at
/// lattice points and elsewhere.
trixel_gen::Pslg lattice_segments(std::uint32_t k, std::size_t num_segments, std::uint64_t seed) {
  trixel_gen::Random rng(seed);
  trixel_gen::Pslg in = trixel_gen::lattice(k);
  while (in.segments.size() < num_segments) {
    const auto a = static_cast<std::uint32_t>(rng.next() % in.points.size());
    const auto b = static_cast<std::uint32_t>(rng.next() % in.points.size());
    if (a != b) in.segments.push_back({a, b});
  }
  return in;
}

TEST(PslgProperty, RandomLatticeSegmentsGiveCleanPieces) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    trixel_gen::Pslg in = lattice_segments(16, 10 * seed, seed);
    // Also short axis-parallel and diagonal ones, which overlap a lot.
    const trixel_gen::Pslg shorts = trixel_gen::lattice_with_segments(16, 20 * seed, seed + 100);
    in.segments.insert(in.segments.end(), shorts.segments.begin(), shorts.segments.end());
    const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::resolve);
    EXPECT_EQ(contract_violation(out), "") << "seed " << seed;
    EXPECT_TRUE(segments_connected(out, in.segments)) << "seed " << seed;
    for (std::size_t v = in.points.size(); v < out.vertices.size(); ++v) {
      EXPECT_TRUE(out.vertices[v].x >= 0 && out.vertices[v].x <= 15 && out.vertices[v].y >= 0 &&
                  out.vertices[v].y <= 15);
    }
  }
}

// Without crossings the result is exact: each segment is cut at exactly the sites on it.
TEST(PslgProperty, AxisParallelLatticeSegmentsAreCutAtEveryLatticePoint) {
  trixel_gen::Random rng(7);
  const std::uint32_t k = 16;
  trixel_gen::Pslg in = trixel_gen::lattice(k);
  for (int n = 0; n < 60; ++n) {
    const auto row = static_cast<std::uint32_t>(rng.next() % k);
    const auto x0 = static_cast<std::uint32_t>(rng.next() % (k - 1));
    const auto x1 = x0 + 1 + static_cast<std::uint32_t>(rng.next() % (k - 1 - x0));
    in.segments.push_back({row * k + x0, row * k + x1});
  }
  const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::reject);
  EXPECT_EQ(out.vertices.size(), in.points.size());
  std::vector<std::pair<std::uint32_t, std::uint32_t>> expected;
  for (const Segment& s : in.segments) {
    for (std::uint32_t v = std::min(s.a, s.b); v < std::max(s.a, s.b); ++v) expected.emplace_back(v, v + 1);
  }
  std::sort(expected.begin(), expected.end());
  expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
  EXPECT_EQ(piece_pairs(out), expected);
}

// Random inputs of several shapes (lattice, uniform, nearly collinear, on a circle, rational), scaled
// from 1e-40 to 1e40 and sometimes shifted far from the origin: the grid, the crossing points and the
// snapping all work relative to the input's magnitude.
TEST(PslgProperty, RandomInputsAtManyScalesGiveCleanPieces) {
  const double scales[] = {1e-40, 1e-6, 1, 1e6, 1e40};
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    trixel_gen::Random rng(seed);
    const int shape = static_cast<int>(seed % 5);
    const double scale = scales[rng.next() % 5];
    const double offset = rng.next() % 3 == 0 ? scale * 1e9 : 0.0;
    std::vector<Point> p;
    const std::size_t n = 20 + rng.next() % 200;
    for (std::size_t k = 0; k < n; ++k) {
      double x = 0;
      double y = 0;
      if (shape == 0) {
        x = static_cast<double>(rng.next() % 8), y = static_cast<double>(rng.next() % 8);
      } else if (shape == 1) {
        x = rng.unit(), y = rng.unit();
      } else if (shape == 2) {
        x = rng.unit(), y = 0.3 * x + 1e-12 * rng.unit();
      } else if (shape == 3) {
        const double angle = 6.283185307179586 * rng.unit();
        x = std::cos(angle), y = std::sin(angle);
      } else {
        x = std::round(rng.unit() * 1000) / 7.0, y = std::round(rng.unit() * 1000) / 3.0;
      }
      p.push_back({offset + x * scale, offset + y * scale});
    }
    p.push_back({offset, offset});
    p.push_back({offset + scale, offset});
    p.push_back({offset, offset + scale});
    std::vector<Segment> s;
    const std::size_t m = 5 + rng.next() % 150;
    for (std::size_t k = 0; k < m; ++k) {
      const auto a = static_cast<std::uint32_t>(rng.next() % p.size());
      const auto b = static_cast<std::uint32_t>(rng.next() % p.size());
      if (!(p[a] == p[b])) s.push_back({a, b});
    }
    const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
    EXPECT_EQ(contract_violation(out), "") << "seed " << seed;
    EXPECT_TRUE(segments_connected(out, s)) << "seed " << seed;
  }
}

// cdt.txt lists segments from a point to itself: under reject they are reported (degenerate_segment,
// the first id); under resolve they are ignored and counted.
TEST(PslgProperty, ArtemOgreTestFilesPrepare) {
  namespace fs = std::filesystem;
  int files = 0;
  for (const auto& entry :
       fs::directory_iterator(fs::path(TRIXEL_TEST_DATA_DIR) / "cdt" / "artem-ogre-CDT")) {
    if (entry.path().extension() != ".txt") continue;
    ++files;
    cdt::io::Pslg in = cdt::io::read_edge_list(entry.path());
    const auto self =
        std::find_if(in.segments.begin(), in.segments.end(), [](const Segment& s) { return s.a == s.b; });
    if (self != in.segments.end()) {
      const auto e = invalid_input(in.points, in.segments, CrossingSegments::reject);
      EXPECT_EQ(e.kind(), Kind::degenerate_segment) << entry.path().filename();
      EXPECT_EQ(e.item(), static_cast<std::uint64_t>(self - in.segments.begin())) << entry.path().filename();
    }
    try {
      const PreparedPslg out = prepare_pslg(in.points, in.segments, CrossingSegments::resolve);
      EXPECT_EQ(contract_violation(out), "") << entry.path().filename();
      EXPECT_TRUE(segments_connected(out, in.segments)) << entry.path().filename();
    } catch (const cdt::Error& e) {
      ADD_FAILURE() << entry.path().filename() << ": " << e.what();
    }
  }
  EXPECT_EQ(files, 36);
}

// Scale: short random segments with many crossings. No timing assertion (machines are shared).
TEST(PslgProperty, HundredThousandRandomSegmentsFinish) {
  trixel_gen::Random rng(42);
  const std::size_t m = 100000;
  std::vector<Point> p;
  std::vector<Segment> s;
  const double reach = 3.0 / std::sqrt(static_cast<double>(m));
  for (std::size_t k = 0; k < m; ++k) {
    const Point a{rng.unit(), rng.unit()};
    const Point b{std::clamp(a.x + reach * (rng.unit() - 0.5), 0.0, 1.0),
                  std::clamp(a.y + reach * (rng.unit() - 0.5), 0.0, 1.0)};
    const auto i = static_cast<std::uint32_t>(p.size());
    p.push_back(a);
    p.push_back(b);
    s.push_back({i, i + 1});
  }
  const PreparedPslg out = prepare_pslg(p, s, CrossingSegments::resolve);
  EXPECT_GT(out.vertices.size(), p.size());
  EXPECT_EQ(contract_violation(out), "");
}

} // namespace
