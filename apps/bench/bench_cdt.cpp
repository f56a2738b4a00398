// CDT benchmark: gCD on the CPU executor against CGAL's constrained Delaunay triangulation, same
// inputs, same run. Inputs: the paper's synthetic PSLGs (random non-crossing segments of many lengths,
// then random points on no segment; uniform and Gaussian), uniform points without segments, and
// optionally a GIS coastline file as printed by `gmt coast -Rg -Dh -W -M` ('>'-separated polylines).
//
// usage: bench_cdt [--quick] [--coast FILE] [--file PSLG]... [--threads N] [--repeat R] [--case TEXT]
// [--no-cgal] [--grid M] [--inner-iterations I]
//                  [--backend auto|cpu|gpu] [--sizes LIST] [--lattice K]
// --sizes replaces the default inputs by the paper's synthetic design at the sizes listed as
// POINTS:SEGMENTS pairs separated by commas (e.g. 10000000:1000000), uniform and Gaussian each, and
// uniform points alone where SEGMENTS is 0; --lattice adds a K x K lattice with K * K / 16 random
// short segments (crossings and overlaps included). --file adds a PSLG file in any format `cdt` reads
// (Triangle's .node or .poly, or the edge-list format), e.g. the PSLG of a photograph that
// `vectorize` triangulates; it may be given several times.
// --cache DIR keeps each generated input of --sizes and --lattice in DIR as a binary file and reads
// it from there next time (large synthetic inputs take longer to generate than to triangulate).
// --case keeps only the inputs whose name contains TEXT; --no-cgal skips the competitor (profiling);
// --grid forces the grid side (Options::grid_size) instead of the automatic choice;
// --inner-iterations sets Options::inner_iterations (the GPU backend's flipping passes per marking pass
// of the constraints); --backend picks the executor (Options::backend). --no-verify leaves out the verifier
// of the first table (its column then says "not checked"): for sweeps of one input whose result another run
// verified, as verifying 20M triangles on one core takes longer than the runs themselves. Prints one Markdown
// row per input: median times of R runs, the backend and per-phase times of the median run (with their
// parallel rounds in parentheses), flips, missing points, the verifier's verdict, peak memory of the run (its
// own process), CGAL's time and the ratio ours/CGAL (<= 1 means faster).
// --limit SECONDS ends an input's run (its own process) that takes longer, printing its threads' states
// and stacks (return addresses, and the executable's mappings to place them) to stderr and "TIMED OUT"
// in its row, and goes on with the next input.
// --together N then triangulates N of the --file PSLGs (cycled) in one cdt::triangulate_many call and
// each alone, R times, and prints a second table: the wall times of both ways (medians), how many
// inputs shared the call, and whether every result verifies.

#include <dirent.h>
#include <execinfo.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"
#include "cdt/io.hpp"
#include "cdt/verify.hpp"
#include "pslg_generators.hpp"

#if defined(TRIXEL_HAVE_CGAL)
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#endif

namespace {

using Clock = std::chrono::steady_clock;

struct Input {
  std::string name;
  trixel_gen::Pslg pslg;
};

/// Reads '>'-separated polylines of "lon lat" lines; exits naming the file and line on anything else
/// (a file of another format, such as the cdt command's, is not read as coordinates).
trixel_gen::Pslg read_coast(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "bench_cdt: cannot read %s\n", path.c_str());
    std::exit(1);
  }
  const auto fail = [&](std::size_t line_number, const char* reason) {
    std::fprintf(stderr, "bench_cdt: %s:%zu: %s\n", path.c_str(), line_number, reason);
    std::exit(1);
  };
  trixel_gen::Pslg p;
  std::string line;
  bool header_seen = false;
  bool open = false;
  for (std::size_t line_number = 1; std::getline(in, line); ++line_number) {
    if (line.empty()) continue;
    if (line[0] == '>') {
      header_seen = true;
      open = false;
      continue;
    }
    if (!header_seen)
      fail(line_number, "not a GMT multi-segment file ('>' header expected before the first point)");
    std::istringstream fields(line);
    double lon = 0;
    double lat = 0;
    std::string rest;
    if (!(fields >> lon >> lat) || (fields >> rest)) fail(line_number, "expected a line 'lon lat'");
    const auto id = static_cast<std::uint32_t>(p.points.size());
    p.points.push_back({lon, lat});
    if (open) p.segments.push_back({id - 1, id});
    open = true;
  }
  if (p.points.empty()) fail(1, "no points");
  return p;
}

