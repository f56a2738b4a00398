// cdt IN: constrained Delaunay triangulation of a PSLG file, with Triangle's file formats.
// Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <system_error>
#include <vector>

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

/// The files a run reads: the input, and for a .poly its .node, where a .poly of no vertices takes them
/// from.
std::vector<fs::path> inputs_of(const fs::path& input) {
  std::vector<fs::path> inputs = {input};
  if (input.extension() == ".poly") inputs.push_back(fs::path(input).replace_extension(".node"));
  return inputs;
}

/// Writes PREFIX.node, .ele, .neigh and .edge, all or none: each first to a part file beside it, then
/// every part renamed into place once all four are written. A part already written is removed when a
/// later one fails.
void write_outputs(const std::array<fs::path, 4>& paths, const cdt::Triangulation& t, unsigned first_index) {
  for (const fs::path& p : paths) {
    std::error_code ec;
    if (fs::is_directory(p, ec)) throw cdt::FileError(p.string(), 0, p.string() + ": is a directory");
  }
  std::array<fs::path, 4> parts;
  struct RemoveParts {
    std::array<fs::path, 4>& parts;
    ~RemoveParts() {
      for (const fs::path& p : parts) {
        std::error_code ec;
        if (!p.empty()) fs::remove(p, ec);
      }
    }
  } remove_parts{parts};
  const auto part = [&](std::size_t k) {
    fs::path p = paths[k];
    p += ".part";
    parts[k] = p;
    return p;
  };
  cdt::io::write_node(part(0), t.vertices, first_index);
  cdt::io::write_ele(part(1), t, first_index);
  cdt::io::write_neigh(part(2), t, first_index);
  cdt::io::write_edge(part(3), t, first_index);
  for (std::size_t k = 0; k < paths.size(); ++k) {
    std::error_code ec;
    fs::rename(parts[k], paths[k], ec);
    if (ec) {
      throw cdt::FileError(paths[k].string(), 0,
                           paths[k].string() + ": cannot rename " + parts[k].string() +
                               " to it: " + ec.message());
    }
    parts[k].clear();
  }
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
                "not be inserted, or the split of the suspect segments alone missed one: every segment was "
                "split first then): the phases sum every attempt\n",
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
    std::array<fs::path, 4> files = {out, out, out, out};
    files[0] += ".node";
    files[1] += ".ele";
    files[2] += ".neigh";
    files[3] += ".edge";
    const auto& [node, ele, neigh, edge] = files;
    for (const fs::path& p : files) {
      for (const fs::path& read : inputs_of(input)) {
        std::error_code ec;
        if (fs::exists(p, ec) && fs::equivalent(p, read, ec)) {
          std::cerr << "cdt: " << p.string()
                    << (read == input
                            ? " is the input file"
                            : " may be read with the input (a .poly of no vertices takes them from it)")
                    << "; choose another -o PREFIX\n";
          return kExitUsage;
        }
      }
    }
    write_outputs(files, t, pslg.first_index);
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
