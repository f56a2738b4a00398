// Stage 8: trixel grouping (Prasad and Skourikhine 2006, sec. 3). Their perceptual grouping joins
// neighbouring trixels of similar colour unless a detected edge separates them; here the join is a
// union-find over edges in order of colour difference, followed by a small-region cleanup.

#include "vectorize/grouping.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <numeric>
#include <queue>
#include <span>
#include <tuple>
#include <utility>

#include "colour_lab.hpp"
#include "cpu_level.hpp"
#include "parallel.hpp"

namespace vectorize {
namespace {

double colour_distance(const std::array<double, 3>& lab1, float alpha1, const std::array<double, 3>& lab2,
                       float alpha2) {
  const double da = 100.0 * (static_cast<double>(alpha1) - alpha2);
  return delta_e(lab1, lab2) + std::abs(da);
}

// Union-find whose roots carry the region's running totals.
class RegionForest {
public:
  // lab[t]: the CIELAB of trixel t's colour.
  RegionForest(const TrixelColours& trixels, const std::vector<std::array<double, 3>>& lab, unsigned threads)
      : parent_(trixels.size()), totals_(trixels.size()) {
    std::iota(parent_.begin(), parent_.end(), 0u);
    for_each_part(trixels.size(), threads, [&](std::size_t first, std::size_t last, unsigned) {
      for (auto t = static_cast<std::uint32_t>(first); t < last; ++t) init(trixels, lab, t);
    });
  }

  // Triangle t as a region of its own.
  void init(const TrixelColours& trixels, const std::vector<std::array<double, 3>>& lab, std::uint32_t t) {
    Totals& r = totals_[t];
    r.area = trixels[t].area;
    for (int c = 0; c < 3; ++c) r.weighted_rgb[c] = trixels[t].area * trixels[t].rgba[c];
    r.weighted_alpha = trixels[t].area * trixels[t].rgba[3];
    r.triangle_count = 1;
    r.covers_solid = trixels[t].covers_solid;
    r.first_triangle = t;
    r.transparent = trixels[t].transparent();
    // The mean of one triangle is its own colour again (area * c / area rounds back to the float c),
    // whose CIELAB is known; the check keeps the result exact should it not be.
    const std::array<float, 3> mean = rgb(t);
    r.lab = mean == std::array<float, 3>{trixels[t].rgba[0], trixels[t].rgba[1], trixels[t].rgba[2]}
                ? lab[t]
                : srgb_to_lab(mean);
  }

  std::uint32_t find(std::uint32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]]; // path halving
      x = parent_[x];
    }
    return x;
  }

  // Joins two distinct roots; the one with more triangles stays root (keeps the trees shallow). Returns it.
  std::uint32_t unite(std::uint32_t a, std::uint32_t b) {
    if (totals_[a].triangle_count < totals_[b].triangle_count) std::swap(a, b);
    parent_[b] = a;
    Totals& ra = totals_[a];
    const Totals& rb = totals_[b];
    ra.area += rb.area;
    for (int c = 0; c < 3; ++c) ra.weighted_rgb[c] += rb.weighted_rgb[c];
    ra.weighted_alpha += rb.weighted_alpha;
    ra.triangle_count += rb.triangle_count;
    ra.covers_solid = ra.covers_solid || rb.covers_solid;
    ra.first_triangle = std::min(ra.first_triangle, rb.first_triangle);
    ra.lab = srgb_to_lab(rgb(a));
    return a;
  }

  std::array<float, 3> rgb(std::uint32_t root) const {
    const Totals& r = totals_[root];
    std::array<float, 3> out{};
    for (int c = 0; c < 3; ++c) out[c] = r.area > 0 ? static_cast<float>(r.weighted_rgb[c] / r.area) : 0.0f;
    return out;
  }
  float alpha(std::uint32_t root) const {
    const Totals& r = totals_[root];
    return r.area > 0 ? static_cast<float>(r.weighted_alpha / r.area) : 1.0f;
  }
  // Colour distance of two regions: Delta E, with a difference in opacity counted as that many
  // hundredths of lightness (fully opaque against half transparent: 50).
  double distance(std::uint32_t a, std::uint32_t b) const {
    return colour_distance(totals_[a].lab, alpha(a), totals_[b].lab, alpha(b));
  }
  // CIELAB of the mean colour, cached: the join compares it once per candidate edge.
  const std::array<double, 3>& lab(std::uint32_t root) const { return totals_[root].lab; }
  double area(std::uint32_t root) const { return totals_[root].area; }
  std::uint32_t triangle_count(std::uint32_t root) const { return totals_[root].triangle_count; }
  bool covers_solid(std::uint32_t root) const { return totals_[root].covers_solid; }
  std::uint32_t first_triangle(std::uint32_t root) const { return totals_[root].first_triangle; }
  bool transparent(std::uint32_t root) const { return totals_[root].transparent; }

