#pragma once
// Public API of the constrained Delaunay triangulation engine (gCD: Qi, Cao and Tan, IEEE TVCG 2013).
//
// In: points and segments (index pairs). Out: a constrained Delaunay triangulation with neighbour
// links, constraint flags carrying their source segment, the duplicate-point map and statistics.
// This header needs the C++ standard library only; it never includes a CUDA header.

#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "cdt/errors.hpp"

namespace cdt {

/// A point in the plane. Coordinates must be finite.
struct Point {
  double x = 0.0;
  double y = 0.0;
  friend bool operator==(const Point&, const Point&) = default;
};

/// A constraint segment between two point indices (0-based, into the points given with it).
struct Segment {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  friend bool operator==(const Segment&, const Segment&) = default;
};

/// Sentinel for "no triangle" (a hull edge's missing neighbour) and "no segment" (an edge that is
/// not a constraint).
inline constexpr std::uint32_t kNone = 0xFFFFFFFFu;

/// Where the algorithm runs.
enum class Backend {
  automatic, ///< the GPU when a CUDA device is present, the CPU otherwise, and the CPU when the device
             ///< fails during the call (out of memory, say)
  cpu,       ///< the CPU executor (threads) for every phase
  gpu,       ///< the CUDA executor for every phase but the host's share of a few (see Statistics::backend);
             ///< an error when no device is present
};

/// What to do with input segments that cross each other in their interiors, and with zero-length
/// segments (from a point to itself or to a point at the same place).
enum class CrossingSegments {
  resolve, ///< split both at the intersection point (a new vertex after the input points); ignore
           ///< zero-length segments and count them in Statistics::zero_length_segments
  reject,  ///< throw CrossingSegmentsError naming both segments; InvalidInputError for zero length
};

/// Options of triangulate(). The defaults suit most inputs.
struct Options {
  Backend backend = Backend::automatic;
  /// Side m of the m x m grid of the digital Voronoi phase; 0 picks a power of two from the input size
  /// and the backend (a coarser one for the CPU executor, see Statistics::grid_size).
  std::uint32_t grid_size = 0;
  /// CPU executor threads; 0 uses every hardware thread.
  unsigned threads = 0;
  /// Inner-loop iterations of constraint insertion per outer iteration (Algorithm 4-5), at least 1. The
  /// GPU backend's; the CPU executor inserts the pieces one by one (Sloan's flipping) after one pass.
  unsigned inner_iterations = 8;
  CrossingSegments crossings = CrossingSegments::resolve;
};

/// Work and time of one phase of the algorithm.
struct PhaseStats {
  /// "prepare", "voronoi", "dualize", "shift", "insert", "delaunay" (Phase 5, Lawson flips to the
  /// Delaunay triangulation), "split" (CPU executor, with segments: segments split at points on them
  /// and at crossings; its missing points are the vertices added at crossings), "constraints", "flip"
  /// (Lawson flips to the CDT) or "output"
  std::string name;
  double milliseconds = 0.0;    ///< wall time (CPU) or CUDA-event time (GPU)
  std::uint64_t flips = 0;      ///< edge flips performed
  std::uint64_t missing = 0;    ///< points handled as missing points
  std::uint64_t iterations = 0; ///< parallel rounds
};

/// Statistics of one triangulate() call.
struct Statistics {
  std::string backend; ///< "cpu", or with the GPU backend "gpu (PHASES) + cpu" naming the device's phases
  std::uint32_t grid_size = 0;            ///< grid side actually used
  std::uint64_t added_vertices = 0;       ///< vertices added where crossing segments were split
  std::uint64_t zero_length_segments = 0; ///< input segments of zero length, ignored
  /// Times the mesh was made: 2 when the segments, split after the sites' mesh, added more vertices
  /// than there were sites (the mesh is then made again from all of them, faster than inserting them)
  /// or, rarely, when a crossing vertex could not be inserted. The phases sum both attempts.
  std::uint32_t attempts = 1;
  /// Inputs triangulated together in one call by triangulate_many() (1 for triangulate()); the grid,
  /// phases and times are then those of the whole call.
  std::uint32_t inputs = 1;
  double total_milliseconds = 0.0;
  std::vector<PhaseStats> phases;
};

namespace detail {
/// Arrays this large or larger may come from the pinned result memory (keep_pinned_results).
inline constexpr std::size_t kPinnedArrayBytes = std::size_t{16} << 20;
/// A block of at least `bytes` bytes of the pinned result memory when the calling thread is inside a
/// PinnedResultScope (cdt/src) and the memory is kept; nullptr otherwise. Never throws.
void* take_pinned_array(std::size_t bytes) noexcept;
/// Returns p to the pinned result memory when it came from there (true); false otherwise.
bool give_back_pinned_array(void* p) noexcept;
} // namespace detail

/// The allocator of Triangulation's per-triangle and per-point arrays. Growing such an array (resize) leaves
/// the new elements unwritten (default-initialised; for Point, whose members' initialisers would write
/// zeros, not even that): the triangulation writes every element itself, in parallel, and a zero fill
/// first would cost as much again at 10^7 elements. Construction with arguments (push_back, assign,
/// copies) behaves as with std::allocator.
///
/// Arrays of kPinnedArrayBytes or more may come from pinned host memory that the process keeps for the
/// GPU backend's results (keep_pinned_results); they go back to it when freed.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  [[nodiscard]] T* allocate(std::size_t n) {
    if (pinnable(n)) {
      if (void* p = detail::take_pinned_array(n * sizeof(T))) return static_cast<T*>(p);
    }
    return std::allocator<T>::allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (pinnable(n) && detail::give_back_pinned_array(p)) return;
    std::allocator<T>::deallocate(p, n);
  }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    // Point is an aggregate of two doubles (an implicit-lifetime type: the allocation holds its objects).
    if constexpr (!std::is_same_v<U, Point>) ::new (static_cast<void*>(p)) U;
  }

