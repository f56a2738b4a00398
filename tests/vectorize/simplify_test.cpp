#include "vectorize/simplify.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "stage_test_util.hpp"
#include "vectorize/chains.hpp"

namespace {

using trixel_test::improper;
using trixel_test::orient;

using vectorize::Chain;
using vectorize::PixelPoint;
using vectorize::Polyline;

using Segments = std::vector<std::pair<PixelPoint, PixelPoint>>;

template <class Line>
Segments segments_of(const std::vector<Line>& lines) {
  Segments out;
  for (const Line& l : lines) {
    const std::size_t n = l.points.size();
    for (std::size_t i = 0; i + 1 < n; ++i) out.push_back({l.points[i], l.points[i + 1]});
    if (l.closed && n >= 3) out.push_back({l.points[n - 1], l.points[0]});
  }
  return out;
}

// The first pair of segments that meet improperly, as a message; empty when there is none.
std::string first_crossing(const Segments& s) {
  for (std::size_t i = 0; i < s.size(); ++i)
    for (std::size_t j = i + 1; j < s.size(); ++j)
      if (improper(s[i].first, s[i].second, s[j].first, s[j].second))
        return "(" + std::to_string(s[i].first.x) + "," + std::to_string(s[i].first.y) + ")-(" +
               std::to_string(s[i].second.x) + "," + std::to_string(s[i].second.y) + ") meets (" +
               std::to_string(s[j].first.x) + "," + std::to_string(s[j].first.y) + ")-(" +
               std::to_string(s[j].second.x) + "," + std::to_string(s[j].second.y) + ")";
  return {};
}

double distance_to_segment(const PixelPoint& a, const PixelPoint& b, const PixelPoint& p) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len_sq = dx * dx + dy * dy;
  const double t = len_sq > 0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len_sq, 0.0, 1.0) : 0.0;
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

// The simplified line is a subsequence of the chain keeping open ends, and every chain point lies within
// tolerance of the segment of the simplified line that spans it.
void expect_faithful(const Chain& chain, const Polyline& line, double tolerance) {
  ASSERT_EQ(line.closed, chain.closed);
  ASSERT_GE(line.points.size(), std::min<std::size_t>(chain.points.size(), 2));
  if (!chain.closed) {
    EXPECT_EQ(line.points.front(), chain.points.front());
    EXPECT_EQ(line.points.back(), chain.points.back());
  }
  // Walk the chain, matching the line's points in order (a closed chain may start anywhere; ours keep
  // the original start when it survives, otherwise the match starts at the first kept point).
  std::size_t start = 0;
  while (start < chain.points.size() && !(chain.points[start] == line.points[0])) ++start;
  ASSERT_LT(start, chain.points.size());
  const std::size_t n = chain.points.size();
  std::size_t k = 0; // index into line.points of the last matched point
  for (std::size_t step = 1; step <= (chain.closed ? n : n - 1 - start); ++step) {
    const PixelPoint& p = chain.points[(start + step) % n];
    const std::size_t next_k = (k + 1) % line.points.size();
    if (p == line.points[next_k] && (chain.closed || next_k != 0)) {
      k = next_k;
      continue;
    }
    EXPECT_LE(distance_to_segment(line.points[k], line.points[next_k], p), tolerance + 1e-12)
        << "point (" << p.x << "," << p.y << ")";
  }
  EXPECT_EQ(k, chain.closed ? 0u : line.points.size() - 1) << "line is not a subsequence of the chain";
}

Chain open_chain(std::vector<PixelPoint> points) { return Chain{std::move(points), false}; }

TEST(Simplify, StraightRunCollapsesToItsEnds) {
  std::vector<PixelPoint> pts;
  for (int x = 0; x <= 50; ++x) pts.push_back({x, 3});
  const auto out = vectorize::simplify_chains({open_chain(pts)}, 0.0);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0].points.size(), 2u);
  EXPECT_EQ(out[0].points[0], (PixelPoint{0, 3}));
  EXPECT_EQ(out[0].points[1], (PixelPoint{50, 3}));
}

// A point of a straight run that another chain ends on stays: removing it would leave that end on the
// middle of the new segment.
TEST(Simplify, StraightRunKeepsThePointAnotherChainEndsOn) {
  std::vector<PixelPoint> run;
  for (int x = 0; x <= 10; ++x) run.push_back({x, 3});
  std::vector<PixelPoint> spur;
  for (int y = 3; y <= 8; ++y) spur.push_back({5, y});
  const auto out = vectorize::simplify_chains({open_chain(run), open_chain(spur)}, 0.0);
  EXPECT_EQ(out[0].points, (std::vector<PixelPoint>{{0, 3}, {5, 3}, {10, 3}}));
  EXPECT_EQ(out[1].points, (std::vector<PixelPoint>{{5, 3}, {5, 8}}));
}

