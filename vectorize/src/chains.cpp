// Stage 3: chains of edge pixels between endpoints and junctions, linked by m-adjacency (Gonzalez and
// Woods, "Digital Image Processing", section 2.5.2), after removing simple points from 2x2 blocks
// (simple points after Yokoi, Toriwaki and Fukumura, "An analysis of topological properties of
// digitized binary pictures using local features", 1975).
#include "vectorize/chains.hpp"

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace vectorize {
namespace {

// Neighbour directions counter-clockwise from east (image y grows downwards, so "north" is y - 1).
constexpr std::array<int, 8> kDx = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr std::array<int, 8> kDy = {0, -1, -1, -1, 0, 1, 1, 1};

// Per ring of 8 neighbours (bit k: direction k on): Yokoi's simple-pixel test and the m-adjacency links.
struct RingTables {
  std::array<std::uint8_t, 256> simple{};
  std::array<std::uint8_t, 256> links{};
};

constexpr RingTables make_ring_tables() {
  RingTables t;
  for (int mask = 0; mask < 256; ++mask) {
    const auto bit = [&](int k) { return (mask >> (k % 8)) & 1; };
    int n = 0;
    for (int k = 0; k < 8; k += 2) {
      const int off0 = 1 - bit(k);
      n += off0 - off0 * (1 - bit(k + 1)) * (1 - bit(k + 2));
    }
    t.simple[mask] = n == 1 ? 1 : 0;
    int links = 0;
    for (int k = 0; k < 8; ++k)
      if (bit(k) != 0 && (k % 2 == 0 || (bit(k + 7) == 0 && bit(k + 1) == 0))) links |= 1 << k;
    t.links[mask] = static_cast<std::uint8_t>(links);
  }
  return t;
}
constexpr RingTables kTables = make_ring_tables();

// The number of links (kTables.links) of a pixel with this ring, in operations on bytes only, so that
// a loop over a row of rings is vectorised.
std::uint8_t link_count(std::uint8_t ring) {
  const auto before =
      static_cast<std::uint8_t>(static_cast<std::uint8_t>(ring << 1) | ring >> 7); // bit k: ring bit k - 1
  const auto after =
      static_cast<std::uint8_t>(ring >> 1 | static_cast<std::uint8_t>(ring << 7)); // bit k: ring bit k + 1
  const auto links = static_cast<std::uint8_t>((ring & 0x55) | (ring & 0xaa & ~before & ~after));
  auto count = static_cast<std::uint8_t>(links - ((links >> 1) & 0x55));
  count = static_cast<std::uint8_t>((count & 0x33) + ((count >> 2) & 0x33));
  return static_cast<std::uint8_t>((count + (count >> 4)) & 0x0f);
}

// The edge pixels with a border of clear pixels around them, so that a pixel's neighbours are read
// without bounds checks: on(x, y) for -1 <= x <= width, -1 <= y <= height.
class Grid {
public:
  explicit Grid(const EdgeMap& edges)
      : width_(edges.width), height_(edges.height), stride_(static_cast<std::size_t>(edges.width) + 2),
        on_(stride_ * (static_cast<std::size_t>(edges.height) + 2), 0), ring_(on_.size(), 0),
        degree_(on_.size(), kClearDegree) {
    for (int y = 0; y < height_; ++y) {
      const auto* from = edges.on.data() + static_cast<std::size_t>(y) * width_;
      std::uint8_t* to = on_.data() + index(0, y);
      for (int x = 0; x < width_; ++x) to[x] = from[x] != 0 ? 1 : 0;
    }
    // Row by row without branches, so that the compiler vectorises it.
    for (int y = 0; y < height_; ++y) {
      const std::uint8_t* above = row(y - 1);
      const std::uint8_t* here = row(y);
      const std::uint8_t* below = row(y + 1);
      std::uint8_t* ring = ring_.data() + index(0, y);
      for (int x = 0; x < width_; ++x)
        ring[x] = static_cast<std::uint8_t>(here[x + 1] | above[x + 1] << 1 | above[x] << 2 |
                                            above[x - 1] << 3 | here[x - 1] << 4 | below[x - 1] << 5 |
                                            below[x] << 6 | below[x + 1] << 7);
    }
    for (int y = 0; y < height_; ++y) {
      const std::uint8_t* here = row(y);
      const std::uint8_t* ring = ring_.data() + index(0, y);
      std::uint8_t* degree = degree_.data() + index(0, y);
      for (int x = 0; x < width_; ++x) {
        const auto set = static_cast<std::uint8_t>(-here[x]); // all ones or none
        degree[x] = static_cast<std::uint8_t>((link_count(ring[x]) & set) | (kClearDegree & ~set));
      }
    }
  }
  int width() const { return width_; }
  int height() const { return height_; }
  bool on(int x, int y) const { return on_[index(x, y)] != 0; }
  void clear(int x, int y) {
    on_[index(x, y)] = 0;
    degree_[index(x, y)] = kClearDegree;
    for (int k = 0; k < 8; ++k) {
      const std::size_t i = index(x + kDx[k], y + kDy[k]);
      ring_[i] &= static_cast<std::uint8_t>(~(1u << ((k + 4) % 8)));
      if (on_[i] != 0) degree_[i] = static_cast<std::uint8_t>(std::popcount(kTables.links[ring_[i]]));
    }
  }
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y + 1) * stride_ + static_cast<std::size_t>(x + 1);
  }
  // Row y's flags, x = 0 first (x = -1 and x = width readable).
  const std::uint8_t* row(int y) const { return on_.data() + index(0, y); }
  // Row y's numbers of links (see degree_), x = 0 first.
  const std::uint8_t* degree_row(int y) const { return degree_.data() + index(0, y); }
  std::size_t size() const { return on_.size(); }

  // Bit k set when the neighbour in direction k is on.
  std::uint8_t ring(int x, int y) const { return ring_[index(x, y)]; }

  // Yokoi's 8-connectivity number: 1 exactly when removing the pixel changes no connectivity of the
  // set pixels (8-connected) or of the background (4-connected).
  bool simple(int x, int y) const { return kTables.simple[ring(x, y)] != 0; }

  // m-adjacency: the diagonal link is dropped when the two pixels are also joined through a shared
  // 4-neighbour, which would otherwise make a triangle of links (a false junction).
  bool linked(int x, int y, int k) const { return (kTables.links[ring(x, y)] >> k & 1) != 0; }
  // The links of pixel (x, y) as bits by direction.
  std::uint8_t links(int x, int y) const { return kTables.links[ring(x, y)]; }
  // The links of the pixel at index(x, y) = i.
  std::uint8_t links_at(std::size_t i) const { return kTables.links[ring_[i]]; }
  int degree(int x, int y) const { return std::popcount(links(x, y)); }

private:
  int width_;
  int height_;
  std::size_t stride_;
  std::vector<std::uint8_t> on_;
  // Every pixel's ring (see ring()), kept as pixels are cleared: a pixel's ring is asked for several
  // times (thinning, pruning, linking, walking), and kept it is one read rather than eight.
  std::vector<std::uint8_t> ring_;
  // Every pixel's number of links, kept likewise, so that ends and nodes are found eight pixels at a
  // time; a clear pixel's is that of a pixel inside a chain (neither an end nor a node), so that those
  // searches need not look at on_.
  static constexpr std::uint8_t kClearDegree = 2;
  std::vector<std::uint8_t> degree_;
};