private:
  struct Totals {
    double area = 0.0;
    double weighted_rgb[3] = {0, 0, 0};
    double weighted_alpha = 0.0;
    std::uint32_t triangle_count = 0;
    bool covers_solid = false;
    std::uint32_t first_triangle = 0;
    bool transparent = false;
    std::array<double, 3> lab{};
  };
  std::vector<std::uint32_t> parent_;
  std::vector<Totals> totals_;
};

// A candidate join: the edge `edge` of `triangle` and the colour distance across it.
struct Candidate {
  double distance;
  std::uint32_t triangle;
  std::uint32_t edge;
};

// Sorts by distance, stably: a least-significant-digit radix sort on the distance's bits (a distance is
// finite and >= 0, so its bits order as the number does), 11 bits a pass, skipping a pass whose digit
// is the same for every element. Several times faster than a comparison sort on tens of thousands.
void sort_by_distance(std::vector<Candidate>& items) {
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  std::vector<Candidate> spare(items.size());
  std::vector<std::size_t> start(kBuckets);
  for (int shift = 0; shift < 64; shift += kBits) {
    const auto digit = [shift](const Candidate& c) {
      return static_cast<std::size_t>(std::bit_cast<std::uint64_t>(c.distance) >> shift) & (kBuckets - 1);
    };
    std::fill(start.begin(), start.end(), 0);
    for (const Candidate& c : items) ++start[digit(c)];
    if (std::find(start.begin(), start.end(), items.size()) != start.end()) continue; // one digit
    std::size_t sum = 0;
    for (std::size_t& s : start) sum += std::exchange(s, sum);
    for (const Candidate& c : items) spare[start[digit(c)]++] = c;
    items.swap(spare);
  }
}

