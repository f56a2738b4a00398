// compare_images: PSNR, SSIM and uncovered-pixel counts on small images with known answers.

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace {

using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;

struct Metrics {
  int width = 0, height = 0;
  std::string psnr; // kept as text: "inf" for equal images
  double ssim = 0, mse = 0;
  long long opaque = -1, uncovered = -1, uncovered_half = -1, translucent = -1, uncovered_solid = -1;
};

/// The compare_images command line with each argument quoted (appending only: GCC 12 warns
/// falsely on `"literal" + std::string` at -O3).
std::string command_line(const std::vector<std::string>& args) {
  std::string command = TRIXEL_COMPARE_IMAGES_BIN;
  for (const auto& a : args) {
    command += ' ';
    command += shell_quote(a);
  }
  return command;
}

Metrics compare(std::vector<std::string> args) {
  args.insert(args.begin(), "--csv");
  const auto r = run(command_line(args));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::vector<std::string> f;
  std::stringstream line(r.output);
  std::string field;
  while (std::getline(line, field, ',')) f.push_back(field);
  Metrics m;
  if (f.size() != 10) {
    ADD_FAILURE() << "want 10 CSV fields, got: " << r.output;
    return m;
  }
  m.width = std::stoi(f[0]);
  m.height = std::stoi(f[1]);
  m.psnr = f[2];
  m.ssim = std::stod(f[3]);
  m.mse = std::stod(f[4]);
  if (!f[5].empty()) m.opaque = std::stoll(f[5]);
  if (!f[6].empty()) m.uncovered = std::stoll(f[6]);
  if (!f[7].empty()) m.uncovered_half = std::stoll(f[7]);
  if (!f[8].empty()) m.translucent = std::stoll(f[8]);
  if (!f[9].empty() && f[9] != "\n") m.uncovered_solid = std::stoll(f[9]);
  return m;
}

std::string write(const ScratchDir& dir, const std::string& name, const cv::Mat& image) {
  const std::string path = (dir / name).string();
  EXPECT_TRUE(cv::imwrite(path, image)) << path;
  return path;
}

/// A textured RGB image with values in [20, 200], so that +-20 never clips.
cv::Mat textured(int w, int h) {
  cv::Mat m(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      m.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<unsigned char>(20 + (x * 37 + y * 11) % 181),
                                        static_cast<unsigned char>(20 + (x * 5 + y * 53) % 181),
                                        static_cast<unsigned char>(20 + (x * y) % 181));
  return m;
}

TEST(CompareImages, IdenticalImagesAreInfinitePsnrSsimOneNothingUncovered) {
  ScratchDir dir;
  const cv::Mat img = textured(40, 30);
  const auto in = write(dir, "in.png", img);
  const auto same = write(dir, "same.png", img);
  const Metrics m = compare({in, same, same});
  EXPECT_EQ(m.width, 40);
  EXPECT_EQ(m.height, 30);
  EXPECT_EQ(m.psnr, "inf");
  EXPECT_EQ(m.mse, 0.0);
  EXPECT_NEAR(m.ssim, 1.0, 1e-9);
  EXPECT_EQ(m.opaque, 40 * 30); // no alpha: every pixel counts
  EXPECT_EQ(m.uncovered, 0);
  EXPECT_EQ(m.uncovered_half, 0);
  EXPECT_EQ(m.translucent, 0);
}

// +10 on every channel of every pixel: MSE 100, PSNR 10 log10(255^2 / 100).
TEST(CompareImages, UniformOffsetGivesItsPsnr) {
  ScratchDir dir;
  const cv::Mat img = textured(40, 30);
  const cv::Mat brighter = img + cv::Scalar::all(10);
  const Metrics m = compare({write(dir, "in.png", img), write(dir, "r.png", brighter)});
  EXPECT_NEAR(m.mse, 100.0, 1e-6);
  EXPECT_NEAR(std::stod(m.psnr), 10.0 * std::log10(255.0 * 255.0 / 100.0), 1e-3);
  EXPECT_LT(m.ssim, 1.0);
  EXPECT_GT(m.ssim, 0.9);
  EXPECT_EQ(m.opaque, -1); // no magenta render: no coverage fields
}

// One channel of half the rows off by 30 (values stay in 50..230): MSE = 900 / 3 / 2 = 150.
TEST(CompareImages, PartialPerturbationGivesItsPsnr) {
  ScratchDir dir;
  const cv::Mat img = textured(40, 30);
  cv::Mat r = img.clone();
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 40; ++x)
      r.at<cv::Vec3b>(y, x)[1] = static_cast<unsigned char>(r.at<cv::Vec3b>(y, x)[1] + 30);
  const Metrics m = compare({write(dir, "in.png", img), write(dir, "r.png", r)});
  EXPECT_NEAR(m.mse, 150.0, 1e-6);
  EXPECT_NEAR(std::stod(m.psnr), 10.0 * std::log10(255.0 * 255.0 / 150.0), 1e-3);
}

