#include "vectorize/chains.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "stage_test_util.hpp"

namespace {

using trixel_test::improper;
using trixel_test::orient;

using vectorize::Chain;
using vectorize::EdgeMap;
using vectorize::PixelPoint;

// '#' is an edge pixel; rows top to bottom.
EdgeMap draw(const std::vector<std::string>& rows) {
  EdgeMap map;
  map.height = static_cast<int>(rows.size());
  map.width = static_cast<int>(rows.front().size());
  map.on.assign(static_cast<std::size_t>(map.width) * map.height, 0);
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x)
      if (rows[y][x] == '#') map.on[static_cast<std::size_t>(y) * map.width + x] = 1;
  return map;
}

bool adjacent8(const PixelPoint& a, const PixelPoint& b) {
  return std::max(std::abs(a.x - b.x), std::abs(a.y - b.y)) == 1;
}

// Each chain's consecutive points (and a closed chain's last to first) are 8-neighbours.
void expect_linked(const std::vector<Chain>& chains) {
  for (const Chain& c : chains) {
    ASSERT_GE(c.points.size(), c.closed ? 3u : 2u);
    for (std::size_t i = 0; i + 1 < c.points.size(); ++i)
      EXPECT_TRUE(adjacent8(c.points[i], c.points[i + 1]));
    if (c.closed) {
      EXPECT_TRUE(adjacent8(c.points.back(), c.points.front()));
    }
  }
}

std::pair<int, int> key(const PixelPoint& p) { return {p.x, p.y}; }

// Chain ends counted per pixel.
std::map<std::pair<int, int>, int> end_counts(const std::vector<Chain>& chains) {
  std::map<std::pair<int, int>, int> ends;
  for (const Chain& c : chains)
    if (!c.closed) {
      ++ends[key(c.points.front())];
      ++ends[key(c.points.back())];
    }
  return ends;
}

TEST(Chains, StraightLineIsOneOpenChain) {
  const auto chains = vectorize::trace_chains(draw({".....", ".###.", "....."}));
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_FALSE(chains[0].closed);
  ASSERT_EQ(chains[0].points.size(), 3u);
  EXPECT_EQ(chains[0].points.front(), (PixelPoint{1, 1}));
  EXPECT_EQ(chains[0].points.back(), (PixelPoint{3, 1}));
}

// A 4-connected staircase has three 8-neighbours at each corner pixel; m-adjacency keeps it one chain.
TEST(Chains, StaircaseDiagonalHasNoFalseJunction) {
  const auto chains = vectorize::trace_chains(draw({
      "##....",
      ".##...",
      "..##..",
      "...##.",
      "....##",
  }));
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_EQ(chains[0].points.size(), 10u);
  expect_linked(chains);
  const auto ends = end_counts(chains);
  EXPECT_EQ(ends.count({0, 0}), 1u);
  EXPECT_EQ(ends.count({5, 4}), 1u);
}

TEST(Chains, DiagonalLineIsOneChain) {
  const auto chains = vectorize::trace_chains(draw({"#...", ".#..", "..#.", "...#"}));
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_EQ(chains[0].points.size(), 4u);
}

TEST(Chains, TJunctionSplitsIntoThreeChainsSharingTheJunction) {
  const auto chains = vectorize::trace_chains(draw({
      "#####",
      "..#..",
      "..#..",
  }));
  ASSERT_EQ(chains.size(), 3u);
  expect_linked(chains);
  const auto ends = end_counts(chains);
  EXPECT_EQ(ends.at({2, 0}), 3); // the junction ends all three
  EXPECT_EQ(ends.at({0, 0}), 1);
  EXPECT_EQ(ends.at({4, 0}), 1);
  EXPECT_EQ(ends.at({2, 2}), 1);
}

TEST(Chains, XCrossingGivesFourChainsAtTheCentre) {
  const auto chains = vectorize::trace_chains(draw({
      "#...#",
      ".#.#.",
      "..#..",
      ".#.#.",
      "#...#",
  }));
  ASSERT_EQ(chains.size(), 4u);
  expect_linked(chains);
  EXPECT_EQ(end_counts(chains).at({2, 2}), 4);
  for (const Chain& c : chains) EXPECT_EQ(c.points.size(), 3u);
}

TEST(Chains, PlusCrossingGivesFourChainsAtTheCentre) {
  const auto chains = vectorize::trace_chains(draw({"..#..", "..#..", "#####", "..#..", "..#.."}));
  ASSERT_EQ(chains.size(), 4u);
  EXPECT_EQ(end_counts(chains).at({2, 2}), 4);
}