// Merges every region smaller than min_area into its closest-colour neighbour of the same transparency.
//
// Only a region below min_area is ever taken from the queue, so only such regions need neighbour lists:
// at the start they are slices of one array (one allocation for all), and when a merged region is still
// small its list is the longer of the two joined with the shorter appended (moved out of the array the
// first time), so that each entry moves O(log n) times. Entries go stale (non-roots, duplicates) and are
// cleaned when read.
void merge_small_regions(const cdt::Triangulation& t, RegionForest& forest, double min_area) {
  const std::size_t n = t.triangles.size();
  // (small root, neighbouring root) for every triangle edge between two regions.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  std::vector<std::size_t> begin(n + 1, 0);
  // The small regions, to be taken smallest first (ties by first triangle): sorted once here, while
  // those that are still small after a merge go to a heap (a few in a hundred).
  using Entry = std::tuple<double, std::uint32_t, std::uint32_t>; // area, first triangle, root
  std::vector<Entry> initial;
  for (std::uint32_t tri = 0; tri < n; ++tri) {
    const std::uint32_t a = forest.find(tri);
    if (forest.area(a) >= min_area) continue;
    if (a == tri) initial.emplace_back(forest.area(tri), forest.first_triangle(tri), tri);
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t other = t.neighbors[tri][i];
      if (other == cdt::kNone) continue;
      const std::uint32_t b = forest.find(other);
      if (a == b) continue;
      pairs.emplace_back(a, b);
      ++begin[a + 1];
    }
  }
  std::sort(initial.begin(), initial.end());
  for (std::size_t r = 0; r < n; ++r) begin[r + 1] += begin[r];
  std::vector<std::size_t> size(n, 0);
  std::vector<std::uint32_t> store(pairs.size());
  for (const auto& [a, b] : pairs) store[begin[a] + size[a]++] = b;
  pairs = {};
  // Lists that outgrew their slice; region r's is grown[owns[r] - 1] where owns[r] is not 0 (few regions
  // have one: a vector per triangle cost more to make and free than the rest of the merge).
  std::vector<std::vector<std::uint32_t>> grown;
  std::vector<std::uint32_t> owns(n, 0);
  const auto list_of = [&](std::uint32_t r) {
    return owns[r] != 0 ? std::span<std::uint32_t>(grown[owns[r] - 1])
                        : std::span(store).subspan(begin[r], size[r]);
  };

  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> again;
  std::size_t next_initial = 0;
  while (next_initial < initial.size() || !again.empty()) {
    Entry entry;
    if (again.empty() || (next_initial < initial.size() && initial[next_initial] < again.top())) {
      entry = initial[next_initial++];
    } else {
      entry = again.top();
      again.pop();
    }
    const auto [area, first, root] = entry;
    // Stale entries: the region was merged away or has grown since it was queued.
    if (forest.find(root) != root || forest.area(root) != area) continue;

    const std::span<std::uint32_t> list = list_of(root);
    for (std::uint32_t& r : list) r = forest.find(r);
    std::sort(list.begin(), list.end());
    auto end = std::unique(list.begin(), list.end());
    end = std::remove(list.begin(), end, root);
    const auto kept = static_cast<std::size_t>(end - list.begin());
    if (owns[root] != 0)
      grown[owns[root] - 1].resize(kept);
    else
      size[root] = kept;

    const auto lab = forest.lab(root);
    std::uint32_t best = cdt::kNone;
    double best_distance = 0.0;
    for (const std::uint32_t r : list.first(kept)) {
      if (forest.transparent(r) != forest.transparent(root)) continue;
      const double d = colour_distance(lab, forest.alpha(root), forest.lab(r), forest.alpha(r));
      if (best == cdt::kNone || d < best_distance ||
          (d == best_distance && forest.first_triangle(r) < forest.first_triangle(best))) {
        best = r;
        best_distance = d;
      }
    }
    if (best == cdt::kNone) continue; // e.g. an opaque speck surrounded by transparency

    const std::uint32_t merged = forest.unite(root, best);
    const std::uint32_t absorbed = merged == root ? best : root;
    if (forest.area(merged) < min_area) { // taken from the queue again: both were small, both have lists
      const std::uint32_t longer = list_of(merged).size() >= list_of(absorbed).size() ? merged : absorbed;
      const std::uint32_t shorter = longer == merged ? absorbed : merged;
      std::vector<std::uint32_t> joined;
      if (owns[longer] != 0) {
        joined = std::move(grown[owns[longer] - 1]);
      } else {
        const auto slice = list_of(longer);
        joined.assign(slice.begin(), slice.end());
      }
      const auto other = list_of(shorter);
      joined.insert(joined.end(), other.begin(), other.end());
      if (owns[merged] == 0) {
        grown.emplace_back();
        owns[merged] = static_cast<std::uint32_t>(grown.size());
      }
      grown[owns[merged] - 1] = std::move(joined);
      again.emplace(forest.area(merged), forest.first_triangle(merged), merged);
    }
    if (owns[absorbed] != 0) grown[owns[absorbed] - 1] = {};
    owns[absorbed] = 0;
    size[absorbed] = 0;
  }
}

} // namespace

