// triangulate(): the gCD pipeline (paper sections 3 and 4). The CPU executor runs every phase; with
// the GPU backend the CUDA executor runs the merge of duplicate points and of the segments between
// them, the sites' order, grid cells and kept sites, the digital Voronoi diagram, the dual triangles
// with their links (Phase 2 but for hull completion and the fake boundary), shifting, missing points,
// the segments' screen, the constraints and the Lawson flips before and after them, each the same
// computation as the CPU executor's step for step, so the result is the same; the CPU executor runs
// the rest (input checks, hull completion and fake boundary, the fake vertices' deletion on a copy of
// their fans, the suspects' split), until those move to the device too.
//
//   prepare   input checks, merge duplicates and the segments between them (cdt/src/pslg.cpp; the
//             merge on the device with the GPU backend)
//   voronoi   Phase 1: grid mapping (Appendix B), digital Voronoi diagram (PBA + Appendix A)
//   dualize   Phase 2: dual triangles, hull completion, fake boundary
//   shift     Phase 3: points back to their true coordinates (Algorithms 1 and 2)
//   insert    Phase 4: missing points (Algorithm 3), fake boundary removal (with the GPU backend: the
//             device flips the fake vertices' fans to convex chains, gcd/flip.hpp flip_fake_fans, and
//             the host deletes the fake vertices from a copy of the fans, delete_fake_vertices)
//   delaunay  Phase 5: Lawson flips to the Delaunay triangulation
//   split     Step 1, after the sites are triangulated: segments split at points on them and at
//             crossings. A segment that is an edge of the Delaunay mesh can neither cross another edge
//             nor hold a vertex, so only the others and what their walks through the mesh meet are
//             tested (gcd/screen.hpp; the screen runs where the mesh is); the vertices added at
//             crossings are then inserted with their flips where the mesh is. On the coastlines 98%
//             of the segments are edges of the Delaunay mesh and need no test.
//
// On CPU threads Phases 4 and 5 and Step 3 are scheduled for a few fast cores rather than thousands of
// slow ones: the mesh's slots are cut into fixed parts, each worked by one thread with Lawson's
// algorithm (the sites' mesh flipped to Delaunay, then each missing point inserted and its flips made
// at once), and what crosses between parts is then done by one thread that owns every slot. The
// paper's rounds spend most of their time re-reading the active lists (about ten passes a round, tens
// of rounds); the parts do the same flips once each. The device keeps the paper's rounds. Where the CDT is
// unique both give the same triangles; with co-circular points each gives one of the CDTs.
//   constraints  Step 2: constraints inserted by flipping (Algorithms 4 and 5 on the device; on CPU
//             threads one walking pass, then the pieces not yet edges one by one, by Sloan's flipping)
//   flip      Step 3: Lawson flips to the constrained Delaunay triangulation, from the triangles
//             that Step 2 flipped

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <iterator>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/trace.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/constraints.hpp"
#include "gcd/dualize.hpp"
#include "gcd/flip.hpp"
#include "gcd/grid_map.hpp"
#include "gcd/insert.hpp"
#include "gcd/mesh.hpp"
#include "gcd/screen.hpp"
#include "gcd/shift.hpp"
#include "gcd/voronoi.hpp"
#include "memory.hpp"
#include "pslg.hpp"

#if defined(TRIXEL_HAVE_CUDA)
#include "cdt_kernels.hpp"
#endif