private:
  static constexpr bool pinnable(std::size_t n) noexcept {
    return n >= (detail::kPinnedArrayBytes + sizeof(T) - 1) / sizeof(T) && n <= SIZE_MAX / sizeof(T);
  }
};

/// One point per vertex, with the same allocator.
using PointArray = std::vector<Point, DefaultInitAllocator<Point>>;

/// Three 32-bit entries per triangle (vertices, neighbours or segments of its edges).
using TriangleArray =
    std::vector<std::array<std::uint32_t, 3>, DefaultInitAllocator<std::array<std::uint32_t, 3>>>;

/// One 32-bit index per element (per input point, its representative), with the same allocator.
using IndexArray = std::vector<std::uint32_t, DefaultInitAllocator<std::uint32_t>>;

/// A constrained Delaunay triangulation.
///
/// Triangle t has vertices triangles[t] in counter-clockwise order. Edge i of t joins
/// triangles[t][(i + 1) % 3] and triangles[t][(i + 2) % 3] (it is opposite vertex i);
/// neighbors[t][i] is the triangle across it or kNone on the hull, and segment_of_edge[t][i] the input
/// segment the edge lies on, or kNone when it is not a constraint.
struct Triangulation {
  /// The input points at their input indices, then vertices added where crossing segments were split.
  PointArray vertices;
  TriangleArray triangles;
  TriangleArray neighbors;
  TriangleArray segment_of_edge;
  /// duplicate_of[i] is the vertex that input point i was merged into (i itself when it is not a
  /// duplicate). Only such representatives appear in triangles.
  IndexArray duplicate_of;
  Statistics stats;
};

/// Puts t in an order that depends on its triangle set alone: the vertices added at crossings are
/// numbered by their coordinates (lexicographic order, after the input points), each triangle starts at
/// its lowest vertex, and the triangles are sorted by their vertices; neighbours follow. The CDT
/// triangulate() returns is unique (ties among co-circular points are broken by one symbolic
/// perturbation), but each backend and schedule lists it in an order of its own; after this call two
/// results for the same input are equal array for array, whichever backend, grid or thread count made
/// them. O(n) for n triangles, plus a sort of the added vertices.
void canonicalize(Triangulation& t);

/// Number of CUDA devices Backend::gpu can use: 0 when there is none, or the library was built
/// without CUDA. Never throws.
int gpu_device_count() noexcept;

/// Starts CUDA in the process before the first triangulation needs it: creates the device's context,
/// loads the kernels a small input uses by triangulating a small fixed PSLG there, and sets aside the
/// memory that the first triangulations of a few hundred thousand points each would otherwise allocate
/// on the way (pinned host memory for their copies and device memory kept for reuse, about 300 MB in
/// all; the start-up costs 0.3-0.4 s on the H200 machine). A program about to run many
/// triangulations on the device can call it on a side thread as it begins, so that its first
/// triangulations (with several threads, each thread's first one) do not wait for the start-up.
/// Returns false, and does nothing else, without a device; never throws (a device that fails here
/// fails again, with its error, in triangulate()).
bool start_gpu() noexcept;

/// Gives back what the process holds on the device (pinned host memory, device memory kept for reuse,
/// the device's context), which the driver otherwise frees at the process's exit. A program done with
/// the device can call it while it finishes other work, on a side thread, so that less of that is
/// left for its exit (a batch of photographs on the H200 machine: its process ended 163-169 ms after
/// its last image, 95-124 ms with the device given back during the last images). No triangulation
/// on the device may be running meanwhile; a later one starts CUDA again. Does nothing without a
/// device; never throws.
void stop_gpu() noexcept;

