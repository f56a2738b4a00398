#include "cdt/io.hpp"

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <ios>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

namespace cdt::io {
namespace {

namespace fs = std::filesystem;

// Counts are capped so that every index fits in a uint32 and kNone stays free as a sentinel.
constexpr std::uint64_t kMaxCount = 0xFFFFFFFFu;

[[noreturn]] void fail(const fs::path& path, std::uint64_t line, const std::string& reason) {
  const std::string name = path.string();
  throw FileError(name, line, name + ":" + std::to_string(line) + ": " + reason);
}

std::string system_reason(int err) {
  return err != 0 ? std::generic_category().message(err) : std::string("unknown error");
}

// Garbage can be arbitrarily long (a binary file, say); messages quote only its start.
std::string quote(std::string_view field) {
  constexpr std::size_t kMaxShown = 40;
  if (field.size() > kMaxShown) return "'" + std::string(field.substr(0, kMaxShown)) + "...'";
  return "'" + std::string(field) + "'";
}

std::string load(const fs::path& path) {
  std::error_code ec;
  // Opening a directory succeeds on Linux and only the read fails, with a vaguer message.
  if (fs::is_directory(path, ec)) fail(path, 0, "cannot read: it is a directory");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, 0, "cannot open: " + system_reason(errno));
  std::string text;
  std::array<char, 1 << 16> chunk{};
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    text.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) fail(path, 0, "read error: " + system_reason(errno));
  return text;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// std::from_chars rejects a leading '+', which strtod (and so Triangle) accepts.
std::string_view strip_plus(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '+' && s[1] != '-') s.remove_prefix(1);
  return s;
}

// Walks a file line by line, splitting lines into fields and turning every problem into a FileError
// that names the line.
class Parser {
public:
  explicit Parser(const fs::path& path) : path_(path), text_(load(path)) {
    for (char c : text_) last_line_ += c == '\n' ? 1 : 0;
    if (!text_.empty() && text_.back() != '\n') ++last_line_;
  }

  [[noreturn]] void fail_here(const std::string& reason) const { fail(path_, line_, reason); }

  // Moves to the next line that holds fields; false at the end of the file.
  bool advance() {
    fields_.clear();
    while (pos_ < text_.size()) {
      std::size_t end = text_.find('\n', pos_);
      if (end == std::string::npos) end = text_.size();
      std::string_view rest(text_.data() + pos_, end - pos_);
      pos_ = end < text_.size() ? end + 1 : end;
      ++line_;
      if (const std::size_t hash = rest.find('#'); hash != std::string_view::npos)
        rest = rest.substr(0, hash);
      std::size_t i = 0;
      while (i < rest.size()) {
        while (i < rest.size() && is_space(rest[i])) ++i;
        const std::size_t start = i;
        while (i < rest.size() && !is_space(rest[i])) ++i;
        if (i > start) fields_.push_back(rest.substr(start, i - start));
      }
      if (!fields_.empty()) {
        seen_data_ = true;
        return true;
      }
    }
    return false;
  }

  // Moves to the next line that holds fields, which must exist; `expected` names it for the error.
  void require(const std::string& expected) {
    if (advance()) return;
    if (text_.empty()) fail(path_, 0, "the file is empty");
    if (!seen_data_) fail(path_, last_line_, "the file holds no data, only blank lines and comments");
    fail(path_, last_line_, "the file ends early: expected " + expected);
  }

  // Fails unless the current line has between min and max fields; `layout` spells them out.
  void expect_fields(std::size_t min, std::size_t max, const std::string& layout) const {
    if (fields_.size() < min) {
      fail_here("wrong field count: expected " + std::to_string(min) + (min == max ? "" : " or more") +
                " fields (" + layout + "), found " + std::to_string(fields_.size()));
    }
    if (fields_.size() > max) fail_here("trailing garbage " + quote(fields_[max]) + " after " + layout);
  }

  // Fails if any data follows; a count too small would otherwise silently drop records.
  void expect_end(const std::string& after) {
    if (advance()) fail_here("unexpected data " + quote(fields_[0]) + " after " + after);
  }

  std::size_t field_count() const { return fields_.size(); }