TEST(Chains, LoopWithoutJunctionIsClosed) {
  const auto chains = vectorize::trace_chains(draw({
      "......",
      "..##..",
      ".#..#.",
      ".#..#.",
      "..##..",
      "......",
  }));
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_TRUE(chains[0].closed);
  EXPECT_EQ(chains[0].points.size(), 8u);
  expect_linked(chains);
  std::set<std::pair<int, int>> distinct;
  for (const auto& p : chains[0].points) distinct.insert(key(p));
  EXPECT_EQ(distinct.size(), 8u); // the first point is not repeated
}

// A loop hanging off a line: the loop is an open chain from the junction back to itself.
TEST(Chains, LoopThroughJunctionStartsAndEndsThere) {
  const auto chains = vectorize::trace_chains(draw({
      ".###.",
      ".#.#.",
      ".###.",
      "..#..",
      "..#..",
  }));
  expect_linked(chains);
  ASSERT_EQ(chains.size(), 2u);
  int loops = 0;
  for (const Chain& c : chains) {
    EXPECT_FALSE(c.closed);
    if (c.points.front() == c.points.back()) {
      ++loops;
      EXPECT_EQ(c.points.front(), (PixelPoint{2, 2}));
      EXPECT_EQ(c.points.size(), 9u);
    }
  }
  EXPECT_EQ(loops, 1);
}

TEST(Chains, IsolatedPixelsGiveNoChain) {
  EXPECT_TRUE(vectorize::trace_chains(draw({"#...#", ".....", "..#.."})).empty());
  EXPECT_TRUE(vectorize::trace_chains(draw({"....."})).empty());
  const auto pair = vectorize::trace_chains(draw({"##..."}));
  ASSERT_EQ(pair.size(), 1u); // two pixels still make a chain
  EXPECT_EQ(pair[0].points.size(), 2u);
}

// A thick spot on a line (a full 2x2 block) is thinned, and the bump left over is pruned, instead of
// making a cluster of junctions.
TEST(Chains, ThickSpotOnALineIsThinned) {
  const auto chains = vectorize::trace_chains(draw({
      "...##...",
      "########",
  }));
  expect_linked(chains);
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_FALSE(chains[0].closed);
  EXPECT_EQ(chains[0].points.size(), 8u);
}

// A longer branch is a real one: only one-pixel spurs are pruned.
TEST(Chains, TwoPixelBranchIsKept) {
  EXPECT_EQ(vectorize::trace_chains(draw({"..#..", "..#..", "#####"})).size(), 3u);
  EXPECT_EQ(vectorize::trace_chains(draw({"..#..", "#####"})).size(), 1u);
}

// On random dense edge maps: every link becomes one chain segment, chain segments form a plane graph
// (the property simplification and the PSLG rely on), and interior points are used by one chain only.
TEST(Chains, RandomMapsGivePlaneChainsCoveringEveryPixelOnce) {
  std::mt19937 rng(3);
  for (int round = 0; round < 30; ++round) {
    EdgeMap map;
    map.width = 24;
    map.height = 18;
    std::bernoulli_distribution on(0.15 + 0.02 * (round % 10));
    for (int i = 0; i < map.width * map.height; ++i) map.on.push_back(on(rng) ? 1 : 0);
    const auto chains = vectorize::trace_chains(map);
    expect_linked(chains);
    std::vector<std::pair<PixelPoint, PixelPoint>> segments;
    std::map<std::pair<int, int>, int> interior_uses;
    for (const Chain& c : chains) {
      const std::size_t n = c.points.size();
      for (std::size_t i = 0; i + 1 < n; ++i) segments.push_back({c.points[i], c.points[i + 1]});
      if (c.closed) segments.push_back({c.points[n - 1], c.points[0]});
      for (std::size_t i = c.closed ? 0 : 1; i < (c.closed ? n : n - 1); ++i) {
        ++interior_uses[key(c.points[i])];
        EXPECT_TRUE(map.at(c.points[i].x, c.points[i].y));
      }
    }
    for (const auto& [p, uses] : interior_uses) EXPECT_EQ(uses, 1) << p.first << "," << p.second;
    const auto ends = end_counts(chains);
    for (const auto& [p, ends_here] : ends)
      EXPECT_EQ(interior_uses.count(p), 0u) << "junction inside a chain";
    for (std::size_t i = 0; i < segments.size(); ++i)
      for (std::size_t j = i + 1; j < segments.size(); ++j)
        ASSERT_FALSE(improper(segments[i].first, segments[i].second, segments[j].first, segments[j].second))
            << "round " << round << ": segments " << i << " and " << j;
  }
}

TEST(Chains, RejectsMalformedMap) {
  EdgeMap bad;
  bad.width = 3;
  bad.height = 3;
  bad.on.resize(4);
  EXPECT_THROW(vectorize::trace_chains(bad), std::invalid_argument);
}

} // namespace
