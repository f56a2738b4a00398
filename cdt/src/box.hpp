#pragma once
// Axis-aligned boxes of points.

#include <cstddef>

namespace cdt::detail {

/// Axis-aligned box.
struct Box {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;

  /// Grows the box to hold (x, y).
  void extend(double x, double y) {
    min_x = x < min_x ? x : min_x;
    min_y = y < min_y ? y : min_y;
    max_x = x > max_x ? x : max_x;
    max_y = y > max_y ? y : max_y;
  }
};

/// The box of count points (at least 1), point(k) giving the k-th (anything with x and y), on the
/// threads of executor (a CpuExecutor).
template <class PointAt, class Executor>
Box box_of_points(std::size_t count, PointAt&& point, Executor& executor) {
  const auto& first = point(0);
  return executor.reduce(
      count, Box{first.x, first.y, first.x, first.y},
      [&](Box& box, std::size_t k) {
        const auto& p = point(k);
        box.extend(p.x, p.y);
      },
      [](Box& box, const Box& part) {
        box.extend(part.min_x, part.min_y);
        box.extend(part.max_x, part.max_y);
      });
}

} // namespace cdt::detail