  std::int64_t integer(std::size_t i, const std::string& what) const {
    const std::string_view s = strip_plus(fields_[i]);
    std::int64_t value = 0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (ec == std::errc::invalid_argument || ptr != s.data() + s.size())
      fail_here(what + " " + quote(fields_[i]) + " is not an integer");
    if (ec != std::errc{}) fail_here(what + " " + quote(fields_[i]) + " is out of range");
    return value;
  }

  // Any double, infinities and NaN included (attributes are not geometry).
  double real(std::size_t i, const std::string& what) const {
    const std::string_view s = strip_plus(fields_[i]);
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (ec == std::errc::invalid_argument || ptr != s.data() + s.size())
      fail_here(what + " " + quote(fields_[i]) + " is not a number");
    if (ec != std::errc{}) fail_here(what + " " + quote(fields_[i]) + " is out of the range of a double");
    return value;
  }

  double coordinate(std::size_t i, const std::string& what) const {
    const double value = real(i, what);
    if (!std::isfinite(value)) fail_here(what + " " + quote(fields_[i]) + " is not finite");
    return value;
  }

  std::uint64_t count(std::size_t i, const std::string& what) const {
    const std::int64_t value = integer(i, what);
    if (value < 0) fail_here(what + " " + quote(fields_[i]) + " is negative");
    if (static_cast<std::uint64_t>(value) > kMaxCount)
      fail_here(what + " " + quote(fields_[i]) + " is too large (at most " + std::to_string(kMaxCount) + ")");
    return static_cast<std::uint64_t>(value);
  }

  // Guards reserve() against absurd counts: every field takes at least one byte. The bound is kept
  // loose on purpose so that a file a few records short reaches the clearer "ends early" error.
  void check_room(std::uint64_t records, std::uint64_t fields_per_record, const std::string& what) const {
    const std::uint64_t remaining = text_.size() - pos_;
    if (records > remaining / fields_per_record) {
      fail_here("the header announces " + std::to_string(records) + " " + what +
                ", more than the remaining " + std::to_string(remaining) + " bytes of the file can hold");
    }
  }

private:
  fs::path path_;
  std::string text_;
  std::size_t pos_ = 0;
  std::uint64_t line_ = 0;
  std::uint64_t last_line_ = 0;
  bool seen_data_ = false;
  std::vector<std::string_view> fields_;
};

// Triangle numbers the records of a section consecutively from 0 or 1; the first record picks which.
class Numbering {
public:
  explicit Numbering(std::string what) : what_(std::move(what)) {}

  void check(const Parser& p, std::uint64_t ordinal) {
    const std::int64_t number = p.integer(0, what_ + " number");
    if (ordinal == 0) {
      if (number != 0 && number != 1)
        p.fail_here("the first " + what_ + " must be numbered 0 or 1, found " + std::to_string(number));
      base_ = static_cast<unsigned>(number);
    } else if (number < 0 || static_cast<std::uint64_t>(number) != base_ + ordinal) {
      p.fail_here("non-consecutive " + what_ + " numbers: expected " + std::to_string(base_ + ordinal) +
                  ", found " + std::to_string(number));
    }
  }

  unsigned base() const { return base_; }

private:
  std::string what_;
  unsigned base_ = 0;
};

// Converts a vertex number of the file (first..first+count-1) to a 0-based index.
std::uint32_t vertex_ref(const Parser& p, std::size_t i, std::uint64_t first, std::uint64_t count,
                         const std::string& what) {
  const std::int64_t number = p.integer(i, what);
  if (number < 0 || static_cast<std::uint64_t>(number) < first ||
      static_cast<std::uint64_t>(number) - first >= count) {
    if (count == 0)
      p.fail_here("index out of range: " + what + " " + std::to_string(number) +
                  ", but there are no vertices");
    p.fail_here("index out of range: " + what + " " + std::to_string(number) + " is not in " +
                std::to_string(first) + ".." + std::to_string(first + count - 1));
  }
  return static_cast<std::uint32_t>(static_cast<std::uint64_t>(number) - first);
}

std::string ordinal_of(std::uint64_t k, std::uint64_t n, const std::string& what) {
  return what + " " + std::to_string(k + 1) + " of " + std::to_string(n);
}