/// POINTS:SEGMENTS[,POINTS:SEGMENTS...] into sizes; false when malformed.
bool parse_sizes(const char* text, std::vector<std::pair<std::size_t, std::size_t>>& sizes) {
  std::stringstream list(text);
  std::string item;
  while (std::getline(list, item, ',')) {
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos) return false;
    char* end = nullptr;
    const unsigned long long points = std::strtoull(item.c_str(), &end, 10);
    if (end != item.c_str() + colon || points < 3) return false;
    const unsigned long long segments = std::strtoull(item.c_str() + colon + 1, &end, 10);
    if (*end != '\0' || 2 * segments > points) return false;
    sizes.emplace_back(points, segments);
  }
  return !sizes.empty();
}

/// The generated input `name` from the cache folder (when given and present), else generate() saved
/// there. File: point count, segment count (64-bit each), then the points and segments as stored.
trixel_gen::Pslg cached(const std::string& cache, const std::string& name,
                        const std::function<trixel_gen::Pslg()>& generate) {
  if (cache.empty()) return generate();
  std::string file = cache + "/";
  for (const char c : name) file += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  file += ".bin";
  trixel_gen::Pslg p;
  if (std::ifstream in{file, std::ios::binary}) {
    std::uint64_t counts[2] = {0, 0};
    in.read(reinterpret_cast<char*>(counts), sizeof counts);
    p.points.resize(counts[0]);
    p.segments.resize(counts[1]);
    in.read(reinterpret_cast<char*>(p.points.data()),
            static_cast<std::streamsize>(p.points.size() * sizeof(cdt::Point)));
    in.read(reinterpret_cast<char*>(p.segments.data()),
            static_cast<std::streamsize>(p.segments.size() * sizeof(cdt::Segment)));
    if (in) return p;
    std::fprintf(stderr, "bench_cdt: %s is truncated; generating the input again\n", file.c_str());
  }
  p = generate();
  const std::string partial = file + ".tmp";
  std::ofstream out(partial, std::ios::binary);
  const std::uint64_t counts[2] = {p.points.size(), p.segments.size()};
  out.write(reinterpret_cast<const char*>(counts), sizeof counts);
  out.write(reinterpret_cast<const char*>(p.points.data()),
            static_cast<std::streamsize>(p.points.size() * sizeof(cdt::Point)));
  out.write(reinterpret_cast<const char*>(p.segments.data()),
            static_cast<std::streamsize>(p.segments.size() * sizeof(cdt::Segment)));
  out.close();
  if (out) std::rename(partial.c_str(), file.c_str());
  return p;
}

