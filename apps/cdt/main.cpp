// cdt IN: constrained Delaunay triangulation of a PSLG file, with Triangle's file formats.
// Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>
#include <string>

#include "cdt/errors.hpp"
#include "cdt/io.hpp"

namespace {
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
} // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "cdt: constrained Delaunay triangulation of a planar straight-line graph (the gCD algorithm).\n"
      "Reads Triangle's .node and .poly files and the 'nV nE / x y / v1 v2' edge-list format.",
      "cdt"};
  app.set_version_flag("--version", std::string("cdt ") + TRIXEL_VERSION);
  app.footer("Examples:\n"
             "  cdt box.poly          writes box.1.node, box.1.ele, box.1.neigh, box.1.edge\n"
             "\n"
             "Exit status: 0 on success, 1 on failure, 2 on bad usage.");
  std::filesystem::path input;
  app.add_option("IN", input, "Input PSLG: .node, .poly, or an edge-list file")->required();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }
  try {
    const cdt::io::Pslg pslg = cdt::io::read_pslg(input);
    std::cerr
        << "cdt: " << input.string() << ": read " << pslg.points.size() << " points and "
        << pslg.segments.size()
        << " segments, but the triangulation engine is not implemented in this version; no output written\n";
    return kExitFailure;
  } catch (const cdt::Error& e) {
    std::cerr << "cdt: " << e.what() << '\n';
    return kExitFailure;
  }
}
