// vectorize --debug DIR as a user runs it: overlays per stage in each format, errors, batch mode.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "../test_util.hpp"
#include "vectorize/debug_overlays.hpp"
#include "vectorize/image.hpp"

namespace {

namespace fs = std::filesystem;
using trixel_test::read_all;
using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;

const std::string kBin = TRIXEL_VECTORIZE_BIN;
const fs::path kSamples = fs::path(TRIXEL_SOURCE_DIR) / "samples";

std::size_t differing_pixels(const vectorize::Image& a, const vectorize::Image& b) {
  std::size_t n = 0;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        if (std::fabs(a.pixel(x, y)[c] - b.pixel(x, y)[c]) > 2.5f / 255.0f) {
          ++n;
          break;
        }
      }
    }
  }
  return n;
}

std::string vectorize_debug(const fs::path& input, const fs::path& out, const fs::path& debug,
                            const std::string& more = "") {
  return shell_quote(kBin) + " " + shell_quote(input) + " " + shell_quote(out) + " --debug " +
         shell_quote(debug) + more;
}

// The dimmed input with nothing drawn, as the CLI draws it.
vectorize::Image blank_overlay(const fs::path& input, const fs::path& scratch) {
  vectorize::OverlayCanvas canvas(vectorize::load_image(input));
  canvas.save(scratch / "blank.png");
  return vectorize::load_image(scratch / "blank.png");
}

