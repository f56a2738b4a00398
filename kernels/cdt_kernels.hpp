#pragma once
// Host-callable entry points of the CUDA code. This header includes no CUDA header, so cdt and the
// tests can include it from plain C++.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cdt/cdt.hpp"

namespace cdt::detail {
struct Mesh;             // cdt/src/gcd/mesh.hpp
struct Box;              // cdt/src/box.hpp
struct GridMapping;      // cdt/src/gcd/grid_map.hpp
struct MissingPoint;     // cdt/src/gcd/shift.hpp
struct ShiftStats;       // cdt/src/gcd/shift.hpp
struct InsertStats;      // cdt/src/gcd/insert.hpp
struct ConstraintPiece2; // cdt/src/gcd/constraints.hpp
struct ConstraintStats;  // cdt/src/gcd/constraints.hpp
struct ScreenedPieces;   // cdt/src/gcd/screen.hpp
struct ConstraintPiece;  // cdt/src/pslg.hpp
struct PieceRun;         // cdt/src/pslg.hpp
using PieceArray = std::vector<ConstraintPiece, DefaultInitAllocator<ConstraintPiece>>; // as in pslg.hpp
using MissingArray = std::vector<MissingPoint, DefaultInitAllocator<MissingPoint>>;     // as in shift.hpp
using FlagArray = std::vector<std::uint8_t, DefaultInitAllocator<std::uint8_t>>;        // as in dualize.hpp
} // namespace cdt::detail