namespace cdt {
namespace {

using Clock = std::chrono::steady_clock;

/// Statistics::backend with the GPU backend: which phases the CUDA executor runs.
constexpr const char* kGpuBackendName =
    "gpu (voronoi, dualize, shift, insert, delaunay, screen, constraints, flip) + cpu";

class PhaseTimer {
public:
  explicit PhaseTimer(Statistics& stats) : stats_(stats), start_(Clock::now()) {}
  PhaseStats& end(const char* name) {
    const auto now = Clock::now();
    PhaseStats phase;
    phase.name = name;
    phase.milliseconds = std::chrono::duration<double, std::milli>(now - start_).count();
    stats_.phases.push_back(phase);
#if defined(TRIXEL_HAVE_CUDA)
    gpu::print_profile(name); // with TRIXEL_CUDA_PROFILE=1: the phase's device steps
#endif
    start_ = now;
    return stats_.phases.back();
  }

private:
  Statistics& stats_;
  Clock::time_point start_;
};

/// Whether the CUDA executor runs (true) or the CPU executor alone. An explicit GPU request never
/// silently runs on the CPU.
bool use_gpu(Backend backend) {
  if (backend == Backend::cpu) return false;
  if (gpu_device_count() > 0) return true;
  if (backend == Backend::gpu) {
#if defined(TRIXEL_HAVE_CUDA)
    throw DeviceError("backend gpu: no CUDA device is available on this machine");
#else
    throw DeviceError("backend gpu: this build has no CUDA support (configure with -DTRIXEL_CUDA=ON)");
#endif
  }
  return false;
}

#if defined(TRIXEL_HAVE_CUDA)
/// The device's flip counts in the CPU executor's terms.
detail::FlipStats flip_stats(const gpu::FlipResult& device) {
  detail::FlipStats stats;
  stats.flips = device.flips;
  stats.rounds = device.rounds;
  return stats;
}
#endif

/// The sites (vertex ids, in `sites` order) reordered by the Z-order index of their grid cells, ties in
/// their given order. Every phase walks fans and reads the coordinates of neighbours; with neighbours
/// numbered close together those reads hit the cache instead of memory (input order is arbitrary, often
/// random). Keeping ties in order keeps the lowest-numbered point of a cell the same point, so the kept
/// sites of Phase 1 do not change.
IndexArray spatial_site_order(const detail::GridMapping& mapping, std::span<const double> x,
                              std::span<const double> y, std::span<const std::uint32_t> sites,
                              detail::CpuExecutor& executor) {
  const std::size_t n = sites.size();
  std::vector<std::uint32_t> key(n);
  executor.for_each(
      n, [&](std::size_t s) { key[s] = detail::z_order_key(mapping.grid_x(x[s]), mapping.grid_y(y[s])); });
  // Stable: ties keep their given order.
  std::vector<std::uint32_t> order(n);
  executor.for_each(n, [&](std::size_t s) { order[s] = static_cast<std::uint32_t>(s); });
  executor.sort_pairs_by_key(key, order, 2 * std::bit_width(mapping.m - 1));
  IndexArray site_vertex;
  site_vertex.reserve(detail::vertex_room(n)); // grows by the split's vertices
  site_vertex.resize(n);
  executor.for_each(n, [&](std::size_t s) { site_vertex[s] = sites[order[s]]; });
  return site_vertex;
}

/// The PSLG's pieces in mesh vertex ids (id: the piece's index), written into `pieces`, whose storage is
/// reused when they are made again after a split (a fresh array of millions of pieces costs its page
/// faults again).
void mesh_pieces(const detail::PreparedPslg& pslg, const IndexArray& site_of_vertex,
                 detail::CpuExecutor& executor, detail::UnzeroedVector<detail::ConstraintPiece2>& pieces) {
  if (pieces.capacity() < pslg.pieces.size()) pieces.reserve(detail::piece_room(pslg.pieces.size()));
  pieces.resize(pslg.pieces.size());
  executor.for_each(pieces.size(), [&](std::size_t k) {
    pieces[k] = {site_of_vertex[pslg.pieces[k].a], site_of_vertex[pslg.pieces[k].b],
                 static_cast<std::uint32_t>(k)};
  });
}

/// Splits the pieces after the sites are triangulated, given their screen against the Delaunay mesh
/// (host or device): only the suspects are split (all of them, should the screen have failed).
/// site_vertex maps mesh vertices to the PSLG's; sites_magnitude is the largest absolute coordinate of
/// the sites where known (negative: split_pieces computes it). Returns whether the pieces may have
/// changed places (false: the same pieces in the same places, their segment ids perhaps lowered), and
/// in new_pieces the indices of the pieces that came when known (the suspects' split), else nothing;
/// in moves, when the suspects' split moved the pieces, where they went (split_pieces); with `later`,
/// the suspects' split leaves the pieces' move to the caller (split_pieces).
bool split_screened(detail::PreparedPslg& pslg, const detail::ScreenedPieces& screen,
                    const IndexArray& site_vertex, CrossingSegments policy, detail::CpuExecutor& executor,
                    double sites_magnitude, std::optional<std::vector<std::uint32_t>>& new_pieces,
                    detail::PieceMoves& moves, detail::PieceMove* later = nullptr) {
  using namespace detail;
  new_pieces.reset();
  if (!screen.complete) {
    split_pieces(pslg, policy, executor);
    return true;
  }
  new_pieces.emplace();
  if (screen.pieces.empty()) return false;
  std::vector<std::uint32_t> sites(screen.sites.size());
  executor.for_each(sites.size(), [&](std::size_t k) { sites[k] = site_vertex[screen.sites[k]]; });
  return split_pieces(pslg, screen.pieces, sites, policy, executor, sites_magnitude, &*new_pieces, &moves,
                      later);
}

/// The vertices the PSLG gained from first_added on, numbered after the mesh's vertices (as many as
/// site_vertex holds) and appended to the vertex maps, as missing points: each starts its walk from a
/// vertex it is joined to by a piece (through other added vertices, inserted before it, if need be).
/// came, when given, holds every piece at an added vertex (the pieces that came in the suspects' split,
/// PieceMoves::came); else all of pslg.pieces are read.
detail::MissingArray added_vertices(const detail::PreparedPslg& pslg, std::size_t first_added,
                                    IndexArray& site_vertex, IndexArray& site_of_vertex,
                                    detail::CpuExecutor& executor,
                                    const std::vector<detail::ConstraintPiece>* came) {
  using namespace detail;
  StepTrace trace("added vertices");
  const std::size_t added = pslg.vertices.size() - first_added;
  const auto first = static_cast<std::uint32_t>(site_vertex.size());
  site_of_vertex.resize(pslg.vertices.size(), kNoId);
  trace.mark("maps grown");
  MissingArray fresh(added);
  for (std::size_t k = 0; k < added; ++k) {
    const auto v = static_cast<std::uint32_t>(first_added + k);
    site_of_vertex[v] = first + static_cast<std::uint32_t>(k);
    site_vertex.push_back(v);
    fresh[k] = {first + static_cast<std::uint32_t>(k), kNoId};
  }
  trace.mark("listed");
  const auto at_added = [&](const ConstraintPiece& p) { return p.a >= first_added || p.b >= first_added; };
  std::vector<ConstraintPiece> links;
  if (came != nullptr) {
    std::copy_if(came->begin(), came->end(), std::back_inserter(links), at_added);
  } else {
    const std::vector<std::uint32_t> at =
        executor.compact(pslg.pieces.size(), [&](std::size_t k) { return at_added(pslg.pieces[k]); });
    links.resize(at.size());
    for (std::size_t k = 0; k < at.size(); ++k) links[k] = pslg.pieces[at[k]];
  }
  trace.mark("pieces at them");
  for (bool changed = true; changed;) {
    changed = false;
    for (const ConstraintPiece& piece : links) {
      const std::uint32_t a = site_of_vertex[piece.a], b = site_of_vertex[piece.b];
      const auto hint = [&](std::uint32_t v, std::uint32_t from) {
        if (v < first || fresh[v - first].hint != kNoId) return;
        if (from >= first && fresh[from - first].hint == kNoId) return;
        fresh[v - first].hint = from;
        changed = true;
      };
      hint(a, b);
      hint(b, a);
    }
  }
  for (MissingPoint& f : fresh)
    if (f.hint == kNoId) f.hint = 0; // not reached: every added vertex lies on a piece
  trace.mark("hints");
  return fresh;
}

/// Inserts the added vertices (added_vertices) with their flips into the Delaunay mesh, which stays
/// Delaunay. Throws Error when one cannot be inserted.
detail::InsertStats insert_added_vertices(detail::Mesh& mesh, const detail::PreparedPslg& pslg,
                                          std::span<const detail::MissingPoint> fresh,
                                          const IndexArray& site_vertex, detail::CpuExecutor& executor) {
  using namespace detail;
  for (const MissingPoint& f : fresh) {
    const Point& p = pslg.vertices[site_vertex[f.vertex]];
    mesh.xy.push_back({p.x, p.y});
    mesh.vert_tri.push_back(kNoId);
  }
  std::vector<std::uint8_t> again;
  InsertStats placed = insert_missing_points_in_parts(mesh, fresh, executor, again, true);
  placed.flips += flip_to_delaunay_in_parts(mesh, executor, again.data()).flips;
  return placed;
}

#if defined(TRIXEL_HAVE_CUDA)
/// The same on the device: the vertices are appended to the device's mesh, inserted by Algorithm 3
/// and flipped to Delaunay there.
detail::InsertStats insert_added_vertices(gpu::DeviceMesh& mesh, const detail::PreparedPslg& pslg,
                                          std::span<const detail::MissingPoint> fresh,
                                          const IndexArray& site_vertex) {
  using namespace detail;
  std::vector<double> x(fresh.size()), y(fresh.size());
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const Point& p = pslg.vertices[site_vertex[fresh[k].vertex]];
    x[k] = p.x;
    y[k] = p.y;
  }
  StepTrace trace("added vertices");
  mesh.add_vertices(x, y);
  trace.mark("appended");
  InsertStats placed = mesh.insert(fresh);
  trace.mark("inserted");
  const gpu::FlipResult flips = mesh.flip_after_insert();
  trace.mark("flipped");
  placed.flips += flips.flips;
  placed.rounds += flips.rounds;
  return placed;
}
#endif

/// One task on a thread of its own while the caller goes on, for host work that can be done while the
/// device works (the host's threads wait for it then). wait() joins it and rethrows what it threw; the
/// destructor joins it too, so a SideTask is declared after what its task uses. A small task (worth less
/// than starting a thread, some tens of microseconds), or one without a thread to be had, runs at once.
class SideTask {
public:
  SideTask() = default;
  SideTask(const SideTask&) = delete;
  SideTask& operator=(const SideTask&) = delete;
  ~SideTask() {
    if (thread_.joinable()) thread_.join();
  }

