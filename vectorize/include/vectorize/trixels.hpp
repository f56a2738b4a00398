#pragma once
// Stage 7 of the pipeline: the colour of each triangle ("trixel", after Prasad and Skourikhine,
// "Vectorized image segmentation via trixel agglomeration", Pattern Recognition 39(4), 2006, sec. 2).
//
// Coordinates are pixel units with y down: the image covers [0, width] x [0, height] and pixel (x, y)
// has its centre at (x + 0.5, y + 0.5).

#include <array>
#include <cstdint>
#include <vector>

#include "cdt/cdt.hpp"
#include "vectorize/image.hpp"

namespace vectorize {

/// The colour of one triangle of the triangulation.
struct Trixel {
  /// Mean non-premultiplied RGBA in [0, 1] of the pixels the triangle owns: alpha is the plain mean,
  /// RGB the alpha-weighted mean (so that the colour under fully transparent pixels does not bleed
  /// in). A triangle that owns no pixel centre takes the colour of the nearest triangle that does and
  /// is reached across non-constraint edges (the neighbour owning the most pixels first); walled in by
  /// constraints, it takes the image sampled bilinearly at its centroid.
  std::array<float, 4> rgba{};
  /// Number of pixel centres the triangle owns under the fill rule (see owner_of_pixels()).
  std::uint32_t pixel_count = 0;
  /// Whether the triangle covers part of a solid pixel (alpha 1): a positive area of that pixel's
  /// square. Such a triangle must be drawn, and drawn without opacity, or the background would show
  /// through that pixel.
  bool covers_solid = false;
  /// Geometric area in square pixels (positive).
  double area = 0.0;
  /// A trixel whose mean alpha is below one half is "no shape" (DESIGN.md, stage 1).
  /// No shape: alpha below one half, unless the triangle covers part of a solid pixel and is not
  /// nearly clear itself (a rim triangle averaging a solid pixel with the anti-aliased ones beside it
  /// is drawn; a large clear triangle that grazes a solid pixel's corner is not).
  bool transparent() const noexcept { return rgba[3] < 0.5f && !(covers_solid && rgba[3] >= 0.2f); }
};

/// One Trixel per triangle, indexed like Triangulation::triangles.
using TrixelColours = std::vector<Trixel>;

/// The CIELAB of each trixel's colour (its RGB as srgb_to_lab in grouping.hpp gives it), indexed like
/// TrixelColours, where it was made with the colours (on the device, beside their sums: cheaper there
/// than in the grouping); NaN where it was not (the grouping then makes it). Empty: none known. Kept
/// apart from Trixel, which the grouping reads several times over.
using TrixelLab = std::vector<std::array<double, 3>>;

/// Where colour_trixels() adds up each triangle's pixels: on the CPU, or on the CUDA device (a build
/// with CUDA; the same sums to the bit, the same rule and order of operations).
enum class TrixelDevice { cpu, gpu };

/// The colour, pixel count and area of every triangle of t over image.
///
/// Preconditions: t is a valid triangulation (counter-clockwise, non-degenerate triangles) whose
/// domain covers [0, image.width] x [0, image.height]; image.rgba holds width * height * 4 values.
/// Every pixel centre is then owned by exactly one triangle; pixel centres outside the domain (a
/// violated precondition) are ignored. Time O(pixels + triangles + the summed heights of the
/// triangles in pixel rows), memory O(triangles). `threads` > 1 shares the triangles among that many
/// threads (0: every hardware thread); the result does not depend on it, nor on `device`. With
/// TrixelDevice::gpu the sums are made on the device (the image and the mesh copied there, the image
/// unless `on_device` holds it already, as detect_edges left it; `threads` unused); that throws
/// cdt::DeviceError on a CUDA failure or in a build without CUDA. `lab`, when given, receives the
/// colours' CIELAB that were made with them (TrixelLab: with TrixelDevice::gpu, of the triangles that
/// own pixels and of those that take a neighbour's colour; empty with TrixelDevice::cpu).
TrixelColours colour_trixels(const Image& image, const cdt::Triangulation& t, unsigned threads = 1,
                             TrixelDevice device = TrixelDevice::cpu, const DevicePixels& on_device = {},
                             TrixelLab* lab = nullptr);

/// Prepares TrixelDevice::gpu for `callers` threads calling colour_trixels() at once: loads its device
/// code and pins host memory for their copies (16 MB per caller, at most 64 MB; the edges' copies on
/// the device use it too), so that their images do not wait for either. Returns false, doing nothing, in a
/// build without CUDA or without a device; never throws.
bool prepare_trixels_on_device(unsigned callers) noexcept;

/// The triangle that owns each pixel centre, row-major from the top-left (width * height entries),
/// cdt::kNone for a centre outside the domain of t. The fill rule: a centre p belongs to the
/// triangle whose interior contains p moved by an infinitesimal step right and an even smaller step
/// down; decided with exact predicates, so a centre on an edge or on a vertex has exactly one owner.
/// colour_trixels() uses the same rule. Preconditions as for colour_trixels(), width, height >= 0.
std::vector<std::uint32_t> owner_of_pixels(int width, int height, const cdt::Triangulation& t);

} // namespace vectorize
