#pragma once
// Readers and writers for the file formats of Shewchuk's Triangle (.node, .poly, .ele, .neigh, .edge,
// https://www.cs.cmu.edu/~quake/triangle.html) and for the plain edge-list format of the test data.
//
// Readers are strict: every malformed input throws FileError whose what() reads
// "<path>:<line>: <reason>" (line 0 when the problem is not tied to a line, e.g. a missing file).
// In every format '#' starts a comment that runs to the end of the line, blank lines are skipped and
// fields are separated by whitespace (CR included, so CRLF files read as well). As in Triangle,
// trailing fields of a header line may be left out: they take Triangle's defaults.
//
// Writers produce files Triangle reads, with coordinates in the shortest form that reads back to the
// same double. They write "<path>.tmp" and rename it over <path>, so a reader never sees half a file;
// on failure the temporary is removed and FileError names <path>.

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"

namespace cdt::io {

/// A planar straight-line graph as read from a file.
struct Pslg {
  /// Vertex coordinates, all finite, in file order (record k of the file is points[k]).
  std::vector<Point> points;
  /// Constraint segments as 0-based indices into points, whatever base the file used.
  std::vector<Segment> segments;
  /// One point inside each hole (from .poly files); empty for the other formats.
  std::vector<Point> holes;
  /// 0 or 1: the number of the file's first vertex; writers reuse it to keep the file's numbering.
  unsigned first_index = 0;
};

/// Reads a Triangle .node file: its vertices (attributes and boundary markers are checked, then
/// dropped). As in Triangle, anything after the vertex section is ignored, so a .poly reads as a .node.
Pslg read_node(const std::filesystem::path& path);

/// Reads a Triangle .poly file: vertices, segments and holes; regional attributes are checked, then
/// dropped. When the file lists 0 vertices they are read from the .node file of the same stem.
Pslg read_poly(const std::filesystem::path& path);

/// Reads an edge list: a line "nV nE", nV lines "x y", then nE lines "v1 v2" of 0-based indices.
/// first_index of the result is 0.
Pslg read_edge_list(const std::filesystem::path& path);

/// Reads a PSLG picking the format by extension: ".node", ".poly", anything else is an edge list.
Pslg read_pslg(const std::filesystem::path& path);

/// Reads a Triangle .ele file (3 or 6 nodes per triangle; the 3 extra nodes and any attributes are
/// dropped). first_index (0 or 1) is the number of the first vertex of the matching .node file; the
/// result holds 0-based vertex indices. Indices are checked against first_index, not against a
/// vertex count, which the .ele does not know.
TriangleArray read_ele(const std::filesystem::path& path, unsigned first_index);

/// Writes a Triangle .node file of the vertices (no attributes, no markers), numbered from
/// first_index (0 or 1). Coordinates must be finite.
void write_node(const std::filesystem::path& path, std::span<const Point> vertices, unsigned first_index);

/// Writes a Triangle .poly file holding vertices, segments and holes (no regional attributes),
/// numbered from pslg.first_index (0 or 1). Segment indices must be < pslg.points.size() and
/// coordinates finite.
void write_poly(const std::filesystem::path& path, const Pslg& pslg);

/// Writes a Triangle .ele file of t.triangles (3 nodes, no attributes): triangles and vertices are
/// numbered from first_index (0 or 1). Every vertex index must be < t.vertices.size().
void write_ele(const std::filesystem::path& path, const Triangulation& t, unsigned first_index);

/// Writes a Triangle .neigh file: neighbour i of a triangle is the one opposite its vertex i (the
/// convention of Triangulation::neighbors), numbered from first_index (0 or 1), -1 where there is none.
/// t.neighbors must have one entry per triangle.
void write_neigh(const std::filesystem::path& path, const Triangulation& t, unsigned first_index);

/// Writes a Triangle .edge file listing each edge of t once, vertices numbered from first_index (0 or
/// 1), with boundary marker 1 on constraint and hull edges and 0 on the others. t.neighbors must have
/// one entry per triangle; t.segment_of_edge too, or be empty (no constraints).
void write_edge(const std::filesystem::path& path, const Triangulation& t, unsigned first_index);

} // namespace cdt::io
