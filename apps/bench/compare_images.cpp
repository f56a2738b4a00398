// compare_images: how closely a rendered SVG reproduces the raster it was made from.
//
// usage: compare_images [--csv] [--tolerance T] [--diff-map OUT.png] INPUT RENDER_OVER_WHITE
//                       [RENDER_OVER_MAGENTA]
//
// The renders are the SVG rasterised at the input's size (rsvg-convert -w W -h H), once with
// --background-color white and, for the coverage check, once with --background-color magenta.
//
// Prints one line, JSON by default (--csv: the same fields as one CSV row, no header; --csv-header
// prints the header alone):
//   psnr_db   PSNR over the R, G and B channels of the input composited over white against the render
//             over white, 8-bit scale (peak 255); null in JSON ("inf" in CSV) when the images are equal.
//   ssim      mean SSIM (Wang et al. 2004: Gaussian 11x11 window, sigma 1.5, K1 0.01, K2 0.03, peak 255)
//             computed on R, G and B separately and averaged over the three channels; the SSIM map is
//             averaged over the window positions that lie inside the image ("valid" region), or over
//             every pixel (reflected borders) when the image is smaller than the window.
//   mse       the mean squared error behind psnr_db.
//   opaque_pixels     pixels of the input with alpha >= 0.5 (all pixels when it has no alpha).
//   uncovered_pixels  opaque pixels where the two renders differ by more than T (default 0) in any
//                     channel: the background shows through there.
//   uncovered_half_pixels  opaque pixels where the background shows through by more than half (the
//                     renders' green channels, 255 over white and 0 over magenta, differ by more than
//                     127): holes rather than anti-aliased seams.
//   uncovered_solid_pixels  the uncovered pixels among the input's solid ones (alpha exactly 1):
//                     where a faithful render must not let any background through.
//   translucent_pixels  opaque pixels of the input with alpha < 1. A faithful render lets the
//                     background show through these too, so they may count as uncovered; this is the
//                     input's own share of the count.
// --diff-map writes, for a look at where the background shows, a grey image of the largest channel
// difference between the two renders at each opaque pixel.
// Input: PNG (or anything OpenCV reads), 8 or 16 bits, grey, grey+alpha, RGB or RGBA.
// Exit status: 0 success, 1 unreadable image or size mismatch (the message names the file), 2 usage.

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

struct CompareError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// An image as float BGR on the 8-bit scale (0..255) plus alpha in [0, 1].
struct Planes {
  cv::Mat bgr;   // CV_32FC3
  cv::Mat alpha; // CV_32FC1
  bool has_alpha = false;
};

Planes load(const std::string& path) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw CompareError(path + ": cannot read the image (missing, unreadable or not an image)");
  double scale = 1.0;
  switch (raw.depth()) {
  case CV_8U:
    break;
  case CV_16U:
    scale = 255.0 / 65535.0;
    break;
  default:
    throw CompareError(path + ": unsupported sample type (want 8 or 16 bits per channel)");
  }
  cv::Mat f;
  raw.convertTo(f, CV_MAKETYPE(CV_32F, raw.channels()), scale);
  Planes p;
  switch (raw.channels()) {
  case 1:
    cv::cvtColor(f, p.bgr, cv::COLOR_GRAY2BGR);
    break;
  case 2: {
    std::vector<cv::Mat> ch;
    cv::split(f, ch);
    cv::cvtColor(ch[0], p.bgr, cv::COLOR_GRAY2BGR);
    p.alpha = ch[1] / 255.0;
    p.has_alpha = true;
    break;
  }
  case 3:
    p.bgr = f;
    break;
  case 4: {
    std::vector<cv::Mat> ch;
    cv::split(f, ch);
    cv::merge(std::vector<cv::Mat>{ch[0], ch[1], ch[2]}, p.bgr);
    p.alpha = ch[3] / 255.0;
    p.has_alpha = true;
    break;
  }
  default:
    throw CompareError(path + ": unsupported channel count " + std::to_string(raw.channels()));
  }
  if (!p.has_alpha) p.alpha = cv::Mat(f.size(), CV_32FC1, cv::Scalar(1.0));
  return p;
}

/// The image composited over a background colour (BGR, 0..255); renders are normally opaque already.
cv::Mat over(const Planes& p, const cv::Scalar& background) {
  cv::Mat a3;
  cv::cvtColor(p.alpha, a3, cv::COLOR_GRAY2BGR);
  cv::Mat back(p.bgr.size(), CV_32FC3, background);
  cv::Mat out = p.bgr.mul(a3) + back.mul(cv::Scalar::all(1.0) - a3);
  return out;
}

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kMagenta(255, 0, 255); // BGR