// Reads the vertex section shared by .node and .poly files into out; returns the announced count.
std::uint64_t read_vertex_section(Parser& p, Pslg& out) {
  const std::string header = "<#vertices> <dimension> <#attributes> <#boundary markers>";
  p.require("the header line " + header);
  p.expect_fields(1, 4, header);
  const std::uint64_t n = p.count(0, "vertex count");
  if (p.field_count() > 1) {
    const std::int64_t dimension = p.integer(1, "dimension");
    if (dimension != 2) p.fail_here("the dimension must be 2, found " + std::to_string(dimension));
  }
  const std::uint64_t attributes = p.field_count() > 2 ? p.count(2, "attribute count") : 0;
  const std::uint64_t markers = p.field_count() > 3 ? p.count(3, "boundary marker count") : 0;
  if (markers > 1)
    p.fail_here("the number of boundary markers must be 0 or 1, found " + std::to_string(markers));
  const std::uint64_t per_record = 3 + attributes + markers;
  p.check_room(n, per_record, "vertices");

  std::string layout = "<index> <x> <y>";
  if (attributes > 0) layout += " <" + std::to_string(attributes) + " attributes>";
  if (markers > 0) layout += " <boundary marker>";
  out.points.reserve(static_cast<std::size_t>(n));
  Numbering numbering("vertex");
  for (std::uint64_t k = 0; k < n; ++k) {
    p.require(ordinal_of(k, n, "vertex"));
    p.expect_fields(static_cast<std::size_t>(per_record), static_cast<std::size_t>(per_record), layout);
    numbering.check(p, k);
    const double x = p.coordinate(1, "x coordinate");
    const double y = p.coordinate(2, "y coordinate");
    for (std::uint64_t a = 0; a < attributes; ++a) p.real(static_cast<std::size_t>(3 + a), "attribute");
    if (markers > 0) p.integer(static_cast<std::size_t>(3 + attributes), "boundary marker");
    out.points.push_back({x, y});
  }
  out.first_index = n > 0 ? numbering.base() : 0;
  return n;
}

void check_first_index(const fs::path& path, unsigned first_index) {
  if (first_index > 1) fail(path, 0, "first_index must be 0 or 1, got " + std::to_string(first_index));
}

// ---- writing ----------------------------------------------------------------------------------

template <class T>
void put(std::string& out, T value) {
  // 32 characters hold any integer and the longest shortest-form double ("-2.2250738585072014e-308").
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  // append(pointer, count) rather than append(first, last): GCC 12 at -O3 reports a bogus -Wrestrict
  // for the iterator form.
  out.append(buffer.data(), static_cast<std::size_t>(result.ptr - buffer.data()));
}

template <class First, class... Rest>
void put_line(std::string& out, First first, Rest... rest) {
  put(out, first);
  ((out.push_back(' '), put(out, rest)), ...);
  out.push_back('\n');
}

// Removes the temporary file on every path out of write_file except a successful rename.
class TemporaryFile {
public:
  explicit TemporaryFile(fs::path path) : path_(std::move(path)) {}
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  ~TemporaryFile() {
    if (armed_) {
      std::error_code ec;
      fs::remove(path_, ec);
    }
  }
  void keep() { armed_ = false; }

private:
  fs::path path_;
  bool armed_ = true;
};

void write_file(const fs::path& path, const std::string& text) {
  fs::path temporary = path;
  temporary += ".tmp";
  errno = 0;
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  if (!out) fail(path, 0, "cannot create " + temporary.string() + ": " + system_reason(errno));
  TemporaryFile guard(temporary);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.close();
  if (!out) fail(path, 0, "cannot write " + temporary.string() + ": " + system_reason(errno));
  std::error_code ec;
  fs::rename(temporary, path, ec);
  if (ec) fail(path, 0, "cannot rename " + temporary.string() + " to it: " + ec.message());
  guard.keep();
}

void put_vertex_section(std::string& out, const fs::path& path, std::span<const Point> vertices,
                        unsigned first_index) {
  put_line(out, static_cast<std::uint64_t>(vertices.size()), 2, 0, 0);
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const Point& v = vertices[k];
    // The readers reject these, so writing them would produce a file that cannot be read back.
    if (!std::isfinite(v.x) || !std::isfinite(v.y))
      fail(path, 0, "vertex " + std::to_string(k) + " has a non-finite coordinate");
    put_line(out, first_index + static_cast<std::uint64_t>(k), v.x, v.y);
  }
}

void check_vertex_indices(const fs::path& path, const Triangulation& t) {
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    for (const std::uint32_t v : t.triangles[k]) {
      if (v >= t.vertices.size()) {
        fail(path, 0,
             "triangle " + std::to_string(k) + " refers to vertex " + std::to_string(v) + ", but there are " +
                 std::to_string(t.vertices.size()) + " vertices");
      }
    }
  }
}

