// vectorize IN OUT.svg: raster image to SVG through edges, a constrained Delaunay triangulation and
// trixel grouping. Exit status: 0 success, 1 failure, 2 bad usage.

#include <CLI/CLI.hpp>

#include <unistd.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(TRIXEL_MIMALLOC)
#include <mimalloc.h>
#endif

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <optional>
#include <string>
#include <system_error>

#include "cdt/errors.hpp"
#include "vectorize/batch.hpp"
#include "vectorize/debug_overlays.hpp"
#include "vectorize/edges.hpp"
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

/// CLI::Range for a real option that also refuses NaN, which compares false with both bounds.
CLI::Validator number_in(double lo, double hi) {
  const CLI::Range range(lo, hi);
  return CLI::Validator(
             [range](std::string& text) -> std::string {
               char* end = nullptr;
               const double value = std::strtod(text.c_str(), &end);
               if (end == text.c_str() || std::isnan(value)) return "Value " + text + " is not a number";
               return range(text);
             },
             range.get_description())
      .name("NUMBER");
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

// Keep freed memory in the heap for the next stage and the next image instead of handing it back to
// the system. By default glibc maps large blocks (the per-pixel and per-triangle arrays) afresh and
// unmaps them when freed, so every stage pays a page fault per 4 KiB it touches again; with the heap
// kept, a 768 x 512 photo takes about a third fewer page faults (11,300 -> 7,100), and a batch of 48
// photographs on one core 95,000 -> 7,000 (about 6% less CPU time). A batch's workers then keep what
// their largest image needed until the batch ends, which is the peak --jobs states anyway. (With
// mimalloc as the allocator these settings reach only the C library's heap, which then holds nothing;
// mimalloc keeps its freed pages a while by itself.)
void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  constexpr int kLarge = 1 << 30; // bytes: above any block one image needs, below mallopt's int limit
  mallopt(M_MMAP_THRESHOLD, kLarge);
  mallopt(M_TRIM_THRESHOLD, kLarge);
#endif
}

// The heap's allocator, for --version: mimalloc only when malloc's blocks really come from it.
std::string allocator_name() {
#if defined(TRIXEL_MIMALLOC)
  void* probe = std::malloc(64);
  const bool ours = mi_is_in_heap_region(probe);
  std::free(probe);
  if (!ours) return "the C library's, though mimalloc is linked";
  const int v = mi_version(); // 209: 2.0.9
  return "mimalloc " + std::to_string(v / 100) + "." + std::to_string(v % 100 / 10) + "." +
         std::to_string(v % 10);
#else
  return "the C library's";
#endif
}

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_interrupts = 0;

// One image: a signal abandons it, removing the temporary file of its output if one is being written,
// and ends the process as the signal would have.
extern "C" void on_signal_alone(int signal) {
  vectorize::remove_unfinished_outputs();
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

// First Ctrl-C: no new image starts, the ones under way finish (their outputs are whole). Second:
// abandon them, removing their temporary files, and exit at once.
extern "C" void on_interrupt(int) {
  g_interrupts = g_interrupts + 1;
  g_stop.store(true);
  if (g_interrupts >= 2) {
    vectorize::remove_unfinished_outputs();
    _exit(130);
  }
  static const char message[] =
      "\nvectorize: stopping after the images under way (Ctrl-C again to abandon them)\n";
  [[maybe_unused]] const auto ignored = ::write(2, message, sizeof message - 1);
}

std::string format_duration(double seconds) {
  const auto s = static_cast<long>(seconds + 0.5);
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  }
  return buf;
}

struct BatchCli {
  std::vector<std::filesystem::path> inputs;
  std::filesystem::path out_dir;
  std::filesystem::path from_list;
  std::filesystem::path report;
  bool recursive = false;
  bool skip_existing = false;
  unsigned jobs = 0;
  std::size_t max_pixels = std::size_t{1} << 27;
  std::string cdt = "auto";
};