double mean_squared_error(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d = a - b;
  d = d.mul(d);
  const cv::Scalar s = cv::mean(d);
  return (s[0] + s[1] + s[2]) / 3.0;
}

/// Mean SSIM of one channel pair (CV_32FC1, 0..255).
double ssim_channel(const cv::Mat& x, const cv::Mat& y) {
  constexpr double kC1 = (0.01 * 255) * (0.01 * 255);
  constexpr double kC2 = (0.03 * 255) * (0.03 * 255);
  const cv::Size window(11, 11);
  constexpr double kSigma = 1.5;
  auto blur = [&](const cv::Mat& m) {
    cv::Mat out;
    cv::GaussianBlur(m, out, window, kSigma, kSigma, cv::BORDER_REFLECT);
    return out;
  };
  cv::Mat xd, yd;
  x.convertTo(xd, CV_64F);
  y.convertTo(yd, CV_64F);
  const cv::Mat mx = blur(xd), my = blur(yd);
  const cv::Mat mx2 = mx.mul(mx), my2 = my.mul(my), mxy = mx.mul(my);
  const cv::Mat sx2 = blur(xd.mul(xd)) - mx2;
  const cv::Mat sy2 = blur(yd.mul(yd)) - my2;
  const cv::Mat sxy = blur(xd.mul(yd)) - mxy;
  cv::Mat num = (2 * mxy + kC1).mul(2 * sxy + kC2);
  cv::Mat den = (mx2 + my2 + kC1).mul(sx2 + sy2 + kC2);
  cv::Mat map;
  cv::divide(num, den, map);
  const int r = window.width / 2;
  if (map.cols > 2 * r && map.rows > 2 * r) map = map(cv::Rect(r, r, map.cols - 2 * r, map.rows - 2 * r));
  return cv::mean(map)[0];
}

double ssim(const cv::Mat& a, const cv::Mat& b) {
  std::vector<cv::Mat> ca, cb;
  cv::split(a, ca);
  cv::split(b, cb);
  double sum = 0;
  for (int c = 0; c < 3; ++c)
    sum += ssim_channel(ca[static_cast<std::size_t>(c)], cb[static_cast<std::size_t>(c)]);
  return sum / 3.0;
}

struct Coverage {
  long long opaque = 0;
  long long uncovered = 0;
  long long uncovered_half = 0;
  long long translucent = 0;
  long long uncovered_solid = 0;
};

/// Counts uncovered opaque pixels; when `diff_map` is given, fills it (CV_8UC1) with each opaque
/// pixel's largest channel difference between the two renders (0 elsewhere).
Coverage coverage(const Planes& input, const cv::Mat& on_white, const cv::Mat& on_magenta, double tolerance,
                  cv::Mat* diff_map) {
  Coverage c;
  if (diff_map != nullptr) *diff_map = cv::Mat::zeros(on_white.size(), CV_8UC1);
  for (int y = 0; y < on_white.rows; ++y) {
    const auto* a = input.alpha.ptr<float>(y);
    const auto* w = on_white.ptr<cv::Vec3f>(y);
    const auto* m = on_magenta.ptr<cv::Vec3f>(y);
    for (int x = 0; x < on_white.cols; ++x) {
      if (a[x] < 0.5F) continue;
      ++c.opaque;
      if (a[x] < 1.0F) ++c.translucent;
      double worst = 0;
      for (int k = 0; k < 3; ++k) worst = std::max(worst, static_cast<double>(std::fabs(w[x][k] - m[x][k])));
      if (worst > tolerance) {
        ++c.uncovered;
        if (a[x] >= 1.0F) ++c.uncovered_solid;
      }
      if (diff_map != nullptr) diff_map->at<unsigned char>(y, x) = cv::saturate_cast<unsigned char>(worst);
      // Green is 255 in white and 0 in magenta: its difference is (1 - coverage) * 255.
      if (std::fabs(w[x][1] - m[x][1]) > 127.0F) ++c.uncovered_half;
    }
  }
  return c;
}

void check_size(const Planes& input, const Planes& render, const std::string& input_path,
                const std::string& render_path) {
  if (input.bgr.size() != render.bgr.size()) {
    throw CompareError(render_path + ": size " + std::to_string(render.bgr.cols) + "x" +
                       std::to_string(render.bgr.rows) + " differs from the input " + input_path + " (" +
                       std::to_string(input.bgr.cols) + "x" + std::to_string(input.bgr.rows) + ")");
  }
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

constexpr const char* kCsvHeader =
    "width,height,psnr_db,ssim,mse,opaque_pixels,uncovered_pixels,uncovered_half_pixels,translucent_pixels,"
    "uncovered_solid_pixels";

int usage(const char* message) {
  if (message != nullptr) std::fprintf(stderr, "compare_images: %s\n", message);
  std::fprintf(stderr,
               "usage: compare_images [--csv] [--tolerance T] [--diff-map OUT.png] INPUT RENDER_OVER_WHITE "
               "[RENDER_OVER_MAGENTA]\n"
               "       compare_images --csv-header\n");
  return kExitUsage;
}

} // namespace