void check_neighbors(const fs::path& path, const Triangulation& t) {
  if (t.neighbors.size() != t.triangles.size()) {
    fail(path, 0,
         "the triangulation has " + std::to_string(t.triangles.size()) + " triangles but " +
             std::to_string(t.neighbors.size()) + " neighbour entries");
  }
  for (std::size_t k = 0; k < t.neighbors.size(); ++k) {
    for (const std::uint32_t n : t.neighbors[k]) {
      if (n != kNone && n >= t.triangles.size())
        fail(path, 0,
             "triangle " + std::to_string(k) + " has neighbour " + std::to_string(n) +
                 ", which does not exist");
    }
  }
}

} // namespace

Pslg read_node(const std::filesystem::path& path) {
  Parser p(path);
  Pslg out;
  read_vertex_section(p, out);
  return out;
}

Pslg read_poly(const std::filesystem::path& path) {
  Parser p(path);
  Pslg out;
  if (read_vertex_section(p, out) == 0) {
    fs::path node = path;
    node.replace_extension(".node");
    try {
      out = read_node(node);
    } catch (const FileError& e) {
      if (e.line() != 0) throw;
      // Without this the caller would see an error about a file it never named.
      throw FileError(e.path(), 0,
                      std::string(e.what()) + " (" + path.string() +
                          " lists 0 vertices, so they are read from here)");
    }
  }
  const auto vertex_count = static_cast<std::uint64_t>(out.points.size());

  const std::string segment_header = "<#segments> <#boundary markers>";
  p.require("the segment header line " + segment_header);
  p.expect_fields(1, 2, segment_header);
  const std::uint64_t segments = p.count(0, "segment count");
  const std::uint64_t markers = p.field_count() > 1 ? p.count(1, "boundary marker count") : 0;
  if (markers > 1)
    p.fail_here("the number of boundary markers must be 0 or 1, found " + std::to_string(markers));
  p.check_room(segments, 3 + markers, "segments");
  const std::string segment_layout =
      markers > 0 ? "<index> <endpoint> <endpoint> <boundary marker>" : "<index> <endpoint> <endpoint>";
  out.segments.reserve(static_cast<std::size_t>(segments));
  Numbering segment_numbering("segment");
  for (std::uint64_t k = 0; k < segments; ++k) {
    p.require(ordinal_of(k, segments, "segment"));
    p.expect_fields(static_cast<std::size_t>(3 + markers), static_cast<std::size_t>(3 + markers),
                    segment_layout);
    segment_numbering.check(p, k);
    const std::uint32_t a = vertex_ref(p, 1, out.first_index, vertex_count, "segment endpoint");
    const std::uint32_t b = vertex_ref(p, 2, out.first_index, vertex_count, "segment endpoint");
    if (markers > 0) p.integer(3, "boundary marker");
    out.segments.push_back({a, b});
  }

  p.require("the hole header line <#holes>");
  p.expect_fields(1, 1, "<#holes>");
  const std::uint64_t holes = p.count(0, "hole count");
  p.check_room(holes, 3, "holes");
  out.holes.reserve(static_cast<std::size_t>(holes));
  Numbering hole_numbering("hole");
  for (std::uint64_t k = 0; k < holes; ++k) {
    p.require(ordinal_of(k, holes, "hole"));
    p.expect_fields(3, 3, "<index> <x> <y>");
    hole_numbering.check(p, k);
    const double x = p.coordinate(1, "x coordinate");
    const double y = p.coordinate(2, "y coordinate");
    out.holes.push_back({x, y});
  }

  // The regional attribute section is optional; its values do not affect a CDT, but are still
  // checked so a damaged file is not half accepted.
  if (!p.advance()) return out;
  p.expect_fields(1, 1, "<#regions>");
  const std::uint64_t regions = p.count(0, "region count");
  p.check_room(regions, 4, "regions");
  Numbering region_numbering("region");
  for (std::uint64_t k = 0; k < regions; ++k) {
    p.require(ordinal_of(k, regions, "region"));
    p.expect_fields(4, 5, "<index> <x> <y> <attribute> <maximum area>");
    region_numbering.check(p, k);
    p.coordinate(1, "x coordinate");
    p.coordinate(2, "y coordinate");
    p.real(3, "regional attribute");
    if (p.field_count() > 4) p.real(4, "maximum area");
  }
  p.expect_end("the last region");
  return out;
}

