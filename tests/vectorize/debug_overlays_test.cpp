// Debug overlays of each stage and the debug folder (overlays, layers, regions.json, index.html).
#include "vectorize/debug_overlays.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "cdt/io.hpp"
#include "vectorize/errors.hpp"

namespace {

namespace fs = std::filesystem;
using trixel_test::read_all;
using trixel_test::ScratchDir;
using vectorize::DebugStage;

const fs::path kLogo = fs::path(TRIXEL_SOURCE_DIR) / "samples" / "logo.png";

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

// Pixels (x + y * width) whose colour differs by more than a rounding step between two images.
std::set<int> differing_pixels(const vectorize::Image& a, const vectorize::Image& b) {
  std::set<int> out;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      for (int c = 0; c < 4; ++c) {
        if (std::fabs(a.pixel(x, y)[c] - b.pixel(x, y)[c]) > 2.5f / 255.0f) {
          out.insert(x + y * a.width);
          break;
        }
      }
    }
  }
  return out;
}

struct Converted {
  vectorize::Image image;
  vectorize::StageRecord record;
  std::string svg;
};

const Converted& logo() {
  static const Converted converted = [] {
    Converted c;
    c.image = vectorize::load_image(kLogo);
    c.svg = vectorize::convert(c.image, vectorize::preset_options(vectorize::Preset::logo), &c.record).svg;
    return c;
  }();
  return converted;
}

vectorize::Image blank_overlay(const vectorize::Image& image, const fs::path& path) {
  vectorize::OverlayCanvas canvas(image);
  canvas.save(path);
  return vectorize::load_image(path);
}

// Each stage must show up: compared with the same canvas with nothing drawn, a stage's overlay differs
// in many pixels. The minimum is far below what the logo gives and far above anti-aliasing noise.
TEST(DebugOverlays, EveryStageDrawsOverTheDimmedInput) {
  ScratchDir dir;
  const Converted& c = logo();
  const auto blank = blank_overlay(c.image, dir / "blank.png");
  for (const DebugStage stage : vectorize::kDebugStages) {
    const auto names = vectorize::debug_stage_names(stage);
    vectorize::OverlayCanvas canvas(c.image);
    vectorize::draw_debug_stage(canvas, stage, c.record);
    const fs::path file = dir / (std::string(names.stem) + ".png");
    canvas.save(file);
    const auto back = vectorize::load_image(file);
    ASSERT_EQ(back.width, c.image.width) << names.stem;
    ASSERT_EQ(back.height, c.image.height) << names.stem;
    const auto differ = differing_pixels(back, blank);
    EXPECT_GT(differ.size(), 500u) << names.stem;
  }
}

// The edge overlay paints exactly the edge pixels: a check that the comparison above sees the stage's
// content where it is and nothing else.
TEST(DebugOverlays, EdgeOverlayDiffersExactlyAtEdgePixels) {
  ScratchDir dir;
  const Converted& c = logo();
  const auto blank = blank_overlay(c.image, dir / "blank.png");
  vectorize::OverlayCanvas canvas(c.image);
  vectorize::draw_debug_stage(canvas, DebugStage::edges, c.record);
  canvas.save(dir / "edges.png");
  const auto differ = differing_pixels(vectorize::load_image(dir / "edges.png"), blank);
  std::set<int> edges;
  for (int y = 0; y < c.record.edges.height; ++y) {
    for (int x = 0; x < c.record.edges.width; ++x) {
      if (c.record.edges.at(x, y)) edges.insert(x + y * c.record.edges.width);
    }
  }
  ASSERT_FALSE(edges.empty());
  EXPECT_EQ(differ, edges);
}

// A record with nothing in it draws nothing: the comparison can tell a blank overlay.
TEST(DebugOverlays, EmptyRecordLeavesTheCanvasBlank) {
  ScratchDir dir;
  const Converted& c = logo();
  const auto blank = blank_overlay(c.image, dir / "blank.png");
  vectorize::StageRecord empty;
  empty.edges.width = c.image.width;
  empty.edges.height = c.image.height;
  empty.edges.on.assign(static_cast<std::size_t>(c.image.width) * c.image.height, 0);
  for (const DebugStage stage : vectorize::kDebugStages) {
    vectorize::OverlayCanvas canvas(c.image);
    vectorize::draw_debug_stage(canvas, stage, empty);
    canvas.save(dir / "o.png");
    EXPECT_TRUE(differing_pixels(vectorize::load_image(dir / "o.png"), blank).empty())
        << vectorize::debug_stage_names(stage).stem;
  }
}