/// Makes freed memory stay in the process for reuse (glibc's allocator: no block is mapped on its own,
/// the heap is not trimmed). Without it every array larger than 32 MiB is mapped when allocated and
/// unmapped when freed, so each comes back as fresh pages whose first touch, at 10^7 points, costs
/// as much as the work done in them; with it later phases and later calls reuse the pages of earlier
/// ones. Process-wide and for the process's lifetime, so it is the program's choice, not the
/// library's: the cdt command and the benchmarks call it first thing. Returns false where the C
/// library does not support it (nothing changes then).
///
/// huge_page_bytes > 0 also grows the heap by that much address space (nothing in it is touched, so
/// it costs no memory) and advises the kernel to back it with transparent huge pages: arrays later
/// carved from it fault in 2 MiB at a time instead of 4 KiB (10^7 points and 10^6 segments on the GPU
/// backend: a fifth less time, most of it in the host's copies). It takes effect where the kernel's THP
/// setting is "madvise" or "always"; the result is false when the advice was refused (the memory
/// policy above still holds then).
bool retain_freed_memory(std::size_t huge_page_bytes = 0) noexcept;

/// Keeps up to `max_bytes` of pinned (page-locked) host memory for the GPU backend's results, so that
/// the device writes a large triangulation's triangles, neighbours and segments straight into the
/// Triangulation's arrays at the bus's speed rather than through staging blocks and a copy on the host
/// (10M points + 1M segments: 720 MB). Pinning costs as much as that copy, about 25 ms per GB, so it
/// pays from the second large triangulation on: arrays of 16 MiB or more (results of about 700K points
/// or more) come from blocks pinned when first needed and return to them when freed, for the next
/// result of the same size or up to twice smaller. Blocks that no longer fit are unpinned to make room.
/// Into such arrays the device also starts the output early, while it inserts the segments: the rows
/// they cannot change go first (the triangles' order in the result then differs from the one without
/// pinned memory; the triangulation is the same). For programs that triangulate large inputs one after
/// another; the cdt command, one input per process, does not call it. Freeing a Triangulation from the kept
/// memory, after stop_gpu() too, is like freeing any other. 0 gives the free blocks back and keeps none from
/// then on. Makes no CUDA call unless it unpins blocks kept before (a process may fork after its first call).
/// Returns false, and does nothing, where the library was built without CUDA. Programs built against a copy
/// of this header from before this function must be rebuilt (the arrays' allocator gives the blocks back).
bool keep_pinned_results(std::size_t max_bytes) noexcept;

/// Computes the constrained Delaunay triangulation of the points and segments.
///
/// The result is unique: among co-circular points the tie is broken by a symbolic perturbation (each
/// point's lift raised by an infinitesimal that is larger for points earlier in lexicographic order),
/// so every backend, grid size and thread count gives the same triangles, listed in an order of its
/// own (canonicalize() makes the lists equal too).
///
/// Duplicate points are merged (see Triangulation::duplicate_of), points lying on a segment split it,
/// overlapping collinear segments are merged, and crossing segments are split at their intersection
/// (CrossingSegments::resolve) or reported (CrossingSegments::reject). Throws InvalidInputError for
/// non-finite coordinates, coordinates beyond +-1e60 or, other than 0, below 1e-60 in magnitude (the
/// exact predicates' products would overflow or underflow), out-of-range indices, degenerate segments, fewer
/// than three distinct points or all points collinear; CrossingSegmentsError under the reject policy;
/// DeviceError when Backend::gpu is asked for and cannot be used.
Triangulation triangulate(std::span<const Point> points, std::span<const Segment> segments,
                          const Options& options = {});

/// One input of triangulate_many().
struct Input {
  std::span<const Point> points;
  std::span<const Segment> segments;
};

/// What triangulate_many() gives for one input: its triangulation, or the error triangulate() throws
/// for it (then the triangulation is empty).
struct ManyResult {
  Triangulation triangulation;
  std::exception_ptr error;
};

/// Triangulates each input as triangulate() does (the same triangles; after canonicalize() the same
/// arrays; the same error for a bad input), in fewer calls. Inputs framed by their segments (every point
/// within the input's bounding box and the box's four sides covered by segments, as in a PSLG with
/// its image border) are placed side by side, apart, translated by whole numbers, and triangulated in
/// one call: a framed input's constrained Delaunay triangles are the same with other inputs outside its
/// frame, so the triangles of the whole are cut back into one triangulation per input. The fixed costs
/// of a call (on the GPU, the launches and waits of every round) are paid once for all of them. Any
/// other input is triangulated on its own, and so is one whose coordinates would not translate exactly,
/// one that gains vertices at crossings (their rounding depends on where they are), or, when the call
/// of the whole fails, each input of it (so that an error names its own input). Statistics::inputs
/// says how many were triangulated together. Results are in the order of `inputs`.
std::vector<ManyResult> triangulate_many(std::span<const Input> inputs, const Options& options = {});

} // namespace cdt