int main(int argc, char** argv) {
  // OpenCV's own warnings (e.g. on a missing file) would duplicate the message below.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  bool csv = false;
  double tolerance = 0;
  std::string diff_map_path;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--csv") {
      csv = true;
    } else if (arg == "--csv-header") {
      std::printf("%s\n", kCsvHeader);
      return 0;
    } else if (arg == "--tolerance") {
      if (i + 1 >= argc) return usage("--tolerance needs a value");
      char* end = nullptr;
      tolerance = std::strtod(argv[++i], &end);
      if (end == argv[i] || *end != '\0' || !(tolerance >= 0) || tolerance > 255)
        return usage("--tolerance wants a number from 0 to 255");
    } else if (arg == "--diff-map") {
      if (i + 1 >= argc) return usage("--diff-map needs a file name");
      diff_map_path = argv[++i];
    } else if (arg == "-h" || arg == "--help") {
      usage(nullptr);
      return 0;
    } else if (arg.size() > 1 && arg[0] == '-') {
      return usage(("unknown option " + arg).c_str());
    } else {
      files.push_back(arg);
    }
  }
  if (files.size() < 2 || files.size() > 3)
    return usage("want INPUT RENDER_OVER_WHITE [RENDER_OVER_MAGENTA]");

  try {
    const Planes input = load(files[0]);
    const Planes white = load(files[1]);
    check_size(input, white, files[0], files[1]);
    const cv::Mat reference = over(input, kWhite);
    const cv::Mat rendered = over(white, kWhite);
    const double mse = mean_squared_error(reference, rendered);
    const double psnr = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : HUGE_VAL;
    const double structural = ssim(reference, rendered);

    bool have_coverage = false;
    Coverage cov;
    if (files.size() == 3) {
      const Planes magenta = load(files[2]);
      check_size(input, magenta, files[0], files[2]);
      // Each render over its own background, so that renders written without one (transparent
      // where nothing was painted) still show the hole.
      cv::Mat diff;
      cov = coverage(input, rendered, over(magenta, kMagenta), tolerance,
                     diff_map_path.empty() ? nullptr : &diff);
      if (!diff_map_path.empty() && !cv::imwrite(diff_map_path, diff))
        throw CompareError(diff_map_path + ": cannot write the difference map");
      have_coverage = true;
    }

    const int w = input.bgr.cols, h = input.bgr.rows;
    char psnr_text[32];
    if (std::isfinite(psnr)) {
      std::snprintf(psnr_text, sizeof psnr_text, "%.4f", psnr);
    } else {
      std::snprintf(psnr_text, sizeof psnr_text, "%s", csv ? "inf" : "null");
    }
    const std::string opaque = have_coverage ? std::to_string(cov.opaque) : (csv ? "" : "null");
    const std::string unc = have_coverage ? std::to_string(cov.uncovered) : (csv ? "" : "null");
    const std::string unc_half = have_coverage ? std::to_string(cov.uncovered_half) : (csv ? "" : "null");
    const std::string translucent = have_coverage ? std::to_string(cov.translucent) : (csv ? "" : "null");
    const std::string unc_solid = have_coverage ? std::to_string(cov.uncovered_solid) : (csv ? "" : "null");
    if (csv) {
      std::printf("%d,%d,%s,%.6f,%.6f,%s,%s,%s,%s,%s\n", w, h, psnr_text, structural, mse, opaque.c_str(),
                  unc.c_str(), unc_half.c_str(), translucent.c_str(), unc_solid.c_str());
    } else {
      std::printf("{\"input\":%s,\"width\":%d,\"height\":%d,\"psnr_db\":%s,\"ssim\":%.6f,\"mse\":%.6f,"
                  "\"opaque_pixels\":%s,\"uncovered_pixels\":%s,\"uncovered_half_pixels\":%s,"
                  "\"translucent_pixels\":%s,\"uncovered_solid_pixels\":%s}\n",
                  json_string(files[0]).c_str(), w, h, psnr_text, structural, mse, opaque.c_str(),
                  unc.c_str(), unc_half.c_str(), translucent.c_str(), unc_solid.c_str());
    }
  } catch (const CompareError& e) {
    std::fprintf(stderr, "compare_images: %s\n", e.what());
    return kExitFailure;
  } catch (const cv::Exception& e) {
    std::fprintf(stderr, "compare_images: %s: OpenCV error: %s\n", files[0].c_str(), e.what());
    return kExitFailure;
  }
  return 0;
}