namespace cdt::gpu {

class DeviceMesh;

/// Runs body(part) for every part in [0, parts), on host threads where it has them (the CPU
/// executor's for_each_part): large copies out of the device spread their host side over it.
using HostParallelFor = std::function<void(std::size_t parts, const std::function<void(std::size_t)>& body)>;

/// Number of CUDA devices this process can use; 0 without a device or driver. Never throws.
int device_count() noexcept;

/// "NAME (compute capability X.Y, N SMs, M MiB)" for device 0; throws DeviceError without a device.
std::string device_description();

/// Sets memory aside for the process's later triangulations on the device, so that the first of them
/// do not pay for it: `staging_blocks` pinned host blocks for staging copies (pinning costs
/// milliseconds per megabyte, and holds the driver's lock, stalling other threads' device work
/// meanwhile), and `device_bytes` of device memory, allocated from the buffer pool and given back to
/// it, which keeps it. Throws DeviceError.
void reserve_memory(std::size_t staging_blocks, std::size_t device_bytes);

/// Gives back everything the process holds on its devices: the pinned staging blocks, the buffer
/// pools and the devices' contexts (cudaDeviceReset), which the driver would otherwise tear down at
/// the process's exit. Only when no triangulation is running on the device; a later one starts CUDA
/// again. Never throws.
void release_device() noexcept;

/// The pinned result memory (cdt::keep_pinned_results): blocks of pinned host memory, up to `bytes` in
/// all, that large result arrays are carved from; 0 unpins and frees the free blocks and keeps none.
void set_result_blocks_limit(std::size_t bytes) noexcept;

/// A free pinned block of at least `bytes` (and at most twice that), pinned now when none is free and
/// the limit leaves room (unpinning free blocks that do not fit to make it); nullptr when the memory is
/// not kept, there is no room or pinning failed. Never throws.
void* take_result_block(std::size_t bytes) noexcept;

/// Whether [p, p + bytes) lies in a block of the pinned result memory in use: the device writes there
/// at the bus's speed, with no staging.
bool in_result_block(const void* p, std::size_t bytes) noexcept;

/// The outputs started early (DeviceMesh::start_early_output) in this process so far: their rows sent
/// while the constraints ran, and of those the rows sent again at the end because they had changed.
struct EarlyOutputRows {
  std::uint64_t sent = 0;
  std::uint64_t again = 0;
};
EarlyOutputRows early_output_rows() noexcept;

/// Marks p's block free again when p is one (true; a block whose pinning stop_gpu undid is freed);
/// false when p is no block of the result memory.
bool give_back_result_block(void* p) noexcept;

/// Synchronise after every launch so a fault shows at the launch that caused it (slow; for debugging).
/// Also turned on by the environment variable TRIXEL_CUDA_SYNC=1.
void set_debug_sync(bool on) noexcept;

/// With TRIXEL_CUDA_PROFILE=1, prints the time of each kind of device step since the last call (each
/// step waited for, so that its time is its own) to stderr under `heading` and starts a new table;
/// nothing otherwise.
void print_profile(const char* heading);

/// Signs of orient2d for num queries on the device; coords holds ax ay bx by cx cy per query (6 * num
/// doubles), signs receives num values in {-1, 0, 1}. Throws DeviceError on any CUDA failure.
void orient2d_signs(const double* coords, int* signs, std::size_t num);

/// Signs of incircle for num queries on the device; coords holds ax ay bx by cx cy dx dy per query
/// (8 * num doubles). Throws DeviceError on any CUDA failure.
void incircle_signs(const double* coords, int* signs, std::size_t num);

/// Bytes of local memory (stack) a thread of incircle_signs' kernel takes, exact fallback included:
/// the driver reserves that much for every thread the device can hold once a kernel with the
/// fallback runs (the flips' proposal has the same code). Throws DeviceError on any CUDA failure.
std::size_t incircle_local_bytes();

// --- Phase 1 of gCD on the device, first half: the sites, their order and grid cells ------------------

/// The sites of Phase 1 prepared on the device: what cdt::triangulate does on the host before the
/// digital Voronoi diagram, step for step, so with the same result. The distinct vertices are
/// renumbered 0..n-1 in the Z order of their grid cells (ties in vertex order), each is given its grid
/// cell, the lowest-numbered site of a cell is kept there (at its grid point) and the others are
/// missing points. The positions and grid cells stay on the device for the diagram (DeviceVoronoi),
/// the dual and shifting; the host gets only the numbering, the kept flags and the missing points.
class DeviceSites {
public:
  /// vertices: the PSLG's vertices (finite coordinates); sites: the distinct ones (vertex ids,
  /// increasing, at least one); m: the grid side, in [1, 32768]. Fills the host's results: the
  /// grid mapping of the sites (cdt::detail::make_grid_mapping); the box of every site's positions,
  /// true and in the diagram; site_vertex (per site, its vertex), site_of_vertex (per vertex, its site
  /// or kNoId), kept (per site, 1 when it is kept) and the missing points (increasing, each with its
  /// cell's kept site as hint). The copies' host side runs on `parallel` when given. Throws
  /// DeviceError when the device lacks the memory or CUDA fails.
  DeviceSites(std::span<const Point> vertices, std::span<const std::uint32_t> sites, std::uint32_t m,
              ::cdt::detail::GridMapping& mapping, ::cdt::detail::Box& bounds, IndexArray& site_vertex,
              IndexArray& site_of_vertex, ::cdt::detail::FlagArray& kept,
              ::cdt::detail::MissingArray& missing, const HostParallelFor& parallel = {});
  /// The same in two steps, from the input: this constructor uploads the points and merges their
  /// duplicates on the device, filling duplicate_of (per point the lowest index with identical
  /// coordinates, -0 equal to +0), sites (the points that are their own, increasing) and the pieces
  /// (the segments between representatives, zero-length ones left out, each pair once with its lowest
  /// segment id, sorted by (a, b)) as the host's merge does (cdt::detail::merge_input); prepare() then
  /// does the rest from the points and sites already on the device. The input checks come first, on the
  /// device: the InvalidInputError of the host's checks for the same point or segment (zero-length
  /// segments are errors unless `policy` is resolve; their number goes to zero_length_segments). With
  /// identity_unwritten given and no two points coinciding, duplicate_of and sites (the identity) are
  /// sized but not written, and *identity_unwritten is set (cdt::detail::InputMerge). Large arrays
  /// come down on a thread of their own, started by prepare(): call finish_downloads() before reading
  /// them.
  DeviceSites(std::span<const Point> points, std::span<const Segment> segments, CrossingSegments policy,
              IndexArray& duplicate_of, IndexArray& sites, ::cdt::detail::PieceArray& pieces,
              std::size_t& zero_length_segments, const HostParallelFor& parallel = {},
              bool* identity_unwritten = nullptr);
  /// Where prepare() puts the missing points: in the host's list, or on the device, where
  /// DeviceMesh::take_missing takes them for its insert() (the host's list is then left empty, with
  /// room for the points appended later, and missing_on_device() is their number).
  enum class MissingTo { host, device };
  void prepare(std::uint32_t m, ::cdt::detail::GridMapping& mapping, ::cdt::detail::Box& bounds,
               IndexArray& site_vertex, IndexArray& site_of_vertex, ::cdt::detail::FlagArray& kept,
               ::cdt::detail::MissingArray& missing, const HostParallelFor& parallel = {},
               MissingTo missing_to = MissingTo::host);
  /// The missing points prepare() left on the device and no mesh has taken yet (0 when none).
  std::size_t missing_on_device() const;
  /// prepare() fills site_vertex and site_of_vertex on a thread of its own, after it returns, and the
  /// merge's duplicate_of, sites and pieces with them: waits for them all (starting the merge's copies
  /// if prepare() has not; throws DeviceError should a copy have failed). Call before reading them;
  /// the destructor waits for copies started.
  void finish_downloads();
  /// The largest absolute coordinate of the sites (after prepare): what the split's snap tolerance
  /// is made from (cdt::detail::split_pieces), known here without a pass over the vertices.
  double magnitude() const;
  ~DeviceSites();
  DeviceSites(DeviceSites&&) noexcept;
  DeviceSites& operator=(DeviceSites&&) noexcept;

