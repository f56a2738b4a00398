#pragma once
// Phase 1 of gCD, second half (paper section 3.1 and Appendix A): the digital Voronoi diagram of the
// grid sites, computed as a Euclidean colouring by the Parallel Banding Algorithm (Cao, Tang, Mei,
// Tan, Lee, I3D 2010) and amended to the Standard-flooding result, whose dual is a valid
// triangulation (Algorithm A.1).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "gcd/grid_map.hpp"

namespace cdt::detail {

class CpuExecutor;

/// colour[gy*m+gx] = the kept point nearest to grid point (gx,gy) (squared Euclidean distance, exact in
/// 64-bit integers); ties broken by the smaller point index (Definition 1), then amended (Appendix A)
/// so that every colour region is connected to its own site (the Standard-flooding result, whose dual
/// is a valid triangulation). Every cell is coloured unless there is no kept point at all (then every
/// cell is kNone). sites.cell_owner must have m * m entries.
std::vector<std::uint32_t> compute_digital_voronoi(const GridSites& sites, std::uint32_t m,
                                                   CpuExecutor& executor);

// --- the two steps, exposed for tests ----------------------------------------------------------------

/// The Euclidean colouring of Definition 1 by the Parallel Banding Algorithm, before the amendment:
/// colour[gy*m+gx] = the owner of the nearest occupied cell, ties to the smaller owner index; kNone
/// everywhere when no cell is occupied. cell_owner: m * m point indices or kNone (GridSites).
/// bands = 0 picks the number of bands from m; tests pass other counts (any in [1, m]) to exercise
/// the band merging, which must not change the result.
std::vector<std::uint32_t> compute_euclidean_colouring(std::span<const std::uint32_t> cell_owner,
                                                       std::uint32_t m, CpuExecutor& executor,
                                                       std::uint32_t bands = 0);

/// Takes the sites in `removed` out of an amended colouring, in place: their regions are cleared and
/// flooded from the neighbouring regions, nearest site first, so every region stays connected to its
/// site. Used when a degenerate corner (three collinear sites meeting at a grid corner) makes the dual
/// invalid: the middle site leaves the diagram and is inserted later as a missing point.
void remove_sites_from_colouring(std::vector<std::uint32_t>& colour, const GridSites& sites, std::uint32_t m,
                                 std::span<const std::uint32_t> removed);

/// Algorithm A.1 on a Euclidean colouring of sites, in place: the debris (cells that no 4-connected
/// path of their own colour reaches from their site; see voronoi.cpp for the exact test) are
/// uncoloured and flooded again from their neighbours. Returns the number of debris cells, each of
/// which may have received its old colour back.
std::size_t amend_to_standard_flooding(std::vector<std::uint32_t>& colour, const GridSites& sites,
                                       std::uint32_t m, CpuExecutor& executor);

} // namespace cdt::detail
