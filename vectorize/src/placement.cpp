// Point placement for stages 4 and 5: outline pixels moved to their shape's edge.
#include "vectorize/placement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace vectorize {
namespace {

constexpr std::array<std::array<int, 2>, 4> kSides = {{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}};
constexpr std::array<std::array<int, 2>, 4> kCorners = {{{-1, -1}, {1, -1}, {-1, 1}, {1, 1}}};

// How a shape pixel meets the no-shape area: not at all, along a side, or only at a corner.
enum class Contact { none, side, corner };

class AlphaField {
public:
  explicit AlphaField(const Image& image) : image_(image) {}

  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < image_.width && y < image_.height; }
  double alpha(int x, int y) const { return image_.pixel(x, y)[3]; }
  bool shape(int x, int y) const { return inside(x, y) && alpha(x, y) >= 0.5; }
  bool solid(int x, int y) const { return inside(x, y) && alpha(x, y) >= 1.0; }

  // The move of shape pixel (x, y) towards its no-shape 4-neighbours, each to where alpha crosses 1/2
  // (capped at the pixel's own edge); with none, towards its no-shape diagonal neighbours. Moves the
  // opposite way cancel (a line one pixel thick stays on its centre line). Sets *contact to how the
  // pixel meets no shape.
  Position crossing_shift(int x, int y, Contact* contact = nullptr) const {
    Position out;
    if (contact != nullptr) *contact = Contact::none;
    const double a = alpha(x, y);
    for (const auto* steps_of : {&kSides, &kCorners}) {
      const auto& steps = *steps_of;
      bool found = false;
      for (const auto& [dx, dy] : steps) {
        // The image border is not an outline: nothing lies beyond it.
        if (!inside(x + dx, y + dy)) continue;
        const double beyond = alpha(x + dx, y + dy);
        if (beyond >= 0.5) continue;
        // a >= 1/2 > beyond: the crossing lies between the two centres.
        const double t = std::min(0.5, (a - 0.5) / (a - beyond));
        out.x += t * dx;
        out.y += t * dy;
        found = true;
      }
      if (found) {
        if (contact != nullptr) *contact = &steps == &kSides ? Contact::side : Contact::corner;
        break;
      }
    }
    // Two diagonal neighbours on one side add up; the point stays in its pixel.
    out.x = std::clamp(out.x, -0.5, 0.5);
    out.y = std::clamp(out.y, -0.5, 0.5);
    return out;
  }

private:
  const Image& image_;
};

} // namespace

PointPlacement::PointPlacement(const Image& image) : image_(image.rgba.empty() ? nullptr : &image) {
  // In blocks without an early exit inside, so that the compiler vectorises the comparisons.
  const std::size_t pixels = image.rgba.size() / 4;
  const float* rgba = image.rgba.data();
  constexpr std::size_t kBlock = 4096;
  if (image.known_opaque) return; // every alpha is 1: no pixel is outside the shape
  for (std::size_t first = 0; first < pixels && !has_outline_; first += kBlock) {
    const std::size_t last = std::min(pixels, first + kBlock);
    unsigned clear = 0;
    for (std::size_t i = first; i < last; ++i) clear |= !(rgba[4 * i + 3] >= 0.5f) ? 1u : 0u; // NaN too
    has_outline_ = clear != 0;
  }
}

Placement PointPlacement::place(PixelPoint p) const {
  Placement out;
  out.at = {p.x + 0.5, p.y + 0.5};
  // Without a no-shape pixel no shape pixel has an outline (crossing_shift finds no contact).
  if (image_ == nullptr || !has_outline_) return out;
  const AlphaField field(*image_);
  if (!field.shape(p.x, p.y)) return out;
  Contact contact = Contact::none;
  Position shift = field.crossing_shift(p.x, p.y, &contact);
  if (contact == Contact::none) return out;
  if (field.solid(p.x, p.y)) {
    // A solid outline pixel is covered whole: along an axis where it has no crossing, its point may go
    // to the edge it shares with a shape pixel that is not solid, and must, should the chain turn
    // there. Thinning may have taken that neighbour out of the chain, and a link from the middle of
    // this pixel's outer edge to the next chain pixel would then cut across it.
    const Position crossing = shift;
    for (const auto& [dx, dy] : kSides) {
      if (!field.shape(p.x + dx, p.y + dy) || field.solid(p.x + dx, p.y + dy)) continue;
      if ((dx != 0 ? crossing.x : crossing.y) != 0.0) continue;
      double& mine = dx != 0 ? shift.x : shift.y;
      mine = std::clamp(mine + 0.5 * (dx != 0 ? dx : dy), -0.5, 0.5);
    }
  } else {
    // Beside a solid outline pixel, the point moves as far out as that pixel's does across the line
    // joining them, should that be further; otherwise the link between the two would cut the solid
    // pixel's corner (at a thin tip, a move the other way loses: the solid pixel must stay covered).
    for (const auto& [dx, dy] : kSides) {
      if (!field.solid(p.x + dx, p.y + dy)) continue;
      const Position beside = field.crossing_shift(p.x + dx, p.y + dy);
      double& mine = dx != 0 ? shift.y : shift.x;
      const double theirs = dx != 0 ? beside.y : beside.x;
      if (std::fabs(theirs) > std::fabs(mine)) mine = theirs;
    }
  }
  // Only a solid pixel's point may reach the edge it shares with a shape pixel (which is then not
  // solid, and keeps its own point off that edge): two points never meet on an edge. A solid pixel
  // meeting no shape only at a corner keeps that corner: no side neighbour can reach it.
  const bool solid = field.solid(p.x, p.y);
  for (const auto& [dx, dy] : kSides) {
    if (solid && contact == Contact::corner) break;
    double& mine = dx != 0 ? shift.x : shift.y;
    const int towards = dx != 0 ? dx : dy;
    if (mine * towards > 0.45 && field.shape(p.x + dx, p.y + dy) &&
        !(solid && !field.solid(p.x + dx, p.y + dy)))
      mine = 0.45 * towards;
  }
  // A shape pixel diagonally across the corner this point reached would put its point there too.
  if (std::fabs(shift.x) == 0.5 && std::fabs(shift.y) == 0.5 &&
      field.shape(p.x + (shift.x > 0 ? 1 : -1), p.y + (shift.y > 0 ? 1 : -1))) {
    shift.x *= 0.9;
    shift.y *= 0.9;
  }
  out.outline = true;
  out.shift = shift;
  out.at.x += shift.x;
  out.at.y += shift.y;
  return out;
}

bool PointPlacement::solid(PixelPoint p) const {
  return image_ != nullptr && AlphaField(*image_).solid(p.x, p.y);
}

} // namespace vectorize