  /// Moves the given sites (left out of the diagram) to their true positions in the diagram's
  /// positions, as missing points are, and clears their kept flag on the device.
  void leave_out(std::span<const std::uint32_t> sites);

  /// Copies the sites' positions in the diagram to the host (kept sites at their grid points, the
  /// others at their true positions), and their true positions when asked for (vectors replaced).
  void positions(std::vector<double>& x, std::vector<double>& y, std::vector<double>* true_x = nullptr,
                 std::vector<double>* true_y = nullptr, const HostParallelFor& parallel = {}) const;

  struct State; ///< device buffers (defined by the CUDA code)
  State& state() { return *state_; }
  const State& state() const { return *state_; }

private:
  std::unique_ptr<State> state_;
};

/// Device memory that DeviceSites needs for num_vertices vertices, num_sites sites and an m x m grid.
std::size_t sites_device_bytes(std::size_t num_vertices, std::size_t num_sites, std::uint32_t m);

// --- Phase 1 of gCD on the device: the digital Voronoi diagram (paper section 3.1, Appendix A) ---------

/// Options of compute_digital_voronoi on the device. The defaults suit every grid size.
struct VoronoiOptions {
  /// true: the Standard-flooding colouring (Algorithm A.1), as triangulation needs; false: the
  /// Euclidean colouring of the Parallel Banding Algorithm alone (Definition 1).
  bool amend = true;
  /// Bands of rows of PBA's phase 1 and bands of columns of its phases 2 and 3; 0 picks them from m.
  /// Every count in [1, m] gives the same colouring (tests vary them to exercise the band merging).
  std::uint32_t row_bands = 0;
  std::uint32_t col_bands = 0;
  /// Device memory the call may use, in bytes; 0: whatever the device has free. An input that needs
  /// more fails with DeviceError before anything is allocated.
  std::size_t memory_limit = 0;
};

/// What the device computation found and did.
struct VoronoiStats {
  std::uint64_t orphans = 0;       ///< cells cut off from their site next to them (Appendix A)
  std::uint64_t debris = 0;        ///< orphans and the cells reachable only through them: recoloured
  std::uint32_t debris_rounds = 0; ///< rounds of the worklist that grows orphans into debris
  std::uint32_t flood_rounds = 0;  ///< rounds of the flood until no debris cell changed colour
  std::size_t device_bytes = 0;    ///< the estimate checked against the memory available
  /// Device time of the steps in milliseconds (CUDA events): copies to the device and the input
  /// check, PBA, the amendment (orphans, debris, flood; with amend false: the owners' lookup), the
  /// copy of the colouring back.
  float upload_ms = 0, pba_ms = 0, amend_ms = 0, download_ms = 0;
};

/// Device memory that compute_digital_voronoi needs for an m x m grid and num_points points, in bytes
/// (the buffers of every step, CUB's scratch, and a margin for the debris worklist).
std::size_t voronoi_device_bytes(std::uint32_t m, std::size_t num_points, const VoronoiOptions& options = {});

/// The digital Voronoi diagram on the device, the same colouring as the CPU executor's
/// cdt::detail::compute_digital_voronoi (or compute_euclidean_colouring with options.amend false):
/// colour[gy*m+gx] = the kept point nearest to grid point (gx, gy), ties to the smaller index, amended
/// so that every region is 4-connected to its site; kNone everywhere when no cell is occupied.
/// cell_owner: m * m point indices or kNone, row-major (GridSites::cell_owner); site_x, site_y: the grid
/// cell of every point (GridSites::gx, gy), each owner sitting in its own cell. 1 <= m <= 32768.
/// Throws Error for inconsistent input (sizes, an owner out of range or not in its cell) and
/// DeviceError when there is no device, the input does not fit in device memory, or CUDA fails.
std::vector<std::uint32_t> compute_digital_voronoi(std::span<const std::uint32_t> cell_owner,
                                                   std::span<const std::uint32_t> site_x,
                                                   std::span<const std::uint32_t> site_y, std::uint32_t m,
                                                   const VoronoiOptions& options = {},
                                                   VoronoiStats* stats = nullptr);

// --- Phase 2 on the device: the dual triangles of the diagram, linked (paper section 3.2) ------------

/// What the device's dualization did.
struct DualStats {
  std::uint64_t dual_triangles = 0;
  std::size_t device_bytes = 0; ///< the estimate checked against the memory available
  /// Device time in milliseconds: the sites' upload and the corners' triangles, their order and links,
  /// the copy of the mesh back.
  float triangles_ms = 0, link_ms = 0, download_ms = 0;
};

/// The digital Voronoi diagram computed on the device and kept there for the next phase, which then
/// reads the colouring without a round trip through host memory. Construction computes what
/// compute_digital_voronoi does, with the same arguments and errors.
class DeviceVoronoi {
public:
  DeviceVoronoi(std::span<const std::uint32_t> cell_owner, std::span<const std::uint32_t> site_x,
                std::span<const std::uint32_t> site_y, std::uint32_t m, const VoronoiOptions& options = {},
                VoronoiStats* stats = nullptr);
  /// The same from sites prepared on the device, whose grid cells it takes over (`sites` keeps its
  /// positions, for complete_dual and DeviceMesh::shift).
  explicit DeviceVoronoi(DeviceSites& sites, const VoronoiOptions& options = {},
                         VoronoiStats* stats = nullptr);
  ~DeviceVoronoi();
  DeviceVoronoi(DeviceVoronoi&&) noexcept;
  DeviceVoronoi& operator=(DeviceVoronoi&&) noexcept;