  template <class F>
  void start(F task, bool worth_a_thread = true) {
    wait();
    if (!worth_a_thread) {
      task();
      return;
    }
    try {
      thread_ = std::thread([this, task]() mutable {
        try {
          task();
        } catch (...) {
          error_ = std::current_exception();
        }
      });
      return;
    } catch (const std::system_error&) {
      // No thread to be had: run here instead.
    }
    task();
  }

  void wait() {
    if (thread_.joinable()) thread_.join();
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

private:
  std::thread thread_;
  std::exception_ptr error_;
};

#if defined(TRIXEL_HAVE_CUDA)
/// Constraints the device inserts on a copy of the mesh while it screens the mesh and the host splits
/// the suspects (DeviceMesh::start_constraints):
/// finish() keeps or undoes them; the destructor, should an exception leave first, stops them, so it is
/// declared after the pieces they read.
class ConstraintsBesideSplit {
public:
  ConstraintsBesideSplit() = default;
  ConstraintsBesideSplit(const ConstraintsBesideSplit&) = delete;
  ConstraintsBesideSplit& operator=(const ConstraintsBesideSplit&) = delete;
  ~ConstraintsBesideSplit() {
    if (mesh_ == nullptr) return;
    try {
      mesh_->finish_constraints(false);
    } catch (...) {
      // Leaving on an exception already; the mesh is not used again.
    }
  }

  /// Starts them, unless the device lacks the memory (then running() stays false).
  void start(gpu::DeviceMesh& mesh, std::span<const detail::ConstraintPiece2> pieces,
             unsigned inner_iterations, const gpu::HostParallelFor& parallel) {
    if (mesh.start_constraints(pieces, inner_iterations, parallel)) mesh_ = &mesh;
  }
  bool running() const { return mesh_ != nullptr; }
  /// Whether the run leaves the suspects out (restart).
  bool without_suspects() const { return without_suspects_; }
  /// Starts the run again without the suspects, which the split alone may change (their pieces are
  /// inserted after it). Returns whether it did.
  bool restart_without(std::span<const std::uint32_t> suspects, unsigned inner_iterations) {
    if (mesh_ == nullptr || suspects.empty()) return false;
    without_suspects_ = mesh_->restart_constraints(suspects, inner_iterations);
    if (!without_suspects_) mesh_ = nullptr; // nothing runs
    return without_suspects_;
  }
  /// DeviceMesh::finish_constraints.
  std::optional<detail::ConstraintStats> finish(bool keep) {
    return std::exchange(mesh_, nullptr)->finish_constraints(keep);
  }

private:
  gpu::DeviceMesh* mesh_ = nullptr;
  bool without_suspects_ = false;
};
#endif

#if defined(TRIXEL_HAVE_CUDA)
/// Waits, when it goes, for the device's copies into the PSLG's maps and pieces (the merge's, started
/// by DeviceSites::prepare and waited for by finish_downloads after shifting): declared after the PSLG,
/// so that an exception leaving before that wait does not free the arrays under the copies.
class MergeDownloads {
public:
  explicit MergeDownloads(std::optional<gpu::DeviceSites>& sites) : sites_(sites) {}
  MergeDownloads(const MergeDownloads&) = delete;
  MergeDownloads& operator=(const MergeDownloads&) = delete;
  ~MergeDownloads() {
    try {
      if (sites_) sites_->finish_downloads();
    } catch (...) {
      // The exception on its way out says what went wrong; a failed copy adds nothing to it.
    }
  }

private:
  std::optional<gpu::DeviceSites>& sites_;
};
#endif

/// The input points copied into the PSLG's vertex array, which merge_input leaves to its caller when the
/// device merged the input: on a thread of its own, while the device works (160 MB at 10^7 points,
/// which took the host's threads 4 ms at the end of the preparation), for large inputs; at once for
/// small ones. wait() before the array is read or moved; the destructor waits too.
class PointCopy {
public:
  void start(std::span<const Point> points, PointArray& vertices) {
    constexpr std::size_t kOnItsOwnFrom = std::size_t{1} << 20;
    task_.start([points, &vertices] { detail::copy_points(points, vertices); },
                points.size() >= kOnItsOwnFrom);
  }

  void wait() { task_.wait(); }

private:
  SideTask task_;
};

/// The identity maps that the device's merge left unwritten (PreparedPslg::identity_maps_unwritten: no
/// two points coincide), written on a thread of their own while the device works (80 MB at 10^7
/// points: 1.5-2.5 ms of the host's threads on the H200 machine, on the critical path before).
class IdentityMaps {
public:
  void start(detail::PreparedPslg& pslg) {
    if (!pslg.identity_maps_unwritten || started_) return;
    // Small maps (a photograph's PSLG) are written here: a thread's start costs more.
    constexpr std::size_t kOnItsOwnFrom = std::size_t{1} << 20;
    task_.start([&pslg] { detail::write_identity_maps(pslg); }, pslg.duplicate_of.size() >= kOnItsOwnFrom);
    started_ = true;
  }

