// Batch conversion: planning the jobs, running them on a pool of workers, reporting.
#include "vectorize/batch.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <future>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <semaphore>
#include <set>
#include <sstream>
#include <system_error>
#include <thread>

#include "vectorize/errors.hpp"
#include "vectorize/image.hpp"

namespace vectorize {

namespace fs = std::filesystem;

const std::vector<std::string>& image_extensions() {
  static const std::vector<std::string> extensions{".png",  ".jpg", ".jpeg", ".tif", ".tiff", ".bmp",
                                                   ".webp", ".gif", ".tga",  ".ppm", ".pgm",  ".pnm",
                                                   ".exr",  ".hdr", ".psd",  ".jp2", ".dpx",  ".sgi"};
  return extensions;
}

namespace {

bool is_image_name(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const auto& known = image_extensions();
  return std::find(known.begin(), known.end(), ext) != known.end();
}

fs::path svg_name(fs::path relative) { return relative.replace_extension(".svg"); }

} // namespace

std::vector<BatchJob> plan_batch(const std::vector<fs::path>& inputs, const fs::path& out_dir, bool recursive,
                                 std::vector<std::string>& collisions) {
  std::vector<BatchJob> jobs;
  for (const fs::path& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      const auto add = [&](const fs::directory_entry& entry) {
        std::error_code e;
        if (!entry.is_regular_file(e) || !is_image_name(entry.path())) return;
        jobs.push_back({entry.path(), out_dir / svg_name(entry.path().lexically_relative(input))});
      };
      if (recursive) {
        for (fs::recursive_directory_iterator it(input, fs::directory_options::skip_permission_denied, ec),
             end;
             !ec && it != end; it.increment(ec)) {
          add(*it);
        }
      } else {
        for (fs::directory_iterator it(input, fs::directory_options::skip_permission_denied, ec), end;
             !ec && it != end; it.increment(ec)) {
          add(*it);
        }
      }
      continue;
    }
    jobs.push_back({input, out_dir / svg_name(input.filename())});
  }
  std::stable_sort(jobs.begin(), jobs.end(),
                   [](const BatchJob& a, const BatchJob& b) { return a.output < b.output; });
  std::vector<BatchJob> unique;
  std::set<fs::path> inputs_seen;
  for (const BatchJob& job : jobs) {
    const fs::path key = job.input.lexically_normal();
    if (!inputs_seen.insert(key).second) continue; // the same input named twice
    if (!unique.empty() && unique.back().output == job.output) {
      collisions.push_back(job.input.string() + ": its output " + job.output.string() +
                           " is already the output of " + unique.back().input.string() + "; not converted");
      continue;
    }
    unique.push_back(job);
  }
  return unique;
}

void assign_debug_folders(std::vector<BatchJob>& jobs, const fs::path& out_dir, const fs::path& debug_dir) {
  for (BatchJob& job : jobs) {
    fs::path relative = job.output.lexically_relative(out_dir);
    // An output not under out_dir (not from plan_batch) keeps its name, never a path out of debug_dir.
    if (relative.empty() || *relative.begin() == "..") relative = job.output.filename();
    job.debug = debug_dir / relative.replace_extension();
  }
}