// --debug DIR and --debug-format.
struct DebugCli {
  std::filesystem::path dir;
  std::string format = "png";
  bool on() const { return !dir.empty(); }
  vectorize::DebugOptions options(const std::filesystem::path& source) const {
    vectorize::DebugOptions o;
    o.format = vectorize::parse_overlay_format(format);
    o.source = source;
    return o;
  }
};

int run_batch_cli(const BatchCli& cli, const DebugCli& debug, const vectorize::Options& options, bool quiet) {
  using vectorize::JobStatus;
  std::vector<std::filesystem::path> inputs = cli.inputs;
  if (!cli.from_list.empty()) {
    const auto listed = vectorize::read_input_list(cli.from_list);
    inputs.insert(inputs.end(), listed.begin(), listed.end());
  }
  std::error_code ec;
  std::error_code created;
  std::filesystem::create_directories(cli.out_dir, created);
  if (!std::filesystem::is_directory(cli.out_dir, ec)) {
    std::cerr << "vectorize: " << cli.out_dir.string() << ": cannot create the output directory: "
              << (std::filesystem::exists(cli.out_dir, ec) ? "a file of that name is there"
                                                           : created.message())
              << '\n';
    return kExitFailure;
  }
  std::vector<vectorize::JobResult> refused; // failed before they start: in the summary and report
  std::vector<vectorize::BatchJob> jobs =
      vectorize::plan_batch(inputs, cli.out_dir, cli.recursive, refused, {cli.out_dir, debug.dir});
  if (debug.on()) vectorize::assign_debug_folders(jobs, cli.out_dir, debug.dir);
  for (const auto& c : refused) std::cerr << "vectorize: " << c.error << '\n';
  if (jobs.empty()) {
    std::cerr << "vectorize: no images to convert" << (refused.empty() ? "" : " (see above)") << '\n';
    return kExitFailure;
  }
  if (!cli.report.empty()) {
    // Checked before any image: the report must not replace an input or an output, and its folder must
    // be there when the batch ends.
    for (const vectorize::BatchJob& job : jobs) {
      for (const std::filesystem::path* p : {&job.input, &job.output}) {
        if (same_file(cli.report, *p)) {
          std::cerr << "vectorize: --report " << cli.report.string() << " is "
                    << (p == &job.input ? "an input" : "an output") << " of the batch; choose another path\n";
          return kExitUsage;
        }
      }
    }
    const std::filesystem::path folder = cli.report.parent_path().empty() ? "." : cli.report.parent_path();
    if (!std::filesystem::is_directory(folder, ec)) {
      std::cerr << "vectorize: --report " << cli.report.string() << ": " << folder.string()
                << " is not a folder\n";
      return kExitUsage;
    }
  }

  const bool terminal = isatty(2) != 0;
  const auto start = std::chrono::steady_clock::now();
  std::size_t failures = 0;
  vectorize::BatchOptions batch;
  batch.conversion = options;
  batch.workers = cli.jobs;
  batch.skip_existing = cli.skip_existing;
  batch.max_pixels = cli.max_pixels;
  batch.shared_cdt = cli.cdt == "shared" ? vectorize::BatchOptions::SharedCdt::always
                     : cli.cdt == "own"  ? vectorize::BatchOptions::SharedCdt::never
                                         : vectorize::BatchOptions::SharedCdt::automatic;
  batch.stop = &g_stop;
  if (debug.on()) {
    batch.write_debug = [&debug](const vectorize::BatchJob& job, const vectorize::Image& image,
                                 const vectorize::Conversion& result, const vectorize::StageRecord& record) {
      vectorize::write_debug_folder(job.debug, image, record, result.svg, debug.options(job.input));
    };
  }
  batch.on_done = [&](const vectorize::JobResult& r, std::size_t done, std::size_t total) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (r.status == JobStatus::failed) {
      ++failures;
      if (terminal && !quiet) std::fputs("\r\033[K", stderr);
      std::fprintf(stderr, "vectorize: FAILED %s\n", r.error.c_str());
    } else if (!quiet && !terminal) {
      std::fprintf(stderr, "vectorize: [%zu/%zu] %s %s -> %s (%.2f s)\n", done, total,
                   r.status == JobStatus::skipped ? "skipped (exists)" : "converted",
                   r.job.input.string().c_str(), r.job.output.string().c_str(), r.seconds);
    }
    if (!quiet && terminal) {
      const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
      const double eta = rate > 0 ? static_cast<double>(total - done) / rate : 0.0;
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(kWidth * done / total);
      std::string bar(static_cast<std::size_t>(filled), '=');
      bar.resize(kWidth, ' ');
      std::fprintf(stderr, "\r\033[K[%s] %zu/%zu  %.1f img/s  ETA %s  failures %zu", bar.c_str(), done, total,
                   rate, format_duration(eta).c_str(), failures);
      if (done == total) std::fputc('\n', stderr);
    }
  };
  // Once, before any image: OpenCV's pool keeps to a conversion's share of the -j budget.
  vectorize::set_opencv_threads(vectorize::threads_per_conversion(batch, jobs.size()));
  std::vector<vectorize::JobResult> results = vectorize::run_batch(jobs, batch);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (terminal && !quiet && results.size() < jobs.size()) std::fputc('\n', stderr);

  const std::size_t not_started = jobs.size() - results.size();
  results.insert(results.end(), refused.begin(), refused.end());
  std::size_t converted = 0, skipped = 0;
  std::vector<const vectorize::JobResult*> failed;
  for (const auto& r : results) {
    converted += r.status == JobStatus::converted;
    skipped += r.status == JobStatus::skipped;
    if (r.status == JobStatus::failed) failed.push_back(&r);
  }
  if (!cli.report.empty()) {
    try {
      vectorize::write_file_atomically(cli.report, vectorize::batch_report_json(results, wall));
    } catch (const vectorize::FileError& e) {
      std::cerr << "vectorize: " << e.what() << '\n';
      return kExitFailure;
    }
  }
  if (!quiet || !failed.empty() || not_started > 0) {
    std::fprintf(stderr, "vectorize: %zu converted, %zu skipped, %zu failed", converted, skipped,
                 failed.size());
    if (not_started > 0) std::fprintf(stderr, ", %zu not started (interrupted)", not_started);
    std::fprintf(stderr, " in %.1f s (%.2f images/s)\n", wall,
                 wall > 0 ? static_cast<double>(converted) / wall : 0.0);
    for (const auto* r : failed) std::fprintf(stderr, "  failed: %s\n", r->error.c_str());
  }
  if (g_interrupts > 0) return 130;
  return failed.empty() && refused.empty() ? 0 : kExitFailure;
}

} // namespace

