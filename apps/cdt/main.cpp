// cdt IN: constrained Delaunay triangulation of a PSLG file, with Triangle's file formats.
// Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"
#include "cdt/io.hpp"
#include "cdt/verify.hpp"

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

namespace fs = std::filesystem;

/// Triangle's output naming: box.poly -> box.1, box.1.node -> box.2.
fs::path default_prefix(const fs::path& input) {
  std::string stem = input.stem().string();
  const auto dot = stem.rfind('.');
  if (dot != std::string::npos && dot + 1 < stem.size()) {
    const std::string tail = stem.substr(dot + 1);
    bool digits = true;
    for (char c : tail) digits = digits && std::isdigit(static_cast<unsigned char>(c));
    if (digits && tail.size() < 9)
      return input.parent_path() / (stem.substr(0, dot) + "." + std::to_string(std::stoi(tail) + 1));
  }
  return input.parent_path() / (stem + ".1");
}

void print_stats(const cdt::Triangulation& t, std::size_t points, std::size_t segments) {
  const auto& s = t.stats;
  std::printf("input: %zu points, %zu segments; output: %zu vertices, %zu triangles\n", points, segments,
              t.vertices.size(), t.triangles.size());
  std::printf("backend %s, grid %u x %u, %llu vertices added at crossings, %llu zero-length segments "
              "ignored\n",
              s.backend.c_str(), s.grid_size, s.grid_size, static_cast<unsigned long long>(s.added_vertices),
              static_cast<unsigned long long>(s.zero_length_segments));
  if (s.attempts > 1) {
    std::printf("mesh made %u times (the crossings added more vertices than there were sites, or one could "
                "not be inserted): the phases sum every attempt\n",
                s.attempts);
  }
  std::printf("%-12s %10s %10s %10s %10s\n", "phase", "ms", "flips", "missing", "rounds");
  for (const auto& p : s.phases) {
    std::printf("%-12s %10.2f %10llu %10llu %10llu\n", p.name.c_str(), p.milliseconds,
                static_cast<unsigned long long>(p.flips), static_cast<unsigned long long>(p.missing),
                static_cast<unsigned long long>(p.iterations));
  }
  std::printf("%-12s %10.2f\n", "total", s.total_milliseconds);
}

} // namespace

