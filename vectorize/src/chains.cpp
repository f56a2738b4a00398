// Stage 3: chains of edge pixels between endpoints and junctions, linked by m-adjacency (Gonzalez and
// Woods, "Digital Image Processing", section 2.5.2), after removing simple points from 2x2 blocks
// (simple points after Yokoi, Toriwaki and Fukumura, "An analysis of topological properties of
// digitized binary pictures using local features", 1975).
#include "vectorize/chains.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

namespace vectorize {
namespace {

// Neighbour directions counter-clockwise from east (image y grows downwards, so "north" is y - 1).
constexpr std::array<int, 8> kDx = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr std::array<int, 8> kDy = {0, -1, -1, -1, 0, 1, 1, 1};

class Grid {
public:
  explicit Grid(const EdgeMap& edges) : width_(edges.width), height_(edges.height), on_(edges.on) {}
  int width() const { return width_; }
  int height() const { return height_; }
  bool on(int x, int y) const {
    return x >= 0 && y >= 0 && x < width_ && y < height_ && on_[index(x, y)] != 0;
  }
  void clear(int x, int y) { on_[index(x, y)] = 0; }
  std::size_t index(int x, int y) const { return static_cast<std::size_t>(y) * width_ + x; }

  // Yokoi's 8-connectivity number: 1 exactly when removing the pixel changes no connectivity of the
  // set pixels (8-connected) or of the background (4-connected).
  bool simple(int x, int y) const {
    std::array<int, 9> off{};
    for (int k = 0; k < 8; ++k) off[k] = on(x + kDx[k], y + kDy[k]) ? 0 : 1;
    off[8] = off[0];
    int n = 0;
    for (int k = 0; k < 8; k += 2) n += off[k] - off[k] * off[k + 1] * off[(k + 2) % 8];
    return n == 1;
  }

  // m-adjacency: the diagonal link is dropped when the two pixels are also joined through a shared
  // 4-neighbour, which would otherwise make a triangle of links (a false junction).
  bool linked(int x, int y, int k) const {
    const int nx = x + kDx[k];
    const int ny = y + kDy[k];
    if (!on(nx, ny)) return false;
    if (k % 2 == 0) return true;
    return !on(nx, y) && !on(x, ny);
  }

  int degree(int x, int y) const {
    int d = 0;
    for (int k = 0; k < 8; ++k) d += linked(x, y, k) ? 1 : 0;
    return d;
  }

private:
  int width_;
  int height_;
  std::vector<std::uint8_t> on_;
};

// Removes simple pixels from fully set 2x2 blocks until none is left (a sequential thinning restricted
// to the blocks, so lines keep their corners and T junctions keep their centre). Every removal keeps
// the topology, so a block whose four pixels each carry a branch stays (as a small loop).
void thin_blocks(Grid& grid) {
  bool changed = true;
  while (changed) {
    changed = false;
    for (int y = 0; y + 1 < grid.height(); ++y)
      for (int x = 0; x + 1 < grid.width(); ++x) {
        if (!(grid.on(x, y) && grid.on(x + 1, y) && grid.on(x, y + 1) && grid.on(x + 1, y + 1))) continue;
        for (const auto& [px, py] :
             {std::array{x, y}, std::array{x + 1, y}, std::array{x, y + 1}, std::array{x + 1, y + 1}}) {
          if (grid.simple(px, py)) {
            grid.clear(px, py);
            changed = true;
            break;
          }
        }
      }
  }
}

// Removes one-pixel spurs: an end pixel whose only link goes to a junction and whose removal keeps the
// topology. Canny leaves such bumps on lines (often where a 2x2 block was thinned); each would split
// the line at a false junction. One pass only, so that longer branches stay.
void prune_spurs(Grid& grid) {
  for (int y = 0; y < grid.height(); ++y)
    for (int x = 0; x < grid.width(); ++x) {
      if (!grid.on(x, y) || grid.degree(x, y) != 1 || !grid.simple(x, y)) continue;
      for (int k = 0; k < 8; ++k)
        if (grid.linked(x, y, k) && grid.degree(x + kDx[k], y + kDy[k]) >= 3) {
          grid.clear(x, y);
          break;
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
  std::vector<std::uint8_t> degree(static_cast<std::size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (grid.on(x, y)) degree[grid.index(x, y)] = static_cast<std::uint8_t>(grid.degree(x, y));
  // Bit k: the link in direction k has been walked.
  std::vector<std::uint8_t> walked(degree.size(), 0);
  auto mark = [&](int x, int y, int k) {
    walked[grid.index(x, y)] |= static_cast<std::uint8_t>(1u << k);
    walked[grid.index(x + kDx[k], y + kDy[k])] |= static_cast<std::uint8_t>(1u << ((k + 4) % 8));
  };
  auto is_node = [&](int x, int y) { return degree[grid.index(x, y)] != 2; };

  std::vector<Chain> chains;
  // Follows the link k from (x, y) through two-link pixels until a node, or back to the start.
  auto walk = [&](int x, int y, int k, bool closed) {
    Chain chain;
    chain.closed = closed;
    chain.points.push_back({x, y});
    const int sx = x;
    const int sy = y;
    for (;;) {
      mark(x, y, k);
      x += kDx[k];
      y += kDy[k];
      if (closed && x == sx && y == sy) break;
      chain.points.push_back({x, y});
      if (!closed && is_node(x, y)) break;
      const int back = (k + 4) % 8;
      int next = -1;
      for (int j = 0; j < 8; ++j)
        if (j != back && grid.linked(x, y, j)) next = j;
      if (next < 0 || (walked[grid.index(x, y)] & (1u << next))) break; // cannot happen on a valid map
      k = next;
    }
    chains.push_back(std::move(chain));
  };

  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!grid.on(x, y) || !is_node(x, y)) continue;
      for (int k = 0; k < 8; ++k)
        if (grid.linked(x, y, k) && !(walked[grid.index(x, y)] & (1u << k))) walk(x, y, k, false);
    }
  // What is left unwalked are loops of two-link pixels.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!grid.on(x, y) || degree[grid.index(x, y)] != 2 || walked[grid.index(x, y)] != 0) continue;
      for (int k = 0; k < 8; ++k)
        if (grid.linked(x, y, k)) {
          walk(x, y, k, true);
          break;
        }
    }
  return chains;
}

} // namespace vectorize