  /// The colouring, copied to the host (compute_digital_voronoi's result); download_ms receives the
  /// copy's device time when given.
  std::vector<std::uint32_t> colour(float* download_ms = nullptr) const;

  /// What dual() made of the diagram.
  enum class DualOutcome {
    built,      ///< the mesh holds the dual triangles, linked
    degenerate, ///< degenerate corners: the sites to take out of the diagram are listed
    declined,   ///< no mesh: the CPU executor's dualize must handle this colouring
  };

  /// The first half of cdt::detail::dualize on the device: the triangles of every 3- and 4-colour grid
  /// corner, in the CPU executor's slot order (by lowest vertex, then row-major corner order), linked,
  /// vert_tri the highest incident slot. mesh.x, mesh.y hold the n sites' positions (kept sites at their
  /// grid points) and stay as they are; tri, adj, seg and vert_tri are replaced (left empty unless
  /// built). A corner whose triangle would not be counter-clockwise (three collinear sites) makes it
  /// list in `degenerate` the sites dualize would list (sorted, distinct), or decline without that
  /// list; an empty dual or one whose edges do not pair up is declined.
  DualOutcome dual(::cdt::detail::Mesh& mesh, DualStats* stats = nullptr,
                   std::vector<std::uint32_t>* degenerate = nullptr);

  /// dual() and then cdt::detail::complete_dual without the mesh leaving the device: only the dual's
  /// open edges come to the host, where the hull completion and the fake boundary are planned
  /// (cdt::detail::plan_dual_completion); the added triangles, their links and the fake vertices go
  /// back up. When built, `out` holds the completed mesh, slot for slot the one complete_dual gives,
  /// and site_vert_tri the n sites' vert_tri (kNoId for the sites the dual does not reach). Also
  /// declined when the dual's boundary is not one simple cycle (complete_dual then starts from the
  /// fake polygon alone). mesh.x, mesh.y hold the n sites as for dual(); the other arrays are left empty.
  DualOutcome complete_dual(::cdt::detail::Mesh& mesh, const ::cdt::detail::Box& bounds,
                            std::optional<DeviceMesh>& out, std::vector<std::uint32_t>& site_vert_tri,
                            std::vector<std::uint32_t>* degenerate = nullptr);