// The first x in [from, width) whose byte in `row` is `value` (or, with `other`, is not), or width:
// eight bytes at a time.
int next_byte(const std::uint8_t* row, int from, int width, std::uint8_t value, bool other) {
  int x = from;
  if constexpr (std::endian::native == std::endian::little) {
    constexpr std::uint64_t kLow7 = 0x7f7f7f7f7f7f7f7fu;
    const std::uint64_t wanted = 0x0101010101010101u * value;
    for (; x + 8 <= width; x += 8) {
      std::uint64_t word = 0;
      std::memcpy(&word, row + x, sizeof word);
      word ^= wanted;
      // The high bit of each byte: whether it differs from value (exact, no carry between bytes).
      std::uint64_t found = (((word & kLow7) + kLow7) | word) & ~kLow7;
      if (!other) found ^= ~kLow7;
      if (found != 0) return x + std::countr_zero(found) / 8;
    }
  }
  while (x < width && (row[x] == value) == other) ++x;
  return x;
}

// The first x in [from, width) whose flag in `on` is set and whose `walked` byte is 0, or width: eight
// pixels at a time, since almost every set pixel has been walked by the time this is asked.
int next_unwalked(const std::uint8_t* on, const std::uint8_t* walked, int from, int width) {
  int x = from;
  if constexpr (std::endian::native == std::endian::little) {
    constexpr std::uint64_t kLow7 = 0x7f7f7f7f7f7f7f7fu;
    constexpr std::uint64_t kHigh = 0x8080808080808080u;
    for (; x + 8 <= width; x += 8) {
      std::uint64_t set = 0;
      std::uint64_t marks = 0;
      std::memcpy(&set, on + x, sizeof set);
      std::memcpy(&marks, walked + x, sizeof marks);
      // The high bit of each byte: whether its walked byte is nonzero (exact, no carry between bytes).
      const std::uint64_t marked = (((marks & kLow7) + kLow7) | marks) & kHigh;
      const std::uint64_t found = (set << 7) & ~marked & kHigh;
      if (found != 0) return x + std::countr_zero(found) / 8;
    }
  }
  while (x < width && (on[x] == 0 || walked[x] != 0)) ++x;
  return x;
}