  /// Waits for them, or writes them here if they were not started; clears the flag.
  void finish(detail::PreparedPslg& pslg) {
    task_.wait();
    if (pslg.identity_maps_unwritten && !started_) detail::write_identity_maps(pslg);
    pslg.identity_maps_unwritten = false;
  }

private:
  SideTask task_;
  bool started_ = false;
};

/// out[k] = pieces[k].segment for every piece, in parts on threads of their own for many pieces: on one
/// thread the coastlines' 1.8 million outlasted the device's constraints and flips beside them (the
/// output waited 0.7 ms for them on average on the H200 machine).
void segments_of_pieces(const detail::PieceArray& pieces, IndexArray& out) {
  constexpr std::size_t kPiecesPerThread = std::size_t{1} << 19;
  const std::size_t parts = std::clamp<std::size_t>(pieces.size() / kPiecesPerThread, 1, 4);
  const auto part = [&](std::size_t p) {
    const std::size_t end = pieces.size() * (p + 1) / parts;
    for (std::size_t k = pieces.size() * p / parts; k < end; ++k) out[k] = pieces[k].segment;
  };
  std::vector<std::thread> helpers;
  for (std::size_t p = 1; p < parts; ++p) {
    try {
      helpers.emplace_back(part, p);
    } catch (const std::system_error&) {
      part(p); // no thread to be had: this one does it
    }
  }
  part(0);
  for (std::thread& helper : helpers) helper.join();
}

/// Where the segments are split at the sites on them and at crossings.
enum class Split {
  first,    ///< before the sites are triangulated, every segment against every other
  screened, ///< after: only the segments the Delaunay mesh leaves suspect (gcd/screen.hpp)
};

/// What a triangulation started again carries over from the attempt before: its start, the phases it
/// spent, and the PSLG when it was split already.
struct Restart {
  Clock::time_point start;
  std::vector<PhaseStats> phases;
  std::uint32_t attempts = 1; // made before this one
  std::optional<detail::PreparedPslg> split_pslg;
};

/// The phases of an earlier attempt and of a later one, one row per name in the order first met, with
/// times, flips, missing points and rounds added up.
std::vector<PhaseStats> add_phases(std::vector<PhaseStats> earlier, const std::vector<PhaseStats>& later) {
  for (const PhaseStats& p : later) {
    const auto same =
        std::find_if(earlier.begin(), earlier.end(), [&](const PhaseStats& e) { return e.name == p.name; });
    if (same == earlier.end()) {
      earlier.push_back(p);
      continue;
    }
    same->milliseconds += p.milliseconds;
    same->flips += p.flips;
    same->missing += p.missing;
    same->iterations += p.iterations;
  }
  return earlier;
}

/// With more vertices added at crossings than this many per site, the mesh is made again from all of
/// them (as when splitting first) rather than inserting them into the sites' mesh: inserting costs
/// rounds that grow with their crowding, the diagram places them in one pass.
constexpr std::size_t kRestartAbovePerSite = 1;

/// Sets aside the output's per-triangle arrays for a triangulation of `points` input points (at most
/// 2n - 5 triangles for n vertices, and two more for each vertex added at a crossing: room for one
/// added vertex in 64 points; more grow the arrays later), before anything else is allocated; nothing
/// is written, so no memory is used until the output is. With the GPU backend they come from the pinned
/// result memory when the process keeps it (keep_pinned_results): the device then writes the output
/// straight into them. Without the room for added vertices a lattice with random segments (one added
/// vertex in 250 points) outgrew them, and its output went through the staging copies instead.
void reserve_output(Triangulation& result, std::size_t points, bool on_gpu) {
  if (points >= kNone / 2) return; // an input refused later, with its reason
  std::optional<detail::PinnedResultScope> pinned;
  if (on_gpu) pinned.emplace();
  const std::size_t triangles = 2 * points + points / 32;
  result.triangles.reserve(triangles);
  result.neighbors.reserve(triangles);
  result.segment_of_edge.reserve(triangles);
}

/// The whole pipeline on the CPU executor alone, or with the CUDA executor's phases when on_gpu.
/// `restart` carries what an earlier attempt on the same input left.
Triangulation triangulate_on(std::span<const Point> points, std::span<const Segment> segments,
                             const Options& options, bool on_gpu, Split split, Restart* restart = nullptr) {
  using namespace detail;
  const auto t_start = restart != nullptr ? restart->start : Clock::now();
  Triangulation result;
  reserve_output(result, points.size(), on_gpu);
  Statistics& stats = result.stats;
  stats.backend = on_gpu ? kGpuBackendName : "cpu";
  PhaseTimer timer(stats);
  CpuExecutor executor(options.threads);
  StepTrace trace("triangulate");

  // Declared before device_sites: the device fills them on a thread of its own after its prepare()
  // returns, and its destructor waits for those copies (DeviceSites::finish_downloads).
  IndexArray site_vertex;    // per site, its vertex
  IndexArray site_of_vertex; // per vertex, its site (kNoId for duplicates)
#if defined(TRIXEL_HAVE_CUDA)
  std::optional<gpu::DeviceSites> device_sites;
  const gpu::HostParallelFor parallel = [&](std::size_t parts, const std::function<void(std::size_t)>& body) {
    executor.for_each_part(parts, body);
  };
  // With the GPU backend the points and segments go to the device once: they are checked, the
  // duplicates merged and the pieces made there, and the sites are prepared from the points already
  // there.
  InputMerge merge;
  if (on_gpu && points.size() >= 3) { // fewer: no triangulation; the host's checks say why
    merge = [&](IndexArray& duplicate_of, IndexArray& sites, PieceArray& pieces, bool& identity_unwritten) {
      std::size_t zero_length_segments = 0;
      device_sites.emplace(points, segments, options.crossings, duplicate_of, sites, pieces,
                           zero_length_segments, parallel, &identity_unwritten);
      return zero_length_segments;
    };
  }
#else
  const InputMerge merge;
#endif
  // Input checks and cleaning.
  const bool split_before = restart != nullptr && restart->split_pslg;
  PreparedPslg pslg = split_before ? std::move(*restart->split_pslg)
                      : split == Split::first
                          ? prepare_pslg(points, segments, options.crossings, executor)
                          : merge_input(points, segments, options.crossings, executor, merge);
  // Declared after pslg, so that an exception waits for the copies before the arrays go.
#if defined(TRIXEL_HAVE_CUDA)
  const MergeDownloads merge_downloads(device_sites);
#endif
  PointCopy point_copy;
  if (!split_before && split == Split::screened && merge) point_copy.start(points, pslg.vertices);
  IdentityMaps identity_maps;
  trace.mark("prepare");
  timer.end("prepare");
  stats.zero_length_segments = pslg.zero_length_segments;

  // Sites: the distinct vertices, numbered 0..n-1 in the mesh in the order of their grid cells along a
  // Z curve (see spatial_site_order), each given its grid cell; the lowest-numbered site of a cell is
  // kept (at its grid point), the others are missing points. With the GPU backend the device does this
  // (gpu::DeviceSites, the same steps) and keeps the positions; the host gets them only should the
  // dual need the host's help (degenerate corners).
  const auto n = static_cast<std::uint32_t>(pslg.sites.size());
  const std::uint32_t m = options.grid_size != 0
                              ? options.grid_size
                              : choose_grid_size(n, on_gpu                ? GridFor::device
                                                    : pslg.pieces.empty() ? GridFor::host_points
                                                                          : GridFor::host);
  stats.grid_size = m;
  GridMapping mapping;
  std::vector<double> true_x, true_y; // per site, its true position (CPU executor)
  std::vector<double> x, y;           // per site, its position in the diagram
  FlagArray kept;                     // per site, 1 when it owns its grid cell
  MissingArray missing;
  std::size_t missing_on_device = 0; // the first missing points, left on the device (GPU backend)
  GridSites grid;
  Box bounds; // the box of both positions of every site
  std::vector<std::uint32_t> colour;
  double sites_magnitude = -1.0; // the largest absolute coordinate of the sites (negative: unknown)
#if defined(TRIXEL_HAVE_CUDA)
  std::optional<gpu::DeviceVoronoi> device_diagram; // Phase 1's colouring stays on the device for Phase 2
  if (on_gpu) {
    if (device_sites) {
      // The missing points stay on the device for Phase 4 (10M points: about 6M, 50 MB each way).
      device_sites->prepare(m, mapping, bounds, site_vertex, site_of_vertex, kept, missing, parallel,
                            gpu::DeviceSites::MissingTo::device);
    } else {
      device_sites.emplace(pslg.vertices, pslg.sites, m, mapping, bounds, site_vertex, site_of_vertex, kept,
                           missing, parallel);
    }
    trace.mark("device sites");
    sites_magnitude = device_sites->magnitude();
    device_diagram.emplace(*device_sites);
    trace.mark("digital voronoi");
    missing_on_device = device_sites->missing_on_device();
    timer.end("voronoi").missing = missing_on_device + missing.size();
  }
#endif
  if (!on_gpu) {
    true_x.resize(n);
    true_y.resize(n);
    executor.for_each(n, [&](std::size_t s) {
      true_x[s] = pslg.vertices[pslg.sites[s]].x;
      true_y[s] = pslg.vertices[pslg.sites[s]].y;
    });
    trace.mark("sites' coordinates");
    mapping = make_grid_mapping(true_x, true_y, m, executor);
    trace.mark("grid mapping");
    site_vertex = spatial_site_order(mapping, true_x, true_y, pslg.sites, executor);
    site_of_vertex.reserve(vertex_room(pslg.vertices.size())); // grows by the split's vertices
    site_of_vertex.assign(pslg.vertices.size(), kNoId);
    trace.mark("spatial order");
    executor.for_each(n, [&](std::size_t s) {
      true_x[s] = pslg.vertices[site_vertex[s]].x;
      true_y[s] = pslg.vertices[site_vertex[s]].y;
      site_of_vertex[site_vertex[s]] = static_cast<std::uint32_t>(s);
    });
    trace.mark("renumbering");

    // Phase 1.
    grid = assign_sites(mapping, true_x, true_y, executor);
    trace.mark("site assignment");
    colour = compute_digital_voronoi(grid, m, executor);
    trace.mark("digital voronoi");
    timer.end("voronoi").missing = grid.missing.size();

    // Phase 2: kept sites at their exact grid positions.
    x = true_x;
    y = true_y;
    kept.assign(n, 0);
    executor.for_each(n, [&](std::size_t s) {
      const std::size_t cell = static_cast<std::size_t>(grid.gy[s]) * m + grid.gx[s];
      if (grid.cell_owner[cell] == s) {
        kept[s] = 1;
        x[s] = mapping.to_x(grid.gx[s]);
        y[s] = mapping.to_y(grid.gy[s]);
      }
    });
    trace.mark("kept sites");
    // With the box, the largest absolute coordinate of the sites' true positions: the split's snap
    // tolerance is made from it (as the device gives it), without another pass over the sites there.
    struct Extent {
      Box box;
      double magnitude;
    };
    const Extent extent = executor.reduce(
        n, Extent{Box{true_x[0], true_y[0], true_x[0], true_y[0]}, 0.0},
        [&](Extent& e, std::size_t s) {
          e.box.extend(x[s], y[s]);
          e.box.extend(true_x[s], true_y[s]);
          e.magnitude = std::max({e.magnitude, std::abs(true_x[s]), std::abs(true_y[s])});
        },
        [&](Extent& e, const Extent& part) {
          e.box.extend(part.box.min_x, part.box.min_y);
          e.box.extend(part.box.max_x, part.box.max_y);
          e.magnitude = std::max(e.magnitude, part.magnitude);
        });
    bounds = extent.box;
    sites_magnitude = extent.magnitude;
    trace.mark("bounds");
    missing.reserve(n); // room for the sites appended later (see DeviceSites::prepare)
    missing.resize(grid.missing.size());
    executor.for_each(missing.size(), [&](std::size_t k) {
      missing[k] = {grid.missing[k], grid.missing_owner[k]};
    });
  }
  // Degenerate corners (collinear sites meeting at a grid corner) take their middle site out of the
  // diagram; it becomes a missing point. A few passes settle every input met so far; should they not,
  // the fake polygon alone is the start and every site a missing point. They are common: kept sites
  // sit on grid points, so three of them are often collinear (10M uniform points: about 6600 sites in
  // the first pass, one more pass). With the GPU backend the colouring and the positions stay on the
  // device through the passes; only should the device decline the diagram do they come to the host,
  // for the CPU executor's dualize.
  Mesh mesh;
#if defined(TRIXEL_HAVE_CUDA)
  std::optional<gpu::DeviceMesh> device_mesh; // the mesh of Phases 3 to 6 with the GPU backend
#endif
  std::vector<std::uint32_t> unreached; // the kept sites the dual does not reach
  std::vector<std::uint32_t> degenerate;
  DualCorners corners; // the CPU executor's dual rows, kept from pass to pass
  int passes = 1;
  for (;; ++passes) {
    std::vector<std::uint32_t>* list = passes <= 8 ? &degenerate : nullptr;
    std::vector<std::uint32_t> owners; // per degenerate site, the site now owning its grid cell
#if defined(TRIXEL_HAVE_CUDA)
    bool removed_on_device = false;
    if (device_diagram) {
      using Outcome = gpu::DeviceVoronoi::DualOutcome;
      // The dual is built and completed on the device and stays there for Phase 3 (only its open
      // edges come to the host).
      const Outcome outcome =
          device_diagram->complete_dual(*device_sites, bounds, device_mesh, unreached, list);
      if (outcome == Outcome::built) {
        trace.mark("device dual");
        break;
      }
      if (outcome == Outcome::degenerate) {
        trace.mark("device dual: degenerate corners");
        owners = device_diagram->remove_sites(degenerate);
        trace.mark("device dual: sites removed");
        device_sites->leave_out(degenerate);
        trace.mark("device dual: sites left out");
        removed_on_device = true;
      } else {
        // Declined: the CPU executor's dualize below, from host copies, from now on.
        device_sites->finish_downloads();
        device_sites->positions(x, y, nullptr, nullptr, parallel);
        device_diagram->site_cells(grid.gx, grid.gy, parallel);
        colour = device_diagram->colour();
        device_diagram.reset();
      }
    }
    if (!removed_on_device) {
#endif
      point_copy.wait(); // the degenerate sites' true positions come from the vertex array
      mesh = dualize(colour, m, x, y, kept, bounds, executor, nullptr, list, &corners);
      if (mesh.num_slots() > 0) {
        unreached =
            executor.compact(n, [&](std::size_t s) { return kept[s] != 0 && mesh.vert_tri[s] == kNoId; });
        break;
      }
      corners.mark_changed(remove_sites_from_colouring(colour, grid, m, degenerate), m);
      for (const std::uint32_t s : degenerate) {
        owners.push_back(colour[static_cast<std::size_t>(grid.gy[s]) * m + grid.gx[s]]);
        x[s] = pslg.vertices[site_vertex[s]].x; // its true position
        y[s] = pslg.vertices[site_vertex[s]].y;
      }
#if defined(TRIXEL_HAVE_CUDA)
    }
#endif
    for (const std::uint32_t s : degenerate) kept[s] = 0;
    for (std::size_t k = 0; k < degenerate.size(); ++k) {
      // The site now owning the removed site's grid point is next to it; the fake boundary, always in
      // the mesh, is the fallback start of the search.
      const std::uint32_t owner = owners[k];
      missing.push_back({degenerate[k], owner != kNone && kept[owner] != 0 ? owner : n});
    }
  }
#if defined(TRIXEL_HAVE_CUDA)
  trace.mark("dual checked");
  device_diagram.reset(); // its device memory is free for the later phases
#endif
  trace.mark("dual");
  // Kept sites the dual did not reach (degenerate diagrams) are inserted like missing points, starting
  // from the fake boundary, which is always in the mesh.
  for (const std::uint32_t s : unreached) missing.push_back({s, n});
  timer.end("dualize").iterations = static_cast<std::uint64_t>(passes);

  // Phases 3 to 6. With the GPU backend the mesh goes to the device once and stays there until the
  // flips are done.
#if defined(TRIXEL_HAVE_CUDA)
  if (on_gpu && !device_mesh) device_mesh.emplace(mesh);
#endif
  // Phases 3 to 6 report their rounds, and their flips or missing points, alike.
  const auto end_phase = [&](const char* name, std::uint64_t iterations, std::uint64_t flips,
                             std::uint64_t missing_points = 0) {
    PhaseStats& p = timer.end(name);
    p.iterations = iterations;
    p.flips = flips;
    p.missing = missing_points;
  };
  // Phase 3.
  ShiftStats shift;
#if defined(TRIXEL_HAVE_CUDA)
  if (on_gpu) {
    shift = device_mesh->shift(n, *device_sites, missing);
    trace.mark("shift");
    device_sites->finish_downloads(); // the vertex maps are on the host from here on
    trace.mark("vertex maps waited for");
    identity_maps.start(pslg);                   // after the vertex maps' copies, whose threads it would slow
    device_mesh->take_vertex_ids(*device_sites); // for the output, which then uploads only added ones
    device_mesh->take_missing(*device_sites);    // inserted before the host's list
    device_mesh->take_pieces(*device_sites);     // the constraints' pieces, made there
    device_sites.reset();                        // its device memory is free for the later phases
  }
#endif
  if (!on_gpu) shift = shift_to_true_positions(mesh, n, true_x, true_y, missing, executor);
  end_phase("shift", shift.rounds, 0, shift.bad);

  // Phase 4.
  InsertStats insert;
#if defined(TRIXEL_HAVE_CUDA)
  if (on_gpu) {
    insert = device_mesh->insert(missing, parallel);
    trace.mark("missing points");
    // The paper's rounds leave the points outside the sites' hull in huge fans of the fake vertices,
    // which the removal would copy to the host and fill there without flips. Without these flips the
    // coastlines' insert phase took 10 ms instead of 13-14, uniform 10M + 1M 18-19 instead of 16-17.
    const gpu::FlipResult fans = device_mesh->flip_fake_fans(n);
    insert.flips += fans.flips;
    insert.rounds += fans.rounds;
    trace.mark("fake fans flipped");
    device_mesh->remove_fake_boundary(
        n, [&](Mesh& fan_copy, std::uint32_t first_fake, std::span<const std::uint32_t> ranked_as) {
          delete_fake_vertices(fan_copy, first_fake, executor, ranked_as.data());
        });
  }
#endif
  // On CPU threads each part inserts its points with Lawson's flips as it goes; what the parts leave is
  // flagged in `dirty` for Phase 5.
  std::vector<std::uint8_t> dirty;
  if (!on_gpu) {
    insert = insert_missing_points_in_parts(mesh, missing, executor, dirty);
    trace.mark("missing points");
    remove_fake_boundary(mesh, n, executor, &dirty, !pslg.pieces.empty());
    trace.mark("fake boundary");
  }
  end_phase("insert", insert.rounds, insert.flips, missing_on_device + missing.size());

  // Phase 5: Lawson flips to the Delaunay triangulation, before the constraints as in the paper. Pieces
  // cross far fewer triangles of a Delaunay mesh than of the one Phase 4 leaves (whose missing points
  // went in without flips): on the coastlines, 0.4M piece-triangle crossings instead of 7.8M. On CPU
  // threads only the triangles the parts left in `dirty` can still fail the incircle test.
  FlipStats delaunay;
  // The pieces in mesh vertex ids, for the screen and then the constraints; made again only when the
  // split changed them. With the GPU backend they are made on the host's threads while the device flips.
  UnzeroedVector<ConstraintPiece2> pieces; // written in parallel by mesh_pieces, not zeroed first
  IndexArray segment_of_piece;             // for the output, not zeroed first
  SideTask beside_device;                  // after what its tasks use: an exception waits for it first
  // A suspects' split whose constraints were inserted beside it leaves the pieces' move (0.9 ms of
  // the coastlines' host with every thread) to a thread of its own, with the output's segment of each
  // piece after it, from the split's end on: while the host waits for those constraints, and the device
  // inserts the added vertices and the suspects' pieces. Until beside_move is waited for, nothing else
  // reads pslg.pieces.
  PieceMove piece_move;
  unsigned long long move_microseconds = 0; // beside_move's task, for the trace
  SideTask beside_move;                     // after what its task uses
  bool pieces_moving = false;
#if defined(TRIXEL_HAVE_CUDA)
  ConstraintsBesideSplit beside_split; // after the pieces it reads
#endif
  // On a thread of its own with the GPU backend only (the CPU executor's phases use the host's
  // threads), and from 2^16 pieces: fewer (a photograph's PSLG has some 10^4) are made faster than a
  // thread is started.
  const auto on_its_own = [&] { return on_gpu && pslg.pieces.size() >= (std::size_t{1} << 16); };
  const auto make_pieces = [&] { mesh_pieces(pslg, site_of_vertex, executor, pieces); };
  const bool screen_first = split == Split::screened && !pslg.pieces.empty();
  if (screen_first) beside_device.start(make_pieces, on_its_own());
#if defined(TRIXEL_HAVE_CUDA)
  if (on_gpu) delaunay = flip_stats(device_mesh->flip());
#endif
  if (!on_gpu) delaunay = flip_to_delaunay_in_parts(mesh, executor, dirty.data());
  trace.mark("delaunay");
  end_phase("delaunay", delaunay.rounds, delaunay.flips);

  // From here on the vertex array and the PSLG's maps are read (the split, the added vertices, the
  // output) or moved.
  point_copy.wait();
  trace.mark("vertex array waited for");
  identity_maps.finish(pslg);
  trace.mark("identity maps waited for");

  // Starts again from the sites, splitting first (with split_pslg, the PSLG split already), the device's
  // memory given back first.
  const auto start_again = [&](std::optional<PreparedPslg> split_pslg) {
#if defined(TRIXEL_HAVE_CUDA)
    device_mesh.reset(); // first: it waits for the output's rows it may be copying into the arrays below
    device_diagram.reset();
    device_sites.reset();
#endif
    // The output's arrays set aside for this attempt go too (pinned blocks among them), for the next's.
    TriangleArray().swap(result.triangles);
    TriangleArray().swap(result.neighbors);
    TriangleArray().swap(result.segment_of_edge);
    Restart next{t_start, restart != nullptr ? add_phases(restart->phases, stats.phases) : stats.phases,
                 restart != nullptr ? restart->attempts + 1 : 1, std::move(split_pslg)};
    return triangulate_on(points, segments, options, on_gpu, Split::first, &next);
  };

  // Step 1's splitting, when screened: the segments are tested against the Delaunay mesh, and only the
  // suspects against each other (screen.hpp). The vertices added at crossings are then inserted with
  // their flips, so the mesh stays Delaunay.
  bool screened = false;
  bool pieces_stale = true;
  // The constraints inserted beside the split without the suspects (their statistics), and the indices
  // of the pieces that came from the suspects, inserted after the added vertices.
  std::optional<ConstraintStats> before_suspects;
  std::vector<std::uint32_t> suspects_after;
  std::vector<ConstraintPiece> suspect_pieces_after; // the pieces at suspects_after, when they moved
  if (screen_first) {
    screened = true;
    const std::size_t first_added = pslg.vertices.size();
    beside_device.wait();
    pieces_stale = false;
    trace.mark("pieces");
    ScreenedPieces screen;
#if defined(TRIXEL_HAVE_CUDA)
    // Most splits change nothing (10^7 points + 10^6 segments: none of 18K suspects cross): the device
    // inserts the constraints on a copy of the mesh while it screens the mesh and the host splits the
    // suspects, and the copy becomes the mesh unless the split changed the pieces.
    if (on_gpu && on_its_own()) {
      beside_split.start(*device_mesh, pieces, std::max(1u, options.inner_iterations), parallel);
      trace.mark("constraints started");
    }
    if (on_gpu) {
      screen = device_mesh->screen(pieces, parallel);
      // While the constraints run, the bus carries the output's rows they cannot change.
      if (beside_split.running() &&
          device_mesh->start_early_output(site_vertex, result.triangles, result.neighbors))
        trace.mark("output started");
    }
#endif
    if (!on_gpu) screen = screen_pieces(mesh.view(), pieces, executor);
    trace.mark("screened");
#if defined(TRIXEL_HAVE_CUDA)
    // When the split will change the pieces (the coastlines: sites on pieces, crossings), the run would
    // be undone after it: it starts again at once without the suspects, beside the split, and the
    // pieces made from the suspects are inserted after it. (Where the screen cannot tell, the run goes
    // on with every piece: most such splits change nothing, 10^7 points + 10^6 segments among them.)
    if (screen.complete && screen.changes &&
        beside_split.restart_without(screen.pieces, std::max(1u, options.inner_iterations)))
      trace.mark("constraints started again without the suspects");
#endif
    std::optional<std::vector<std::uint32_t>> new_pieces;
    PieceMoves moves;
    PieceMove* later = nullptr;
#if defined(TRIXEL_HAVE_CUDA)
    if (beside_split.running() && beside_split.without_suspects()) later = &piece_move;
#endif
    try {
      pieces_stale = split_screened(pslg, screen, site_vertex, options.crossings, executor, sites_magnitude,
                                    new_pieces, moves, later);
    } catch (const SplitNotConvergingError&) {
      // The suspects' crossings, rounded, kept crossing again among themselves: the whole input's split
      // (every piece in every round) may settle them, and says so when it does not.
#if defined(TRIXEL_HAVE_CUDA)
      if (beside_split.running()) beside_split.finish(false);
#endif
      return start_again(std::nullopt);
    }
    trace.mark("split");
    InsertStats placed;
    const std::size_t added = pslg.vertices.size() - first_added;
    // The pieces' move left to the caller starts at once (on the coastlines (H200 machine) it took 2.2
    // ms, and the constraints beside the split went on 2.3 ms after the split).
    if (piece_move.pending) {
      segment_of_piece.resize(piece_move.size);
      beside_move.start(
          [&] {
            const auto started = Clock::now();
            apply_piece_move(pslg.pieces, piece_move, 4);
            segments_of_pieces(pslg.pieces, segment_of_piece);
            move_microseconds =
                std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - started).count();
          },
          on_its_own());
      pieces_moving = true;
    }
#if defined(TRIXEL_HAVE_CUDA)
    if (beside_split.running() && beside_split.without_suspects()) {
      before_suspects = beside_split.finish(true);
      if (before_suspects) {
        // Its ids are the old pieces' indices.
        if (pieces_stale) device_mesh->renumber_constraints(moves.runs);
        suspects_after = pieces_stale ? std::move(moves.from_suspects) : std::move(screen.pieces);
        if (pieces_stale) suspect_pieces_after = std::move(moves.suspect_pieces);
      }
      trace.mark(before_suspects ? "constraints beside the split kept"
                                 : "constraints beside the split failed");
    } else if (beside_split.running() && (pieces_stale || added > 0)) {
      beside_split.finish(false);
      trace.mark("constraints beside the split undone");
    }
#endif
    // Every other reader of the pieces (here on, or the run started again) wants them moved: waited for
    // now unless the suspects' pieces go in after the others, beside the move.
    if (!before_suspects || added > kRestartAbovePerSite * n) beside_move.wait();
    if (added > kRestartAbovePerSite * n) {
      end_phase("split", 0, 0, added);
      return start_again(std::move(pslg));
    }
    if (added > 0) {
      const MissingArray fresh = added_vertices(pslg, first_added, site_vertex, site_of_vertex, executor,
                                                new_pieces ? &moves.came : nullptr);
      trace.mark("added vertices listed");
      // The new pieces in mesh ids while the device inserts the vertices (not needed when only the
      // suspects' are inserted after them).
      if (pieces_stale && !before_suspects) {
        beside_device.start(make_pieces, on_its_own());
        pieces_stale = false;
      }
      try {
#if defined(TRIXEL_HAVE_CUDA)
        if (on_gpu) {
          const auto first_fresh = fresh.empty() ? 0u : fresh.front().vertex;
          placed = insert_added_vertices(*device_mesh, pslg, fresh, site_vertex);
          // Into constraints inserted already, a vertex must not land on one.
          if (before_suspects) device_mesh->check_constraints_unsplit(first_fresh);
        }
#endif
        if (!on_gpu) placed = insert_added_vertices(mesh, pslg, fresh, site_vertex, executor);
      } catch (const DeviceError&) {
        throw;
      } catch (const Error&) {
        // A crossing vertex rounded out of the sites' hull (the exact crossing is inside it, but may be
        // within rounding of its boundary) cannot be inserted: split first, where it is a site.
        beside_device.wait();
        beside_move.wait();
        return start_again(std::nullopt);
      }
      beside_device.wait();
      trace.mark("added vertices");
    }
    end_phase("split", placed.rounds, placed.flips, pslg.vertices.size() - first_added);
  }
  stats.added_vertices = pslg.vertices.size() - points.size();

