// Each stage of the vectorize pipeline timed on its own, on one core: every image is converted once
// (CPU backend) to record its stages' inputs, then each stage's function runs again on them, the best
// of --repeat runs kept. Prints per-image means in milliseconds as Markdown table rows, and a hash of
// the images' SVGs (FNV-1a), so that two builds can be compared for speed and for identical output.
//
// usage: bench_stages [--preset logo|illustration|photo] [--repeat N] [--only STAGE,...] IMAGE...
//        stages: decode edges chains simplify pslg cdt trixels grouping polygons svg

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <string>
#include <vector>

#include "vectorize/pipeline.hpp"

namespace {

const std::vector<std::string> kStages = {"decode", "edges",   "chains",   "simplify", "pslg",
                                          "cdt",    "trixels", "grouping", "polygons", "svg"};

double best_ms(int repeat, const std::function<void()>& run) {
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    run();
    best = std::min(
        best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

std::uint64_t fnv1a(std::uint64_t hash, const std::string& bytes) {
  for (const unsigned char c : bytes) hash = (hash ^ c) * 0x100000001b3ull;
  return hash;
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_stages [--preset logo|illustration|photo] [--repeat N] [--only STAGE,...] "
               "IMAGE...\n");
  return 2;
}

} // namespace

int main(int argc, char** argv) {
  using namespace vectorize;
  std::string preset = "illustration";
  int repeat = 5;
  std::vector<std::string> only;
  std::vector<std::string> images;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "--preset" || arg == "--repeat" || arg == "--only") && i + 1 == argc) return usage();
    if (arg == "--preset") {
      preset = argv[++i];
    } else if (arg == "--repeat") {
      repeat = std::atoi(argv[++i]);
      if (repeat < 1) return usage();
    } else if (arg == "--only") {
      const std::string list = argv[++i];
      for (std::size_t at = 0; at <= list.size();) {
        const std::size_t comma = std::min(list.find(',', at), list.size());
        only.push_back(list.substr(at, comma - at));
        at = comma + 1;
      }
      for (const std::string& stage : only)
        if (std::find(kStages.begin(), kStages.end(), stage) == kStages.end()) return usage();
    } else if (arg.starts_with("-")) {
      return usage();
    } else {
      images.push_back(arg);
    }
  }
  if (images.empty()) return usage();
  const auto wanted = [&](const std::string& stage) {
    return only.empty() || std::find(only.begin(), only.end(), stage) != only.end();
  };

  try {
    Options options = preset_options(parse_preset(preset));
    options.threads = 1;
    options.backend = cdt::Backend::cpu;
    cdt::Options cdt_options;
    cdt_options.backend = cdt::Backend::cpu;
    cdt_options.threads = 1;
    std::vector<double> total(kStages.size(), 0.0);
    std::uint64_t hash = 0xcbf29ce484222325ull;
    for (const std::string& path : images) {
      Image image;
      const double decode = best_ms(wanted("decode") ? repeat : 1, [&] { image = load_image(path); });
      StageRecord record;
      const Conversion conversion = convert(image, options, &record);
      hash = fnv1a(hash, conversion.svg);
      const PointPlacement placement{image};
      const std::vector<std::function<void()>> runs = {
          [] {},
          [&] { (void)detect_edges(image, options.edges, 1, EdgeDevice::cpu); },
          [&] { (void)trace_chains(record.edges); },
          [&] { (void)simplify_chains(record.chains, options.simplify_tolerance_px, placement, 1); },
          [&] {
            (void)build_pslg(record.polylines, image.width, image.height, image, options.interior, placement);
          },
          [&] { (void)cdt::triangulate(record.pslg.points, record.pslg.segments, cdt_options); },
          [&] { (void)colour_trixels(image, record.triangulation, 1, TrixelDevice::cpu); },
          [&] { (void)group_trixels(record.triangulation, record.trixels, options.grouping, 1); },
          [&] { (void)trace_polygons(record.triangulation, record.regions, TransparentRegions::include); },
          [&] {
            (void)svg_document(record.polygons, record.regions, image.width, image.height, options.svg);
          },
      };
      total[0] += decode;
      for (std::size_t s = 1; s < kStages.size(); ++s)
        if (wanted(kStages[s])) total[s] += best_ms(repeat, runs[s]);
    }
    std::printf("| images | preset | best of |");
    for (const std::string& stage : kStages)
      if (wanted(stage)) std::printf(" %s |", stage.c_str());
    std::printf(" SVGs' hash |\n| --- | --- | --- |");
    for (const std::string& stage : kStages)
      if (wanted(stage)) std::printf(" --- |");
    std::printf(" --- |\n| %zu | %s | %d |", images.size(), preset.c_str(), repeat);
    for (std::size_t s = 0; s < kStages.size(); ++s)
      if (wanted(kStages[s])) std::printf(" %.2f |", total[s] / static_cast<double>(images.size()));
    std::printf(" %016llx |\n", static_cast<unsigned long long>(hash));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_stages: %s\n", e.what());
    return 1;
  }
  return 0;
}