// The first x in [from, last) where the 2x2 block of rows `upper` and `lower` at columns x and x + 1 is
// fully set, or last (from, when that is past last): eight blocks at a time.
int next_full(const std::uint8_t* upper, const std::uint8_t* lower, int from, int last) {
  int x = from;
  if constexpr (std::endian::native == std::endian::little) {
    for (; x + 8 <= last; x += 8) {
      std::array<std::uint64_t, 4> words{};
      std::memcpy(&words[0], upper + x, sizeof words[0]);
      std::memcpy(&words[1], upper + x + 1, sizeof words[1]);
      std::memcpy(&words[2], lower + x, sizeof words[2]);
      std::memcpy(&words[3], lower + x + 1, sizeof words[3]);
      const std::uint64_t found = words[0] & words[1] & words[2] & words[3];
      if (found != 0) return x + std::countr_zero(found) / 8;
    }
  }
  while (x < last && (upper[x] & upper[x + 1] & lower[x] & lower[x + 1]) == 0) ++x;
  return x;
}

// Removes simple pixels from fully set 2x2 blocks until none is left (a sequential thinning restricted
// to the blocks, so lines keep their corners and T junctions keep their centre). Every removal keeps
// the topology, so a block whose four pixels each carry a branch stays (as a small loop).
void thin_blocks(Grid& grid) {
  // Removes the first simple pixel of the full block at (x, y); false when none is simple.
  const auto thin = [&](int x, int y) {
    for (const auto& [px, py] :
         {std::array{x, y}, std::array{x + 1, y}, std::array{x, y + 1}, std::array{x + 1, y + 1}}) {
      if (grid.simple(px, py)) {
        grid.clear(px, py);
        return true;
      }
    }
    return false;
  };
  const auto full = [&](int x, int y) {
    const std::uint8_t* upper = grid.row(y);
    const std::uint8_t* lower = grid.row(y + 1);
    return (upper[x] & upper[x + 1] & lower[x] & lower[x + 1]) != 0;
  };
  // Pixels are only ever cleared, so a block that is not full, or was thinned, stays so: a pass after
  // the first only has the blocks that stayed full in the pass before to look at, in the same order.
  std::vector<std::array<int, 2>> stuck;
  bool changed = false;
  for (int y = 0; y + 1 < grid.height(); ++y) {
    const std::uint8_t* upper = grid.row(y);
    const std::uint8_t* lower = grid.row(y + 1);
    const int last = grid.width() - 1; // blocks at x < last
    // Read again from x + 1 after each block: thinning one clears pixels of the next.
    for (int x = next_full(upper, lower, 0, last); x < last; x = next_full(upper, lower, x + 1, last)) {
      if (thin(x, y))
        changed = true;
      else
        stuck.push_back({x, y});
    }
  }
  std::vector<std::array<int, 2>> still_stuck;
  while (changed) {
    changed = false;
    still_stuck.clear();
    for (const auto& [x, y] : stuck) {
      if (!full(x, y)) continue;
      if (thin(x, y))
        changed = true;
      else
        still_stuck.push_back({x, y});
    }
    stuck.swap(still_stuck);
  }
}