// A segment between points far apart passes through a centre of the straight run (the chains touch
// already): no segment of the run next to that contact may change, whatever the run's straightness.
TEST(Simplify, RunTouchedByALongSegmentStaysAsGiven) {
  const Chain run = open_chain({{0, 3}, {1, 3}, {2, 3}, {3, 3}, {4, 3}});
  const Chain across = open_chain({{2, 0}, {2, 6}});
  const auto out = vectorize::simplify_chains({run, across}, 0.0);
  EXPECT_EQ(out[0].points, run.points);
  EXPECT_EQ(out[1].points, across.points);
}

// Two diagonals of one 2 x 2 block cross without sharing a pixel: the run through the crossing keeps
// its middle point, as the greedy pass keeps any removal that would touch another segment.
TEST(Simplify, DiagonalRunCrossedByAnotherDiagonalKeepsItsMiddle) {
  const Chain run = open_chain({{0, 0}, {1, 1}, {2, 2}});
  const Chain across = open_chain({{1, 0}, {0, 1}});
  const auto out = vectorize::simplify_chains({run, across}, 0.0);
  EXPECT_EQ(out[0].points, run.points);
  EXPECT_EQ(out[1].points, across.points);
}

// Chains at the far ends of the int range: no overflow in the straight-run pass (a crash or a
// sanitizer report otherwise).
TEST(Simplify, FarApartPointsAreHandled) {
  constexpr int lo = std::numeric_limits<int>::min();
  constexpr int hi = std::numeric_limits<int>::max();
  const auto out = vectorize::simplify_chains(
      {open_chain({{lo, lo}}), open_chain({{hi, hi}}), open_chain({{lo, 0}, {1, 0}})}, 1.0);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].points.size(), 2u);
}

// A solid line one pixel thick between transparent rows: its points stay at their centres (the moves
// up and down cancel) but are outline points, and a segment skipping one would cut through that solid
// pixel. Every point stays, whatever the tolerance.
TEST(Simplify, SolidThinLineKeepsEveryPoint) {
  vectorize::Image image;
  image.width = 10;
  image.height = 3;
  image.rgba.assign(10 * 3 * 4, 0.0f);
  for (int x = 0; x < 10; ++x) image.pixel(x, 1)[3] = 1.0f;
  std::vector<PixelPoint> line;
  for (int x = 0; x < 10; ++x) line.push_back({x, 1});
  const vectorize::PointPlacement placement(image);
  ASSERT_EQ(placement.position({4, 1}), (vectorize::Position{4.5, 1.5}));
  for (const double tolerance : {0.0, 1.0}) {
    const auto out = vectorize::simplify_chains({open_chain(line)}, tolerance, placement);
    EXPECT_EQ(out[0].points, line) << "tolerance " << tolerance;
  }
}

TEST(Simplify, ZeroToleranceKeepsCorners) {
  const Chain l = open_chain({{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 1}, {3, 2}, {3, 3}});
  const auto out = vectorize::simplify_chains({l}, 0.0);
  EXPECT_EQ(out[0].points, (std::vector<PixelPoint>{{0, 0}, {3, 0}, {3, 3}}));
}

// A staircase diagonal within a pixel of the straight line becomes that line.
TEST(Simplify, StaircaseBecomesALineAndRespectsTolerance) {
  std::vector<PixelPoint> pts;
  for (int i = 0; i < 30; ++i) {
    pts.push_back({i, i});
    pts.push_back({i + 1, i});
  }
  const Chain chain = open_chain(pts);
  const auto out = vectorize::simplify_chains({chain}, 1.0);
  EXPECT_EQ(out[0].points.size(), 2u);
  expect_faithful(chain, out[0], 1.0);
  const auto tight = vectorize::simplify_chains({chain}, 0.5);
  EXPECT_GT(tight[0].points.size(), 2u);
  expect_faithful(chain, tight[0], 0.5);
}

// Straightening the bump would run the line through the end of the dangling chain below it; the
// crossing check must keep the bump (without it, the tolerance alone allows the straight line).
TEST(Simplify, DoesNotSweepOverAnotherChainsEnd) {
  std::vector<PixelPoint> a;
  for (int x = 0; x <= 8; ++x) a.push_back({x, 0});
  a.push_back({9, -1});
  a.push_back({10, -2});
  a.push_back({11, -1});
  for (int x = 12; x <= 20; ++x) a.push_back({x, 0});
  std::vector<PixelPoint> b;
  for (int y = 5; y >= -1; --y) b.push_back({10, y});
  const std::vector<Chain> chains = {open_chain(a), open_chain(b)};
  ASSERT_EQ(first_crossing(segments_of(chains)), "");
  const auto alone = vectorize::simplify_chains({chains[0]}, 2.5);
  EXPECT_EQ(alone[0].points.size(), 2u); // the bump is within tolerance
  const auto out = vectorize::simplify_chains(chains, 2.5);
  EXPECT_EQ(first_crossing(segments_of(out)), "");
  EXPECT_GT(out[0].points.size(), 2u);
  expect_faithful(chains[0], out[0], 2.5);
  expect_faithful(chains[1], out[1], 2.5);
}

