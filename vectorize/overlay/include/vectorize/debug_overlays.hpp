#pragma once
// Debug output of one conversion: an overlay per pipeline stage drawn over the dimmed input, and an
// inspector page (index.html) that stacks them as layers with the region data (regions.json).

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "vectorize/image.hpp"
#include "vectorize/overlay.hpp"
#include "vectorize/pipeline.hpp"

namespace vectorize {

/// The stages that get an overlay, in pipeline order.
enum class DebugStage {
  edges,          ///< edge pixels
  chains,         ///< pixel chains, their simplified polylines, endpoints and junctions
  pslg,           ///< PSLG segments, points and interior points
  cdt,            ///< triangle edges, constraint edges highlighted
  trixel_colours, ///< each triangle filled with its mean colour
  trixel_groups,  ///< each region in a distinct colour, region boundaries drawn
  polygons,       ///< outlines of the final polygons (outer rings and holes)
};

/// Every DebugStage, in pipeline order.
inline constexpr std::array<DebugStage, 7> kDebugStages{
    DebugStage::edges,          DebugStage::chains,        DebugStage::pslg,    DebugStage::cdt,
    DebugStage::trixel_colours, DebugStage::trixel_groups, DebugStage::polygons};

/// File name stem ("01-edges" ... "07-polygons") and a human title of a stage's overlay.
struct DebugStageNames {
  const char* stem;
  const char* title;
};
DebugStageNames debug_stage_names(DebugStage stage) noexcept;

/// Draws one stage of `record` onto the canvas (which must have the image's size). Throws Error when
/// the record does not match the canvas (an edge map of another size, triangle ids out of range).
void draw_debug_stage(OverlayCanvas& canvas, DebugStage stage, const StageRecord& record);

/// A distinct, saturated colour for region `id` (neighbouring ids get far-apart hues), RGB in [0, 1].
std::array<float, 3> region_id_colour(std::uint32_t id) noexcept;

/// Options of write_debug_folder().
struct DebugOptions {
  /// Format of the overlays. The inspector page shows PNG layers for png and pdf, SVG for svg.
  OverlayFormat format = OverlayFormat::png;
  /// How far the input is blended towards black under the overlays, in [0, 1].
  double dim = 0.6;
  /// The input file, copied into the folder when a browser shows its format (PNG, JPEG, GIF, WebP,
  /// BMP); otherwise, or when empty, the decoded image is written as input.png.
  std::filesystem::path source;
  /// Shown as the inspector page's title; the source's file name when empty.
  std::string title;
};

/// Throws FileError naming `dir` when it cannot be a debug folder: it, or a parent of it, exists and
/// is not a directory. Cheap; for checking a command line before any work is done.
void check_debug_folder(const std::filesystem::path& dir);

/// Writes the debug folder of one conversion into `dir` (created if missing):
/// - 01-edges ... 07-polygons (.png, .svg or .pdf): each stage over the dimmed input;
/// - layers/: the same drawings on a transparent background, for the inspector to stack;
/// - the input (see DebugOptions::source) and result.svg (the `svg` document);
/// - regions.json: size, counts, layers and every region's id, colour, area, triangle count and
///   polygon rings (pixel coordinates, y down);
/// - index.html: the inspector page, with regions.json embedded so that it works from file://.
/// Every file goes through a temporary name. On failure, the files written by this call (and `dir`
/// when this call created it) are removed again and FileError names the path and the reason.
/// Returns the files written.
std::vector<std::filesystem::path> write_debug_folder(const std::filesystem::path& dir, const Image& image,
                                                      const StageRecord& record, std::string_view svg,
                                                      const DebugOptions& options = {});

namespace detail {

/// The region data of the inspector as JSON (what regions.json holds); `layers_json` is the JSON
/// array of the page's layers, inserted as is.
std::string inspector_json(const StageRecord& record, int width, int height, std::string_view title,
                           std::string_view layers_json);

/// The inspector page with `data_json` embedded.
std::string inspector_html(std::string_view title, std::string_view data_json);

} // namespace detail

} // namespace vectorize