TEST(DebugOverlays, RecordOfAnotherImageIsAnError) {
  const Converted& c = logo();
  vectorize::Image small;
  small.width = 10;
  small.height = 10;
  small.rgba.assign(400, 1.0f);
  vectorize::OverlayCanvas canvas(small);
  EXPECT_THROW(vectorize::draw_debug_stage(canvas, DebugStage::edges, c.record), vectorize::Error);
  vectorize::StageRecord broken = c.record;
  broken.trixels.pop_back();
  vectorize::OverlayCanvas full(c.image);
  EXPECT_THROW(vectorize::draw_debug_stage(full, DebugStage::trixel_colours, broken), vectorize::Error);
}

// Neighbouring regions usually have consecutive ids; their colours must be told apart at a glance.
TEST(DebugOverlays, ConsecutiveRegionIdsGetDistinctColours) {
  for (std::uint32_t id = 0; id < 200; ++id) {
    const auto a = vectorize::region_id_colour(id);
    const auto b = vectorize::region_id_colour(id + 1);
    const double d = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    EXPECT_GT(d, 0.2) << id;
    for (const float v : a) {
      EXPECT_GE(v, 0.0f);
      EXPECT_LE(v, 1.0f);
    }
  }
}

TEST(DebugFolder, WritesOverlaysLayersDataAndPage) {
  ScratchDir dir;
  const Converted& c = logo();
  vectorize::DebugOptions options;
  options.source = kLogo;
  const fs::path out = dir / "debug" / "logo";
  const auto files = vectorize::write_debug_folder(out, c.image, c.record, c.svg, options);
  EXPECT_EQ(files.size(), 19u);
  for (const DebugStage stage : vectorize::kDebugStages) {
    const std::string stem = vectorize::debug_stage_names(stage).stem;
    const auto overlay = vectorize::load_image(out / (stem + ".png"));
    EXPECT_EQ(overlay.width, c.image.width);
    EXPECT_EQ(overlay.height, c.image.height);
    EXPECT_TRUE(fs::exists(out / "layers" / (stem + ".png"))) << stem;
  }
  EXPECT_EQ(read_all(out / "input.png"), read_all(kLogo));
  EXPECT_EQ(read_all(out / "result.svg"), c.svg);
  // The PSLG, to the bit, as the cdt tool reads it.
  const cdt::io::Pslg pslg = cdt::io::read_pslg(out / "pslg.poly");
  EXPECT_EQ(pslg.points, c.record.pslg.points);
  EXPECT_EQ(pslg.segments, c.record.pslg.segments);
  const std::string json = read_all(out / "regions.json");
  EXPECT_EQ(count(json, "{\"id\":"), c.record.regions.regions.size());
  EXPECT_NE(json.find("\"width\":256"), std::string::npos);
  const std::string page = read_all(out / "index.html");
  // The data is embedded whole, so that the page works from file:// where fetch() is blocked.
  EXPECT_NE(page.find(json.substr(0, json.size() - 1)), std::string::npos);
  EXPECT_EQ(page.find("{{DATA}}"), std::string::npos);
  EXPECT_EQ(page.find("{{TITLE}}"), std::string::npos);
  EXPECT_EQ(page.find("http://"), page.find("http://www.w3.org/2000/svg")) << "no network references";
  EXPECT_EQ(page.find("https://"), std::string::npos);
  // Nothing but the files reported.
  std::size_t on_disk = 0;
  for (const auto& entry : fs::recursive_directory_iterator(out)) on_disk += entry.is_regular_file();
  EXPECT_EQ(on_disk, files.size());
}

TEST(DebugFolder, VectorFormatsAndTheirLayers) {
  ScratchDir dir;
  const Converted& c = logo();
  vectorize::DebugOptions options;
  options.format = vectorize::OverlayFormat::svg;
  vectorize::write_debug_folder(dir / "svg", c.image, c.record, c.svg, options);
  const std::string cdt = read_all(dir / "svg" / "04-cdt.svg");
  EXPECT_NE(cdt.find("viewBox=\"0 0 256 256\""), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "svg" / "layers" / "04-cdt.svg"));
  // Without a source file the decoded image is the base layer.
  EXPECT_EQ(vectorize::load_image(dir / "svg" / "input.png").width, 256);

  options.format = vectorize::OverlayFormat::pdf;
  vectorize::write_debug_folder(dir / "pdf", c.image, c.record, c.svg, options);
  EXPECT_EQ(read_all(dir / "pdf" / "07-polygons.pdf").substr(0, 4), "%PDF");
  // A browser cannot stack PDFs: the page's layers are PNGs.
  EXPECT_EQ(vectorize::load_image(dir / "pdf" / "layers" / "07-polygons.png").width, 256);
}