Pslg read_edge_list(const std::filesystem::path& path) {
  Parser p(path);
  Pslg out;
  const std::string header = "<#vertices> <#edges>";
  p.require("the header line " + header);
  p.expect_fields(2, 2, header);
  const std::uint64_t vertices = p.count(0, "vertex count");
  const std::uint64_t edges = p.count(1, "edge count");
  p.check_room(vertices + edges, 2, "vertices and edges");
  out.points.reserve(static_cast<std::size_t>(vertices));
  for (std::uint64_t k = 0; k < vertices; ++k) {
    p.require(ordinal_of(k, vertices, "vertex"));
    p.expect_fields(2, 2, "<x> <y>");
    const double x = p.coordinate(0, "x coordinate");
    const double y = p.coordinate(1, "y coordinate");
    out.points.push_back({x, y});
  }
  out.segments.reserve(static_cast<std::size_t>(edges));
  for (std::uint64_t k = 0; k < edges; ++k) {
    p.require(ordinal_of(k, edges, "edge"));
    p.expect_fields(2, 2, "<v1> <v2>");
    const std::uint32_t a = vertex_ref(p, 0, 0, vertices, "edge endpoint");
    const std::uint32_t b = vertex_ref(p, 1, 0, vertices, "edge endpoint");
    out.segments.push_back({a, b});
  }
  p.expect_end("the last edge (the header announces " + std::to_string(vertices) + " vertices and " +
               std::to_string(edges) + " edges)");
  return out;
}

Pslg read_pslg(const std::filesystem::path& path) {
  const fs::path extension = path.extension();
  if (extension == ".node") return read_node(path);
  if (extension == ".poly") return read_poly(path);
  return read_edge_list(path);
}

TriangleArray read_ele(const std::filesystem::path& path, unsigned first_index) {
  check_first_index(path, first_index);
  Parser p(path);
  const std::string header = "<#triangles> <nodes per triangle> <#attributes>";
  p.require("the header line " + header);
  p.expect_fields(1, 3, header);
  const std::uint64_t n = p.count(0, "triangle count");
  const std::int64_t nodes = p.field_count() > 1 ? p.integer(1, "nodes per triangle") : 3;
  if (nodes != 3 && nodes != 6)
    p.fail_here("nodes per triangle must be 3 or 6, found " + std::to_string(nodes));
  const std::uint64_t attributes = p.field_count() > 2 ? p.count(2, "attribute count") : 0;
  const std::uint64_t per_record = 1 + static_cast<std::uint64_t>(nodes) + attributes;
  p.check_room(n, per_record, "triangles");

  std::string layout = nodes == 3 ? "<index> <v1> <v2> <v3>" : "<index> <v1> ... <v6>";
  if (attributes > 0) layout += " <" + std::to_string(attributes) + " attributes>";
  TriangleArray triangles;
  triangles.reserve(static_cast<std::size_t>(n));
  Numbering numbering("triangle");
  for (std::uint64_t k = 0; k < n; ++k) {
    p.require(ordinal_of(k, n, "triangle"));
    p.expect_fields(static_cast<std::size_t>(per_record), static_cast<std::size_t>(per_record), layout);
    numbering.check(p, k);
    std::array<std::uint32_t, 3> triangle{};
    for (std::size_t j = 0; j < static_cast<std::size_t>(nodes); ++j) {
      // The vertex count lives in the .node file, so only the uint32 range can be checked here.
      const std::uint32_t v = vertex_ref(p, 1 + j, first_index, kMaxCount, "vertex");
      if (j < 3) triangle[j] = v;
    }
    for (std::uint64_t a = 0; a < attributes; ++a)
      p.real(static_cast<std::size_t>(1 + static_cast<std::uint64_t>(nodes) + a), "attribute");
    triangles.push_back(triangle);
  }
  p.expect_end("the last triangle (the header announces " + std::to_string(n) + ")");
  return triangles;
}

void write_node(const std::filesystem::path& path, std::span<const Point> vertices, unsigned first_index) {
  check_first_index(path, first_index);
  std::string out;
  put_vertex_section(out, path, vertices, first_index);
  write_file(path, out);
}

