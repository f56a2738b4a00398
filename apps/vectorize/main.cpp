// vectorize IN OUT.svg: raster image to SVG through edges, a constrained Delaunay triangulation and
// trixel grouping. Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <system_error>

#include "cdt/errors.hpp"
#include "vectorize/errors.hpp"
#include "vectorize/image.hpp"
#include "vectorize/pipeline.hpp"

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  if (std::filesystem::equivalent(a, b, ec)) return true;
  return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

void print_stats_text(const vectorize::Stats& s, const std::filesystem::path& input) {
  std::fprintf(stderr, "%s: %d x %d px\n", input.string().c_str(), s.width, s.height);
  std::fprintf(stderr, "  edge pixels %zu, chains %zu, PSLG %zu points / %zu segments\n", s.edge_pixels,
               s.chains, s.points, s.segments);
  std::fprintf(stderr, "  triangles %zu (cdt on %s), regions %zu, paths %zu, %zu bytes\n", s.triangles,
               s.cdt_backend.c_str(), s.regions, s.paths, s.bytes);
  std::fprintf(stderr, "  %-10s %10s\n", "stage", "ms");
  for (const auto& stage : s.stages)
    std::fprintf(stderr, "  %-10s %10.2f\n", stage.name.c_str(), stage.milliseconds);
  std::fprintf(stderr, "  %-10s %10.2f\n", "total", s.total_milliseconds);
}

} // namespace

int main(int argc, char** argv) {
  CLI::App app{"vectorize: convert a raster image (PNG, JPEG, TIFF, BMP, WebP, ...) into an SVG of coloured\n"
               "polygons, through edge detection, a constrained Delaunay triangulation of the edge map and\n"
               "grouping of its triangles (trixels) by colour. Transparent areas (alpha < 0.5) stay empty.",
               "vectorize"};
  app.set_version_flag("--version", std::string("vectorize ") + TRIXEL_VERSION);
  app.footer("Presets set every knob; the options after --preset adjust it.\n"
             "  logo          flat colours, crisp shapes (no interior points, broad colour merging)\n"
             "  illustration  flat areas with some shading (default)\n"
             "  photo         smooth shading everywhere (dense interior points, fine colour tolerance)\n"
             "\n"
             "Examples:\n"
             "  vectorize samples/logo.png logo.svg --preset logo\n"
             "  vectorize photo.jpg photo.svg --preset photo --stats\n"
             "  vectorize scan.png scan.svg --colour-tolerance 6 --min-area 20 --simplify 1.5\n"
             "  vectorize icon.png icon.svg --stats json -q\n"
             "\n"
             "Exit status: 0 on success, 1 on failure (the message names the file and the reason), 2 on bad\n"
             "usage. The output is written to a temporary file and renamed, so a failure leaves no partial\n"
             "file, and OUT may not be IN.");

  std::filesystem::path input;
  std::filesystem::path output;
  std::string preset_name = "illustration";
  std::optional<double> colour_tolerance, min_area, simplify, blur, edge_low, edge_high, seam_width;
  std::optional<int> detail, precision;
  std::string backend_name = "auto";
  bool no_seams = false;
  std::string stats_format;
  bool quiet = false;
  bool verbose = false;
  app.add_option("IN", input, "Input raster image")->required();
  app.add_option("OUT", output, "Output SVG file")->required();
  app.add_option("-p,--preset", preset_name, "Starting point: logo, illustration or photo")
      ->check(CLI::IsMember({"logo", "illustration", "photo"}))
      ->capture_default_str();
  app.add_option("-c,--colour-tolerance,--color-tolerance", colour_tolerance,
                 "Largest colour difference (CIELAB Delta E) joined into one region; larger = fewer, "
                 "flatter regions")
      ->check(CLI::Range(0.0, 200.0));
  app.add_option("--min-area", min_area, "Regions smaller than this (square pixels) merge into a neighbour")
      ->check(CLI::Range(0.0, 1e9));
  app.add_option("-s,--simplify", simplify, "Edge simplification tolerance, pixels")
      ->check(CLI::Range(0.0, 100.0));
  app.add_option("-d,--detail", detail,
                 "Interior-point grid cell, pixels: smaller follows shading more closely; 0 = none")
      ->check(CLI::Range(0, 10000));
  app.add_option("--blur", blur, "Gaussian blur before edge detection, sigma in pixels; 0 = none")
      ->check(CLI::Range(0.0, 50.0));
  app.add_option("--edge-low", edge_low, "Canny low threshold (Sobel units on 8-bit values); 0 = automatic")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--edge-high", edge_high, "Canny high threshold; 0 = automatic")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--precision", precision, "Decimal places of SVG coordinates")->check(CLI::Range(0, 6));
  app.add_flag("--no-seams", no_seams,
               "Do not stroke regions to hide the hairline cracks anti-aliasing renderers show between them");
  app.add_option("--seam-width", seam_width, "Width of the seam-hiding stroke, pixels")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--backend", backend_name, "CDT engine: auto (GPU when present), cpu or gpu")
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
      ->capture_default_str();
  app.add_option("--stats", stats_format, "Print per-stage times and counts to stderr: text or json")
      ->expected(0, 1)
      ->default_str("text")
      ->check(CLI::IsMember({"text", "json"}));
  app.add_flag("-q,--quiet", quiet, "Print nothing but errors (and --stats)");
  app.add_flag("-v,--verbose", verbose, "Say what was written");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }
  if (app.count("--stats") > 0 && stats_format.empty()) stats_format = "text";

  if (same_file(input, output)) {
    std::cerr << "vectorize: refusing to overwrite the input " << input << " with the output\n";
    return kExitUsage;
  }
  const auto out_dir = output.has_parent_path() ? output.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(out_dir, ec)) {
    std::cerr << "vectorize: " << output.string() << ": output directory " << out_dir << " does not exist\n";
    return kExitFailure;
  }

  vectorize::Options options = vectorize::preset_options(vectorize::parse_preset(preset_name));
  if (colour_tolerance) options.grouping.colour_tolerance = *colour_tolerance;
  if (min_area) options.grouping.min_region_area = *min_area;
  if (simplify) options.simplify_tolerance_px = *simplify;
  if (detail) options.interior.cell_size_px = *detail;
  if (blur) options.edges.blur_sigma_px = *blur;
  if (edge_low) options.edges.low = *edge_low;
  if (edge_high) options.edges.high = *edge_high;
  if (precision) options.svg.precision = *precision;
  if (seam_width) options.svg.seam_width = *seam_width;
  if (no_seams) options.svg.seams = false;
  options.backend = backend_name == "cpu"   ? cdt::Backend::cpu
                    : backend_name == "gpu" ? cdt::Backend::gpu
                                            : cdt::Backend::automatic;

  try {
    const vectorize::Image image = vectorize::load_image(input);
    vectorize::Conversion result = vectorize::convert(image, options);
    vectorize::write_file_atomically(output, result.svg);
    if (stats_format == "json") {
      std::cerr << vectorize::stats_to_json(result.stats) << '\n';
    } else if (stats_format == "text") {
      print_stats_text(result.stats, input);
    }
    if (verbose && !quiet) {
      std::cerr << "vectorize: wrote " << output.string() << " (" << result.stats.paths << " paths, "
                << result.stats.bytes << " bytes)\n";
    }
    return 0;
  } catch (const vectorize::FileError& e) {
    std::cerr << "vectorize: " << e.what() << '\n'; // names the file and the reason
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "vectorize: " << input.string() << ": " << e.what() << '\n';
    return kExitFailure;
  }
}
