// vectorize IN OUT.svg: raster image to SVG through edges, a constrained Delaunay triangulation and
// trixel grouping. Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <string>
#include <system_error>

#include "vectorize/errors.hpp"
#include "vectorize/image.hpp"

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  if (std::filesystem::equivalent(a, b, ec)) return true;
  return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

} // namespace

int main(int argc, char** argv) {
  CLI::App app{"vectorize: convert a raster image (PNG, JPEG, TIFF, BMP, WebP, ...) into an SVG of coloured\n"
               "polygons, through edge detection, a constrained Delaunay triangulation of the edge map and\n"
               "grouping of its triangles (trixels) by colour.",
               "vectorize"};
  app.set_version_flag("--version", std::string("vectorize ") + TRIXEL_VERSION);
  app.footer("Examples:\n"
             "  vectorize samples/logo.png logo.svg\n"
             "  vectorize photo.jpg photo.svg -v\n"
             "\n"
             "Exit status: 0 on success, 1 on failure, 2 on bad usage.");

  std::filesystem::path input;
  std::filesystem::path output;
  bool quiet = false;
  bool verbose = false;
  app.add_option("IN", input, "Input raster image")->required();
  app.add_option("OUT", output, "Output SVG file (written to a temporary name, then renamed)")->required();
  app.add_flag("-q,--quiet", quiet, "Print nothing but errors");
  app.add_flag("-v,--verbose", verbose, "Print what each stage did");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }

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

  try {
    const vectorize::Image image = vectorize::load_image(input);
    if (verbose && !quiet) {
      std::cerr << "vectorize: " << input.string() << ": " << image.width << " x " << image.height << ", "
                << image.source_channels << " channel(s)\n";
    }
    // The stages after loading (edges, chains, PSLG, CDT, trixels, grouping, SVG) are not part of this
    // build yet. Say so plainly and write nothing rather than produce a placeholder file.
    std::cerr << "vectorize: " << input.string()
              << ": decoded, but the conversion stages (edges -> CDT -> trixel grouping -> SVG) are not "
                 "implemented in this version; no output written\n";
    return kExitFailure;
  } catch (const vectorize::Error& e) {
    std::cerr << "vectorize: " << e.what() << '\n';
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "vectorize: " << input.string() << ": " << e.what() << '\n';
    return kExitFailure;
  }
}
