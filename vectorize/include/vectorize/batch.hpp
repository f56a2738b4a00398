#pragma once
// Batch conversion: many images, several workers, every failure reported and none fatal to the rest.

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "vectorize/pipeline.hpp"

namespace vectorize {

/// One image to convert and where its SVG goes.
struct BatchJob {
  std::filesystem::path input;
  std::filesystem::path output;
  /// Where its debug folder goes (BatchOptions::write_debug); empty for none.
  std::filesystem::path debug = {};
};

/// The file name extensions (lower case, with the dot) that directory scans pick up as images.
const std::vector<std::string>& image_extensions();

struct JobResult;

/// Expands command-line inputs into jobs writing under out_dir, mirroring the input tree:
/// - a file gives out_dir / (its stem + ".svg") — given explicitly, it is converted whatever its
///   extension (a non-image then fails with a clear message);
/// - a directory gives its images (image_extensions()), directly inside it or, with `recursive`, in
///   any subdirectory, each at out_dir / (path relative to the directory, extension ".svg").
/// Inputs that do not exist are returned as jobs too (they fail with "no such file" when run), so
/// that they are reported with the rest. Two inputs mapping to one output keep the first; the others,
/// and the folders that cannot be read, are added to `refused` as failed jobs, with the reason. The result
/// is sorted by output path and duplicates of the same input are removed. The folders of `own` (the batch's
/// output and debug folders) are not walked into: inside an input folder, their overlays would become inputs.
std::vector<BatchJob> plan_batch(const std::vector<std::filesystem::path>& inputs,
                                 const std::filesystem::path& out_dir, bool recursive,
                                 std::vector<JobResult>& refused,
                                 const std::vector<std::filesystem::path>& own = {});

/// Gives every job a debug folder under debug_dir that mirrors its output under out_dir: the output
/// out_dir/a/b.svg gets debug_dir/a/b (the output's path relative to out_dir without its extension).
void assign_debug_folders(std::vector<BatchJob>& jobs, const std::filesystem::path& out_dir,
                          const std::filesystem::path& debug_dir);

/// Reads input paths, one per line (blanks at a line's end dropped; blank lines and lines starting with
/// '#' skipped), from a file or, for "-", from standard input. Throws FileError when the list cannot be
/// read.
std::vector<std::filesystem::path> read_input_list(const std::filesystem::path& list);

enum class JobStatus { converted, skipped, failed };

/// The outcome of one job.
struct JobResult {
  BatchJob job;
  JobStatus status = JobStatus::failed;
  std::string error;    ///< the reason, for a failed job
  double seconds = 0.0; ///< wall time of load + convert + write
  double started = 0.0; ///< when the job began, in seconds after run_batch began
  std::size_t input_bytes = 0;
  Stats stats; ///< of a converted job
};

/// With the automatic backend, a batch of at least this many images per worker shares the device, when
/// there is one, as with the GPU backend (BatchOptions::SharedCdt::automatic); a smaller batch converts
/// on the CPU, each worker triangulating its own images. The device's start (0.3-0.4 s) and end pay
/// only in longer batches (H200 machine, 16 workers, images/s sharing the device against each worker
/// on the CPU: 64 images 80-91 against 113-114, 200 images 124-136 against 120-131, 256 images
/// 146-157 against 134-143, 1000 images 176-205 against 132-137).
inline constexpr std::size_t kDeviceBatchImagesPerWorker = 16;

struct BatchOptions {
  Options conversion;
  /// Cores to use (the -j budget): that many images at a time, each on one thread, or with fewer images
  /// the cores shared out among them; 0 uses every hardware thread.
  unsigned workers = 0;
  /// Leave jobs whose output already exists alone (resuming an interrupted batch).
  bool skip_existing = false;
  /// Images with more pixels than this are refused before decoding their pixels.
  std::size_t max_pixels = std::size_t{1} << 27;
  /// Whether the images' PSLGs are triangulated together: threads of their own (two with four workers
  /// or more, else one) triangulate the PSLGs waiting, about `workers` at a time, in one call of
  /// cdt::triangulate_many each, so that the fixed costs of a call, on the GPU most of its time at a
  /// photograph's size, are shared. A worker never waits for them: it sets the image aside and takes
  /// another, and finishes the image when its CDT is back.
  /// Up to 5 x max(2, workers) + workers images are under way at once (their pixels and PSLGs held).
  /// The SVGs are the same either way.
  enum class SharedCdt {
    /// with the GPU backend (cdt::Backend::gpu) and more than one image, or with the automatic backend
    /// and at least kDeviceBatchImagesPerWorker images per worker: the batch then starts CUDA as it
    /// begins and, when there is a device, converts as with the GPU backend (edges, CDT and trixel
    /// colours there, the CPU until it is up); without one, each worker triangulates its own images on
    /// the CPU
    automatic,
    always, ///< with any backend, the CPU's too (more than one image)
    never,
  };
  SharedCdt shared_cdt = SharedCdt::automatic;
  /// Set (e.g. from a signal handler) to stop: no new job starts, jobs under way finish.
  const std::atomic<bool>* stop = nullptr;
  /// Writes the debug folder of a converted image whose job has one (BatchJob::debug), with every
  /// stage's output; called from the worker, before the SVG is written, so that an exception from it
  /// fails the image and leaves no SVG. Unset: no debug folders.
  std::function<void(const BatchJob&, const Image&, const Conversion&, const StageRecord&)> write_debug;
  /// Called after each job, from the worker that ran it, one call at a time.
  std::function<void(const JobResult&, std::size_t done, std::size_t total)> on_done;
};

/// The threads each conversion of a batch of `num_jobs` images gets: options.conversion.threads when
/// set, else the -j budget shared out among the images converted at once (1 when there are at least as
/// many images as cores).
unsigned threads_per_conversion(const BatchOptions& options, std::size_t num_jobs);

/// Runs the jobs on min(options.workers, jobs) threads, each converting one image at a time (so memory
/// stays bounded by the workers x one image's working set; with a shared CDT, see
/// BatchOptions::shared_cdt, up to 5 x max(2, workers) + workers images are held), the cores of
/// options.workers shared out between them. With a shared CDT and the device in use, the workers lower
/// their threads' priority (10 nice levels) below the CDT threads' and the device start's, which the
/// batch waits on. Every job's result is returned in the order of `jobs`; jobs never started because
/// of `stop` are absent.
std::vector<JobResult> run_batch(const std::vector<BatchJob>& jobs, const BatchOptions& options);

/// The results as a JSON report (one object per image: input, output, status, error, when it started
/// and how long it took, sizes, counts and stage times).
std::string batch_report_json(const std::vector<JobResult>& results, double wall_seconds);

} // namespace vectorize
