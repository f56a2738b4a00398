#pragma once
// Preparation of the planar straight-line graph before the gCD algorithm runs: input checks, merging of
// duplicate points, and splitting of segments so that what reaches the triangulator is a set of pieces
// that neither cross nor overlap and carry no vertex in their interiors.
//
// Every geometric decision (is a point on a segment, do two segments cross) is made with the exact
// predicates; the only inexact step is the rounding of a crossing point to doubles. The pieces bent
// through it are checked again until nothing crosses. To make that converge where segments overlap
// to within rounding error, a rounded crossing point reuses an added vertex within a few ulps of the
// largest coordinate, and a vertex new in a repair round also splits segments passing that close to
// it (snap rounding in miniature). Input points are only ever reused when hit exactly.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <span>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/host_device.hpp"

namespace cdt::detail {

/// Largest coordinate magnitude accepted. The exact predicates need the fourth powers of coordinate
/// differences in incircle to stay finite (see cdt/detail/predicates.hpp): (2 * 1e60)^4 is far below
/// the largest double.
inline constexpr double kMaxCoordinate = 1e60;

/// Smallest magnitude of a nonzero coordinate accepted. The floating-point filters and orient2d's
/// expansions need their products not to underflow: a nonzero coordinate of at least 1e-60 is a
/// multiple of 2^-252, so every difference is 0 or at least that, and products of two are at least
/// 2^-504 (2^-1008 for four), far above the smallest normal double. Below it (subnormals, say) the
/// predicates lied: three points at 0 and 1e-300 were found collinear.
inline constexpr double kMinCoordinate = 1e-60;

/// A constraint between two distinct vertices that must appear as one edge of the triangulation.
struct ConstraintPiece {
  std::uint32_t a;       ///< vertex index (into PreparedPslg::vertices)
  std::uint32_t b;       ///< vertex index, != a
  std::uint32_t segment; ///< the lowest input segment id that covers this piece
};

/// Pieces, grown without a zero fill: every element is written in parallel where it is made.
using PieceArray = std::vector<ConstraintPiece, DefaultInitAllocator<ConstraintPiece>>;

/// Pieces [from, from + count) of an array that are [to, to + count) of its successor: how the suspects'
/// split (split_pieces) moved the pieces that stayed, runs by increasing from.
struct PieceRun {
  std::uint32_t from, to, count;
};

/// Where the suspects' split put the pieces, when pieces came or went: the runs of those that stayed
/// (every piece that is in no run left), and the new indices of the pieces made from the suspects
/// (those that came, and the suspects that came back as they were), increasing.
struct PieceMoves {
  std::vector<PieceRun> runs;
  std::vector<std::uint32_t> from_suspects;
  /// The pieces at from_suspects, in that order, and the pieces that came (at new_pieces), in that
  /// order: what the array holds there once moved, known before it is (PieceMove).
  std::vector<ConstraintPiece> suspect_pieces, came;
};

/// The last step of a suspects' split that changed the pieces: the kept pieces' runs (cut into chunks,
/// none moving farther than `reach`), moved within the array when `in_place` (else copied into a new
/// one), and the pieces that came written at their places. split_pieces does it, or leaves it to the
/// caller (apply_piece_move), who may then do it while other work goes on.
struct PieceMove {
  std::vector<PieceRun> chunks;
  std::size_t reach = 0;
  std::size_t size = 0; ///< the pieces after the move
  bool in_place = false;
  std::vector<ConstraintPiece> inserted;
  std::vector<std::uint32_t> inserted_at;
  bool pending = false; ///< left to the caller, and not done yet
};

/// The cleaned input of the triangulator.
struct PreparedPslg {
  /// The input points at their input indices, then the vertices added at crossings.
  PointArray vertices;
  /// Per input point: its representative, the lowest index with identical coordinates.
  IndexArray duplicate_of;
  /// The distinct vertices to triangulate (representatives, then added vertices), increasing.
  IndexArray sites;
  /// Pieces that pairwise neither cross nor overlap, with no site in their interiors; a < b, sorted by
  /// (a, b). A segment's pieces follow it exactly, except where a crossing bent it: then they pass
  /// through the rounded crossing vertex, a few ulps off its line (and through any vertex exactly on
  /// the bent pieces).
  PieceArray pieces;
  /// Input segments from a point to itself (or to a duplicate of it), ignored.
  std::size_t zero_length_segments = 0;
  /// No two points coincide, and duplicate_of and sites (both the identity) have their sizes but their
  /// elements are not written yet (merge_input with a merge that left them so): the caller writes them
  /// (write_identity_maps) before anything reads them, and clears the flag.
  bool identity_maps_unwritten = false;
};

/// Room for the pieces of n input pieces that split_pieces (the suspects' form) may add without moving
/// the array: a crossing adds two. The device's merge download reserves the same.
inline std::size_t piece_room(std::size_t n) { return n + n / 256 + 1024; }

/// Room for the vertices (and arrays per vertex or per site) of n input points, with those that
/// crossings may add: growing such an array would copy it all (10^7 points: 40-160 MB into fresh
/// pages) for the first vertex added. Room never written costs no memory.
inline std::size_t vertex_room(std::size_t n) { return n + n / 256 + 1024; }

/// The bits of v with -0 taken as +0, so that equal coordinates give equal bits.
CDT_HD_INLINE std::uint64_t coordinate_bits(double v) {
  if (v == 0.0) v = 0.0;
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  return bits;
}

/// A mix of both coordinates' bits: equal points hash alike, distinct ones collide about never. The
/// host groups duplicate points by its low 32 bits; the device's hash table of points starts each probe
/// at its high bits.
CDT_HD_INLINE std::uint64_t point_hash(double x, double y) {
  std::uint64_t h = coordinate_bits(x) * 0x9E3779B97F4A7C15ull;
  h ^= (h >> 29) ^ coordinate_bits(y);
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  h *= 0x94D049BB133111EBull;
  return h ^ (h >> 29);
}

/// Whether a coordinate passes the input checks: 0, or finite with a magnitude from kMinCoordinate to
/// kMaxCoordinate (a NaN or an infinity fails the comparison).
CDT_HD_INLINE bool coordinate_is_valid(double v) {
  const double magnitude = v < 0 ? -v : v;
  return magnitude <= kMaxCoordinate && (magnitude >= kMinCoordinate || magnitude == 0.0);
}

/// Whether a point passes the input checks (the same test on the host and the device).
CDT_HD_INLINE bool point_is_valid(double x, double y) {
  return coordinate_is_valid(x) && coordinate_is_valid(y);
}

/// The InvalidInputError of merge_input's checks for point i, which fails point_is_valid.
[[noreturn]] void throw_invalid_point(std::span<const Point> points, std::size_t i);

/// The InvalidInputError of merge_input's checks for segment s: an end beyond the points, or both ends
/// at one place (an error under CrossingSegments::reject).
[[noreturn]] void throw_invalid_segment(std::span<const Point> points, std::span<const Segment> segments,
                                        std::size_t s);

/// merge_input's work done elsewhere than on the host (the device), the input checks included: throws
/// the errors merge_input's checks throw, for the same point or segment, then fills, for the points and
/// segments given to merge_input, duplicate_of (per point the lowest index with identical coordinates,
/// -0 equal to +0), sites (the points that are their own representative, increasing) and pieces
/// (merge_input's), as the host would. Returns the number of zero-length segments. When no two points
/// coincide it may size duplicate_of and sites without writing them (both are the identity) and set
/// identity_unwritten (see PreparedPslg::identity_maps_unwritten). It may also return with the three
/// arrays sized and their elements still on their way (the device's copies, waited for by its owner
/// before they are read): merge_input reads only their sizes.
using InputMerge = std::function<std::size_t(IndexArray& duplicate_of, IndexArray& sites, PieceArray& pieces,
                                             bool& identity_unwritten)>;

/// Checks and cleans the input of triangulate(). Throws InvalidInputError (non-finite coordinates,
/// coordinates beyond kMaxCoordinate or nonzero ones below kMinCoordinate in magnitude, out-of-range indices,
/// zero-length segments under CrossingSegments::reject (ignored under resolve), fewer than 3 distinct points,
/// all points collinear; item() is the point or segment id, or the number of distinct points for the last
/// two), CrossingSegmentsError when segments cross under CrossingSegments::reject (the lowest pair of ids,
/// lower first; segments that cross exactly at an input point are split there, not rejected), and
/// SplitNotConvergingError when crossing resolution does not converge. Runs in O((n + m) log(n + m) + k) for
/// n points, m segments and k candidate pairs from the grid (about linear for inputs whose segments are short
/// compared with the domain).
PreparedPslg prepare_pslg(std::span<const Point> points, std::span<const Segment> segments,
                          CrossingSegments policy);

class CpuExecutor;

/// The same, with the sort and the candidate screening run on `executor`; the result does not depend on
/// its thread count. merge_input followed by split_pieces.
PreparedPslg prepare_pslg(std::span<const Point> points, std::span<const Segment> segments,
                          CrossingSegments policy, CpuExecutor& executor);

/// The first half of prepare_pslg: input checks (the same errors), duplicate points merged, and as
/// pieces the input segments between representatives, each vertex pair once (the lowest segment id),
/// sorted by (a, b), not yet split at points on them or at crossings. The checks are made, the
/// duplicates merged and the pieces made by `merge` when given, else on `executor`. With `merge`, the
/// vertex array has the points' size but its elements are not written: the caller copies the points
/// into it (copy_points) before anything reads them, so that the copy (160 MB at 10^7 points) can run
/// while the device works.
PreparedPslg merge_input(std::span<const Point> points, std::span<const Segment> segments,
                         CrossingSegments policy, CpuExecutor& executor, const InputMerge& merge = {});

/// Writes the points into the first points.size() elements of vertices (merge_input's copy of the input).
void copy_points(std::span<const Point> points, PointArray& vertices);

/// Writes duplicate_of and sites as the identity (PreparedPslg::identity_maps_unwritten), on this thread;
/// leaves the flag to the caller.
void write_identity_maps(PreparedPslg& pslg);

/// The second half: splits every piece at the sites on it and at crossings (the errors of prepare_pslg
/// for crossings), adding the crossing vertices to vertices and sites.
void split_pieces(PreparedPslg& pslg, CrossingSegments policy, CpuExecutor& executor);

/// Thrown by split_pieces when rounding the crossing points keeps making new crossings round after
/// round (segments that nearly overlap at the limit of double precision).
class SplitNotConvergingError : public Error {
public:
  using Error::Error;
};

/// The same, testing only the suspect pieces (indices into pslg.pieces), against each other and against
/// the suspect sites (vertex ids, increasing, holding every end of a suspect piece); the other pieces are
/// kept as they are and merge with identical resolved ones. The caller vouches that nothing else can
/// meet a suspect: for instance every other piece is an edge of a triangulation of the sites, and the
/// suspects' neighbourhoods in it are suspect too (screen_pieces). Pairs met in the first round are
/// then exactly those of split_pieces; vertices added later are snapped with the whole input's
/// tolerance, but only into suspects. sites_magnitude, when not negative, is the largest absolute
/// coordinate of pslg.sites, which that tolerance is made from (computed here otherwise). Returns
/// whether pieces came or went; when not, pslg.pieces holds the same pieces in the same places (only
/// their segment ids may be lower) and no vertex was added. new_pieces, when given, is set to the
/// indices of the pieces that came, increasing (every piece at an added vertex is among them).
/// moves, when given and pieces came or went, says where every old piece that stayed went and which
/// pieces came from the suspects (PieceMoves). The pieces move within pslg.pieces when its capacity
/// holds them and few came or went (else into a new array with the same room).
/// With `later`, a split that changes the pieces leaves their move to the caller (pslg.pieces is then
/// the old array, its segment ids updated, until apply_piece_move); new_pieces and moves already name
/// the places after the move.
bool split_pieces(PreparedPslg& pslg, std::span<const std::uint32_t> suspect_pieces,
                  std::span<const std::uint32_t> suspect_sites, CrossingSegments policy,
                  CpuExecutor& executor, double sites_magnitude = -1.0,
                  std::vector<std::uint32_t>* new_pieces = nullptr, PieceMoves* moves = nullptr,
                  PieceMove* later = nullptr);

/// Does a move split_pieces left (nothing when none is pending) on `threads` threads of its own (this
/// one among them), so that it can run beside a caller that holds the executor's pool.
void apply_piece_move(PieceArray& pieces, PieceMove& move, unsigned threads);

/// The new index of old piece `old` after a split that moved the pieces by runs[0, num_runs) (by
/// increasing from), or kNone when it left. The same on the host and the device (renumbered constraints).
CDT_HD inline std::uint32_t moved_piece(const PieceRun* runs, std::uint32_t num_runs, std::uint32_t old) {
  // The last run starting at or before old.
  std::uint32_t lo = 0, hi = num_runs;
  while (lo < hi) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (runs[mid].from <= old) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo == 0 || old - runs[lo - 1].from >= runs[lo - 1].count) return kNone;
  return runs[lo - 1].to + (old - runs[lo - 1].from);
}
inline std::uint32_t moved_piece(std::span<const PieceRun> runs, std::uint32_t old) {
  return moved_piece(runs.data(), static_cast<std::uint32_t>(runs.size()), old);
}

} // namespace cdt::detail
