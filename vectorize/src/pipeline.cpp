// The pipeline: stages composed in the order of DESIGN.md, with their times and counts.
#include "vectorize/pipeline.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "cdt/errors.hpp"
#include "vectorize/chains.hpp"
#include "vectorize/errors.hpp"
#include "vectorize/polygons.hpp"
#include "vectorize/simplify.hpp"
#include "vectorize/trixels.hpp"

namespace vectorize {

Options preset_options(Preset preset) {
  Options o;
  switch (preset) {
  case Preset::logo:
    // Flat colours: edges carry the shapes; interior points would only split flat areas.
    o.edges.blur_sigma_px = 0.7;
    o.simplify_tolerance_px = 0.6;
    o.interior.cell_size_px = 0;
    o.grouping.colour_tolerance = 14.0;
    o.grouping.min_region_area = 6.0;
    break;
  case Preset::illustration:
    // Flat areas and soft gradients (icons, drawings): interior points every 6 px, a colour
    // tolerance near two just-noticeable differences (Tango icons: 24.6 dB at 39 KB per icon).
    o.edges.blur_sigma_px = 1.0;
    o.simplify_tolerance_px = 0.75;
    o.interior.cell_size_px = 6;
    o.grouping.colour_tolerance = 4.0;
    o.grouping.min_region_area = 4.0;
    break;
  case Preset::photo:
    // Shading everywhere: many interior points so trixels follow it, and a fine colour tolerance.
    o.edges.blur_sigma_px = 1.2;
    o.simplify_tolerance_px = 0.9;
    o.interior.cell_size_px = 4;
    o.interior.min_std_dev = 0.01;
    o.grouping.colour_tolerance = 3.0;
    o.grouping.min_region_area = 3.0;
    break;
  }
  return o;
}

Preset parse_preset(std::string_view name) {
  if (name == "logo") return Preset::logo;
  if (name == "illustration") return Preset::illustration;
  if (name == "photo") return Preset::photo;
  throw std::invalid_argument("unknown preset '" + std::string(name) +
                              "' (choose logo, illustration or photo)");
}

namespace {

using Clock = std::chrono::steady_clock;

// Adds each stage's time to the statistics: from the end of the stage before it (or the start).
class StageTimer {
public:
  StageTimer(Stats& stats, Clock::time_point start, Clock::time_point last)
      : stats_(stats), start_(start), last_(last) {}
  explicit StageTimer(Stats& stats) : StageTimer(stats, Clock::now(), Clock::now()) {}
  void end(const char* name) {
    const auto now = Clock::now();
    stats_.stages.push_back({name, std::chrono::duration<double, std::milli>(now - last_).count()});
    last_ = now;
  }
  void finish() {
    stats_.total_milliseconds = std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
  }
  Clock::time_point start() const { return start_; }

private:
  Stats& stats_;
  Clock::time_point start_;
  Clock::time_point last_;
};

// step(true) runs a stage on the device, step(false) on the CPU (the same result). On the device when
// `on_device`; with the automatic backend a device that fails there (out of memory, say, when other
// processes hold it) leaves the stage to the CPU, as it leaves the CDT.
template <class Step>
auto on_device_or_cpu(cdt::Backend backend, bool on_device, const Step& step) {
  if (!on_device) return step(false);
  if (backend != cdt::Backend::automatic) return step(true);
  try {
    return step(true);
  } catch (const cdt::DeviceError&) {
    return step(false);
  }
}

} // namespace

PslgStage convert_to_pslg(const Image& image, const Options& options, StageRecord* record,
                          bool device_ready) {
  if (image.width <= 0 || image.height <= 0) throw Error("the image has zero size");
  PslgStage out;
  Stats& stats = out.stats;
  stats.width = image.width;
  stats.height = image.height;
  StageTimer timer(stats);

  // On the device when it is ready and the backend is not the CPU's.
  const EdgeMap edges = on_device_or_cpu(
      options.backend, options.backend != cdt::Backend::cpu && device_ready, [&](bool device) {
        return detect_edges(image, options.edges, options.threads, device ? EdgeDevice::gpu : EdgeDevice::cpu,
                            device ? &out.device_pixels : nullptr);
      });
  for (const std::uint8_t e : edges.on) stats.edge_pixels += e;
  timer.end("edges");
  const std::vector<Chain> chains = trace_chains(edges);
  stats.chains = chains.size();
  timer.end("chains");
  const PointPlacement placement{image};
  const std::vector<Polyline> polylines =
      simplify_chains(chains, options.simplify_tolerance_px, placement, options.threads);
  timer.end("simplify");
  out.pslg = build_pslg(polylines, image.width, image.height, image, options.interior, placement);
  stats.points = out.pslg.points.size();
  stats.segments = out.pslg.segments.size();
  timer.end("pslg");

  out.cdt_options.backend =
      options.backend == cdt::Backend::automatic && out.pslg.points.size() < kDevicePslgPoints
          ? cdt::Backend::cpu
          : options.backend;
  out.cdt_options.threads = options.threads;
  out.started = timer.start();
  // Copied after timing, so that recording does not show in the stage times.
  if (record != nullptr) {
    record->edges = edges;
    record->chains = chains;
    record->polylines = polylines;
    record->pslg = out.pslg;
  }
  out.stages_done = Clock::now();
  return out;
}

Conversion finish_conversion(const Image& image, const Options& options, PslgStage&& first,
                             cdt::Triangulation triangulation, StageRecord* record,
                             const std::function<void()>& device_done) {
  Conversion out;
  Stats& stats = out.stats;
  stats = std::move(first.stats);
  // The CDT stage runs from the end of the first half: with a CDT made elsewhere it includes the wait.
  StageTimer timer(stats, first.started, first.stages_done);
  // The CDT is unique; in its canonical order the stages below, and so the SVG, are the same whichever
  // backend made it.
  cdt::canonicalize(triangulation);
  stats.triangles = triangulation.triangles.size();
  stats.cdt_backend = triangulation.stats.backend;
  stats.cdt_inputs = triangulation.stats.inputs;
  for (const cdt::PhaseStats& phase : triangulation.stats.phases)
    stats.cdt_phases.push_back({phase.name, phase.milliseconds});
  timer.end("cdt");

  // Where the CDT was made, the trixels' sums are made: a CDT from the device says it is up, and there
  // the sums take it a fraction of what they take a core. The colours are the same either way.
  TrixelLab lab; // the colours' CIELAB, where the device made it with them
  const TrixelColours trixels =
      on_device_or_cpu(options.backend, triangulation.stats.backend.starts_with("gpu"), [&](bool device) {
        return colour_trixels(image, triangulation, options.threads,
                              device ? TrixelDevice::gpu : TrixelDevice::cpu, first.device_pixels, &lab);
      });
  first.device_pixels.reset(); // its device memory freed before the device may be given back
  if (device_done) device_done();
  timer.end("trixels");
  const Regions regions = group_trixels(triangulation, trixels, options.grouping, options.threads, &lab);
  stats.regions = regions.regions.size();
  timer.end("grouping");
  // Transparent regions too: the SVG does not draw them, but keeps its seam underlay off them.
  const std::vector<RegionPolygon> polygons =
      trace_polygons(triangulation, regions, TransparentRegions::include);
  timer.end("polygons");
  out.svg = svg_document(polygons, regions, image.width, image.height, options.svg);
  stats.bytes = out.svg.size();
  // Drawn paths: one per opaque region with rings (transparent ones only mask the underlay).
  for (const RegionPolygon& polygon : polygons)
    stats.paths += !regions.regions[polygon.region].transparent && !polygon.rings.empty() ? 1 : 0;
  timer.end("svg");
  timer.finish();
  if (record != nullptr) {
    record->polygons = polygons;
    record->trixels = trixels;
    record->regions = regions;
    record->triangulation = std::move(triangulation);
  }
  return out;
}

Conversion convert(const Image& image, const Options& options, StageRecord* record) {
  PslgStage first = convert_to_pslg(image, options, record, options.backend == cdt::Backend::gpu);
  cdt::Triangulation triangulation =
      cdt::triangulate(first.pslg.points, first.pslg.segments, first.cdt_options);
  return finish_conversion(image, options, std::move(first), std::move(triangulation), record);
}

namespace {

// Temporary files being written, so that a signal handler can remove them: fixed slots of plain
// characters, claimed and released with atomics (nothing a signal handler may not touch).
constexpr std::size_t kSlots = 256;
constexpr std::size_t kPathMax = 4096;
char temporary_names[kSlots][kPathMax];
std::atomic<bool> slot_used[kSlots];

class TemporaryRegistration {
public:
  explicit TemporaryRegistration(const std::filesystem::path& path) {
    const std::string name = path.string();
    if (name.size() >= kPathMax) return;
    for (std::size_t k = 0; k < kSlots; ++k) {
      bool expected = false;
      if (slot_used_claimed_[k].compare_exchange_strong(expected, true)) {
        std::memcpy(temporary_names[k], name.c_str(), name.size() + 1);
        slot_used[k].store(true);
        slot_ = k;
        return;
      }
    }
  }
  ~TemporaryRegistration() {
    if (slot_ == kSlots) return;
    slot_used[slot_].store(false);
    slot_used_claimed_[slot_].store(false);
  }
  TemporaryRegistration(const TemporaryRegistration&) = delete;
  TemporaryRegistration& operator=(const TemporaryRegistration&) = delete;

private:
  static inline std::atomic<bool> slot_used_claimed_[kSlots];
  std::size_t slot_ = kSlots;
};

} // namespace

void remove_unfinished_outputs() noexcept {
  for (std::size_t k = 0; k < kSlots; ++k) {
    if (slot_used[k].load()) ::unlink(temporary_names[k]);
  }
}

void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
  namespace fs = std::filesystem;
  std::error_code status_error;
  const fs::file_status status = fs::status(path, status_error);
  if (fs::is_character_file(status) || fs::is_fifo(status)) {
    // A device or a pipe (/dev/null, /dev/stdout): written in place, since a rename would replace it
    // with a file.
    std::ofstream file(path, std::ios::binary);
    if (!file) throw FileError(path, "cannot open it for writing: " + std::string(std::strerror(errno)));
    file.write(content.data(), static_cast<std::streamsize>(content.size()));
    file.flush();
    if (!file) throw FileError(path, "write failed");
    return;
  }
  if (fs::is_directory(status)) throw FileError(path, "is a directory");
  if (fs::exists(status) && !fs::is_regular_file(status))
    throw FileError(path, "is neither a regular file nor a device or a pipe");
  // A name unique to this process and call, beside the target so that the rename stays on one
  // file system.
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  fs::path temporary = path;
  temporary += ".tmp-" + std::to_string(rng() % 1000000000);
  const TemporaryRegistration registration(temporary);
  {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) {
      throw FileError(path, "cannot create a temporary file beside it (" + temporary.string() +
                                "): " + std::strerror(errno));
    }
    file.write(content.data(), static_cast<std::streamsize>(content.size()));
    file.flush();
    if (!file) {
      std::error_code ignored;
      fs::remove(temporary, ignored);
      throw FileError(path, "write failed (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(temporary, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw FileError(path, "cannot rename the temporary file to it: " + ec.message());
  }
}

std::string stats_to_json(const Stats& s) {
  std::ostringstream j;
  j << "{\"width\":" << s.width << ",\"height\":" << s.height << ",\"edge_pixels\":" << s.edge_pixels
    << ",\"chains\":" << s.chains << ",\"points\":" << s.points << ",\"segments\":" << s.segments
    << ",\"triangles\":" << s.triangles << ",\"regions\":" << s.regions << ",\"paths\":" << s.paths
    << ",\"bytes\":" << s.bytes << ",\"cdt_backend\":\"" << s.cdt_backend
    << "\",\"cdt_inputs\":" << s.cdt_inputs << ",\"stages_ms\":{";
  char number[32];
  for (std::size_t k = 0; k < s.stages.size(); ++k) {
    std::snprintf(number, sizeof number, "%.3f", s.stages[k].milliseconds);
    j << (k ? "," : "") << '"' << s.stages[k].name << "\":" << number;
  }
  // A list, not an object: a CDT made twice (cdt::Statistics::attempts) repeats its phases' names.
  j << "},\"cdt_phases_ms\":[";
  for (std::size_t k = 0; k < s.cdt_phases.size(); ++k) {
    std::snprintf(number, sizeof number, "%.3f", s.cdt_phases[k].milliseconds);
    j << (k ? "," : "") << "[\"" << s.cdt_phases[k].name << "\"," << number << ']';
  }
  std::snprintf(number, sizeof number, "%.3f", s.total_milliseconds);
  j << "],\"total_ms\":" << number << "}";
  return j.str();
}

} // namespace vectorize
