#pragma once
// Where the PSLG puts an edge pixel's point (used by stages 4 and 5): the pixel centre, or, on the
// outline of a shape with transparency, where the shape's edge is.

#include "vectorize/chains.hpp"
#include "vectorize/image.hpp"

namespace vectorize {

/// A position in image coordinates: the image covers [0, width] x [0, height], y down; pixel (x, y)
/// is the unit square from (x, y) to (x + 1, y + 1).
struct Position {
  double x = 0.0;
  double y = 0.0;
  friend bool operator==(const Position&, const Position&) = default;
};

/// A pixel's point and what simplification must respect around it.
struct Placement {
  /// Where the point is.
  Position at;
  /// How far it lies from the pixel centre, pointing out of the shape; zero off an outline.
  Position shift;
  /// Whether the pixel is on a shape's outline (a shape pixel with a no-shape neighbour).
  bool outline = false;
};

/// Places the points of edge pixels.
///
/// Without an image (or one without transparency) every point is its pixel's centre. With one, a
/// pixel on the shape's outline (a shape pixel, alpha >= 1/2, with a no-shape 4-neighbour) moves
/// towards each such neighbour to where alpha, interpolated linearly between the two pixel centres,
/// crosses 1/2, but at most half a pixel: a hard edge lands on the boundary between the two pixels,
/// an anti-aliased one where it was drawn. A shape pixel whose only no-shape neighbours are diagonal
/// ones moves the same way along the diagonal. A point through the middle of the outline pixels would
/// leave half of each outside the polygons, and the background would show through the shape's rim.
/// Points stay inside their own pixel (its closed square), and distinct pixels never share a point:
/// where two shape pixels touch only at a corner, neither moves all the way into that corner.
class PointPlacement {
public:
  /// Every point at its pixel's centre.
  PointPlacement() = default;
  /// Outline pixels of `image` moved as described; the image must outlive the placement. Reads the
  /// alpha of every pixel once (unless Image::known_opaque): an image with no no-shape pixel has no
  /// outline to move points to.
  explicit PointPlacement(const Image& image);

  /// The point of pixel p (inside the image).
  Placement place(PixelPoint p) const;
  Position position(PixelPoint p) const { return place(p).at; }
  /// Whether pixel p (any coordinates) lies in the image and is solid (alpha 1): a pixel the polygons
  /// must cover completely, so simplification may not cut into it.
  bool solid(PixelPoint p) const;
  /// The image this placement was made for (null for the default one and an empty image).
  const Image* image() const { return image_; }
  /// Whether some pixel is no shape (alpha not >= 1/2, NaN included).
  bool any_no_shape() const { return has_outline_; }

private:
  const Image* image_ = nullptr;
  bool has_outline_ = false; // some pixel is no shape (alpha not >= 1/2)
};

} // namespace vectorize