  /// complete_dual with the n sites' positions and kept flags read from `sites` on the device. Instead
  /// of the sites' vert_tri, `unreached` receives the kept sites the dual does not reach (increasing),
  /// and a site not kept that the dual reaches is an Error (check_missing_sites_left_out).
  DualOutcome complete_dual(const DeviceSites& sites, const ::cdt::detail::Box& bounds,
                            std::optional<DeviceMesh>& out, std::vector<std::uint32_t>& unreached,
                            std::vector<std::uint32_t>* degenerate = nullptr);

  /// cdt::detail::remove_sites_from_colouring on the device, with the same result: the regions of the
  /// `removed` sites (sorted, distinct) are cleared there, and only the cleared cells with their
  /// neighbours' colours come to the host for the flood (cdt::detail::flood_cleared_cells), whose
  /// colours go back. Returns per removed site the site now owning its grid cell (kNone if none).
  std::vector<std::uint32_t> remove_sites(std::span<const std::uint32_t> removed);

  /// The sites' grid cells it was made from (site_x, site_y, or those taken from DeviceSites), copied
  /// to the host (vectors replaced).
  void site_cells(std::vector<std::uint32_t>& gx, std::vector<std::uint32_t>& gy,
                  const HostParallelFor& parallel = {}) const;

  struct State; ///< device buffers and stream (defined by the CUDA code)

private:
  std::unique_ptr<State> state_;
};

// --- Phase 5 and Step 3 on the device: Lawson flips to the (constrained) Delaunay triangulation --------

/// What the device's flipping did.
struct FlipResult {
  std::uint64_t flips = 0;
  std::uint64_t rounds = 0;
  std::size_t device_bytes = 0; ///< the estimate checked against the memory available
  /// Milliseconds: the copies to and from the device (wall time; 0 for DeviceMesh::flip) and the flips
  /// (device time).
  float upload_ms = 0, flip_ms = 0, download_ms = 0;
};

/// cdt::detail::flip_to_delaunay on the device, round for round the same (so the same result): the
/// mesh is copied to the device, flipped there and copied back in place. Throws Error when the links
/// are inconsistent and DeviceError when the mesh does not fit in device memory or CUDA fails.
FlipResult flip_to_delaunay(::cdt::detail::Mesh& mesh);

// --- Phases 3 to 6 on a mesh that stays on the device --------------------------------------------------

/// A triangle mesh (cdt::detail::Mesh) held in device memory, on which the later phases run one after
/// the other without copying it back: shifting (Phase 3), missing points and the fake boundary's
/// removal (Phase 4), constraints (Step 2) and Lawson flips (Phase 6). Each step runs the CPU executor's
/// driver step for step on the CUDA executor, from the same per-element code, so the mesh is the same slot
/// for slot. Steps throw Error when the mesh breaks a precondition (as the CPU executor's do) and DeviceError
/// when CUDA fails or the device lacks the memory.
class DeviceMesh {
public:
  /// Copies the mesh to the device.
  explicit DeviceMesh(const ::cdt::detail::Mesh& mesh);
  struct State; ///< device buffers and stream (defined by the CUDA code)
  /// Takes over a mesh already on the device (the CUDA code builds one in DeviceVoronoi::complete_dual).
  explicit DeviceMesh(std::unique_ptr<State> state);
  ~DeviceMesh();
  DeviceMesh(DeviceMesh&&) noexcept;
  DeviceMesh& operator=(DeviceMesh&&) noexcept;

  /// cdt::detail::shift_to_true_positions: the bad cases are appended to `missing` in the same order.
  ::cdt::detail::ShiftStats shift(std::uint32_t num_sites, std::span<const double> true_x,
                                  std::span<const double> true_y, ::cdt::detail::MissingArray& missing);

  /// The same with the sites' true positions read from `sites` on the device.
  ::cdt::detail::ShiftStats shift(std::uint32_t num_sites, const DeviceSites& sites,
                                  ::cdt::detail::MissingArray& missing);