std::vector<fs::path> read_input_list(const fs::path& list) {
  std::ifstream file;
  std::istream* in = &std::cin;
  if (list != "-") {
    file.open(list);
    if (!file) throw FileError(list, "cannot read the input list");
    in = &file;
  }
  std::vector<fs::path> paths;
  std::string line;
  while (std::getline(*in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    paths.emplace_back(line);
  }
  if (in->bad()) throw FileError(list, "read error in the input list");
  return paths;
}

namespace {

JobResult run_job(const BatchJob& job, const BatchOptions& options, const Options& conversion,
                  const Triangulator& triangulator) {
  JobResult r;
  r.job = job;
  const auto start = std::chrono::steady_clock::now();
  std::error_code ec;
  if (options.skip_existing && fs::exists(job.output, ec)) {
    r.status = JobStatus::skipped;
    return r;
  }
  try {
    if (fs::exists(job.output, ec) && fs::equivalent(job.output, job.input, ec)) {
      throw FileError(job.output, "is the input itself; refusing to overwrite it");
    }
    r.input_bytes =
        fs::is_regular_file(job.input, ec) ? static_cast<std::size_t>(fs::file_size(job.input, ec)) : 0;
    const Image image = load_image(job.input, options.max_pixels);
    const bool debug = !job.debug.empty() && options.write_debug;
    StageRecord record;
    const Conversion result = convert(image, conversion, debug ? &record : nullptr, triangulator);
    fs::create_directories(job.output.parent_path(), ec);
    if (ec) throw FileError(job.output.parent_path(), "cannot create the output directory: " + ec.message());
    // Debug folder first: when it fails, the image fails without an SVG (so --skip-existing retries it).
    if (debug) options.write_debug(job, image, result, record);
    write_file_atomically(job.output, result.svg);
    r.stats = result.stats;
    r.status = JobStatus::converted;
  } catch (const FileError& e) {
    r.error = e.what();
  } catch (const std::exception& e) {
    r.error = job.input.string() + ": " + e.what();
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

// -j N is a budget of N cores: N images at a time, each on one thread; with fewer images than that,
// the cores are shared out among them. So -j 1 converts on one core, and N workers never run
// N x cores threads.
unsigned batch_cores(const BatchOptions& options) {
  return options.workers == 0 ? std::max(1u, std::thread::hardware_concurrency()) : options.workers;
}

unsigned batch_workers(const BatchOptions& options, std::size_t num_jobs) {
  return std::max(1u, std::min<unsigned>(batch_cores(options),
                                         static_cast<unsigned>(std::max<std::size_t>(num_jobs, 1))));
}

// The workers' PSLGs triangulated together on a thread of its own: each call takes every PSLG waiting
// then (up to a limit), so that calls grow with the load and an idle batch waits for no one.
class SharedTriangulation {
public:
  explicit SharedTriangulation(const cdt::Options& options) : options_(options), thread_([this] { run(); }) {}
  SharedTriangulation(const SharedTriangulation&) = delete;
  SharedTriangulation& operator=(const SharedTriangulation&) = delete;
  ~SharedTriangulation() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  // Blocks until the PSLG's call is done; throws what cdt::triangulate() would for it alone.
  cdt::Triangulation triangulate(const Pslg& pslg) {
    Request request{&pslg, {}};
    std::future<cdt::Triangulation> result = request.result.get_future();
    {
      std::lock_guard lock(mutex_);
      pending_.push_back(&request);
    }
    wake_.notify_one();
    return result.get();
  }

private:
  // One call stays well inside a device's memory and a batch's latency.
  static constexpr std::size_t kMaxInputs = 64;
  static constexpr std::size_t kMaxPoints = std::size_t{1} << 22;

  struct Request {
    const Pslg* pslg;
    std::promise<cdt::Triangulation> result;
  };

  void run() {
    for (;;) {
      std::vector<Request*> taken;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || !pending_.empty(); });
        if (pending_.empty()) return;
        std::size_t points = 0;
        while (!pending_.empty() && taken.size() < kMaxInputs &&
               (taken.empty() || points + pending_.front()->pslg->points.size() <= kMaxPoints)) {
          points += pending_.front()->pslg->points.size();
          taken.push_back(pending_.front());
          pending_.pop_front();
        }
      }
      std::vector<cdt::Input> inputs;
      inputs.reserve(taken.size());
      for (const Request* r : taken) inputs.push_back({r->pslg->points, r->pslg->segments});
      try {
        std::vector<cdt::ManyResult> results = cdt::triangulate_many(inputs, options_);
        for (std::size_t k = 0; k < taken.size(); ++k) {
          if (results[k].error) {
            taken[k]->result.set_exception(results[k].error);
          } else {
            taken[k]->result.set_value(std::move(results[k].triangulation));
          }
        }
      } catch (...) { // out of memory, say: every image of the call fails with it
        for (Request* r : taken) r->result.set_exception(std::current_exception());
      }
    }
  }

  cdt::Options options_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Request*> pending_;
  bool stop_ = false;
  std::thread thread_; // last: started once the members above exist
};

bool shares_cdt(const BatchOptions& options, std::size_t num_jobs) {
  if (num_jobs < 2) return false;
  switch (options.shared_cdt) {
  case BatchOptions::SharedCdt::always:
    return true;
  case BatchOptions::SharedCdt::never:
    return false;
  case BatchOptions::SharedCdt::automatic:
    break;
  }
  return options.conversion.backend == cdt::Backend::gpu ||
         (options.conversion.backend == cdt::Backend::automatic && cdt::gpu_device_count() > 0);
}

} // namespace

unsigned threads_per_conversion(const BatchOptions& options, std::size_t num_jobs) {
  if (options.conversion.threads != 0) return options.conversion.threads;
  return std::max(1u, batch_cores(options) / batch_workers(options, num_jobs));
}