TEST(DebugFolder, FileInTheWayIsNamed) {
  ScratchDir dir;
  std::ofstream(dir / "taken") << "a file";
  try {
    vectorize::check_debug_folder(dir / "taken");
    ADD_FAILURE() << "no error";
  } catch (const vectorize::FileError& e) {
    EXPECT_EQ(e.path(), dir / "taken");
    EXPECT_NE(std::string(e.what()).find("not a directory"), std::string::npos) << e.what();
  }
  EXPECT_THROW(vectorize::check_debug_folder(dir / "taken" / "below"), vectorize::FileError);
  EXPECT_NO_THROW(vectorize::check_debug_folder(dir / "new" / "folder"));
  EXPECT_NO_THROW(vectorize::check_debug_folder(dir.path()));
}

// A failure part way leaves no partial folder: what the call wrote goes, what was there stays.
TEST(DebugFolder, FailureRemovesWhatWasWritten) {
  ScratchDir dir;
  const Converted& c = logo();
  fs::create_directories(dir / "existing");
  std::ofstream(dir / "existing" / "layers") << "a file where the layers folder goes";
  try {
    vectorize::write_debug_folder(dir / "existing", c.image, c.record, c.svg);
    ADD_FAILURE() << "no error";
  } catch (const vectorize::FileError& e) {
    EXPECT_NE(std::string(e.what()).find("layers"), std::string::npos) << e.what();
  }
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir / "existing")) ++entries;
  EXPECT_EQ(entries, 1u);

  // The source cannot be copied after the folder was created: the folder goes again.
  vectorize::DebugOptions options;
  options.source = dir / "missing.png";
  EXPECT_THROW(vectorize::write_debug_folder(dir / "new" / "deeper", c.image, c.record, c.svg, options),
               vectorize::FileError);
  EXPECT_FALSE(fs::exists(dir / "new"));
}

// An input kept in the debug folder under a name the folder uses is never overwritten; an input named
// like the copy is left as it is (and kept when the folder fails).
TEST(DebugFolder, NeverOverwritesTheInput) {
  ScratchDir dir;
  const Converted& c = logo();
  fs::create_directories(dir / "d");
  fs::copy_file(kLogo, dir / "d" / "04-cdt.png");
  vectorize::DebugOptions options;
  options.source = dir / "d" / "04-cdt.png";
  EXPECT_THROW(vectorize::write_debug_folder(dir / "d", c.image, c.record, c.svg, options),
               vectorize::FileError);
  EXPECT_EQ(read_all(dir / "d" / "04-cdt.png"), read_all(kLogo));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir / "d")) ++entries;
  EXPECT_EQ(entries, 1u);

  fs::create_directories(dir / "e");
  fs::copy_file(kLogo, dir / "e" / "input.png");
  options.source = dir / "e" / "input.png";
  vectorize::write_debug_folder(dir / "e", c.image, c.record, c.svg, options);
  EXPECT_EQ(read_all(dir / "e" / "input.png"), read_all(kLogo));
}

TEST(DebugFolder, PageEscapesTheTitle) {
  const std::string page = vectorize::detail::inspector_html("<b>&\"x\"", "{\"regions\":[]}");
  EXPECT_NE(page.find("&lt;b&gt;&amp;&quot;x&quot;"), std::string::npos);
  EXPECT_EQ(page.find("<b>&"), std::string::npos);
  EXPECT_NE(page.find("{\"regions\":[]}"), std::string::npos);
}

// JSON inside a <script> element must not be able to close it.
TEST(DebugFolder, JsonCannotCloseTheScriptElement) {
  const Converted& c = logo();
  const std::string json = vectorize::detail::inspector_json(c.record, 256, 256, "</script><b>", "[]");
  EXPECT_EQ(json.find("</script>"), std::string::npos);
  EXPECT_EQ(json.find('<'), std::string::npos);
}

} // namespace