  /// Appends vertices at (x[k], y[k]) after the mesh's own, in no triangle yet (vert_tri kNoId), for
  /// insert() to place.
  void add_vertices(std::span<const double> x, std::span<const double> y);

  /// Takes over the missing points that `sites` left on the device (DeviceSites::MissingTo::device;
  /// none otherwise): the next insert() inserts them first, before its host list.
  void take_missing(DeviceSites& sites);

  /// cdt::detail::insert_missing_points (the mesh grows on the device when free slots are short) of
  /// the points take_missing took (then no longer held) followed by `missing`: one list, in that
  /// order. The host list's upload is spread over `parallel`.
  ::cdt::detail::InsertStats insert(std::span<const ::cdt::detail::MissingPoint> missing,
                                    const HostParallelFor& parallel = {});

  /// cdt::detail::flip_fake_fans: the fake vertices' fans made convex chains before their removal.
  FlipResult flip_fake_fans(std::uint32_t first_fake);

  /// The host's part of the fake boundary's removal (cdt::detail::delete_fake_vertices): the fake
  /// vertices' fans numbered locally, the first local fake vertex, and each local vertex's id in the mesh.
  using RemoveOnHost = std::function<void(::cdt::detail::Mesh& fans, std::uint32_t first_fake,
                                          std::span<const std::uint32_t> ranked_as)>;

  /// cdt::detail::remove_fake_boundary: the fake vertices leave, the slots are compacted in the order
  /// of their lowest vertex. The fake vertices' fans are numbered locally and copied to the host, which
  /// deletes the fake vertices (remove_on_host), and the result is written back: the fans are few
  /// triangles, but walking them is serial work.
  void remove_fake_boundary(std::uint32_t first_fake, const RemoveOnHost& remove_on_host);

  /// cdt::detail::screen_pieces on the device, the same result: the pieces (mesh vertex ids; the id
  /// field is ignored) that are no edges of the mesh, the edge-pieces they cross and the sites near
  /// them. Reads the mesh only; only the suspects' indices come back to the host. The pieces' upload is
  /// spread over `parallel` (as are the other large copies).
  ::cdt::detail::ScreenedPieces screen(std::span<const ::cdt::detail::ConstraintPiece2> pieces,
                                       const HostParallelFor& parallel = {});

  /// Starts output() early, while the constraints run beside the host: the rows of the slots that
  /// the last screen() found away from every corridor (no piece crosses them or a neighbour) are made
  /// now, numbered first, and copied straight into `triangles` and `neighbors` (their room, not their
  /// size) while the device inserts the constraints; output() then makes and sends the other rows, and
  /// of the early ones only those that changed after all (the last flips reach past the corridors now
  /// and then; a split adds vertices). vertex_of as output()'s, of which the entries the device does
  /// not hold already are uploaded. Only into pinned result memory (keep_pinned_results) with room for
  /// every slot, for meshes whose output is made in parts; returns whether it started. The arrays must
  /// keep their memory until output(), which must be given them; a slot that dies meanwhile (none
  /// does after the fake boundary is gone) makes output() send every row again.
  bool start_early_output(std::span<const std::uint32_t> vertex_of, TriangleArray& triangles,
                          TriangleArray& neighbors);

  /// cdt::detail::insert_constraints (Step 2, Algorithms 4 and 5), with the same hang guard. Keeps on
  /// the device which slots its flips rewrote, for flip_after_constraints().
  /// With `more`, the pieces are added to constraints already in the mesh (a run beside the host that
  /// left some out, then restart_constraints' renumbering and added vertices): the slots rewritten since
  /// then (by that run, by the last insert() and by these flips) are what flip_after_constraints checks.
  ::cdt::detail::ConstraintStats insert_constraints(std::span<const ::cdt::detail::ConstraintPiece2> pieces,
                                                    unsigned inner_iterations,
                                                    const HostParallelFor& parallel = {}, bool more = false);

  /// insert_constraints started on a thread of its own, on a copy of the mesh's links, while the
  /// caller goes on: for the host's split of the suspects, which on most inputs changes nothing, and
  /// the screen before it, which reads the mesh itself meanwhile (and takes the pieces uploaded here,
  /// which must be its own). `pieces` must stay alive and unchanged until finish_constraints. Returns
  /// false, starting nothing, when there are no pieces or the device lacks the memory for the copy, the
  /// constraints' buffers and a screen's, or the host a thread. Until finish_constraints the mesh may
  /// only be screened.
  bool start_constraints(std::span<const ::cdt::detail::ConstraintPiece2> pieces, unsigned inner_iterations,
                         const HostParallelFor& parallel = {});