std::vector<JobResult> run_batch(const std::vector<BatchJob>& jobs, const BatchOptions& options) {
  const unsigned workers = batch_workers(options, jobs.size());
  Options conversion = options.conversion;
  conversion.threads = threads_per_conversion(options, jobs.size());

  std::vector<JobResult> results(jobs.size());
  std::vector<char> ran(jobs.size(), 0);
  std::atomic<std::size_t> next{0};
  std::size_t done = 0;
  std::mutex report;

  // With a shared CDT a worker gives its core back while its PSLG waits to be triangulated, and more
  // threads than cores keep the cores busy meanwhile.
  std::optional<SharedTriangulation> shared;
  std::counting_semaphore<> cores(workers);
  Triangulator triangulator;
  unsigned threads = workers;
  if (shares_cdt(options, jobs.size())) {
    cdt::Options cdt_options;
    cdt_options.backend = conversion.backend;
    cdt_options.threads = 1;
    shared.emplace(cdt_options);
    threads = static_cast<unsigned>(std::min<std::size_t>(workers + std::max(1u, workers / 2), jobs.size()));
    triangulator = [&](const Pslg& pslg, const cdt::Options&) {
      cores.release();
      struct Reacquire {
        std::counting_semaphore<>& cores;
        ~Reacquire() { cores.acquire(); }
      } reacquire{cores};
      return shared->triangulate(pslg);
    };
  }
  const auto work = [&] {
    for (;;) {
      if (options.stop != nullptr && options.stop->load()) return;
      const std::size_t k = next.fetch_add(1);
      if (k >= jobs.size()) return;
      if (shared) cores.acquire();
      JobResult r = run_job(jobs[k], options, conversion, triangulator);
      if (shared) cores.release();
      std::lock_guard lock(report);
      results[k] = std::move(r);
      ran[k] = 1;
      ++done;
      if (options.on_done) options.on_done(results[k], done, jobs.size());
    }
  };
  // With the GPU backend and more than one image, CUDA starts on a side thread while the first images
  // are decoded, instead of in the first triangulation that every worker would wait for.
  std::thread start_device;
  if (conversion.backend == cdt::Backend::gpu && jobs.size() > 1)
    start_device = std::thread([] { cdt::start_gpu(); });
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < threads; ++w) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (start_device.joinable()) start_device.join();
  std::vector<JobResult> out;
  out.reserve(done);
  for (std::size_t k = 0; k < jobs.size(); ++k) {
    if (ran[k]) out.push_back(std::move(results[k]));
  }
  return out;
}

namespace {

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
    case '"':
      out += "\\\"";
      break;
    case '\\':
      out += "\\\\";
      break;
    case '\n':
      out += "\\n";
      break;
    case '\t':
      out += "\\t";
      break;
    case '\r':
      out += "\\r";
      break;
    default:
      if (static_cast<unsigned char>(c) < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        out += buf;
      } else {
        out += c;
      }
    }
  }
  return out + "\"";
}

} // namespace

std::string batch_report_json(const std::vector<JobResult>& results, double wall_seconds) {
  std::size_t converted = 0, skipped = 0, failed = 0;
  for (const auto& r : results) {
    converted += r.status == JobStatus::converted;
    skipped += r.status == JobStatus::skipped;
    failed += r.status == JobStatus::failed;
  }
  std::ostringstream j;
  char number[32];
  std::snprintf(number, sizeof number, "%.3f", wall_seconds);
  j << "{\"converted\":" << converted << ",\"skipped\":" << skipped << ",\"failed\":" << failed
    << ",\"wall_seconds\":" << number << ",\"images\":[";
  for (std::size_t k = 0; k < results.size(); ++k) {
    const JobResult& r = results[k];
    const char* status = r.status == JobStatus::converted ? "converted"
                         : r.status == JobStatus::skipped ? "skipped"
                                                          : "failed";
    std::snprintf(number, sizeof number, "%.3f", r.seconds);
    j << (k ? ",\n" : "\n") << "{\"input\":" << json_string(r.job.input.string())
      << ",\"output\":" << json_string(r.job.output.string()) << ",\"status\":\"" << status << "\"";
    if (r.status == JobStatus::converted && !r.job.debug.empty()) {
      j << ",\"debug\":" << json_string(r.job.debug.string());
    }
    if (r.status == JobStatus::failed) j << ",\"error\":" << json_string(r.error);
    j << ",\"seconds\":" << number << ",\"input_bytes\":" << r.input_bytes;
    if (r.status == JobStatus::converted) j << ",\"stats\":" << stats_to_json(r.stats);
    j << "}";
  }
  j << "\n]}\n";
  return j.str();
}

} // namespace vectorize