std::array<double, 3> srgb_to_lab(const std::array<float, 3>& rgb) {
  std::array<double, 3> lab{};
  detail::lab_of_rgb(rgb.data(), detail::srgb_linear_table(), lab.data());
  return lab;
}

// A plain square root of the sum of squares: CIELAB differences are far from overflow or underflow,
// and std::hypot's scaling costs several divisions per call, at every candidate edge.
double delta_e(const std::array<double, 3>& lab1, const std::array<double, 3>& lab2) {
  const double dl = lab1[0] - lab2[0];
  const double da = lab1[1] - lab2[1];
  const double db = lab1[2] - lab2[2];
  return std::sqrt(dl * dl + da * da + db * db);
}

namespace {

// The CIELAB of trixels [first, last) into lab: lab_of_rgb's operations in the same order (the same
// bits), a block of trixels at a time, each step in a loop of its own over the block so that the
// compiler vectorises the cube roots (one colour at a time, the chains of divisions in them bound the
// loop) and the conversion to XYZ. Where lab_f takes its linear part, its cube root is made and dropped,
// by a mask rather than a branch, which would keep the loop from being vectorised.
void lab_of_trixels(const TrixelColours& trixels, std::size_t first, std::size_t last,
                    std::vector<std::array<double, 3>>& lab) {
  constexpr std::size_t kBlock = 128;
  constexpr double delta = 6.0 / 29.0;
  const double* table = detail::srgb_linear_table();
  alignas(32) double linear[3 * kBlock];
  alignas(32) double xyz[3 * kBlock];
  alignas(32) double f[3 * kBlock];
  for (std::size_t begin = first; begin < last; begin += kBlock) {
    const std::size_t count = std::min(kBlock, last - begin);
    for (std::size_t k = 0; k < count; ++k)
      for (int c = 0; c < 3; ++c)
        linear[3 * k + c] = detail::srgb_to_linear(
            detail::clamp_unit(static_cast<double>(trixels[begin + k].rgba[c])), table);
    for (std::size_t k = 0; k < count; ++k) detail::xyz_of_linear(&linear[3 * k], &xyz[3 * k]);
    for (std::size_t j = 0; j < 3 * count; ++j) f[j] = detail::cube_root_estimate(xyz[j]);
    for (std::size_t j = 0; j < 3 * count; ++j) {
      const double cube = detail::cube_root_refine(xyz[j], f[j]);
      const double below = detail::lab_f_linear(xyz[j]);
      const std::uint64_t take_cube =
          std::uint64_t{0} - static_cast<std::uint64_t>(xyz[j] > delta * delta * delta);
      f[j] = std::bit_cast<double>((std::bit_cast<std::uint64_t>(cube) & take_cube) |
                                   (std::bit_cast<std::uint64_t>(below) & ~take_cube));
    }
    for (std::size_t k = 0; k < count; ++k)
      detail::lab_of_f(f[3 * k], f[3 * k + 1], f[3 * k + 2], lab[begin + k].data());
  }
}

Regions group_all(const cdt::Triangulation& t, const TrixelColours& trixels, const GroupingOptions& options,
                  unsigned threads, const TrixelLab* known) {
  const std::size_t n = t.triangles.size();
  // Each thread takes a contiguous run of triangles; two per thread at the least, or it is not worth it.
  const auto parts = static_cast<unsigned>(
      std::min<std::size_t>(resolve_threads(threads), std::max<std::size_t>(1, n / 8192)));
  const bool given = known != nullptr && known->size() == n;
  std::vector<std::array<double, 3>> lab(n);
  for_each_part(n, parts, [&](std::size_t first, std::size_t last, unsigned) {
    if (!given) return lab_of_trixels(trixels, first, last, lab);
    for (std::size_t tri = first; tri < last; ++tri)
      lab[tri] = !std::isnan((*known)[tri][0])
                     ? (*known)[tri]
                     : srgb_to_lab({trixels[tri].rgba[0], trixels[tri].rgba[1], trixels[tri].rgba[2]});
  });
  RegionForest forest(trixels, lab, parts);

  // Transparent trixels join each other, in triangle order.
  for (std::uint32_t tri = 0; tri < n; ++tri) {
    if (!trixels[tri].transparent()) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t other = t.neighbors[tri][i];
      if (other == cdt::kNone || other < tri || !trixels[other].transparent()) continue;
      const std::uint32_t ra = forest.find(tri);
      const std::uint32_t rb = forest.find(other);
      if (ra != rb) forest.unite(ra, rb);
    }
  }

