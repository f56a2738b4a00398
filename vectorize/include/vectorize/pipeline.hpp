#pragma once
// The whole conversion, raster to SVG: the stages of the pipeline composed in order. The CLI and any
// other front end call convert(); nothing here does file I/O except write_file_atomically().

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "cdt/cdt.hpp"
#include "vectorize/chains.hpp"
#include "vectorize/edges.hpp"
#include "vectorize/grouping.hpp"
#include "vectorize/image.hpp"
#include "vectorize/polygons.hpp"
#include "vectorize/pslg_build.hpp"
#include "vectorize/simplify.hpp"
#include "vectorize/svg.hpp"
#include "vectorize/trixels.hpp"

namespace vectorize {

/// Named starting points for the options, from flat artwork to photographs.
enum class Preset {
  logo,         ///< flat colours, crisp shapes: no interior points, generous colour merging
  illustration, ///< flat areas with some shading (the default)
  photo,        ///< smooth shading everywhere: dense interior points, fine colour tolerance
};

/// The size of PSLG from which the automatic backend triangulates one image on the GPU. A photograph's
/// PSLG (10-50K points for 0.4-1.6 megapixels) alone converts about as fast on the CPU, without CUDA's
/// start (0.3-0.4 s). Which backend runs changes no output.
inline constexpr std::size_t kDevicePslgPoints = 50000;

/// Every knob of the pipeline, in human units (pixels, Delta E).
struct Options {
  EdgeOptions edges;
  /// Largest distance of a simplified polyline from its edge pixels, pixels.
  double simplify_tolerance_px = 0.75;
  InteriorOptions interior;
  GroupingOptions grouping;
  SvgOptions svg;
  /// cdt::Backend::automatic takes the GPU, when there is one, for PSLGs of kDevicePslgPoints points or
  /// more, and the CPU below that (a batch large enough to share the device takes it for every image:
  /// see run_batch); cpu and gpu are taken as they are. The SVG is the same whichever runs: the CDT is
  /// unique, and the pipeline puts it in canonical order (cdt::canonicalize). An image whose CDT was
  /// made on the device has its trixel colours added up there too (TrixelDevice::gpu); with
  /// cdt::Backend::gpu its edges are found there as well (EdgeDevice::gpu), the same edges.
  cdt::Backend backend = cdt::Backend::automatic;
  /// Threads one conversion may use (simplification, the CDT engine's CPU executor, trixel colours);
  /// 0 uses every hardware thread. The output is the same for any number.
  unsigned threads = 0;
};

/// The options of a preset.
Options preset_options(Preset preset);

/// Parses "logo", "illustration" or "photo"; throws std::invalid_argument naming the valid ones.
Preset parse_preset(std::string_view name);

/// Time of one stage.
struct StageTime {
  std::string name;
  double milliseconds = 0.0;
};

/// What one conversion did.
struct Stats {
  int width = 0;
  int height = 0;
  std::size_t edge_pixels = 0;
  std::size_t chains = 0;
  std::size_t points = 0;   ///< PSLG points (chain vertices, border, interior points)
  std::size_t segments = 0; ///< PSLG segments
  std::size_t triangles = 0;
  std::size_t regions = 0;    ///< opaque and transparent regions after grouping
  std::size_t paths = 0;      ///< <path> elements written
  std::size_t bytes = 0;      ///< size of the SVG document
  std::string cdt_backend;    ///< "cpu" or "gpu"
  std::size_t cdt_inputs = 1; ///< PSLGs triangulated together with this one (cdt::Statistics::inputs)
  std::vector<StageTime> stages;
  /// The CDT engine's phases (cdt::Statistics::phases; with cdt_inputs > 1, those of the whole call).
  std::vector<StageTime> cdt_phases;
  double total_milliseconds = 0.0;
};

/// The result of convert().
struct Conversion {
  std::string svg;
  Stats stats;
};

/// Every stage's output of one conversion, kept for debug overlays and inspection.
struct StageRecord {
  EdgeMap edges;
  std::vector<Chain> chains;
  std::vector<Polyline> polylines;
  Pslg pslg;
  cdt::Triangulation triangulation;
  TrixelColours trixels;
  Regions regions;
  /// Every region's polygon, transparent ones included (the SVG draws only the opaque ones).
  std::vector<RegionPolygon> polygons;
};

/// Converts a decoded image into an SVG document: edges, chains, simplification, PSLG, CDT, trixel
/// colours, grouping, polygons, SVG. With `record`, every stage's output is also copied there.
/// Throws Error (or cdt::Error from the CDT engine) on failure; an image of zero size is an Error.
/// The same as convert_to_pslg(), cdt::triangulate() with its cdt_options, then finish_conversion().
Conversion convert(const Image& image, const Options& options = {}, StageRecord* record = nullptr);

/// The first half of a conversion, up to its PSLG, for a caller that makes the CDT itself (a batch
/// triangulates several images' PSLGs in one call of cdt::triangulate_many).
struct PslgStage {
  Pslg pslg;
  /// What convert() triangulates the PSLG with (the backend the options choose for its size).
  cdt::Options cdt_options;
  /// Counts and stage times so far.
  Stats stats;
  std::chrono::steady_clock::time_point started;     ///< when the conversion began
  std::chrono::steady_clock::time_point stages_done; ///< when this half ended: the CDT stage's start
  /// The image left on the device by its edges, for its trixel colours (finish_conversion drops it
  /// once they are made); empty when its edges were found on the CPU.
  DevicePixels device_pixels;
};

/// The stages of convert() up to the PSLG (edges, chains, simplification, PSLG); `record` gets theirs.
/// With `device_ready` and options.backend other than cdt::Backend::cpu the edges are found on the
/// device (with the automatic backend, on the CPU should the device fail); else on the CPU (a batch
/// whose device is still starting finds them there meanwhile): the same edges either way. convert()
/// passes true for the GPU backend.
PslgStage convert_to_pslg(const Image& image, const Options& options = {}, StageRecord* record = nullptr,
                          bool device_ready = false);

/// The rest of convert() given the PSLG's CDT: canonical order, trixel colours, grouping, polygons, SVG.
/// The CDT stage's time runs from the end of the first half, so it includes any wait for the CDT.
/// `device_done`, when given, is called once the conversion needs the CUDA device no more (after the
/// trixel colours, which a CDT made on the device has made there too), not at all when it fails before.
Conversion finish_conversion(const Image& image, const Options& options, PslgStage&& first,
                             cdt::Triangulation triangulation, StageRecord* record = nullptr,
                             const std::function<void()>& device_done = {});

/// Writes `content` to `path` through a temporary file in the same directory, renamed over `path`
/// once complete, so that a failure never leaves a partial file. Throws FileError naming the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

/// Removes the temporary files that write_file_atomically() calls are writing at this moment.
/// Async-signal-safe: for a handler that ends the program (a second Ctrl-C) without leaving partial
/// files behind.
void remove_unfinished_outputs() noexcept;

/// The statistics as one JSON object (stable keys; times in milliseconds).
std::string stats_to_json(const Stats& stats);

} // namespace vectorize