  /// Ends what start_constraints started. With keep, waits for it and returns its statistics, as
  /// insert_constraints would have, the copy now the mesh; without, stops it at its next step. Returns
  /// nothing, the mesh as it was, when not kept or when the run failed with Error or DeviceError (the
  /// caller inserts the pieces it has then and meets any such error itself).
  std::optional<::cdt::detail::ConstraintStats> finish_constraints(bool keep);

  /// Stops what start_constraints started and starts the same pieces again beside the host but those
  /// listed in `skip` (indices, increasing: the screen's suspects, when it says the split will change
  /// them), on a fresh copy of the links; each id in the mesh is then an index into start_constraints'
  /// pieces (renumber_constraints maps them through the split). Returns false, nothing running, when
  /// it cannot be started.
  bool restart_constraints(std::span<const std::uint32_t> skip, unsigned inner_iterations);

  /// After the split moved the pieces (split_pieces' runs): every constraint id in the mesh becomes its
  /// piece's new index. Throws Error for an id in no run (a piece the split took away).
  void renumber_constraints(std::span<const ::cdt::detail::PieceRun> runs);

  /// Throws Error when a vertex from `first` on lies inside a constraint edge that it split (insert()
  /// places a point on an edge by splitting it, which a constraint must not be).
  void check_constraints_unsplit(std::uint32_t first);

  /// cdt::detail::flip_to_delaunay (constraint edges never flip); upload_ms and download_ms stay 0.
  FlipResult flip();

  /// The same checking at first only the triangles the last insert() split or made: what restores the
  /// Delaunay property after points were inserted into a Delaunay mesh.
  FlipResult flip_after_insert();

  /// Step 3 after Phase 5: cdt::detail::flip_to_delaunay checking at first only the slots that the last
  /// insert_constraints flipped (none when it was not called).
  FlipResult flip_after_constraints();

  /// Takes over the sites' vertex ids (the site_vertex that `sites` gave the host), so that output()
  /// uploads only the entries the host appended after them (10^7 sites: 40 MB not sent again).
  void take_vertex_ids(DeviceSites& sites);

  /// Takes over the merge's pieces in mesh ids that `sites` made on the device (none when the merge was
  /// the host's), for start_constraints, which then uploads nothing: they must be the pieces the host
  /// gives it, made from the same PSLG (cdt::triangulate's mesh_pieces before any split).
  void take_pieces(DeviceSites& sites);

  /// Copies the mesh back into `mesh` (every array replaced).
  void download(::cdt::detail::Mesh& mesh) const;

  /// cdt::Triangulation's triangles, neighbors and segment_of_edge, made on the device from the live
  /// slots in order (cdt::detail::output_triangle) and copied straight into the arrays (replaced):
  /// sites mapped to vertex ids through vertex_of (whose first entries, taken over by take_vertex_ids,
  /// must be the ones the device holds), constraint pieces to input segments through
  /// segment_of_piece. The mesh itself is not copied back. The copies' host side runs on `parallel`
  /// when given (it writes fresh pages of 36 bytes per triangle). Into pinned result memory, with few
  /// pieces against the triangles, only segment_of_edge's words that are not kNoId are sent (as
  /// (word, segment) pairs) and the host fills the rest.
  void output(std::span<const std::uint32_t> vertex_of, std::span<const std::uint32_t> segment_of_piece,
              TriangleArray& triangles, TriangleArray& neighbors, TriangleArray& segment_of_edge,
              const HostParallelFor& parallel = {}) const;

  /// For a caller whose host threads wait on the device (constraints beside the host): sizes
  /// segment_of_edge for an output of every slot and fills it with kNoId on `parallel`, when output()
  /// with `pieces` pieces would send only its other words, so that output() need not. Returns whether
  /// it did; output() fills it again should the rows have changed.
  bool prefill_segments(std::size_t pieces, TriangleArray& segment_of_edge, const HostParallelFor& parallel);

private:
  std::unique_ptr<State> state_;
};

} // namespace cdt::gpu