// Removes one-pixel spurs: an end pixel whose only link goes to a junction and whose removal keeps the
// topology. Canny leaves such bumps on lines (often where a 2x2 block was thinned); each would split
// the line at a false junction. One pass only, so that longer branches stay.
void prune_spurs(Grid& grid) {
  for (int y = 0; y < grid.height(); ++y) {
    const std::uint8_t* degree = grid.degree_row(y);
    // Read again from x + 1 after each pixel: clearing one changes its neighbours' numbers of links.
    for (int x = next_byte(degree, 0, grid.width(), 1, false); x < grid.width();
         x = next_byte(degree, x + 1, grid.width(), 1, false)) {
      if (!grid.simple(x, y)) continue;
      for (int k = 0; k < 8; ++k)
        if (grid.linked(x, y, k) && grid.degree(x + kDx[k], y + kDy[k]) >= 3) {
          grid.clear(x, y);
          break;
        }
    }
  }
}

} // namespace

std::vector<Chain> trace_chains(const EdgeMap& edges) {
  if (edges.width < 0 || edges.height < 0 ||
      edges.on.size() != static_cast<std::size_t>(edges.width) * edges.height)
    throw std::invalid_argument("trace_chains: edges.on must hold width * height values");
  Grid grid(edges);
  thin_blocks(grid);
  prune_spurs(grid);

  const int w = grid.width();
  const int h = grid.height();
  // Bit k: the link in direction k has been walked.
  std::vector<std::uint8_t> walked(grid.size(), 0);
  // The walk goes by index: the step in direction k.
  std::array<std::ptrdiff_t, 8> step{};
  for (int k = 0; k < 8; ++k)
    step[k] = static_cast<std::ptrdiff_t>(grid.index(1 + kDx[k], 1 + kDy[k])) -
              static_cast<std::ptrdiff_t>(grid.index(1, 1));
  // An end or a junction, by its links.
  auto is_node = [](std::uint8_t links) { return std::popcount(links) != 2; };

  std::vector<Chain> chains;
  // A chain's points are collected here, then copied at their size: one allocation per chain rather
  // than one per doubling (an image has thousands of chains).
  std::vector<PixelPoint> points;
  // Follows the link k from (x, y) through two-link pixels until a node, or back to the start.
  auto walk = [&](int x, int y, int k, bool closed) {
    points.clear();
    points.push_back({x, y});
    const std::size_t start = grid.index(x, y);
    std::size_t i = start;
    for (;;) {
      walked[i] |= static_cast<std::uint8_t>(1u << k);
      i += static_cast<std::size_t>(step[k]);
      walked[i] |= static_cast<std::uint8_t>(1u << ((k + 4) % 8));
      x += kDx[k];
      y += kDy[k];
      if (closed && i == start) break;
      points.push_back({x, y});
      const std::uint8_t links = grid.links_at(i);
      if (!closed && is_node(links)) break;
      const int back = (k + 4) % 8;
      // The highest other link.
      const unsigned others = links & ~(1u << back) & 0xffu;
      const int next = others == 0 ? -1 : std::bit_width(others) - 1;
      if (next < 0 || (walked[i] & (1u << next))) break; // cannot happen on a valid map
      k = next;
    }
    chains.push_back({std::vector<PixelPoint>(points.begin(), points.end()), closed});
  };

  for (int y = 0; y < h; ++y) {
    const std::uint8_t* degree = grid.degree_row(y);
    for (int x = next_byte(degree, 0, w, 2, true); x < w; x = next_byte(degree, x + 1, w, 2, true)) {
      const std::uint8_t links = grid.links(x, y);
      for (int k = 0; k < 8; ++k)
        if ((links >> k & 1) != 0 && !(walked[grid.index(x, y)] & (1u << k))) walk(x, y, k, false);
    }
  }
  // What is left unwalked are loops of two-link pixels.
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* on = grid.row(y);
    const std::uint8_t* walked_row = walked.data() + grid.index(0, y);
    for (int x = next_unwalked(on, walked_row, 0, w); x < w; x = next_unwalked(on, walked_row, x + 1, w)) {
      if (is_node(grid.links(x, y))) continue;
      for (int k = 0; k < 8; ++k)
        if (grid.linked(x, y, k)) {
          walk(x, y, k, true);
          break;
        }
    }
  }
  return chains;
}

} // namespace vectorize