TEST(Simplify, ClosedLoopKeepsThreePoints) {
  Chain square{{{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}}, true};
  const auto out = vectorize::simplify_chains({square}, 100.0);
  ASSERT_EQ(out[0].points.size(), 3u);
  EXPECT_TRUE(out[0].closed);
  const auto& p = out[0].points;
  EXPECT_NE(orient(p[0], p[1], p[2]), 0); // a real triangle, not a collapsed loop
}

TEST(Simplify, LoopThroughJunctionKeepsFourPoints) {
  const Chain loop = open_chain({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}, {0, 0}});
  const auto out = vectorize::simplify_chains({loop}, 100.0);
  ASSERT_EQ(out[0].points.size(), 4u);
  EXPECT_EQ(out[0].points.front(), (PixelPoint{0, 0}));
  EXPECT_EQ(out[0].points.back(), (PixelPoint{0, 0}));
  EXPECT_EQ(first_crossing(segments_of(out)), "");
}

// Two chains between the same two junctions must not both become the same straight segment.
TEST(Simplify, ParallelChainsBetweenTheSameJunctionsStayApart) {
  const Chain upper = open_chain({{0, 0}, {1, -1}, {2, -1}, {3, -1}, {4, 0}});
  const Chain lower = open_chain({{0, 0}, {1, 1}, {2, 1}, {3, 1}, {4, 0}});
  const auto out = vectorize::simplify_chains({upper, lower}, 3.0);
  EXPECT_EQ(first_crossing(segments_of(out)), "");
  EXPECT_EQ(out[0].points.size() + out[1].points.size(), 5u); // one keeps a bend, the other goes straight
}

// Many wiggly curves a few pixels apart, traced from a raster like real edges and simplified with a
// tolerance larger than their spacing: no crossing appears and every chain stays within tolerance.
// The chains left and right of the middle are simplified apart (on two threads when given), around the
// waves across it: the result is the same with one thread.
TEST(Simplify, RandomCloseCurvesNeverCross) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> phase(0.0, 6.283);
  std::uniform_real_distribution<double> amp(1.0, 6.0);
  for (int round = 0; round < 6; ++round) {
    vectorize::EdgeMap map;
    map.width = 160;
    map.height = 120;
    map.on.assign(static_cast<std::size_t>(map.width) * map.height, 0);
    auto set = [&](int x, int y) {
      if (x >= 0 && y >= 0 && x < map.width && y < map.height)
        map.on[static_cast<std::size_t>(y) * map.width + x] = 1;
    };
    // Horizontal-ish waves 3 pixels apart, and a few circles and vertical waves crossing them.
    for (int row = 5; row < 115; row += 3) {
      const double a = amp(rng), p = phase(rng), f = 0.05 + 0.1 * (round % 3);
      for (double x = 0; x < 160; x += 0.25)
        set(static_cast<int>(x), static_cast<int>(row + a * std::sin(f * x + p)));
    }
    for (int k = 0; k < 4; ++k) {
      const double cx = 20 + 40 * k, cy = 60, r = 10 + 5 * k;
      for (double t = 0; t < 6.2832; t += 0.01)
        set(static_cast<int>(cx + r * std::cos(t)), static_cast<int>(cy + r * std::sin(t)));
      const double p = phase(rng);
      for (double y = 0; y < 120; y += 0.25)
        set(static_cast<int>(10 + 40 * k + 4 * std::sin(0.2 * y + p)), static_cast<int>(y));
    }
    const auto chains = vectorize::trace_chains(map);
    ASSERT_EQ(first_crossing(segments_of(chains)), "");
    const double tolerance = 1.0 + round;
    const auto out = vectorize::simplify_chains(chains, tolerance, {}, 2);
    ASSERT_EQ(out.size(), chains.size());
    ASSERT_EQ(first_crossing(segments_of(out)), "") << "round " << round;
    const auto one_thread = vectorize::simplify_chains(chains, tolerance, {}, 1);
    ASSERT_EQ(one_thread.size(), out.size());
    for (std::size_t c = 0; c < out.size(); ++c)
      EXPECT_TRUE(one_thread[c].points == out[c].points) << "round " << round << ", chain " << c;
    std::size_t before = 0, after = 0;
    for (std::size_t c = 0; c < chains.size(); ++c) {
      expect_faithful(chains[c], out[c], tolerance);
      before += chains[c].points.size();
      after += out[c].points.size();
    }
    EXPECT_LT(after * 2, before) << "simplification removed too little";
  }
}

TEST(Simplify, RejectsBadTolerance) {
  EXPECT_THROW(vectorize::simplify_chains({}, -1.0), std::invalid_argument);
  EXPECT_THROW(vectorize::simplify_chains({}, std::nan("")), std::invalid_argument);
  EXPECT_TRUE(vectorize::simplify_chains({}, 1.0).empty());
}

} // namespace