int main(int argc, char** argv) {
  CLI::App app{"vectorize: convert a raster image (PNG, JPEG, TIFF, BMP, WebP, ...) into an SVG of coloured\n"
               "polygons, through edge detection, a constrained Delaunay triangulation of the edge map and\n"
               "grouping of its triangles (trixels) by colour. Transparent areas (alpha < 0.5) stay empty.",
               "vectorize"};
  app.set_version_flag("--version",
                       std::string("vectorize ") + TRIXEL_VERSION + " (allocator: " + allocator_name() + ")");
  app.footer(
      "Presets set every knob; the options after --preset adjust it.\n"
      "  logo          flat colours, crisp shapes (no interior points, broad colour merging)\n"
      "  illustration  flat areas with some shading (default)\n"
      "  photo         smooth shading everywhere (dense interior points, fine colour tolerance)\n"
      "\n"
      "Examples:\n"
      "  vectorize samples/logo.png logo.svg --preset logo\n"
      "  vectorize photo.jpg photo.svg --preset photo --stats\n"
      "  vectorize scan.png scan.svg --colour-tolerance 6 --min-area 20 --simplify 1.5\n"
      "  vectorize icon.png icon.svg --stats json -q\n"
      "  vectorize photos/ -r -o svg/ -j 4 --report report.json     (batch: mirrors photos/ under svg/)\n"
      "  find . -name '*.png' | vectorize --from-list - -o out/ --skip-existing\n"
      "  vectorize samples/logo.png logo.svg --debug logo-debug/   (then open logo-debug/index.html)\n"
      "  vectorize art/ -r -o svg/ --debug debug/ --debug-format svg (one debug folder per image)\n"
      "\n"
      "Debugging (--debug DIR): DIR (created if missing) gets one overlay per stage drawn over the\n"
      "dimmed input -- 01-edges, 02-chains (chains, simplified polylines, endpoints, junctions), 03-pslg,\n"
      "04-cdt (constraint edges in red), 05-trixel-colours, 06-trixel-groups, 07-polygons -- as PNG, or SVG\n"
      "or PDF with --debug-format; a copy of the input, result.svg, regions.json (every region's id,\n"
      "colour, area, triangle count and rings) and index.html: an inspector page that stacks input,\n"
      "overlays and result as layers (checkbox and opacity each, wheel zoom, drag to pan) and names\n"
      "the region under the pointer. It works offline, from file://. In batch mode, DIR mirrors the\n"
      "input tree like the SVGs: debug/a/b/ for the input a/b.png.\n"
      "\n"
      "Batch mode (-o OUTDIR): every image is tried; a bad one gets one line naming it and the reason,\n"
      "the rest go on, and the summary lists the failures. Ctrl-C lets the images under way finish\n"
      "(press it again to abandon them); rerun with --skip-existing to resume.\n"
      "\n"
      "Exit status: 0 on success, 1 on failure (the message names the file and the reason; in batch\n"
      "mode, when any image failed), 2 on bad usage, 130 when interrupted. Outputs are written to a\n"
      "temporary file and renamed, so a failure leaves no partial file, and an input is never\n"
      "overwritten.");

  std::vector<std::filesystem::path> positional;
  BatchCli batch;
  std::string preset_name = "illustration";
  std::optional<double> colour_tolerance, min_area, simplify, blur, edge_low, edge_high, seam_width;
  std::optional<int> detail, precision;
  std::string backend_name = "auto";
  bool no_seams = false;
  std::string seams_name = "underlay";
  std::string stats_format;
  bool quiet = false;
  bool verbose = false;
  app.add_option("IN OUT.svg | IN...", positional,
                 "One image and its SVG; or, with -o, any number of images and directories");
  auto* out_dir_option = app.add_option("-o,--output-dir", batch.out_dir,
                                        "Batch mode: write IN... as SVGs under this directory (created if "
                                        "missing), mirroring the input tree");
  app.add_flag("-r,--recursive", batch.recursive, "Batch mode: also convert images in subdirectories");
  app.add_option("--from-list", batch.from_list,
                 "Batch mode: read more input paths from FILE, one per line ('-' = stdin)");
  app.add_option("-j,--jobs", batch.jobs,
                 "Batch mode: cores to use, one image at a time on each (default: every core; with fewer "
                 "images than cores, each image gets several). Memory grows with it: about "
                 "64 bytes per pixel of the largest image per worker, plus 20 MB (a 3072 x 2048 photo "
                 "peaks at 400 MB); with a shared CDT (--batch-cdt) up to 6 N images (11 at -j 1) are "
                 "held, each about 20 bytes per pixel while it waits for its CDT; with the device shared, "
                 "16 MB of pinned memory per worker (at most 64 MB) for copies to the device")
      ->check(CLI::Range(0u, 1024u));
  app.add_option("--batch-cdt", batch.cdt,
                 "Batch mode: auto (shared with --backend gpu, and with --backend auto in a batch of "
                 "at least " +
                     std::to_string(vectorize::kDeviceBatchImagesPerWorker) +
                     " images per worker), shared (the images' PSLGs triangulated "
                     "together, about N per call, on threads of their own; a worker sets its image aside "
                     "meanwhile and takes another), own (each worker triangulates its image's PSLG). The "
                     "SVGs are the same")
      ->check(CLI::IsMember({"auto", "shared", "own"}))
      ->capture_default_str();
  app.add_flag("--skip-existing", batch.skip_existing,
               "Batch mode: leave images whose SVG exists (resume a batch)");
  app.add_option("--report", batch.report,
                 "Batch mode: write a JSON report (status, error, times, counts per image)");
  app.add_option("--max-pixels", batch.max_pixels, "Refuse images larger than this many pixels")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 40))
      ->capture_default_str();
  app.add_option("-p,--preset", preset_name, "Starting point: logo, illustration or photo")
      ->check(CLI::IsMember({"logo", "illustration", "photo"}))
      ->capture_default_str();
  app.add_option("-c,--colour-tolerance,--color-tolerance", colour_tolerance,
                 "Largest colour difference (CIELAB Delta E) joined into one region; larger = fewer, "
                 "flatter regions")
      ->check(number_in(0.0, 200.0));
  app.add_option("--min-area", min_area, "Regions smaller than this (square pixels) merge into a neighbour")
      ->check(number_in(0.0, 1e9));
  app.add_option("-s,--simplify", simplify, "Edge simplification tolerance, pixels")
      ->check(number_in(0.0, 100.0));
  app.add_option("-d,--detail", detail,
                 "Interior-point grid cell, pixels: smaller follows shading more closely; 0 = none")
      ->check(CLI::Range(0, 10000));
  app.add_option("--blur", blur, "Gaussian blur before edge detection, sigma in pixels; 0 = none")
      ->check(number_in(0.0, 50.0));
  app.add_option("--edge-low", edge_low, "Canny low threshold (Sobel units on 8-bit values); 0 = automatic")
      ->check(number_in(0.0, 1e6));
  app.add_option("--edge-high", edge_high, "Canny high threshold; 0 = automatic")->check(number_in(0.0, 1e6));
  app.add_option("--precision", precision, "Decimal places of SVG coordinates")->check(CLI::Range(0, 6));
  app.add_option("--seams", seams_name,
                 "How to hide the hairline cracks anti-aliasing renderers show between regions: underlay "
                 "(each path also drawn stroked beneath the exact fills; no background shows through), "
                 "stroke (a thin same-colour stroke; smaller files), none")
      ->check(CLI::IsMember({"underlay", "stroke", "none"}))
      ->capture_default_str();
  app.add_flag("--no-seams", no_seams, "Same as --seams none");
  app.add_option("--seam-width", seam_width,
                 "Width of the seam stroke, pixels (default: 3 for underlay, 0.5 for stroke)")
      ->check(number_in(0.0, 10.0));
  app.add_option("--backend", backend_name,
                 "CDT engine: auto (the GPU when present, for PSLGs of " +
                     std::to_string(vectorize::kDevicePslgPoints) +
                     " points or more; the CPU below; in a batch of at least " +
                     std::to_string(vectorize::kDeviceBatchImagesPerWorker) +
                     " images per worker, as gpu when there is a device), cpu or gpu (the edges too are "
                     "then found on the device, and an image whose CDT was made there gets its colours "
                     "there; in batch mode, images that come before the device has started stay on the "
                     "CPU: the same result)")
      ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
      ->capture_default_str();
  app.add_option("--stats", stats_format, "Print per-stage times and counts to stderr: text or json")
      ->expected(0, 1)
      ->default_str("text")
      ->check(CLI::IsMember({"text", "json"}));
  DebugCli debug;
  app.add_option("--debug", debug.dir,
                 "Write per-stage overlays and an inspector page (index.html) into this directory (created "
                 "if missing); in batch mode one folder per image under it");
  auto* debug_format_option =
      app.add_option("--debug-format", debug.format, "Format of the --debug overlays: png, svg or pdf")
          ->check(CLI::IsMember({"png", "svg", "pdf"}))
          ->capture_default_str();
  app.add_flag("-q,--quiet", quiet, "Print nothing but errors (and --stats)");
  app.add_flag("-v,--verbose", verbose, "Say what was written");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }
  if (app.count("--stats") > 0 && stats_format.empty()) stats_format = "text";
  const bool batch_mode = out_dir_option->count() > 0;
  if (!batch_mode &&
      (batch.recursive || !batch.from_list.empty() || batch.skip_existing || !batch.report.empty())) {
    std::cerr << "vectorize: --recursive, --from-list, --skip-existing and --report need -o OUTDIR\n";
    return kExitUsage;
  }
  if (!batch_mode && positional.size() != 2) {
    std::cerr << "vectorize: expected IN OUT.svg (or IN... -o OUTDIR); see --help\n";
    return kExitUsage;
  }
  if (batch_mode && positional.empty() && batch.from_list.empty()) {
    std::cerr << "vectorize: no inputs given (IN... or --from-list FILE)\n";
    return kExitUsage;
  }
  if (debug_format_option->count() > 0 && !debug.on()) {
    std::cerr << "vectorize: --debug-format needs --debug DIR\n";
    return kExitUsage;
  }
  if (debug.on()) {
    // Before any work: a file in the way fails at once and leaves nothing behind.
    try {
      vectorize::check_debug_folder(debug.dir);
    } catch (const vectorize::FileError& e) {
      std::cerr << "vectorize: " << e.what() << '\n';
      return kExitFailure;
    }
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
  options.svg.seams = no_seams ? vectorize::Seams::none : vectorize::parse_seams(seams_name);
  options.backend = backend_name == "cpu"   ? cdt::Backend::cpu
                    : backend_name == "gpu" ? cdt::Backend::gpu
                                            : cdt::Backend::automatic;

  keep_freed_memory_for_reuse();
  if (batch_mode) {
    batch.inputs = positional;
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
    try {
      return run_batch_cli(batch, debug, options, quiet);
    } catch (const std::exception& e) {
      std::cerr << "vectorize: " << e.what() << '\n';
      return kExitFailure;
    }
  }

  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) std::signal(signal, on_signal_alone);
  const std::filesystem::path input = positional[0];
  const std::filesystem::path output = positional[1];
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
    const vectorize::Image image = vectorize::load_image(input, batch.max_pixels);
    vectorize::StageRecord record;
    vectorize::Conversion result = vectorize::convert(image, options, debug.on() ? &record : nullptr);
    // The debug folder first: when it cannot be written, the run fails without an SVG.
    std::size_t debug_files = 0;
    if (debug.on()) {
      debug_files =
          vectorize::write_debug_folder(debug.dir, image, record, result.svg, debug.options(input)).size();
    }
    vectorize::write_file_atomically(output, result.svg);
    if (stats_format == "json") {
      std::cerr << vectorize::stats_to_json(result.stats) << '\n';
    } else if (stats_format == "text") {
      print_stats_text(result.stats, input);
    }
    if (verbose && !quiet) {
      std::cerr << "vectorize: wrote " << output.string() << " (" << result.stats.paths << " paths, "
                << result.stats.bytes << " bytes)\n";
      if (debug.on()) {
        std::cerr << "vectorize: wrote " << debug_files << " debug files into " << debug.dir.string()
                  << "; open " << (debug.dir / "index.html").string() << '\n';
      }
    }
    return 0;
  } catch (const vectorize::FileError& e) {
    std::cerr << "vectorize: " << e.what() << '\n'; // names the file and the reason
    return kExitFailure;
  } catch (const std::bad_alloc&) {
    std::cerr << "vectorize: " << input.string() << ": " << vectorize::kOutOfMemory << '\n';
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "vectorize: " << input.string() << ": " << e.what() << '\n';
    return kExitFailure;
  }
}