  // The candidate edges between opaque trixels, each interior edge once, sorted by Delta E, ties in
  // (triangle, edge) order: listed per thread for a run of triangles, the runs joined in order, then
  // sorted stably by distance.
  std::vector<std::vector<Candidate>> runs(parts);
  for_each_part(n, parts, [&](std::size_t first, std::size_t last, unsigned k) {
    std::vector<Candidate>& run = runs[k];
    for (auto tri = static_cast<std::uint32_t>(first); tri < last; ++tri)
      for (std::uint32_t i = 0; i < 3; ++i) {
        const std::uint32_t other = t.neighbors[tri][i];
        if (other == cdt::kNone || other < tri) continue;
        if (trixels[tri].transparent() || trixels[other].transparent() ||
            t.segment_of_edge[tri][i] != cdt::kNone)
          continue;
        run.push_back(
            {colour_distance(lab[tri], trixels[tri].rgba[3], lab[other], trixels[other].rgba[3]), tri, i});
      }
  });
  std::vector<Candidate> candidates = std::move(runs[0]);
  for (unsigned k = 1; k < parts; ++k) candidates.insert(candidates.end(), runs[k].begin(), runs[k].end());
  sort_by_distance(candidates);
  for (const Candidate& c : candidates) {
    const std::uint32_t a = forest.find(c.triangle);
    const std::uint32_t b = forest.find(t.neighbors[c.triangle][c.edge]);
    if (a == b) continue;
    if (forest.distance(a, b) <= options.colour_tolerance) forest.unite(a, b);
  }

  if (options.min_region_area > 0) merge_small_regions(t, forest, options.min_region_area);

  Regions out;
  out.region_of_triangle.assign(n, cdt::kNone);
  std::vector<std::uint32_t> id_of_root(n, cdt::kNone);
  for (std::uint32_t tri = 0; tri < n; ++tri) {
    const std::uint32_t root = forest.find(tri);
    if (id_of_root[root] == cdt::kNone) {
      id_of_root[root] = static_cast<std::uint32_t>(out.regions.size());
      out.regions.push_back({forest.rgb(root), forest.area(root), forest.triangle_count(root),
                             forest.transparent(root), forest.alpha(root), forest.covers_solid(root)});
    }
    out.region_of_triangle[tri] = id_of_root[root];
  }
  return out;
}

#if TRIXEL_HAVE_V3_LOOPS
TRIXEL_V3_CLONE Regions group_all_v3(const cdt::Triangulation& t, const TrixelColours& trixels,
                                     const GroupingOptions& options, unsigned threads,
                                     const TrixelLab* known) {
  return group_all(t, trixels, options, threads, known);
}
#endif

} // namespace

Regions group_trixels(const cdt::Triangulation& t, const TrixelColours& trixels,
                      const GroupingOptions& options, unsigned threads, const TrixelLab* known) {
#if TRIXEL_HAVE_V3_LOOPS
  if (detail::v3_loops()) return group_all_v3(t, trixels, options, threads, known);
#endif
  return group_all(t, trixels, options, threads, known);
}

} // namespace vectorize
