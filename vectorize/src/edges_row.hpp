#pragma once
// The per-pixel step of edge detection that picks each pixel's strongest colour channel, for the
// tests that check its vector form against the plain rule.

#include <cstdint>
#include <vector>

namespace vectorize::detail {

/// One row of the gradient: per pixel the channel whose gradient (gx, gy) is longest (the first of
/// equally long ones), its derivatives rounded to the nearest integer (ties to even) and saturated
/// to 16 bits as cv::saturate_cast<short> does, and at shape pixels (shape[x] != 0) the squared
/// length appended to `squared`. gx and gy hold `width` pixels of 3 floats each.
void strongest_channel_row(const float* gx, const float* gy, const std::uint8_t* shape, int width,
                           short* out_x, short* out_y, std::vector<float>& squared);

} // namespace vectorize::detail