/// The '|'-separated fields of a child's row.
std::vector<std::string> fields_of(const std::string& row) {
  std::vector<std::string> f;
  std::stringstream ss(row);
  std::string item;
  while (std::getline(ss, item, '|')) f.push_back(item);
  return f;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

#if defined(TRIXEL_HAVE_CGAL)
double run_cgal(const trixel_gen::Pslg& in) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, CGAL::Default, CGAL::Exact_predicates_tag>;
  std::vector<K::Point_2> points;
  points.reserve(in.points.size());
  for (const auto& p : in.points) points.emplace_back(p.x, p.y);
  std::vector<std::pair<std::size_t, std::size_t>> segments;
  segments.reserve(in.segments.size());
  for (const auto& s : in.segments) segments.emplace_back(s.a, s.b);
  const auto t0 = Clock::now();
  Cdt cdt;
  // Range insertion (spatially sorted); insert_constraints with no segments would insert nothing.
  if (segments.empty()) {
    cdt.insert(points.begin(), points.end());
  } else {
    cdt.insert_constraints(points.begin(), points.end(), segments.begin(), segments.end());
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  // Every distinct input point must be a vertex: CGAL did the whole job.
  std::vector<std::pair<double, double>> distinct;
  distinct.reserve(in.points.size());
  for (const auto& p : in.points) distinct.emplace_back(p.x, p.y);
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  if (cdt.number_of_vertices() < distinct.size() || cdt.number_of_faces() == 0) {
    std::fprintf(stderr, "CGAL kept only %zu of %zu distinct points\n",
                 static_cast<std::size_t>(cdt.number_of_vertices()), distinct.size());
  }
  return ms;
}
#endif

/// The ids of process pid's threads, from /proc, in increasing order.
std::vector<long> thread_ids_of(pid_t pid) {
  std::vector<long> tids;
  const std::string task = "/proc/" + std::to_string(pid) + "/task";
  if (DIR* dir = opendir(task.c_str())) {
    while (const dirent* e = readdir(dir))
      if (e->d_name[0] != '.') tids.push_back(std::atol(e->d_name));
    closedir(dir);
  }
  std::sort(tids.begin(), tids.end());
  return tids;
}

/// What each thread of process `pid` is doing, from /proc: "tid state wchan syscall" lines.
std::string threads_of(pid_t pid) {
  const std::string task = "/proc/" + std::to_string(pid) + "/task";
  const auto first_line = [](const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    return line;
  };
  std::string out;
  for (const long id : thread_ids_of(pid)) {
    const std::string tid = std::to_string(id);
    const std::string stat = first_line(task + "/" + tid + "/stat");
    const std::size_t close = stat.rfind(')'); // the state follows the command's closing parenthesis
    const char state = close != std::string::npos && close + 2 < stat.size() ? stat[close + 2] : '?';
    out += "  thread " + tid + " state " + state + " wchan " + first_line(task + "/" + tid + "/wchan") +
           " syscall " + first_line(task + "/" + tid + "/syscall") + "\n";
  }
  return out;
}

/// The signal that makes a thread of a benchmark's child write its own stack to stderr.
constexpr int kStackSignal = SIGUSR2;

/// Writes the calling thread's stack (return addresses, with their module and offset where known) to
/// stderr; async-signal-safe once backtrace() has been called before (it loads the unwinder).
void write_own_stack(int) {
  void* frames[48];
  const int n = backtrace(frames, 48);
  char head[48] = "stack of thread ";
  std::size_t len = std::strlen(head);
  char digits[24];
  std::size_t d = 0;
  for (auto tid = static_cast<unsigned long>(syscall(SYS_gettid)); d == 0 || tid != 0; tid /= 10)
    digits[d++] = static_cast<char>('0' + tid % 10);
  while (d > 0 && len + 2 < sizeof head) head[len++] = digits[--d];
  head[len++] = ':';
  head[len++] = '\n';
  [[maybe_unused]] const ssize_t wrote = write(STDERR_FILENO, head, len);
  backtrace_symbols_fd(frames, n, STDERR_FILENO);
}

/// In a benchmark's child: lets every thread answer kStackSignal with its stack (stacks_of).
void answer_stack_requests() {
  void* warm[1];
  backtrace(warm, 1);
  struct sigaction action {};
  action.sa_handler = write_own_stack;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  sigaction(kStackSignal, &action, nullptr);
}

/// Every thread of child `pid` (answer_stack_requests) writes its stack to stderr, one after another,
/// then the child's executable mappings follow, so that the addresses can be turned into source lines
/// (scripts/gpu-check.sh's stall part does). A debugger is no help here: cuda-gdb's attach to a child
/// whose device work did not end did not return either.
void stacks_of(pid_t pid) {
  for (const long tid : thread_ids_of(pid)) {
    syscall(SYS_tgkill, pid, tid, kStackSignal);
    std::this_thread::sleep_for(std::chrono::milliseconds(300)); // one stack at a time on stderr
  }
  std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
  std::fprintf(stderr, "bench_cdt: the child's executable mappings:\n");
  for (std::string line; std::getline(maps, line);)
    if (line.find('/') != std::string::npos &&
        (line.find(" r-xp ") != std::string::npos || line.find(" 00000000 ") != std::string::npos))
      std::fprintf(stderr, "  %s\n", line.c_str());
}

/// Runs f in a child process so its peak memory is its own; returns the child's maxrss in MiB. A child
/// still running after limit_seconds (0: no limit) has its threads' states printed to stderr and is
/// killed; timed_out says so, and the rest of the benchmark goes on.
double peak_mib_of(const std::function<void(int)>& f, std::string& child_output, int limit_seconds,
                   bool& timed_out) {
  timed_out = false;
  int fds[2];
  if (pipe(fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    answer_stack_requests();
    f(fds[1]);
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  const auto deadline = Clock::now() + std::chrono::seconds(limit_seconds);
  char buffer[4096];
  for (;;) {
    int wait_ms = -1;
    if (limit_seconds > 0) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      wait_ms = static_cast<int>(std::clamp<long long>(left, 0, 60000));
    }
    pollfd readable{fds[0], POLLIN, 0};
    const int ready = poll(&readable, 1, wait_ms);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      if (Clock::now() < deadline) continue;
      timed_out = true;
      std::fprintf(stderr, "bench_cdt: the run still had not ended after %d s; its threads:\n%s",
                   limit_seconds, threads_of(pid).c_str());
      std::fflush(stderr);
      stacks_of(pid);
      kill(pid, SIGKILL);
      break;
    }
    const ssize_t got = read(fds[0], buffer, sizeof buffer);
    if (got <= 0) break;
    child_output.append(buffer, static_cast<std::size_t>(got));
  }
  close(fds[0]);
  int status = 0;
  rusage usage{};
  if (!timed_out) {
    wait4(pid, &status, 0, &usage);
    return usage.ru_maxrss / 1024.0;
  }
  // A child killed inside the driver may take its time to go (or never): not waited for past 10 s.
  for (int i = 0; i < 100 && wait4(pid, &status, WNOHANG, &usage) == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return usage.ru_maxrss / 1024.0;
}

/// Half the machine's physical memory in bytes (0 when unknown).
std::size_t half_the_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<std::size_t>(pages) * static_cast<std::size_t>(page) / 2 : 0;
}

} // namespace