  // Step 2: constraints (pieces named by their index; seg holds the piece index).
  if (pieces_stale && !before_suspects) make_pieces();
  trace.mark("pieces");
  // The output's segment of each piece, while the device inserts the constraints (on threads of their
  // own: the constraints use the host's threads for their copies).
  if (!pieces_moving) {
    segment_of_piece.resize(pslg.pieces.size());
    beside_device.start([&] { segments_of_pieces(pslg.pieces, segment_of_piece); }, on_its_own());
  }
  ConstraintStats cons;
  // The slots the constraints' flips rewrote: after Phase 5, only their edges can fail the incircle test.
  std::vector<std::uint8_t> flipped;
  try {
#if defined(TRIXEL_HAVE_CUDA)
    // Inserted beside the split, unless that run failed (then inserted again here, to fail the same way).
    std::optional<ConstraintStats> done;
    if (before_suspects) {
      // The suspects' pieces, into the mesh that holds the others.
      std::vector<ConstraintPiece2> rest(suspects_after.size());
      for (std::size_t k = 0; k < rest.size(); ++k) {
        const ConstraintPiece& p =
            suspect_pieces_after.empty() ? pslg.pieces[suspects_after[k]] : suspect_pieces_after[k];
        rest[k] = {site_of_vertex[p.a], site_of_vertex[p.b], suspects_after[k]};
      }
      const ConstraintStats after =
          device_mesh->insert_constraints(rest, std::max(1u, options.inner_iterations), parallel, true);
      done = *before_suspects;
      done->flips += after.flips;
      done->outer_iterations += after.outer_iterations;
      done->inner_iterations += after.inner_iterations;
      done->intersections += after.intersections;
    } else if (beside_split.running()) {
      // The host's threads would only wait for the device here: the output's segment array is filled
      // now rather than beside the output's copies, where it slowed them.
      device_mesh->prefill_segments(pslg.pieces.size(), result.segment_of_edge, parallel);
      trace.mark("output's segments prefilled");
      done = beside_split.finish(true);
    }
    if (done)
      cons = *done;
    else if (on_gpu)
      cons = device_mesh->insert_constraints(pieces, std::max(1u, options.inner_iterations), parallel);
#endif
    if (!on_gpu) {
      flipped.assign(mesh.num_slots(), 0);
      cons = insert_constraints_one_by_one(mesh, pieces, executor, flipped.data());
    }
  } catch (const DeviceError&) {
    throw;
  } catch (const Error&) {
    // Insertion checks what splitting promised: no site on a piece, no two pieces crossing. Should
    // the screen have missed a pair (a crossing point rounded onto another piece, or a piece bent
    // through it across another), the whole input is split first instead; so too when this attempt
    // took its PSLG from a screened split (started again for the vertices that split added).
    if (!screened && !split_before) throw;
    beside_device.wait();
    beside_move.wait();
    return start_again(std::nullopt);
  }
  trace.mark("constraints");
  end_phase("constraints", cons.outer_iterations, cons.flips);

