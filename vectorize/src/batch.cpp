// Batch conversion: planning the jobs, running them on a pool of workers, reporting.
#include "vectorize/batch.hpp"

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <new>
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
                                 std::vector<JobResult>& refused, const std::vector<fs::path>& own) {
  const auto is_own = [&](const fs::path& folder) {
    std::error_code e;
    return std::any_of(own.begin(), own.end(),
                       [&](const fs::path& o) { return fs::equivalent(folder, o, e); });
  };
  // A folder that cannot be listed is refused with the reason, not skipped in silence.
  const auto readable = [&](const fs::path& folder) {
    if (::access(folder.c_str(), R_OK | X_OK) == 0) return true;
    JobResult unread;
    unread.job.input = folder;
    unread.error = folder.string() + ": cannot read the folder: " + std::strerror(errno);
    refused.push_back(std::move(unread));
    return false;
  };
  std::vector<BatchJob> jobs;
  for (const fs::path& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      if (!readable(input)) continue;
      const auto add = [&](const fs::directory_entry& entry) {
        std::error_code e;
        if (!entry.is_regular_file(e) || !is_image_name(entry.path())) return;
        jobs.push_back({entry.path(), out_dir / svg_name(entry.path().lexically_relative(input))});
      };
      if (recursive) {
        for (fs::recursive_directory_iterator it(input, fs::directory_options::skip_permission_denied, ec),
             end;
             !ec && it != end; it.increment(ec)) {
          std::error_code e;
          if (it->is_directory(e) && (is_own(it->path()) || !readable(it->path()))) {
            it.disable_recursion_pending();
            continue;
          }
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
      JobResult collision;
      collision.job = job;
      collision.error = job.input.string() + ": its output " + job.output.string() +
                        " is already the output of " + unique.back().input.string() + "; not converted";
      refused.push_back(std::move(collision));
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
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
      line.pop_back();
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t") == std::string::npos) continue;
    paths.emplace_back(line);
  }
  if (in->bad()) throw FileError(list, "read error in the input list");
  return paths;
}

namespace {

// One image on its way through a job: what the first half of its conversion made, until its CDT
// comes back (a shared CDT) or is made on the spot.
struct Flight {
  std::size_t index = 0; // into the jobs
  JobResult result;
  std::chrono::steady_clock::time_point start;
  Image image;
  bool debug = false;
  StageRecord record;
  PslgStage first;
  cdt::Triangulation triangulation;
  std::exception_ptr error; // of the CDT
};

// Records the exception being handled as the job's error, named by the file when it is a FileError.
void fail(JobResult& r) {
  try {
    throw;
  } catch (const FileError& e) {
    r.error = e.what();
  } catch (const std::bad_alloc&) {
    r.error = r.job.input.string() + ": " + kOutOfMemory;
  } catch (const std::exception& e) {
    r.error = r.job.input.string() + ": " + e.what();
  } catch (...) {
    r.error = r.job.input.string() + ": unknown error";
  }
}

void set_seconds(Flight& f) {
  f.result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - f.start).count();
}

// The first half of a job: checks, decoding, the conversion up to its PSLG (its edges on the device
// when the GPU backend is asked for and `device_ready`). False when the job has ended already (skipped,
// or failed: the result says why).
bool begin_job(Flight& f, const BatchJob& job, const BatchOptions& options, const Options& conversion,
               bool device_ready) {
  f.result.job = job;
  f.start = std::chrono::steady_clock::now();
  std::error_code ec;
  if (options.skip_existing && fs::exists(job.output, ec)) {
    f.result.status = JobStatus::skipped;
    return false;
  }
  try {
    if (fs::exists(job.output, ec) && fs::equivalent(job.output, job.input, ec)) {
      throw FileError(job.output, "is the input itself; refusing to overwrite it");
    }
    f.result.input_bytes =
        fs::is_regular_file(job.input, ec) ? static_cast<std::size_t>(fs::file_size(job.input, ec)) : 0;
    f.image = load_image(job.input, options.max_pixels);
    f.debug = !job.debug.empty() && static_cast<bool>(options.write_debug);
    f.first = convert_to_pslg(f.image, conversion, f.debug ? &f.record : nullptr, device_ready);
    return true;
  } catch (...) {
    fail(f.result);
  }
  set_seconds(f);
  return false;
}

// The image's CDT on this thread, with `backend`; an error is kept for end_job.
void triangulate_here(Flight& f, cdt::Backend backend) {
  cdt::Options options = f.first.cdt_options;
  options.backend = backend;
  try {
    f.triangulation = cdt::triangulate(f.first.pslg.points, f.first.pslg.segments, options);
  } catch (...) {
    f.error = std::current_exception();
  }
}

// The second half, once f.triangulation (or f.error) is there: the rest of the conversion, the debug
// folder, the SVG. `device_done` as for finish_conversion.
void end_job(Flight& f, const BatchOptions& options, const Options& conversion,
             const std::function<void()>& device_done = {}) {
  const BatchJob& job = f.result.job;
  try {
    if (f.error) std::rethrow_exception(f.error);
    const Conversion result =
        finish_conversion(f.image, conversion, std::move(f.first), std::move(f.triangulation),
                          f.debug ? &f.record : nullptr, device_done);
    std::error_code ec;
    fs::create_directories(job.output.parent_path(), ec);
    if (ec) throw FileError(job.output.parent_path(), "cannot create the output directory: " + ec.message());
    // Debug folder first: when it fails, the image fails without an SVG (so --skip-existing retries it).
    if (f.debug) options.write_debug(job, f.image, result, f.record);
    write_file_atomically(job.output, result.svg);
    f.result.stats = result.stats;
    f.result.status = JobStatus::converted;
  } catch (...) {
    fail(f.result);
  }
  f.first.device_pixels.reset(); // a failed image's too, before the device may be given back
  set_seconds(f);
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
  switch (options.conversion.backend) {
  case cdt::Backend::gpu:
    return true;
  case cdt::Backend::automatic:
    return num_jobs >= kDeviceBatchImagesPerWorker * batch_workers(options, num_jobs);
  case cdt::Backend::cpu:
    return false;
  }
  return false;
}

// How a batch uses the CUDA device.
enum class DeviceUse {
  never,     ///< the CPU backend, or the automatic one with each worker triangulating its own images
  later,     ///< the GPU backend for one image: the first use starts CUDA
  gpu,       ///< the GPU backend: started as the batch begins; images fail with its error without a device
  automatic, ///< the automatic backend with a shared CDT: started as the batch begins when there is a
             ///< device, and the CPU for everything when there is none
};

// CUDA started on a side thread while the first images are decoded (0.3-0.4 s on the H200 machine,
// the device count alone 0.1-0.25 s of it; the first triangulations on the device would wait for
// it). Until the device is up, a worker triangulates its image on the CPU instead: the CDT is the
// same on every backend, so the SVG is too (the report names the backend each image used). Whether
// there is a device at all is settled first, and takes a fraction of the start: without one the
// images go to the GPU backend as asked, and fail with its error, or with the automatic backend stay
// on the CPU. The start also readies the edges and the trixel colours on the device for the workers
// (prepare_edges_on_device, prepare_trixels_on_device).
class DeviceStart {
public:
  /// `workers`: the threads that will make trixel colours on the device at once. `share_without`: with
  /// DeviceUse::automatic and no device, whether the images' CDTs are still triangulated together (on
  /// the CPU; asked for by --batch-cdt shared) rather than each by its worker.
  DeviceStart(DeviceUse use, unsigned workers, bool share_without = false)
      : use_(use), share_without_(share_without) {
    if (use != DeviceUse::gpu && use != DeviceUse::automatic) return;
    try {
      thread_ = std::thread([this, workers] {
        const bool found = cdt::gpu_device_count() > 0;
        state_.store(found ? kStarting : kNone);
        state_.notify_all();
        if (!found) return;
        // A device that does not start (in use by another process in exclusive mode, say) counts as
        // none: the GPU backend's images fail with its error, the automatic backend's use the CPU.
        const bool started = cdt::start_gpu();
        if (started) {
          prepare_trixels_on_device(workers);
          prepare_edges_on_device();
        }
        state_.store(started ? kUp : kNone);
        state_.notify_all();
        if (!started) return;
        // Then gives the device back when the batch says so (stop), or leaves that to the process's exit.
        end_.wait(kRunning);
        if (end_.load() == kGiveBack) cdt::stop_gpu();
      });
    } catch (const std::system_error&) {
      state_.store(kUp); // no thread for it: the first triangulation starts CUDA
    }
  }
  DeviceStart(const DeviceStart&) = delete;
  DeviceStart& operator=(const DeviceStart&) = delete;
  ~DeviceStart() {
    int running = kRunning;
    end_.compare_exchange_strong(running, kLeave);
    end_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  /// The backend to triangulate with now instead of `asked`: the CPU while the device is starting, and
  /// with DeviceUse::automatic, the CPU without a device (unless the CDTs are shared without one).
  cdt::Backend backend_now(cdt::Backend asked) {
    if (asked == cdt::Backend::cpu || !started()) return asked;
    state_.wait(kCounting);
    const int state = state_.load();
    if (state == kStarting) return cdt::Backend::cpu;
    if (state == kNone && use_ == DeviceUse::automatic && !share_without_) return cdt::Backend::cpu;
    return asked;
  }

  /// Whether the batch's images are converted with the device: the GPU backend's always (they fail
  /// without one), the automatic backend's once a device is found. Never blocks.
  bool in_use() const {
    const int state = state_.load();
    return use_ == DeviceUse::gpu || (use_ == DeviceUse::automatic && (state == kStarting || state == kUp));
  }

  /// Whether the edges of an image may be found on the device now: it is up (with DeviceUse::later,
  /// whenever: a first use starts it). Never blocks.
  bool ready() const {
    switch (use_) {
    case DeviceUse::never:
      return false;
    case DeviceUse::later:
      return true;
    case DeviceUse::gpu: // without a device, the edges too fail with its error, as asked
      return !thread_.joinable() || state_.load() == kUp || state_.load() == kNone;
    case DeviceUse::automatic:
      return state_.load() == kUp;
    }
    return false;
  }

  /// Once the batch needs the device no more: gives it back (cdt::stop_gpu) after the start-up is
  /// done, on the thread that started it, so that the driver's cleanup (0.1-0.15 s on the H100
  /// machine) overlaps the last images' conversion instead of holding up the worker that finished the
  /// device's last image, or following the batch at the process's exit. Only when this batch started
  /// CUDA; once. The destructor waits for it.
  void stop() {
    int running = kRunning;
    end_.compare_exchange_strong(running, kGiveBack);
    end_.notify_all();
  }

private:
  bool started() const { return use_ == DeviceUse::gpu || use_ == DeviceUse::automatic; }

  enum State : int { kCounting, kStarting, kUp, kNone };
  const DeviceUse use_;
  const bool share_without_;
  enum End : int { kRunning, kGiveBack, kLeave };
  std::atomic<int> state_{kCounting};
  std::atomic<int> end_{kRunning};
  std::thread thread_;
};

// Lowers the calling thread's scheduling priority (nice 10 above what it was) for a worker of a batch
// whose images are converted with the device. The CDT threads and the device's start are on the
// critical path and were starved by the workers busy on every core. With the workers lowered, 200
// photographs on the H200 machine (16 cores, GPU backend, four rounds each in one call) converted at
// 161.8-175.6 images/s against 147.4-160.2, the first image done on the device 0.41-0.47 s after the
// start against 0.51-0.72, and the CDT stage's mean (the wait for a shared call included) was 98-118
// ms against 183-226; in an earlier call nice 5 did about half as well as 10. Best effort: without
// the call (not Linux) or when refused, nothing changes.
void yield_to_cdt_threads() {
#if defined(__linux__)
  constexpr int kLower = 10;
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (now == -1 && errno != 0) return;
  setpriority(PRIO_PROCESS, tid, std::min(19, now + kLower));
#endif
}

// The jobs with a shared CDT. A worker takes, in this order: an image whose CDT is back (to finish
// it), a new image (while fewer than `in_flight_limit` are under way), or waits. Its PSLG joins the
// queue of the CDT threads, one of which triangulates what is queued in one call of
// cdt::triangulate_many once `batch` PSLGs wait, when no more images can start, or when a worker has
// nothing else to do; a call takes at most kMaxInputs PSLGs and kMaxPoints points. With four workers
// or more there are two CDT threads: a call's host steps (placing the PSLGs, the engine's host phases,
// cutting the result apart) are about half of it, and with one thread, sixteen workers left it busy
// three quarters of the time and waited on it for a fifth of theirs; with two, one call's host steps
// overlap the other's device work. Once the batch's last image needs the device no more (its CDT
// and trixel colours made) the device is given back while the last images are finished
// (DeviceStart::stop).
class SharedCdtBatch {
public:
  SharedCdtBatch(const std::vector<BatchJob>& jobs, const BatchOptions& options, const Options& conversion,
                 unsigned workers, const std::function<void(JobResult&&, std::size_t)>& report,
                 DeviceStart& device)
      : jobs_(jobs), options_(options), conversion_(conversion), report_(report), device_(device),
        workers_(workers), batch_(std::clamp<std::size_t>(workers, 2, kMaxInputs)),
        in_flight_limit_(5 * batch_ + workers), cdt_threads_(workers >= 4 ? 2 : 1) {
    cdt_options_.backend = conversion.backend;
    cdt_options_.threads = 1;
  }

  void run() {
    std::vector<std::thread> cdt_threads;
    for (unsigned c = 0; c < cdt_threads_; ++c) cdt_threads.emplace_back([this] { triangulate_queued(); });
    // The workers run on threads of their own, so that the batch's thread keeps its priority: a worker
    // may lower its own (yield_to_cdt_threads), and a thread cannot raise it again.
    std::vector<std::thread> pool;
    for (unsigned w = 0; w < workers_; ++w) pool.emplace_back([this] { work(); });
    for (auto& t : pool) t.join();
    {
      std::lock_guard lock(mutex_);
      done_ = true;
    }
    cdt_wake_.notify_all();
    for (auto& t : cdt_threads) t.join();
  }

private:
  static constexpr std::size_t kMaxInputs = 64;
  static constexpr std::size_t kMaxPoints = std::size_t{1} << 22;

  bool may_start() const {
    return next_ < jobs_.size() && in_flight_ < in_flight_limit_ &&
           (options_.stop == nullptr || !options_.stop->load());
  }
  bool starts_over() const {
    return next_ >= jobs_.size() || (options_.stop != nullptr && options_.stop->load());
  }

  void work() {
    bool lowered = false;
    std::unique_lock lock(mutex_);
    for (;;) {
      if (!lowered && device_.in_use()) {
        yield_to_cdt_threads();
        lowered = true;
      }
      if (!ready_.empty()) {
        std::unique_ptr<Flight> f = std::move(ready_.front());
        ready_.pop_front();
        lock.unlock();
        // Its trixel colours may be made on the device (as its CDT was): it is owed until they are.
        bool settled = false;
        const auto settle = [&] {
          if (std::exchange(settled, true)) return;
          std::unique_lock relock(mutex_);
          --owed_;
          stop_device_if_done();
        };
        end_job(*f, options_, conversion_, settle);
        settle();
        report_(std::move(f->result), f->index);
        f.reset();
        lock.lock();
        --in_flight_;
        continue;
      }
      if (may_start()) {
        auto f = std::make_unique<Flight>();
        f->index = next_++;
        ++in_flight_;
        ++owed_;
        lock.unlock();
        bool begun = begin_job(*f, jobs_[f->index], options_, conversion_, device_.ready());
        if (begun && device_.backend_now(cdt_options_.backend) != cdt_options_.backend) {
          triangulate_here(*f, cdt::Backend::cpu);
          end_job(*f, options_, conversion_);
          begun = false;
        }
        if (!begun) report_(std::move(f->result), f->index);
        lock.lock();
        if (begun) {
          queued_.push_back(std::move(f));
          cdt_wake_.notify_one();
        } else {
          --in_flight_;
          --owed_;
          stop_device_if_done();
        }
        continue;
      }
      if (starts_over() && in_flight_ == 0) {
        worker_wake_.notify_all();
        return;
      }
      ++idle_;
      cdt_wake_.notify_one();
      worker_wake_.wait(lock);
      --idle_;
    }
  }

  void triangulate_queued() {
    std::unique_lock lock(mutex_);
    for (;;) {
      cdt_wake_.wait(lock, [&] {
        return done_ || (!queued_.empty() && (queued_.size() >= batch_ || idle_ > 0 || starts_over() ||
                                              in_flight_ >= in_flight_limit_));
      });
      if (queued_.empty()) return; // done
      std::vector<std::unique_ptr<Flight>> taken;
      std::size_t points = 0;
      while (!queued_.empty() && taken.size() < kMaxInputs &&
             (taken.empty() || points + queued_.front()->first.pslg.points.size() <= kMaxPoints)) {
        points += queued_.front()->first.pslg.points.size();
        taken.push_back(std::move(queued_.front()));
        queued_.pop_front();
      }
      if (!queued_.empty()) cdt_wake_.notify_one(); // more than one call's worth: another thread's
      lock.unlock();
      std::vector<cdt::Input> inputs;
      inputs.reserve(taken.size());
      for (const auto& f : taken) inputs.push_back({f->first.pslg.points, f->first.pslg.segments});
      try {
        std::vector<cdt::ManyResult> results = cdt::triangulate_many(inputs, cdt_options_);
        for (std::size_t k = 0; k < taken.size(); ++k) {
          taken[k]->triangulation = std::move(results[k].triangulation);
          taken[k]->error = results[k].error;
        }
      } catch (...) { // out of memory, say: every image of the call fails with it
        for (auto& f : taken) f->error = std::current_exception();
      }
      lock.lock();
      for (auto& f : taken) ready_.push_back(std::move(f));
      worker_wake_.notify_all();
    }
  }

  // Once no image needs the device any more, gives it back while the last images are finished (on a
  // thread of DeviceStart's).
  void stop_device_if_done() {
    if (device_stopped_ || owed_ > 0 || !starts_over()) return;
    device_stopped_ = true;
    device_.stop();
  }

  const std::vector<BatchJob>& jobs_;
  const BatchOptions& options_;
  const Options& conversion_;
  const std::function<void(JobResult&&, std::size_t)>& report_;
  DeviceStart& device_;
  cdt::Options cdt_options_;
  const unsigned workers_;
  const std::size_t batch_;
  /// Images under way at most: five calls' worth beyond one per worker. With the trixel colours on the
  /// device the workers' freed time went into waiting for calls; 64 at sixteen workers beat 48 in ten
  /// rounds of ten (H200 machine, 200 images: mean 124.6 against 120.0 images/s, about 90 MB more).
  /// With the edges there too, 96 at sixteen workers shortened a 200-image batch from 1.64-1.70 s to
  /// 1.55-1.58 s and the workers' waiting from 1.4-1.9 to 0.6-1.1 s in all (H100 machine, three rounds
  /// each); in another call 200 images 112.4 against 109.0 images/s (means of four rounds), 1000 the
  /// same, -j 4 36.8 against 33.7, for 200-300 MB more at sixteen workers.
  const std::size_t in_flight_limit_;
  const unsigned cdt_threads_;

  std::mutex mutex_;
  std::condition_variable worker_wake_;
  std::condition_variable cdt_wake_;
  std::size_t next_ = 0;
  std::size_t in_flight_ = 0;
  /// Images begun that may still need the device: their CDT is not back yet (queued, in a call, or
  /// beginning), or their trixel colours, made on the device with a CDT from there, are not done.
  std::size_t owed_ = 0;
  bool device_stopped_ = false;
  unsigned idle_ = 0;
  bool done_ = false;
  std::deque<std::unique_ptr<Flight>> queued_; // waiting for their CDT
  std::deque<std::unique_ptr<Flight>> ready_;  // their CDT is back
};

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
  std::size_t done = 0;
  std::mutex report_mutex;
  const auto batch_start = std::chrono::steady_clock::now();
  const std::function<void(JobResult&&, std::size_t)> report = [&](JobResult&& r, std::size_t k) {
    const double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - batch_start).count();
    r.started = std::max(0.0, now - r.seconds);
    std::lock_guard lock(report_mutex);
    results[k] = std::move(r);
    ran[k] = 1;
    ++done;
    if (options.on_done) options.on_done(results[k], done, jobs.size());
  };

  // With the GPU backend and more than one image, or the automatic one and a shared CDT, CUDA starts
  // on a side thread, and images whose CDT comes before it is up are triangulated on the CPU.
  const bool shared = shares_cdt(options, jobs.size());
  DeviceUse use = DeviceUse::never;
  if (conversion.backend == cdt::Backend::gpu) use = jobs.size() > 1 ? DeviceUse::gpu : DeviceUse::later;
  if (conversion.backend == cdt::Backend::automatic && shared) use = DeviceUse::automatic;
  DeviceStart device(use, workers, options.shared_cdt == BatchOptions::SharedCdt::always);
  if (shared) {
    SharedCdtBatch(jobs, options, conversion, workers, report, device).run();
  } else {
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
      for (;;) {
        if (options.stop != nullptr && options.stop->load()) return;
        const std::size_t k = next.fetch_add(1);
        if (k >= jobs.size()) return;
        Flight f;
        if (begin_job(f, jobs[k], options, conversion, device.ready())) {
          triangulate_here(f, device.backend_now(f.first.cdt_options.backend));
          end_job(f, options, conversion);
        }
        report(std::move(f.result), k);
      }
    };
    std::vector<std::thread> pool;
    for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
  }
  std::vector<JobResult> out;
  out.reserve(done);
  for (std::size_t k = 0; k < jobs.size(); ++k) {
    if (ran[k]) out.push_back(std::move(results[k]));
  }
  return out;
}