int main(int argc, char** argv) {
  cdt::retain_freed_memory(); // large inputs: later phases reuse the pages of earlier ones
  CLI::App app{
      "cdt: constrained Delaunay triangulation of a planar straight-line graph (the gCD algorithm,\n"
      "exact predicates). Reads Triangle's .node and .poly files and the 'nV nE / x y / v1 v2' edge-list\n"
      "format; writes PREFIX.node, PREFIX.ele, PREFIX.neigh and PREFIX.edge like Triangle.",
      "cdt"};
  app.set_version_flag("--version", std::string("cdt ") + TRIXEL_VERSION);
  app.footer("Examples:\n"
             "  cdt box.poly                  writes box.1.node, box.1.ele, box.1.neigh, box.1.edge\n"
             "  cdt coast.txt -o out/coast --verify --stats\n"
             "  cdt lines.poly --crossings reject   fails naming the first two crossing segments\n"
             "\n"
             "Exit status: 0 on success, 1 on failure (including a failed --verify), 2 on bad usage.");
  fs::path input;
  std::string prefix;
  bool verify = false;
  bool stats = false;
  bool quiet = false;
  cdt::Options options;
  const std::map<std::string, cdt::Backend> backends{
      {"auto", cdt::Backend::automatic}, {"cpu", cdt::Backend::cpu}, {"gpu", cdt::Backend::gpu}};
  const std::map<std::string, cdt::CrossingSegments> crossings{{"resolve", cdt::CrossingSegments::resolve},
                                                               {"reject", cdt::CrossingSegments::reject}};
  app.add_option("IN", input, "Input PSLG: .node, .poly, or an edge-list file (any other extension)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-o,--output", prefix,
                 "Output prefix (default: Triangle's naming, IN without extension + .1)");
  app.add_flag("--verify", verify, "Check the result exactly (validity, constraints, Delaunay property)");
  app.add_flag("--stats", stats, "Print the per-phase table: time, flips, missing points, rounds");
  app.add_option("--backend", options.backend, "auto (GPU when present), cpu, or gpu")
      ->transform(CLI::CheckedTransformer(backends, CLI::ignore_case))
      ->default_str("auto");
  app.add_option("--threads", options.threads, "CPU threads, 0 = all")->default_str("0");
  app.add_option("--grid", options.grid_size,
                 "Digital Voronoi grid side m (16..16384), 0 = chosen from the input")
      ->check(CLI::Range(0u, 16384u))
      ->default_str("0");
  app.add_option("--inner-iterations", options.inner_iterations,
                 "Constraint-insertion inner iterations per outer iteration (>= 1)")
      ->check(CLI::Range(1u, 1000u))
      ->default_str("8");
  app.add_option("--crossings", options.crossings,
                 "Crossing segments: resolve (split at the intersection) or reject (error)")
      ->transform(CLI::CheckedTransformer(crossings, CLI::ignore_case))
      ->default_str("resolve");
  app.add_flag("-q,--quiet", quiet, "Print nothing but errors");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }
  if (options.grid_size != 0 && options.grid_size < 16) {
    std::cerr << "cdt: --grid must be 0 (automatic) or at least 16\n";
    return kExitUsage;
  }
  const fs::path out = prefix.empty() ? default_prefix(input) : fs::path(prefix);
  try {
    const cdt::io::Pslg pslg = cdt::io::read_pslg(input);
    // The arrays to come, at most about a kilobyte per point and segment, fault in huge pages.
    cdt::retain_freed_memory(1024 * (pslg.points.size() + pslg.segments.size()));
    const cdt::Triangulation t = cdt::triangulate(pslg.points, pslg.segments, options);
    if (verify) {
      const cdt::VerifyReport report = cdt::verify(t, pslg.points, pslg.segments, options.threads);
      if (!report.ok()) {
        std::cerr << "cdt: " << input.string() << ": verification FAILED with " << report.num_problems
                  << " problem(s):\n";
        for (const auto& p : report.problems) std::cerr << "  " << p << '\n';
        return kExitFailure;
      }
      if (!quiet) std::cout << "verified: valid constrained Delaunay triangulation\n";
    }
    if (!quiet && t.stats.zero_length_segments > 0) {
      std::cerr << "cdt: " << input.string() << ": warning: ignored " << t.stats.zero_length_segments
                << " zero-length segment(s) (--crossings reject makes them an error)\n";
    }
    fs::path node = out, ele = out, neigh = out, edge = out;
    node += ".node";
    ele += ".ele";
    neigh += ".neigh";
    edge += ".edge";
    for (const fs::path& p : {node, ele, neigh, edge}) {
      std::error_code ec;
      if (fs::exists(p, ec) && fs::equivalent(p, input, ec)) {
        std::cerr << "cdt: " << p.string() << " is the input file; choose another -o PREFIX\n";
        return kExitUsage;
      }
    }
    cdt::io::write_node(node, t.vertices, pslg.first_index);
    cdt::io::write_ele(ele, t, pslg.first_index);
    cdt::io::write_neigh(neigh, t, pslg.first_index);
    cdt::io::write_edge(edge, t, pslg.first_index);
    if (stats) print_stats(t, pslg.points.size(), pslg.segments.size());
    if (!quiet) {
      std::cout << "wrote " << node.string() << ", " << ele.string() << ", " << neigh.string() << ", "
                << edge.string() << " (" << t.triangles.size() << " triangles)\n";
    }
    return 0;
  } catch (const cdt::FileError& e) {
    std::cerr << "cdt: " << e.what() << '\n'; // already names the file and line
    return kExitFailure;
  } catch (const cdt::Error& e) {
    std::cerr << "cdt: " << input.string() << ": " << e.what() << '\n';
    return kExitFailure;
  }
}
