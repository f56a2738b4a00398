// Batch conversion as a user runs it: mixed good and bad inputs, resuming, determinism across worker
// counts, interruption.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "cdt/cdt.hpp"
#include "vectorize/batch.hpp"

namespace {

namespace fs = std::filesystem;
using trixel_test::read_all;
using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;

const std::string kBin = TRIXEL_VECTORIZE_BIN;
const fs::path kSamples = fs::path(TRIXEL_SOURCE_DIR) / "samples";

/// Every file under dir, relative to it.
std::vector<std::string> files_under(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) out.push_back(e.path().lexically_relative(dir).string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

bool complete_svg(const fs::path& path) {
  const std::string svg = read_all(path);
  return svg.find("<svg") != std::string::npos && svg.find("</svg>") != std::string::npos;
}

/// A folder of inputs: the samples, one in a subfolder, and every kind of bad file.
void make_mixed_inputs(const fs::path& in) {
  fs::create_directories(in / "sub");
  for (const char* name : {"logo.png", "strokes.png", "gradient.png", "photo.png"}) {
    fs::copy_file(kSamples / name, in / name);
  }
  fs::copy_file(kSamples / "logo.png", in / "sub" / "nested.png");
  std::ofstream(in / "corrupt.png") << "this is not a PNG";
  std::ofstream(in / "zero.png").flush();
  const std::string photo = read_all(kSamples / "photo.png");
  std::ofstream(in / "sub" / "truncated.png", std::ios::binary) << photo.substr(0, photo.size() / 3);
  std::ofstream(in / "notes.txt") << "not an image, and not named like one";
}

// The -j budget: N images at a time on one thread each; fewer images share the cores out; an explicit
// thread count wins.
TEST(VectorizeBatch, ThreadsPerConversionShareTheBudget) {
  vectorize::BatchOptions options;
  options.workers = 4;
  EXPECT_EQ(vectorize::threads_per_conversion(options, 100), 1u);
  EXPECT_EQ(vectorize::threads_per_conversion(options, 4), 1u);
  EXPECT_EQ(vectorize::threads_per_conversion(options, 2), 2u);
  EXPECT_EQ(vectorize::threads_per_conversion(options, 1), 4u);
  EXPECT_EQ(vectorize::threads_per_conversion(options, 3), 1u);
  options.workers = 16;
  EXPECT_EQ(vectorize::threads_per_conversion(options, 5), 3u);
  options.conversion.threads = 7;
  EXPECT_EQ(vectorize::threads_per_conversion(options, 100), 7u);
}

// Every good image converted, every bad one reported by name, exit status 1, no partial files.
TEST(VectorizeBatch, MixedInputsConvertTheGoodReportTheBad) {
  ScratchDir dir;
  make_mixed_inputs(dir / "in");
  const auto r =
      run(shell_quote(kBin) + " " + shell_quote(dir / "in") + " " + shell_quote(dir / "in" / "notes.txt") +
          " -r -o " + shell_quote(dir / "out") + " --report " + shell_quote(dir / "report.json"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_EQ(files_under(dir / "out"), (std::vector<std::string>{"gradient.svg", "logo.svg", "photo.svg",
                                                                "strokes.svg", "sub/nested.svg"}))
      << r.output;
  for (const auto& f : files_under(dir / "out")) EXPECT_TRUE(complete_svg(dir / "out" / f)) << f;
  for (const char* bad : {"corrupt.png", "zero.png", "truncated.png", "notes.txt"}) {
    EXPECT_NE(r.output.find(bad), std::string::npos) << bad << " not reported:\n" << r.output;
  }
  EXPECT_NE(r.output.find("5 converted, 0 skipped, 4 failed"), std::string::npos) << r.output;
  const std::string report = read_all(dir / "report.json");
  EXPECT_NE(report.find("\"converted\":5"), std::string::npos) << report;
  EXPECT_NE(report.find("\"failed\":4"), std::string::npos) << report;
  EXPECT_NE(report.find("truncated.png"), std::string::npos) << report;
  // Every image says when it started, within the batch's wall time.
  const std::regex wall_field("\"wall_seconds\":([0-9.]+)");
  const std::regex started_field("\"started\":([0-9.]+),\"seconds\":([0-9.]+)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(report, m, wall_field)) << report;
  const double wall = std::stod(m[1]);
  int timed = 0;
  for (auto it = std::sregex_iterator(report.begin(), report.end(), started_field);
       it != std::sregex_iterator(); ++it, ++timed) {
    const double started = std::stod((*it)[1]);
    const double seconds = std::stod((*it)[2]);
    EXPECT_GE(started, 0.0);
    EXPECT_LE(started + seconds, wall + 0.002) << report; // both rounded to milliseconds
  }
  EXPECT_EQ(timed, 9) << report;
}

// An output folder that cannot be written (a file stands where a subfolder must go): the image is
// reported, the others still convert.
TEST(VectorizeBatch, UnwritableOutputIsReportedAndTheRestGoOn) {
  ScratchDir dir;
  fs::create_directories(dir / "in" / "sub");
  fs::copy_file(kSamples / "logo.png", dir / "in" / "logo.png");
  fs::copy_file(kSamples / "strokes.png", dir / "in" / "sub" / "strokes.png");
  fs::create_directories(dir / "out");
  std::ofstream(dir / "out" / "sub") << "a file in the way";
  const auto r =
      run(shell_quote(kBin) + " " + shell_quote(dir / "in") + " -r -o " + shell_quote(dir / "out"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(complete_svg(dir / "out" / "logo.svg")) << r.output;
  EXPECT_NE(r.output.find("sub"), std::string::npos) << r.output;
  EXPECT_EQ(files_under(dir / "out"), (std::vector<std::string>{"logo.svg", "sub"}));
}

// An interrupted batch resumes: --skip-existing converts only what is missing.
TEST(VectorizeBatch, SkipExistingConvertsOnlyWhatIsMissing) {
  ScratchDir dir;
  fs::create_directories(dir / "in");
  for (const char* name : {"logo.png", "strokes.png", "gradient.png", "photo.png"}) {
    fs::copy_file(kSamples / name, dir / "in" / name);
  }
  const std::string base =
      shell_quote(kBin) + " " + shell_quote(dir / "in") + " -o " + shell_quote(dir / "out");
  ASSERT_EQ(run(base).exit_code, 0);
  const std::string kept = read_all(dir / "out" / "logo.svg");
  fs::remove(dir / "out" / "photo.svg");
  fs::remove(dir / "out" / "strokes.svg");
  std::ofstream(dir / "out" / "logo.svg", std::ios::app) << "<!-- marker -->";
  const auto r = run(base + " --skip-existing --report " + shell_quote(dir / "report.json"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 converted, 2 skipped, 0 failed"), std::string::npos) << r.output;
  EXPECT_EQ(read_all(dir / "out" / "logo.svg"), kept + "<!-- marker -->"); // left alone
  EXPECT_TRUE(complete_svg(dir / "out" / "photo.svg"));
  EXPECT_TRUE(complete_svg(dir / "out" / "strokes.svg"));
}

// The worker count changes nothing in the output.
TEST(VectorizeBatch, SameBytesWithOneAndTwoWorkers) {
  ScratchDir dir;
  const std::string inputs = shell_quote(kSamples / "logo.png") + " " + shell_quote(kSamples / "photo.png") +
                             " " + shell_quote(kSamples / "strokes.png") + " " +
                             shell_quote(kSamples / "gradient.png");
  ASSERT_EQ(run(shell_quote(kBin) + " " + inputs + " -j 1 -o " + shell_quote(dir / "j1")).exit_code, 0);
  ASSERT_EQ(run(shell_quote(kBin) + " " + inputs + " -j 2 -o " + shell_quote(dir / "j2")).exit_code, 0);
  const auto names = files_under(dir / "j1");
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names, files_under(dir / "j2"));
  for (const auto& n : names) EXPECT_EQ(read_all(dir / "j1" / n), read_all(dir / "j2" / n)) << n;
}

// The GPU backend in a batch (CUDA started on a side thread as it begins): with a device the same
// bytes as the CPU backend (the CDT is unique and in canonical order); without one every image fails
// with the reason, none is written, and the batch ends.
TEST(VectorizeBatch, GpuBackendGivesTheCpuBytesOrFailsEveryImageClearly) {
  ScratchDir dir;
  const std::string inputs = shell_quote(kSamples / "logo.png") + " " + shell_quote(kSamples / "photo.png");
  ASSERT_EQ(run(shell_quote(kBin) + " " + inputs + " -j 2 -q --backend cpu -o " + shell_quote(dir / "cpu"))
                .exit_code,
            0);
  const auto r =
      run(shell_quote(kBin) + " " + inputs + " -j 2 -q --backend gpu -o " + shell_quote(dir / "gpu"));
  if (cdt::gpu_device_count() > 0) {
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto names = files_under(dir / "cpu");
    ASSERT_EQ(names.size(), 2u);
    EXPECT_EQ(names, files_under(dir / "gpu"));
    for (const auto& n : names) EXPECT_EQ(read_all(dir / "cpu" / n), read_all(dir / "gpu" / n)) << n;
  } else {
    EXPECT_EQ(r.exit_code, 1) << r.output;
    for (const char* name : {"logo.png", "photo.png"}) {
      EXPECT_NE(r.output.find(std::string(name) + ": "), std::string::npos) << r.output;
    }
    // "no CUDA device is available", or in a build without CUDA "this build has no CUDA support".
    EXPECT_NE(r.output.find("CUDA"), std::string::npos) << r.output;
    EXPECT_TRUE(!fs::exists(dir / "gpu") || files_under(dir / "gpu").empty());
  }
}

// The stages skip reading the alphas of an image whose reader knows them all to be 1 (RGB and grey
// files), and convert it as when they read them.
TEST(VectorizePipeline, KnownOpaqueImagesConvertAsWhenTheirAlphasAreRead) {
  EXPECT_FALSE(vectorize::load_image(kSamples / "logo.png").known_opaque); // RGBA
  for (const char* name : {"photo.png", "strokes.png", "gradient.png"}) {
    const vectorize::Image image = vectorize::load_image(kSamples / name);
    ASSERT_TRUE(image.known_opaque) << name;
    vectorize::Image unknown = image;
    unknown.known_opaque = false;
    EXPECT_EQ(vectorize::convert(image).svg, vectorize::convert(unknown).svg) << name;
  }
}

// The pipeline's PSLGs are framed by the image border, so cdt::triangulate_many triangulates them
// together, and each gets the CDT it gets alone.
TEST(VectorizeBatch, PslgsOfImagesTriangulatedTogetherGiveTheirOwnCdts) {
  std::vector<vectorize::Pslg> pslgs;
  for (const char* name : {"logo.png", "photo.png", "strokes.png", "gradient.png"}) {
    vectorize::StageRecord record;
    vectorize::convert(vectorize::load_image(kSamples / name), {}, &record);
    pslgs.push_back(record.pslg);
  }
  std::vector<cdt::Input> inputs;
  for (const auto& p : pslgs) inputs.push_back({p.points, p.segments});
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  std::vector<cdt::ManyResult> got = cdt::triangulate_many(inputs, options);
  ASSERT_EQ(got.size(), pslgs.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_FALSE(got[i].error) << i;
    EXPECT_EQ(got[i].triangulation.stats.inputs, pslgs.size()) << i;
    cdt::Triangulation alone = cdt::triangulate(pslgs[i].points, pslgs[i].segments, options);
    cdt::canonicalize(alone);
    cdt::canonicalize(got[i].triangulation);
    EXPECT_EQ(got[i].triangulation.vertices, alone.vertices) << i;
    EXPECT_EQ(got[i].triangulation.triangles, alone.triangles) << i;
    EXPECT_EQ(got[i].triangulation.neighbors, alone.neighbors) << i;
    EXPECT_EQ(got[i].triangulation.segment_of_edge, alone.segment_of_edge) << i;
  }
}

// `copies` copies of each of the four samples in `in`, named COPY-NAME.
void copy_samples(const fs::path& in, int copies) {
  fs::create_directories(in);
  for (const char* name : {"logo.png", "photo.png", "strokes.png", "gradient.png"}) {
    for (int copy = 0; copy < copies; ++copy)
      fs::copy_file(kSamples / name, in / (std::to_string(copy) + "-" + name));
  }
}

// Both folders hold the same `count` files, byte for byte.
void expect_same_files(const fs::path& a, const fs::path& b, std::size_t count) {
  const auto names = files_under(a);
  ASSERT_EQ(names.size(), count);
  EXPECT_EQ(names, files_under(b));
  for (const auto& n : names) EXPECT_EQ(read_all(a / n), read_all(b / n)) << n;
}

// A shared CDT (several workers' PSLGs per call; four workers: two CDT threads) changes no byte, and a
// bad image still fails alone.
TEST(VectorizeBatch, SharedCdtGivesTheSameBytes) {
  ScratchDir dir;
  copy_samples(dir / "in", 3);
  std::ofstream(dir / "in" / "corrupt.png") << "this is not a PNG";
  const std::string common = shell_quote(kBin) + " " + shell_quote(dir / "in") + " -q --backend cpu -j 4";
  const auto own = run(common + " --batch-cdt own -o " + shell_quote(dir / "own"));
  const auto shared = run(common + " --batch-cdt shared -o " + shell_quote(dir / "shared") + " --report " +
                          shell_quote(dir / "report.json"));
  EXPECT_EQ(own.exit_code, 1) << own.output;
  EXPECT_EQ(shared.exit_code, 1) << shared.output;
  EXPECT_NE(shared.output.find("corrupt.png"), std::string::npos) << shared.output;
  expect_same_files(dir / "own", dir / "shared", 12);
  EXPECT_NE(read_all(dir / "report.json").find("\"cdt_inputs\":"), std::string::npos);
  EXPECT_EQ(run(common + " --batch-cdt sometimes -o " + shell_quote(dir / "x")).exit_code, 2);
}

// Counts `"key":value` in a report.
std::size_t count_in_report(const std::string& report, const std::string& key_value) {
  std::size_t n = 0;
  for (std::size_t at = report.find(key_value); at != std::string::npos; at = report.find(key_value, at + 1))
    ++n;
  return n;
}

// The automatic backend (the default) in a batch of at least 16 images per worker shares the device
// when there is one, as the GPU backend does; the SVGs are the CPU backend's either way, a bad image
// fails alone, and without a device nothing fails for the want of one: each worker triangulates its
// own images on the CPU, unless --batch-cdt shared asks for them to be triangulated together.
TEST(VectorizeBatch, AutomaticBackendInALargeBatchGivesTheCpuBytes) {
  ScratchDir dir;
  copy_samples(dir / "in", 8);
  std::ofstream(dir / "in" / "truncated.png") << read_all(kSamples / "photo.png").substr(0, 2000);
  const std::string common = shell_quote(kBin) + " " + shell_quote(dir / "in") + " -q -j 2";
  const auto cpu = run(common + " --backend cpu -o " + shell_quote(dir / "cpu"));
  const auto automatic =
      run(common + " -o " + shell_quote(dir / "auto") + " --report " + shell_quote(dir / "auto.json"));
  EXPECT_EQ(cpu.exit_code, 1) << cpu.output;
  EXPECT_EQ(automatic.exit_code, 1) << automatic.output;
  EXPECT_NE(automatic.output.find("truncated.png"), std::string::npos) << automatic.output;
  expect_same_files(dir / "cpu", dir / "auto", 32);
  if (cdt::gpu_device_count() > 0) return;
  const std::string report = read_all(dir / "auto.json");
  EXPECT_EQ(count_in_report(report, "\"cdt_backend\":\"cpu\""), 32u) << report;
  EXPECT_EQ(count_in_report(report, "\"cdt_inputs\":1,"), 32u) << report;
  // Asked for, the CDTs are shared on the CPU too.
  const auto shared = run(common + " --batch-cdt shared -o " + shell_quote(dir / "shared") + " --report " +
                          shell_quote(dir / "shared.json"));
  EXPECT_EQ(shared.exit_code, 1) << shared.output;
  EXPECT_LT(count_in_report(read_all(dir / "shared.json"), "\"cdt_inputs\":1,"), 32u);
  expect_same_files(dir / "cpu", dir / "shared", 32);
}

TEST(VectorizeBatch, InputListFromStandardInput) {
  ScratchDir dir;
  const auto r = run("printf '%s\\n# a comment\\n\\n%s\\n' " + shell_quote(kSamples / "logo.png") + " " +
                     shell_quote(kSamples / "strokes.png") + " | " + shell_quote(kBin) +
                     " --from-list - -o " + shell_quote(dir / "out") + " -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(files_under(dir / "out"), (std::vector<std::string>{"logo.svg", "strokes.svg"}));
  EXPECT_EQ(r.output, ""); // -q: silence
}

// A list's lines lose their trailing blanks, and lines of blanks are skipped: "logo.png   " claimed
// logo.svg, failed, and left the real logo.png unconverted.
TEST(VectorizeBatch, InputListLinesLoseTrailingBlanks) {
  ScratchDir dir;
  std::ofstream(dir / "list.txt") << (kSamples / "logo.png").string() << "   \n"
                                  << (kSamples / "logo.png").string() << "\n   \n";
  const auto r = run(shell_quote(kBin) + " --from-list " + shell_quote(dir / "list.txt") + " -o " +
                     shell_quote(dir / "out") + " -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(files_under(dir / "out"), (std::vector<std::string>{"logo.svg"}));
}

// Two inputs with one output: the second is not converted, and counts as failed in the summary and
// the report.
TEST(VectorizeBatch, InputsSharingAnOutputAreReportedAsFailed) {
  ScratchDir dir;
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  fs::copy_file(kSamples / "logo.png", dir / "a" / "x.png");
  fs::copy_file(kSamples / "strokes.png", dir / "b" / "x.png");
  const auto r = run(shell_quote(kBin) + " " + shell_quote(dir / "a" / "x.png") + " " +
                     shell_quote(dir / "b" / "x.png") + " -o " + shell_quote(dir / "out") + " --report " +
                     shell_quote(dir / "report.json"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("1 converted, 0 skipped, 1 failed"), std::string::npos) << r.output;
  const std::string report = read_all(dir / "report.json");
  EXPECT_NE(report.find("\"failed\":1"), std::string::npos) << report;
  EXPECT_NE(report.find((dir / "b" / "x.png").string()), std::string::npos) << report;
}

// The batch's own output and debug folders inside its input tree are not walked into: a second run
// converted the first run's overlays as images.
TEST(VectorizeBatch, OwnFoldersInsideTheInputTreeAreNotInputs) {
  ScratchDir dir;
  fs::create_directories(dir / "src");
  fs::copy_file(kSamples / "logo.png", dir / "src" / "logo.png");
  const std::string command = shell_quote(kBin) + " " + shell_quote(dir / "src") + " -r -o " +
                              shell_quote(dir / "src" / "out") + " --debug " +
                              shell_quote(dir / "src" / "dbg");
  for (int round = 0; round < 2; ++round) {
    const auto r = run(command);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("1 converted"), std::string::npos) << "round " << round << ": " << r.output;
  }
  EXPECT_EQ(files_under(dir / "src" / "out"), (std::vector<std::string>{"logo.svg"}));
}

// A file name that is not UTF-8 is written into the report as U+FFFD, so that it stays valid JSON.
TEST(VectorizeBatch, ReportStaysJsonForNamesThatAreNotUtf8) {
  ScratchDir dir;
  fs::create_directories(dir / "in");
  fs::copy_file(kSamples / "logo.png", dir / "in" / std::string("bad\xff.png"));
  const auto r = run(shell_quote(kBin) + " " + shell_quote(dir / "in") + " -o " + shell_quote(dir / "out") +
                     " -q --report " + shell_quote(dir / "report.json"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const std::string report = read_all(dir / "report.json");
  EXPECT_NE(report.find("bad\\ufffd.png"), std::string::npos) << report;
  EXPECT_EQ(report.find('\xff'), std::string::npos);
}

TEST(VectorizeBatch, ImagesOverThePixelLimitAreRefused) {
  ScratchDir dir;
  const auto r = run(shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " -o " +
                     shell_quote(dir / "out") + " --max-pixels 1000");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("logo.png"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1000"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out" / "logo.svg"));
}

TEST(VectorizeBatch, BatchOnlyOptionsNeedAnOutputDirectory) {
  EXPECT_EQ(run(shell_quote(kBin) + " a.png b.svg --recursive").exit_code, 2);
  EXPECT_EQ(run(shell_quote(kBin) + " a.png b.png c.png").exit_code, 2);
  EXPECT_EQ(run(shell_quote(kBin) + " -o out").exit_code, 2);
}

// Ctrl-C: the batch stops, the images under way finish, nothing partial is left, exit status 130.
// The signal is sent once the first image is written: a background job of a non-interactive shell
// starts with SIGINT ignored, so a signal sent before the handler is installed would be lost.
void expect_clean_interrupt(const std::string& options, int jobs) {
  ScratchDir dir;
  fs::create_directories(dir / "in");
  for (int k = 0; k < 120; ++k) {
    std::string name = std::to_string(k);
    name += ".png"; // built by appending: gcc 12 warns falsely (-Wrestrict) on "p" + to_string(k) + ".png"
    fs::copy_file(kSamples / "photo.png", dir / "in" / name);
  }
  const auto r =
      run("{ " + shell_quote(kBin) + " " + shell_quote(dir / "in") + " -o " + shell_quote(dir / "out") +
          " -j " + std::to_string(jobs) + options + " & pid=$!; n=0; until ls " + shell_quote(dir / "out") +
          "/*.svg >/dev/null 2>&1 || [ $n -ge 600 ]; do sleep 0.05; n=$((n+1)); done; kill -INT $pid; "
          "wait $pid; echo \"exit=$?\"; }");
  EXPECT_NE(r.output.find("exit=130"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not started (interrupted)"), std::string::npos) << r.output;
  const auto written = files_under(dir / "out");
  EXPECT_LT(written.size(), 120u);
  for (const auto& f : written) {
    EXPECT_EQ(fs::path(f).extension(), ".svg") << f; // no temporary file left
    EXPECT_TRUE(complete_svg(dir / "out" / f)) << f;
  }
}

// With a shared CDT too (images set aside for their CDT finish as well), by one CDT thread (two
// workers) and by two (four workers).
TEST(VectorizeBatch, InterruptStopsCleanly) {
  for (const char* cdt : {"own", "shared"}) {
    for (const int jobs : {2, 4}) {
      SCOPED_TRACE(std::string(cdt) + ", -j " + std::to_string(jobs));
      expect_clean_interrupt(std::string(" --backend cpu --batch-cdt ") + cdt, jobs);
    }
  }
}

} // namespace