int main(int argc, char** argv) {
  bool quick = false;
  bool small_pages = false;
  bool unpinned = false;
  std::string coast;
  std::vector<std::string> files;
  unsigned threads = 0;
  int repeat = 3;
  std::string only;
  bool with_cgal = true;
  bool check = true;
  std::uint32_t grid = 0;
  unsigned inner_iterations = cdt::Options{}.inner_iterations;
  std::string backend_name = "auto";
  std::vector<std::pair<std::size_t, std::size_t>> sizes;
  std::uint32_t lattice_side = 0;
  std::string cache;
  int together = 0;
  int limit = 0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else if (!std::strcmp(argv[i], "--coast") && i + 1 < argc)
      coast = argv[++i];
    else if (!std::strcmp(argv[i], "--file") && i + 1 < argc)
      files.emplace_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = static_cast<unsigned>(std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--repeat") && i + 1 < argc)
      repeat = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--case") && i + 1 < argc)
      only = argv[++i];
    else if (!std::strcmp(argv[i], "--grid") && i + 1 < argc)
      grid = static_cast<std::uint32_t>(std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--inner-iterations") && i + 1 < argc && std::atoi(argv[i + 1]) > 0)
      inner_iterations = static_cast<unsigned>(std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--sizes") && i + 1 < argc && parse_sizes(argv[i + 1], sizes))
      ++i;
    else if (!std::strcmp(argv[i], "--cache") && i + 1 < argc)
      cache = argv[++i];
    else if (!std::strcmp(argv[i], "--together") && i + 1 < argc)
      together = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--limit") && i + 1 < argc && std::atoi(argv[i + 1]) > 0)
      limit = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--lattice") && i + 1 < argc)
      lattice_side = static_cast<std::uint32_t>(std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--no-cgal"))
      with_cgal = false;
    else if (!std::strcmp(argv[i], "--no-verify"))
      check = false;
    else if (!std::strcmp(argv[i], "--small-pages"))
      small_pages = true;
    else if (!std::strcmp(argv[i], "--unpinned"))
      unpinned = true;
    else if (!std::strcmp(argv[i], "--backend") && i + 1 < argc &&
             (!std::strcmp(argv[i + 1], "auto") || !std::strcmp(argv[i + 1], "cpu") ||
              !std::strcmp(argv[i + 1], "gpu")))
      backend_name = argv[++i];
    else {
      std::fprintf(stderr, "usage: bench_cdt [--quick] [--coast FILE] [--file PSLG]... [--threads N] "
                           "[--repeat R] [--case TEXT] "
                           "[--no-cgal] [--grid M] [--inner-iterations I] [--backend auto|cpu|gpu] "
                           "[--sizes POINTS:SEGMENTS,...] "
                           "[--lattice K] [--cache DIR] [--small-pages] [--unpinned] [--together N] "
                           "[--no-verify] [--limit SECONDS]\n");
      return 2;
    }
  }
  // Both libraries' large arrays reuse freed pages instead of faulting in fresh ones, from a heap
  // advised for transparent huge pages as large as half the machine's memory unless --small-pages (see
  // cdt::retain_freed_memory); CGAL runs in this process too, under the same policy.
  const bool huge = cdt::retain_freed_memory(small_pages ? 0 : half_the_memory());
  std::printf("memory: freed pages reused, %s\n", small_pages ? "small pages"
                                                  : huge      ? "heap advised for huge pages"
                                                              : "huge pages refused");
  // The GPU backend's large results go into pinned memory kept from run to run unless --unpinned (see
  // cdt::keep_pinned_results): a run's first large result pins it, the repeats reuse it.
  const bool pinned = !unpinned && cdt::keep_pinned_results(half_the_memory() / 2);
  std::printf("results: %s\n", pinned ? "pinned memory kept (GPU backend)" : "not pinned");
  const cdt::Backend backend = backend_name == "cpu"   ? cdt::Backend::cpu
                               : backend_name == "gpu" ? cdt::Backend::gpu
                                                       : cdt::Backend::automatic;
  // Only the children touch CUDA: a process that initialised it before fork() could not use it after.
  std::printf("backend: %s\n", backend_name.c_str());
  const std::size_t n = quick ? 100000 : 1000000;
  const auto wanted = [&](const char* name) {
    return only.empty() || std::strstr(name, only.c_str()) != nullptr;
  };
  std::vector<Input> inputs;
  for (const auto& [points, segments] : sizes) {
    const std::string size = " " + std::to_string(points) + " + " + std::to_string(segments);
    std::uint64_t seed = 10 + points + segments;
    if (segments == 0) {
      const std::string name = "uniform points" + size;
      if (wanted(name.c_str()))
        inputs.push_back({name, cached(cache, name, [&] {
                            return trixel_gen::random_points(points, trixel_gen::Distribution::uniform, seed);
                          })});
      continue;
    }
    for (const auto& [label, d] : {std::pair{"synthetic uniform", trixel_gen::Distribution::uniform},
                                   std::pair{"synthetic gaussian", trixel_gen::Distribution::gaussian}}) {
      const std::string name = label + size;
      ++seed;
      if (wanted(name.c_str()))
        inputs.push_back({name, cached(cache, name, [&] {
                            return trixel_gen::synthetic_pslg(points, segments, d, seed);
                          })});
    }
  }
  if (lattice_side > 0) {
    const std::string name = "lattice " + std::to_string(lattice_side) + "^2";
    if (wanted(name.c_str()))
      inputs.push_back({name, cached(cache, name, [&] {
                          return trixel_gen::lattice_with_segments(
                              lattice_side, std::size_t{lattice_side} * lattice_side / 16, 5);
                        })});
  }
  // --sizes replaces the default inputs.
  if (sizes.empty() && wanted("uniform points"))
    inputs.push_back({"uniform points", trixel_gen::random_points(n, trixel_gen::Distribution::uniform, 1)});
  if (sizes.empty() && wanted("synthetic uniform"))
    inputs.push_back(
        {"synthetic uniform", trixel_gen::synthetic_pslg(n, n / 10, trixel_gen::Distribution::uniform, 2)});
  if (sizes.empty() && wanted("synthetic gaussian"))
    inputs.push_back(
        {"synthetic gaussian", trixel_gen::synthetic_pslg(n, n / 10, trixel_gen::Distribution::gaussian, 3)});
  if (!coast.empty()) {
    // The GSHHG extraction of scripts/bench-cdt.sh keeps its name in the tables; any other coastline
    // file is named by its file name.
    const std::string base = coast.substr(coast.find_last_of('/') + 1);
    std::string lower = base;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    const std::string name =
        lower.find("gshhg") != std::string::npos ? "GSHHG coastlines" : "coastlines " + base;
    if (wanted(name.c_str())) inputs.push_back({name, read_coast(coast)});
  }
  std::vector<std::size_t> file_inputs; // the --file inputs, by their place in `inputs`
  for (const std::string& file : files) {
    if (!wanted(file.c_str())) continue;
    try {
      cdt::io::Pslg read = cdt::io::read_pslg(file);
      inputs.push_back({file, {std::move(read.points), std::move(read.segments)}});
      file_inputs.push_back(inputs.size() - 1);
    } catch (const cdt::Error& e) {
      std::fprintf(stderr, "bench_cdt: %s\n", e.what());
      return 1;
    }
  }

  std::printf("| input | points | segments | ours ms (median of %d) | phases ms | flips | missing | verified "
              "| peak MiB "
              "| CGAL ms | ours / CGAL |\n",
              repeat);
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  cdt::Options options;
  options.threads = threads;
  options.grid_size = grid;
  options.inner_iterations = inner_iterations;
  options.backend = backend;
  for (const Input& input : inputs) {
    std::string row;
    bool timed_out = false;
    const double peak = peak_mib_of(
        [&](int fd) {
          // Every run gives the same triangulation; the phases printed are those of the median run
          // (the first run also pays for starting the device, which would show in its first phase).
          std::vector<double> times;
          std::vector<cdt::Statistics> runs;
          cdt::Triangulation last;
#if defined(__GLIBC__)
          // The parent's free heap is shared with this child until written: without this, the first
          // arrays carved from it would pay a copy of every page (copy-on-write) on top of the fault.
          malloc_trim(0);
#endif
          for (int r = 0; r < repeat; ++r) {
            // The last run's result is released first, so that each run reuses the memory of the one
            // before, as a process triangulating one input after another would.
            last = cdt::Triangulation{};
            last = cdt::triangulate(input.pslg.points, input.pslg.segments, options);
            times.push_back(last.stats.total_milliseconds);
            runs.push_back(last.stats);
          }
          const cdt::Statistics& best =
              *std::find_if(runs.begin(), runs.end(),
                            [&](const cdt::Statistics& s) { return s.total_milliseconds == median(times); });
          const char* verdict = !check ? "not checked"
                                : cdt::verify(last, input.pslg.points, input.pslg.segments, threads).ok()
                                    ? "yes"
                                    : "NO";
          std::string phases = best.backend + ":";
          std::uint64_t flips = 0;
          std::uint64_t missing = 0;
          for (const auto& p : best.phases) {
            char part[64];
            if (p.iterations > 0) {
              std::snprintf(part, sizeof part, "%s %s %.0f (%llu)", phases.back() == ':' ? "" : ",",
                            p.name.c_str(), p.milliseconds, static_cast<unsigned long long>(p.iterations));
            } else {
              std::snprintf(part, sizeof part, "%s %s %.0f", phases.back() == ':' ? "" : ",", p.name.c_str(),
                            p.milliseconds);
            }
            phases += part;
            flips += p.flips;
            if (p.name == "insert") missing = p.missing;
          }
          phases += ", grid " + std::to_string(best.grid_size);
          char text[1024];
          const int len = std::snprintf(text, sizeof text, "%.1f|%s|%llu|%llu|%s", median(times),
                                        phases.c_str(), static_cast<unsigned long long>(flips),
                                        static_cast<unsigned long long>(missing), verdict);
          if (write(fd, text, static_cast<std::size_t>(len)) < 0) _exit(1);
        },
        row, limit, timed_out);
    if (timed_out) {
      std::printf("| %s | %zu | %zu | TIMED OUT after %d s (child output: %s) |\n", input.name.c_str(),
                  input.pslg.points.size(), input.pslg.segments.size(), limit, row.c_str());
      std::fflush(stdout);
      continue;
    }
    double cgal_ms = -1;
#if defined(TRIXEL_HAVE_CGAL)
    if (with_cgal) {
      std::vector<double> cgal;
      for (int r = 0; r < repeat; ++r) cgal.push_back(run_cgal(input.pslg));
      cgal_ms = median(cgal);
    }
#else
    (void)with_cgal; // no competitor in this build: the column says -1
#endif
    const std::vector<std::string> f = fields_of(row);
    if (f.size() != 5) {
      std::printf("| %s | %zu | %zu | FAILED (child output: %s) |\n", input.name.c_str(),
                  input.pslg.points.size(), input.pslg.segments.size(), row.c_str());
      continue;
    }
    const double ours = std::atof(f[0].c_str());
    std::printf("| %s | %zu | %zu | %s | %s | %s | %s | %s | %.0f | %.1f | %.2f |\n", input.name.c_str(),
                input.pslg.points.size(), input.pslg.segments.size(), f[0].c_str(), f[1].c_str(),
                f[2].c_str(), f[3].c_str(), f[4].c_str(), peak, cgal_ms, cgal_ms > 0 ? ours / cgal_ms : 0.0);
    std::fflush(stdout);
  }
  if (together > 0 && !file_inputs.empty()) {
    std::printf(
        "\n| inputs | points | segments | alone ms (median of %d, the sum of the calls) | together ms "
        "(median) | alone / together | inputs per call | verified |\n",
        repeat);
    std::printf("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    std::vector<cdt::Input> many;
    std::size_t points = 0;
    std::size_t segments = 0;
    for (int k = 0; k < together; ++k) {
      const trixel_gen::Pslg& p = inputs[file_inputs[static_cast<std::size_t>(k) % file_inputs.size()]].pslg;
      many.push_back({p.points, p.segments});
      points += p.points.size();
      segments += p.segments.size();
    }
    std::string row;
    bool timed_out = false;
    const double peak = peak_mib_of(
        [&](int fd) {
          // A first call starts the device, if any, outside the timings.
          (void)cdt::triangulate(many[0].points, many[0].segments, options);
          std::vector<double> alone;
          std::vector<double> joint;
          std::vector<cdt::ManyResult> results;
          for (int r = 0; r < repeat; ++r) {
            auto start = Clock::now();
            for (const cdt::Input& in : many) (void)cdt::triangulate(in.points, in.segments, options);
            alone.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
            results.clear();
            start = Clock::now();
            results = cdt::triangulate_many(many, options);
            joint.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
          }
          bool ok = true;
          for (std::size_t k = 0; k < many.size(); ++k)
            ok = ok && !results[k].error &&
                 cdt::verify(results[k].triangulation, many[k].points, many[k].segments, threads).ok();
          char text[256];
          const int len =
              std::snprintf(text, sizeof text, "%.1f|%.1f|%u|%s", median(alone), median(joint),
                            results[0].error ? 0u : results[0].triangulation.stats.inputs, ok ? "yes" : "NO");
          if (write(fd, text, static_cast<std::size_t>(len)) < 0) _exit(1);
        },
        row, limit, timed_out);
    const std::vector<std::string> f = fields_of(row);
    if (timed_out || f.size() != 4) {
      std::printf("| %d | %zu | %zu | FAILED (child output: %s) |\n", together, points, segments,
                  row.c_str());
    } else {
      const double a = std::atof(f[0].c_str());
      const double t = std::atof(f[1].c_str());
      std::printf("| %d | %zu | %zu | %s | %s | %.2fx | %s | %s (peak %.0f MiB) |\n", together, points,
                  segments, f[0].c_str(), f[1].c_str(), t > 0 ? a / t : 0.0, f[2].c_str(), f[3].c_str(),
                  peak);
    }
  }
  return 0;
}