TEST(VectorizeDebugCli, PngOverlaysHaveTheImageSizeAndShowEachStage) {
  ScratchDir dir;
  const fs::path input = kSamples / "logo.png";
  const auto r = run(vectorize_debug(input, dir / "logo.svg", dir / "debug", " --preset logo -v"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("index.html"), std::string::npos) << r.output;
  const auto blank = blank_overlay(input, dir.path());
  for (const auto stage : vectorize::kDebugStages) {
    const std::string stem = vectorize::debug_stage_names(stage).stem;
    const auto overlay = vectorize::load_image(dir / "debug" / (stem + ".png"));
    EXPECT_EQ(overlay.width, blank.width) << stem;
    EXPECT_EQ(overlay.height, blank.height) << stem;
    EXPECT_GT(differing_pixels(overlay, blank), 500u) << stem;
  }
  EXPECT_EQ(read_all(dir / "debug" / "result.svg"), read_all(dir / "logo.svg"));
  EXPECT_EQ(read_all(dir / "debug" / "input.png"), read_all(input));
  EXPECT_TRUE(fs::exists(dir / "debug" / "regions.json"));
  EXPECT_TRUE(fs::exists(dir / "debug" / "index.html"));
}

// The size of an SVG overlay is in its viewBox; rendered (where rsvg-convert is installed), it must
// differ from the blank canvas rendered the same way.
TEST(VectorizeDebugCli, SvgOverlays) {
  ScratchDir dir;
  const fs::path input = kSamples / "logo.png";
  const auto r = run(vectorize_debug(input, dir / "logo.svg", dir / "debug", " --debug-format svg"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  vectorize::OverlayCanvas blank_canvas(vectorize::load_image(input));
  blank_canvas.save(dir / "blank.svg", vectorize::OverlayFormat::svg);
  const std::string blank = read_all(dir / "blank.svg");
  const bool have_rsvg = run("command -v rsvg-convert").exit_code == 0;
  if (have_rsvg) {
    ASSERT_EQ(run("rsvg-convert -o " + shell_quote(dir / "blank.png") + " " + shell_quote(dir / "blank.svg"))
                  .exit_code,
              0);
  }
  for (const auto stage : vectorize::kDebugStages) {
    const std::string stem = vectorize::debug_stage_names(stage).stem;
    const fs::path file = dir / "debug" / (stem + ".svg");
    const std::string svg = read_all(file);
    EXPECT_NE(svg.find("viewBox=\"0 0 256 256\""), std::string::npos) << stem;
    EXPECT_GT(svg.size(), blank.size() + 200) << stem << ": no more than the blank canvas";
    EXPECT_TRUE(fs::exists(dir / "debug" / "layers" / (stem + ".svg"))) << stem;
    if (have_rsvg) {
      const fs::path png = dir / (stem + ".png");
      ASSERT_EQ(run("rsvg-convert -o " + shell_quote(png) + " " + shell_quote(file)).exit_code, 0);
      const auto rendered = vectorize::load_image(png);
      EXPECT_EQ(rendered.width, 256);
      EXPECT_EQ(rendered.height, 256);
      EXPECT_GT(differing_pixels(rendered, vectorize::load_image(dir / "blank.png")), 500u) << stem;
    }
  }
  if (!have_rsvg) std::printf("rsvg-convert not installed: SVG overlays were not rendered\n");
}

TEST(VectorizeDebugCli, PdfOverlays) {
  ScratchDir dir;
  const auto r =
      run(vectorize_debug(kSamples / "logo.png", dir / "logo.svg", dir / "debug", " --debug-format pdf"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const auto stage : vectorize::kDebugStages) {
    const std::string stem = vectorize::debug_stage_names(stage).stem;
    EXPECT_EQ(read_all(dir / "debug" / (stem + ".pdf")).substr(0, 5), "%PDF-") << stem;
  }
}

// A file where the folder should go: exit 1 naming it, nothing written (no SVG, file untouched).
TEST(VectorizeDebugCli, RegularFileAsDebugFolderFailsNamingIt) {
  ScratchDir dir;
  std::ofstream(dir / "notes.txt") << "keep me";
  const auto r = run(vectorize_debug(kSamples / "logo.png", dir / "logo.svg", dir / "notes.txt"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find((dir / "notes.txt").string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not a directory"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "logo.svg"));
  EXPECT_EQ(read_all(dir / "notes.txt"), "keep me");
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1u);

  const auto below = run(vectorize_debug(kSamples / "logo.png", dir / "logo.svg", dir / "notes.txt" / "sub"));
  EXPECT_EQ(below.exit_code, 1) << below.output;
  EXPECT_NE(below.output.find("notes.txt"), std::string::npos) << below.output;
  EXPECT_FALSE(fs::exists(dir / "logo.svg"));
}

TEST(VectorizeDebugCli, FormatWithoutFolderOrUnknownIsUsageError) {
  ScratchDir dir;
  const std::string base =
      shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " + shell_quote(dir / "x.svg");
  EXPECT_EQ(run(base + " --debug-format svg").exit_code, 2);
  EXPECT_EQ(run(base + " --debug " + shell_quote(dir / "d") + " --debug-format gif").exit_code, 2);
  EXPECT_FALSE(fs::exists(dir / "x.svg"));
  EXPECT_FALSE(fs::exists(dir / "d"));
}

TEST(VectorizeDebugCli, HelpDocumentsTheOptions) {
  const auto r = run(shell_quote(kBin) + " --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("--debug "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--debug-format"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("index.html"), std::string::npos) << r.output;
}

// Batch mode: one folder per image mirroring the input tree; an image whose folder cannot be written
// fails alone, with the path in the message and no SVG.
TEST(VectorizeDebugCli, BatchWritesOneFolderPerImage) {
  ScratchDir dir;
  fs::create_directories(dir / "in" / "sub");
  fs::copy_file(kSamples / "logo.png", dir / "in" / "logo.png");
  fs::copy_file(kSamples / "strokes.png", dir / "in" / "sub" / "strokes.png");
  fs::copy_file(kSamples / "gradient.png", dir / "in" / "sub" / "gradient.png");
  fs::create_directories(dir / "debug" / "sub");
  std::ofstream(dir / "debug" / "sub" / "gradient") << "in the way";
  const auto r = run(shell_quote(kBin) + " " + shell_quote(dir / "in") + " -r -o " +
                     shell_quote(dir / "out") + " --debug " + shell_quote(dir / "debug") + " -j 2");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("1 failed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find((dir / "debug" / "sub" / "gradient").string()), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out" / "sub" / "gradient.svg"));
  for (const char* name : {"logo", "sub/strokes"}) {
    EXPECT_TRUE(fs::exists(dir / "out" / (std::string(name) + ".svg"))) << name;
    const fs::path folder = dir / "debug" / name;
    EXPECT_TRUE(fs::exists(folder / "index.html")) << name;
    EXPECT_TRUE(fs::exists(folder / "07-polygons.png")) << name;
    EXPECT_EQ(read_all(folder / "result.svg"), read_all(dir / "out" / (std::string(name) + ".svg"))) << name;
  }
  EXPECT_EQ(read_all(dir / "debug" / "sub" / "gradient"), "in the way");

  // The whole folder in the way: refused before any image is converted.
  std::ofstream(dir / "flat") << "x";
  const auto refused = run(shell_quote(kBin) + " " + shell_quote(dir / "in") + " -o " +
                           shell_quote(dir / "out2") + " --debug " + shell_quote(dir / "flat"));
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find((dir / "flat").string()), std::string::npos) << refused.output;
  EXPECT_FALSE(fs::exists(dir / "out2" / "logo.svg"));
}

} // namespace