  // Step 3: Lawson flips to the CDT, from the triangles the constraints flipped.
  FlipStats flips;
#if defined(TRIXEL_HAVE_CUDA)
  if (on_gpu) flips = flip_stats(device_mesh->flip_after_constraints());
#endif
  if (!on_gpu) flips = flip_to_delaunay_in_parts(mesh, executor, flipped.data());
  end_phase("flip", flips.rounds, flips.flips);

  // Output in input numbering: live slots in order, links renumbered to triangle indices.
  trace.mark("flip");
  result.vertices = std::move(pslg.vertices);
  result.duplicate_of = std::move(pslg.duplicate_of);
  static_assert(kNone == kNoId);
  beside_device.wait();
  beside_move.wait();
  if (pieces_moving) trace.count("pieces' move and their segments beside, us", move_microseconds);
#if defined(TRIXEL_HAVE_CUDA)
  if (device_mesh) {
    // Made on the device and copied straight into the result; the mesh itself stays there.
    trace.mark("segment of piece");
    device_mesh->output(site_vertex, segment_of_piece, result.triangles, result.neighbors,
                        result.segment_of_edge, parallel);
    trace.mark("device output");
    device_mesh.reset();
    trace.mark("device mesh freed");
  }
#endif
  if (!on_gpu) {
    const MeshView view = mesh.view();
    const std::vector<std::uint32_t> live = executor.compact(
        view.num_slots, [&](std::size_t t) { return view.alive(static_cast<std::uint32_t>(t)); });
    std::vector<std::uint32_t> index_of_slot(view.num_slots, kNoId);
    executor.for_each(live.size(),
                      [&](std::size_t k) { index_of_slot[live[k]] = static_cast<std::uint32_t>(k); });
    result.triangles.resize(live.size());
    result.neighbors.resize(live.size());
    result.segment_of_edge.resize(live.size());
    executor.for_each(live.size(), [&](std::size_t out) {
      output_triangle(view, live[out], site_vertex.data(), index_of_slot.data(), segment_of_piece.data(),
                      result.triangles[out].data(), result.neighbors[out].data(),
                      result.segment_of_edge[out].data());
    });
  }
  timer.end("output");
  if (restart != nullptr) {
    stats.phases = add_phases(std::move(restart->phases), stats.phases);
    stats.attempts = restart->attempts + 1;
  }
  stats.total_milliseconds = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
  return result;
}

} // namespace

Triangulation triangulate(std::span<const Point> points, std::span<const Segment> segments,
                          const Options& options) {
  const bool on_gpu = use_gpu(options.backend);
  if (!on_gpu || options.backend == Backend::gpu)
    return triangulate_on(points, segments, options, on_gpu, Split::screened);
  // backend auto: a device that fails (out of memory, say, when other processes hold it) leaves the
  // work to the CPU executor, which gives the same result.
  try {
    return triangulate_on(points, segments, options, true, Split::screened);
  } catch (const DeviceError&) {
    return triangulate_on(points, segments, options, false, Split::screened);
  }
}

namespace detail {

Triangulation triangulate_splitting_first(std::span<const Point> points, std::span<const Segment> segments,
                                          const Options& options) {
  return triangulate_on(points, segments, options, false, Split::first);
}

} // namespace detail

} // namespace cdt