void write_poly(const std::filesystem::path& path, const Pslg& pslg) {
  check_first_index(path, pslg.first_index);
  const std::uint64_t base = pslg.first_index;
  std::string out;
  put_vertex_section(out, path, pslg.points, pslg.first_index);
  put_line(out, static_cast<std::uint64_t>(pslg.segments.size()), 0);
  for (std::size_t k = 0; k < pslg.segments.size(); ++k) {
    const Segment& s = pslg.segments[k];
    if (s.a >= pslg.points.size() || s.b >= pslg.points.size()) {
      fail(path, 0,
           "segment " + std::to_string(k) + " refers to a vertex beyond the " +
               std::to_string(pslg.points.size()) + " given");
    }
    put_line(out, base + k, base + s.a, base + s.b);
  }
  put_line(out, static_cast<std::uint64_t>(pslg.holes.size()));
  for (std::size_t k = 0; k < pslg.holes.size(); ++k) {
    const Point& h = pslg.holes[k];
    if (!std::isfinite(h.x) || !std::isfinite(h.y))
      fail(path, 0, "hole " + std::to_string(k) + " has a non-finite coordinate");
    put_line(out, base + k, h.x, h.y);
  }
  write_file(path, out);
}

void write_ele(const std::filesystem::path& path, const Triangulation& t, unsigned first_index) {
  check_first_index(path, first_index);
  check_vertex_indices(path, t);
  const std::uint64_t base = first_index;
  std::string out;
  put_line(out, static_cast<std::uint64_t>(t.triangles.size()), 3, 0);
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    const auto& v = t.triangles[k];
    put_line(out, base + k, base + v[0], base + v[1], base + v[2]);
  }
  write_file(path, out);
}

void write_neigh(const std::filesystem::path& path, const Triangulation& t, unsigned first_index) {
  check_first_index(path, first_index);
  check_neighbors(path, t);
  const std::int64_t base = first_index;
  const auto number = [base](std::uint32_t n) -> std::int64_t { return n == kNone ? -1 : base + n; };
  std::string out;
  put_line(out, static_cast<std::uint64_t>(t.neighbors.size()), 3);
  for (std::size_t k = 0; k < t.neighbors.size(); ++k) {
    const auto& n = t.neighbors[k];
    put_line(out, base + static_cast<std::int64_t>(k), number(n[0]), number(n[1]), number(n[2]));
  }
  write_file(path, out);
}

void write_edge(const std::filesystem::path& path, const Triangulation& t, unsigned first_index) {
  check_first_index(path, first_index);
  check_vertex_indices(path, t);
  check_neighbors(path, t);
  const bool has_constraints = !t.segment_of_edge.empty();
  if (has_constraints && t.segment_of_edge.size() != t.triangles.size()) {
    fail(path, 0,
         "the triangulation has " + std::to_string(t.triangles.size()) + " triangles but " +
             std::to_string(t.segment_of_edge.size()) + " segment_of_edge entries");
  }
  const auto is_constraint = [&](std::size_t k, std::size_t i) {
    return has_constraints && t.segment_of_edge[k][i] != kNone;
  };
  struct Edge {
    std::uint32_t a, b, marker;
  };
  std::vector<Edge> edges;
  edges.reserve(t.triangles.size() * 3 / 2 + 3);
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    for (std::size_t i = 0; i < 3; ++i) {
      const std::uint32_t n = t.neighbors[k][i];
      // An interior edge is written from the lower-numbered of its two triangles only.
      if (n != kNone && n < k) continue;
      bool constraint = is_constraint(k, i);
      if (n != kNone) {
        // Trust either side's flag, so an edge flagged on one side only is still a constraint.
        for (std::size_t j = 0; j < 3; ++j)
          constraint = constraint || (t.neighbors[n][j] == k && is_constraint(n, j));
      }
      const auto& v = t.triangles[k];
      edges.push_back({v[(i + 1) % 3], v[(i + 2) % 3], (n == kNone || constraint) ? 1u : 0u});
    }
  }
  const std::uint64_t base = first_index;
  std::string out;
  put_line(out, static_cast<std::uint64_t>(edges.size()), 1);
  for (std::size_t k = 0; k < edges.size(); ++k)
    put_line(out, base + k, base + edges[k].a, base + edges[k].b, edges[k].marker);
  write_file(path, out);
}

} // namespace cdt::io