// Flat images have no variance, so SSIM reduces to its luminance term (2ab + C1) / (a^2 + b^2 + C1).
TEST(CompareImages, SsimOfFlatImagesIsTheLuminanceTerm) {
  ScratchDir dir;
  const cv::Mat a(30, 30, CV_8UC3, cv::Scalar::all(100));
  const cv::Mat b(30, 30, CV_8UC3, cv::Scalar::all(120));
  const Metrics m = compare({write(dir, "a.png", a), write(dir, "b.png", b)});
  const double c1 = (0.01 * 255) * (0.01 * 255);
  EXPECT_NEAR(m.ssim, (2 * 100.0 * 120.0 + c1) / (100.0 * 100.0 + 120.0 * 120.0 + c1), 1e-6);
}

// The input's transparent pixels are composited over white before comparing.
TEST(CompareImages, TransparentInputIsComparedOverWhite) {
  ScratchDir dir;
  cv::Mat in(20, 20, CV_8UC4, cv::Scalar(0, 0, 0, 0)); // fully transparent black
  const cv::Mat white(20, 20, CV_8UC3, cv::Scalar::all(255));
  const Metrics m = compare({write(dir, "in.png", in), write(dir, "w.png", white)});
  EXPECT_EQ(m.psnr, "inf");
}

// A 30x20 opaque rectangle plus one pixel just above half alpha; a 4x3 hole and one faint seam pixel
// show the background in the magenta render. Pixels below half alpha never count.
TEST(CompareImages, HoleInRenderIsCountedAmongOpaquePixelsOnly) {
  ScratchDir dir;
  const cv::Rect shape(5, 5, 30, 20), hole(12, 10, 4, 3);
  cv::Mat in(30, 40, CV_8UC4, cv::Scalar(50, 100, 150, 0));
  in(shape).setTo(cv::Scalar(50, 100, 150, 255));
  in.at<cv::Vec4b>(1, 1)[3] = 127; // 0.498: not opaque
  in.at<cv::Vec4b>(1, 2)[3] = 128; // 0.502: opaque, but the renders leave it unpainted
  // The renders paint the rectangle but for the hole; elsewhere the background shows.
  cv::Mat on_white(30, 40, CV_8UC3, cv::Scalar::all(255));
  cv::Mat on_magenta(30, 40, CV_8UC3, cv::Scalar(255, 0, 255));
  for (cv::Mat* r : {&on_white, &on_magenta}) {
    (*r)(shape).setTo(cv::Scalar(50, 100, 150));
    (*r)(hole).setTo(r == &on_white ? cv::Scalar::all(255) : cv::Scalar(255, 0, 255));
  }
  on_magenta.at<cv::Vec3b>(20, 30)[1] = 90; // a seam: 10 levels of the background show through
  const auto in_path = write(dir, "in.png", in);
  const auto w = write(dir, "w.png", on_white);
  const auto mg = write(dir, "m.png", on_magenta);
  const Metrics m = compare({in_path, w, mg});
  EXPECT_EQ(m.opaque, 30 * 20 + 1);
  EXPECT_EQ(m.uncovered, 4 * 3 + 1 + 1); // hole, seam pixel, the unpainted half-alpha pixel
  EXPECT_EQ(m.uncovered_half, 4 * 3 + 1);
  EXPECT_EQ(m.translucent, 1);             // the half-alpha pixel
  EXPECT_EQ(m.uncovered_solid, 4 * 3 + 1); // the translucent pixel is not solid
  const Metrics tolerant = compare({"--tolerance", "10", in_path, w, mg});
  EXPECT_EQ(tolerant.uncovered, 4 * 3 + 1);
}

// Renders written without a background (transparent where nothing was painted) still show holes.
TEST(CompareImages, TransparentRenderPixelsCountAsUncovered) {
  ScratchDir dir;
  const cv::Mat in = textured(20, 20);
  cv::Mat render;
  cv::cvtColor(in, render, cv::COLOR_BGR2BGRA);
  render(cv::Rect(3, 4, 5, 2)).setTo(cv::Scalar::all(0));
  const auto r = write(dir, "r.png", render);
  const Metrics m = compare({write(dir, "in.png", in), r, r});
  EXPECT_EQ(m.uncovered, 5 * 2);
}

// Bad input: a clear message naming the file, never a crash.
TEST(CompareImages, BadInputNamesTheFile) {
  ScratchDir dir;
  const auto in = write(dir, "in.png", textured(20, 20));
  const auto small = write(dir, "small.png", textured(10, 20));
  const auto missing = (dir / "missing.png").string();
  auto r = run(command_line({in, missing}));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(missing), std::string::npos) << r.output;
  r = run(command_line({in, small}));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(small), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("differs"), std::string::npos) << r.output;
  const auto text = (dir / "text.png").string();
  std::FILE* f = std::fopen(text.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("not an image", f);
  std::fclose(f);
  r = run(command_line({text, in}));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(text), std::string::npos) << r.output;
  r = run(command_line({in}));
  EXPECT_EQ(r.exit_code, 2);
}

} // namespace