namespace {

/// The length of the well-formed UTF-8 sequence at s[i], or 0 when there is none.
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto at = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = at(i);
  const std::size_t n = c < 0x80                 ? 1
                        : c >= 0xC2 && c <= 0xDF ? 2
                        : c >= 0xE0 && c <= 0xEF ? 3
                        : c >= 0xF0 && c <= 0xF4 ? 4
                                                 : 0;
  if (n == 0 || i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k)
    if ((at(i + k) & 0xC0) != 0x80) return 0;
  // Overlong forms, surrogates and code points past U+10FFFF.
  if (n == 3 && ((c == 0xE0 && at(i + 1) < 0xA0) || (c == 0xED && at(i + 1) >= 0xA0))) return 0;
  if (n == 4 && ((c == 0xF0 && at(i + 1) < 0x90) || (c == 0xF4 && at(i + 1) >= 0x90))) return 0;
  return n;
}

/// s as a JSON string; bytes that are not UTF-8 (a file name's, say) become U+FFFD, so that the report
/// stays valid JSON.
std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
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
      } else if (const std::size_t n = utf8_length(s, i); n == 0) {
        out += "\\ufffd";
      } else {
        out.append(s, i, n);
        i += n;
        continue;
      }
    }
    ++i;
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
    char started[32];
    std::snprintf(number, sizeof number, "%.3f", r.seconds);
    std::snprintf(started, sizeof started, "%.3f", r.started);
    j << (k ? ",\n" : "\n") << "{\"input\":" << json_string(r.job.input.string())
      << ",\"output\":" << json_string(r.job.output.string()) << ",\"status\":\"" << status << "\"";
    if (r.status == JobStatus::converted && !r.job.debug.empty()) {
      j << ",\"debug\":" << json_string(r.job.debug.string());
    }
    if (r.status == JobStatus::failed) j << ",\"error\":" << json_string(r.error);
    j << ",\"started\":" << started << ",\"seconds\":" << number << ",\"input_bytes\":" << r.input_bytes;
    if (r.status == JobStatus::converted) j << ",\"stats\":" << stats_to_json(r.stats);
    j << "}";
  }
  j << "\n]}\n";
  return j.str();
}

} // namespace vectorize
