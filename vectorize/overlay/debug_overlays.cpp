// Debug overlays of each pipeline stage and the folder that holds them with the inspector page.
#include "vectorize/debug_overlays.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <system_error>

#include "cdt/io.hpp"
#include "vectorize/errors.hpp"

namespace vectorize {

namespace fs = std::filesystem;

DebugStageNames debug_stage_names(DebugStage stage) noexcept {
  switch (stage) {
  case DebugStage::edges:
    return {"01-edges", "Edge pixels"};
  case DebugStage::chains:
    return {"02-chains", "Chains, polylines"};
  case DebugStage::pslg:
    return {"03-pslg", "PSLG"};
  case DebugStage::cdt:
    return {"04-cdt", "CDT"};
  case DebugStage::trixel_colours:
    return {"05-trixel-colours", "Trixel colours"};
  case DebugStage::trixel_groups:
    return {"06-trixel-groups", "Trixel groups"};
  case DebugStage::polygons:
    return {"07-polygons", "Polygons"};
  }
  return {"00-unknown", "Unknown"};
}

std::array<float, 3> region_id_colour(std::uint32_t id) noexcept {
  // Hues stepped by the golden ratio stay far apart for consecutive ids; three lightness levels
  // separate ids whose hues come close again.
  const double hue = std::fmod(static_cast<double>(id) * 0.61803398874989485, 1.0) * 6.0;
  const double value = id % 3 == 0 ? 0.95 : (id % 3 == 1 ? 0.78 : 0.62);
  const double saturation = 0.7;
  const double chroma = value * saturation;
  const double x = chroma * (1.0 - std::fabs(std::fmod(hue, 2.0) - 1.0));
  const double m = value - chroma;
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(hue)) {
  case 0:
    r = chroma, g = x;
    break;
  case 1:
    r = x, g = chroma;
    break;
  case 2:
    g = chroma, b = x;
    break;
  case 3:
    g = x, b = chroma;
    break;
  case 4:
    r = x, b = chroma;
    break;
  default:
    r = chroma, b = x;
    break;
  }
  return {static_cast<float>(r + m), static_cast<float>(g + m), static_cast<float>(b + m)};
}

namespace {

// Line widths and dot sizes in image pixels: thin on small images, a little thicker on large ones
// so that they still show when the whole image is on screen.
double unit_for(int width, int height) {
  return std::clamp(static_cast<double>(std::max(width, height)) / 600.0, 0.75, 2.0);
}

float centre(int v) { return static_cast<float>(v) + 0.5f; }

void check_triangulation(const StageRecord& r) {
  const auto num_vertices = r.triangulation.vertices.size();
  for (const auto& tri : r.triangulation.triangles) {
    for (const std::uint32_t v : tri) {
      if (v >= num_vertices) throw Error("debug overlay: triangle vertex id out of range");
    }
  }
}

void draw_edges(OverlayCanvas& canvas, const StageRecord& r) {
  const EdgeMap& e = r.edges;
  if (e.width != canvas.width() || e.height != canvas.height() ||
      e.on.size() != static_cast<std::size_t>(e.width) * e.height) {
    throw Error("debug overlay: the edge map (" + std::to_string(e.width) + " x " + std::to_string(e.height) +
                ") does not match the image (" + std::to_string(canvas.width()) + " x " +
                std::to_string(canvas.height()) + ")");
  }
  const float yellow[] = {1.0f, 0.88f, 0.1f, 1.0f};
  canvas.pixels(e.on.data(), yellow);
}

void draw_chains(OverlayCanvas& canvas, const StageRecord& r, double u) {
  const float chain_colour[] = {0.35f, 0.85f, 1.0f, 0.55f};
  const float polyline_colour[] = {1.0f, 0.45f, 0.1f, 1.0f};
  const float vertex_colour[] = {1.0f, 1.0f, 1.0f, 1.0f};
  const float endpoint_colour[] = {0.2f, 1.0f, 0.3f, 1.0f};
  const float junction_colour[] = {1.0f, 0.2f, 0.9f, 1.0f};
  std::vector<float> xy;
  // How many chain ends each end pixel has: one at an endpoint, more at a junction.
  std::map<std::pair<int, int>, int> ends;
  for (const Chain& chain : r.chains) {
    xy.clear();
    for (const PixelPoint& p : chain.points) {
      xy.push_back(centre(p.x));
      xy.push_back(centre(p.y));
    }
    canvas.polyline(xy.data(), static_cast<int>(chain.points.size()), chain.closed, chain_colour, 0.6 * u);
    if (!chain.closed && !chain.points.empty()) {
      ++ends[{chain.points.front().x, chain.points.front().y}];
      ++ends[{chain.points.back().x, chain.points.back().y}];
    }
  }
  std::vector<float> vertices;
  for (const Polyline& line : r.polylines) {
    xy.clear();
    for (const PixelPoint& p : line.points) {
      xy.push_back(centre(p.x));
      xy.push_back(centre(p.y));
    }
    canvas.polyline(xy.data(), static_cast<int>(line.points.size()), line.closed, polyline_colour, 1.2 * u);
    vertices.insert(vertices.end(), xy.begin(), xy.end());
  }
  canvas.dots(vertices.data(), vertices.size() / 2, 0.55 * u, vertex_colour);
  std::vector<float> endpoints, junctions;
  for (const auto& [p, count] : ends) {
    auto& into = count == 1 ? endpoints : junctions;
    into.push_back(centre(p.first));
    into.push_back(centre(p.second));
  }
  canvas.dots(endpoints.data(), endpoints.size() / 2, 1.4 * u, endpoint_colour);
  canvas.dots(junctions.data(), junctions.size() / 2, 1.8 * u, junction_colour);
}

void draw_pslg(OverlayCanvas& canvas, const StageRecord& r, double u) {
  const float segment_colour[] = {0.3f, 0.9f, 1.0f, 1.0f};
  const float point_colour[] = {1.0f, 1.0f, 1.0f, 1.0f};
  const float interior_colour[] = {1.0f, 0.55f, 0.1f, 1.0f};
  const auto& points = r.pslg.points;
  std::vector<char> on_segment(points.size(), 0);
  std::vector<float> xy;
  xy.reserve(r.pslg.segments.size() * 4);
  for (const cdt::Segment& s : r.pslg.segments) {
    if (s.a >= points.size() || s.b >= points.size()) throw Error("debug overlay: PSLG segment out of range");
    on_segment[s.a] = on_segment[s.b] = 1;
    xy.insert(xy.end(), {static_cast<float>(points[s.a].x), static_cast<float>(points[s.a].y),
                         static_cast<float>(points[s.b].x), static_cast<float>(points[s.b].y)});
  }
  canvas.segments(xy.data(), r.pslg.segments.size(), segment_colour, 0.9 * u);
  std::vector<float> linked, free;
  for (std::size_t i = 0; i < points.size(); ++i) {
    auto& into = on_segment[i] ? linked : free;
    into.push_back(static_cast<float>(points[i].x));
    into.push_back(static_cast<float>(points[i].y));
  }
  canvas.dots(linked.data(), linked.size() / 2, 0.7 * u, point_colour);
  canvas.dots(free.data(), free.size() / 2, 1.3 * u, interior_colour);
}

// Each edge once: from the triangle with the lower index, or from the only one on the hull.
template <typename Visit>
void for_each_edge(const cdt::Triangulation& t, Visit&& visit) {
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t other = k < t.neighbors.size() ? t.neighbors[k][i] : cdt::kNone;
      if (other != cdt::kNone && other < k) continue;
      const cdt::Point& a = t.vertices[t.triangles[k][(i + 1) % 3]];
      const cdt::Point& b = t.vertices[t.triangles[k][(i + 2) % 3]];
      visit(k, i, other, a, b);
    }
  }
}

void push_segment(std::vector<float>& xy, const cdt::Point& a, const cdt::Point& b) {
  xy.insert(xy.end(), {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(b.x),
                       static_cast<float>(b.y)});
}

void draw_cdt(OverlayCanvas& canvas, const StageRecord& r, double u) {
  check_triangulation(r);
  const cdt::Triangulation& t = r.triangulation;
  const float edge_colour[] = {0.92f, 0.92f, 0.92f, 0.6f};
  const float constraint_colour[] = {1.0f, 0.2f, 0.25f, 1.0f};
  std::vector<float> plain, constraints;
  for_each_edge(t, [&](std::size_t k, int i, std::uint32_t, const cdt::Point& a, const cdt::Point& b) {
    const bool constrained = k < t.segment_of_edge.size() && t.segment_of_edge[k][i] != cdt::kNone;
    push_segment(constrained ? constraints : plain, a, b);
  });
  canvas.segments(plain.data(), plain.size() / 4, edge_colour, 0.45 * u);
  canvas.segments(constraints.data(), constraints.size() / 4, constraint_colour, 1.1 * u);
}

void fill_triangle(OverlayCanvas& canvas, const cdt::Triangulation& t, std::size_t k, const float rgba[4],
                   double seam) {
  float xy[6];
  for (int i = 0; i < 3; ++i) {
    xy[2 * i] = static_cast<float>(t.vertices[t.triangles[k][i]].x);
    xy[2 * i + 1] = static_cast<float>(t.vertices[t.triangles[k][i]].y);
  }
  canvas.fill_polygon(xy, 3, rgba, seam);
}

void draw_trixel_colours(OverlayCanvas& canvas, const StageRecord& r) {
  check_triangulation(r);
  const cdt::Triangulation& t = r.triangulation;
  if (r.trixels.size() != t.triangles.size())
    throw Error("debug overlay: trixel colours do not match the CDT");
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    const auto& c = r.trixels[k].rgba;
    const float rgba[] = {c[0], c[1], c[2], c[3]};
    // A thin stroke in the fill colour hides the anti-aliasing seams between adjacent triangles.
    fill_triangle(canvas, t, k, rgba, 0.35);
  }
}

void draw_trixel_groups(OverlayCanvas& canvas, const StageRecord& r, double u) {
  check_triangulation(r);
  const cdt::Triangulation& t = r.triangulation;
  const auto& region_of = r.regions.region_of_triangle;
  if (region_of.size() != t.triangles.size()) throw Error("debug overlay: the regions do not match the CDT");
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    const auto c = region_id_colour(region_of[k]);
    const float rgba[] = {c[0], c[1], c[2], 0.92f};
    fill_triangle(canvas, t, k, rgba, 0.35);
  }
  const float boundary_colour[] = {0.05f, 0.05f, 0.05f, 0.95f};
  std::vector<float> boundaries;
  for_each_edge(t, [&](std::size_t k, int, std::uint32_t other, const cdt::Point& a, const cdt::Point& b) {
    if (other == cdt::kNone || region_of[other] != region_of[k]) push_segment(boundaries, a, b);
  });
  canvas.segments(boundaries.data(), boundaries.size() / 4, boundary_colour, 0.9 * u);
}

void draw_polygons(OverlayCanvas& canvas, const StageRecord& r, double u) {
  const float outer_colour[] = {1.0f, 0.85f, 0.2f, 1.0f};
  const float hole_colour[] = {0.3f, 0.9f, 1.0f, 1.0f};
  const float transparent_colour[] = {0.75f, 0.75f, 0.75f, 0.8f};
  std::vector<float> xy;
  for (const RegionPolygon& polygon : r.polygons) {
    const bool transparent =
        polygon.region < r.regions.regions.size() && r.regions.regions[polygon.region].transparent;
    for (const Ring& ring : polygon.rings) {
      xy.clear();
      for (const cdt::Point& p : ring.points) {
        xy.push_back(static_cast<float>(p.x));
        xy.push_back(static_cast<float>(p.y));
      }
      const float* colour = transparent ? transparent_colour : ring.hole() ? hole_colour : outer_colour;
      canvas.polyline(xy.data(), static_cast<int>(ring.points.size()), true, colour, 0.9 * u,
                      transparent || ring.hole() ? 3.0 * u : 0.0);
    }
  }
}

} // namespace

void draw_debug_stage(OverlayCanvas& canvas, DebugStage stage, const StageRecord& record) {
  const double u = unit_for(canvas.width(), canvas.height());
  switch (stage) {
  case DebugStage::edges:
    draw_edges(canvas, record);
    break;
  case DebugStage::chains:
    draw_chains(canvas, record, u);
    break;
  case DebugStage::pslg:
    draw_pslg(canvas, record, u);
    break;
  case DebugStage::cdt:
    draw_cdt(canvas, record, u);
    break;
  case DebugStage::trixel_colours:
    draw_trixel_colours(canvas, record);
    break;
  case DebugStage::trixel_groups:
    draw_trixel_groups(canvas, record, u);
    break;
  case DebugStage::polygons:
    draw_polygons(canvas, record, u);
    break;
  }
}

void check_debug_folder(const fs::path& dir) {
  if (dir.empty()) throw FileError(dir, "empty debug folder name");
  std::error_code ec;
  // The folder itself, or the nearest existing folder above it, must be a directory.
  for (fs::path p = dir; !p.empty(); p = p.parent_path()) {
    const auto status = fs::status(p, ec);
    if (ec && status.type() != fs::file_type::not_found) {
      throw FileError(p, "cannot use it for the debug folder: " + ec.message());
    }
    if (fs::exists(status)) {
      if (!fs::is_directory(status)) {
        throw FileError(p, p == dir ? "exists and is not a directory; cannot write the debug folder there"
                                    : "is not a directory; cannot create the debug folder " + dir.string());
      }
      return;
    }
    if (p == p.parent_path()) return;
  }
}

namespace {

// Undoes a partly written folder: files written so far, then the directories this call created.
class FolderTransaction {
public:
  explicit FolderTransaction(fs::path dir) : dir_(std::move(dir)) {}
  ~FolderTransaction() {
    if (committed_) return;
    std::error_code ec;
    for (const fs::path& f : files_) fs::remove(f, ec);
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) fs::remove(*it, ec); // only if empty
  }
  FolderTransaction(const FolderTransaction&) = delete;
  FolderTransaction& operator=(const FolderTransaction&) = delete;

  // Creates dir (and missing parents), remembering which ones were new.
  void make_directory(const fs::path& dir) {
    std::vector<fs::path> missing;
    std::error_code ec;
    for (fs::path p = dir; !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
      missing.push_back(p);
      if (p == p.parent_path()) break;
    }
    for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
      if (!fs::create_directory(*it, ec) && ec) {
        throw FileError(*it, "cannot create the debug folder: " + ec.message());
      }
      created_.push_back(*it);
    }
    if (!fs::is_directory(dir, ec)) {
      throw FileError(dir, "exists and is not a directory; cannot write the debug folder there");
    }
  }
  void wrote(const fs::path& file) { files_.push_back(file); }
  std::vector<fs::path> commit() {
    committed_ = true;
    return files_;
  }

private:
  fs::path dir_;
  std::vector<fs::path> files_;
  std::vector<fs::path> created_;
  bool committed_ = false;
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool browser_shows(const fs::path& file) {
  const std::string ext = lower(file.extension().string());
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".gif" || ext == ".webp" || ext == ".bmp";
}

// Returns false when `to` is `from` itself (the input already sits in the folder).
bool copy_atomically(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  if (fs::exists(to, ec) && fs::equivalent(from, to, ec)) return false;
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  fs::path tmp = to;
  tmp += ".tmp-" + std::to_string(rng() % 1000000000);
  fs::copy_file(from, tmp, fs::copy_options::overwrite_existing, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw FileError(to, "cannot copy the input " + from.string() + " here: " + ec.message());
  }
  fs::rename(tmp, to, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw FileError(to, "cannot copy the input here: " + ec.message());
  }
  return true;
}

std::string json_escape(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || c == '<' || c == '>' || c == '&') {
      // <, > and & escaped too, so that the JSON can sit inside a <script> element as is.
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", u);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string layer_json(std::string_view key, std::string_view title, const std::string& file,
                       const std::string& overlay, bool visible, double opacity) {
  char number[16];
  std::snprintf(number, sizeof number, "%.2f", opacity);
  std::string j =
      "{\"key\":" + json_escape(key) + ",\"title\":" + json_escape(title) + ",\"file\":" + json_escape(file);
  if (!overlay.empty()) j += ",\"overlay\":" + json_escape(overlay);
  return j + ",\"visible\":" + (visible ? "true" : "false") + ",\"opacity\":" + number + "}";
}

} // namespace

std::vector<fs::path> write_debug_folder(const fs::path& dir, const Image& image, const StageRecord& record,
                                         std::string_view svg, const DebugOptions& options) {
  check_debug_folder(dir);
  // The page needs layers a browser draws: PDF overlays get PNG layers.
  const OverlayFormat layer_format =
      options.format == OverlayFormat::svg ? OverlayFormat::svg : OverlayFormat::png;
  const auto overlay_name = [&](DebugStage stage) {
    return std::string(debug_stage_names(stage).stem) + "." + overlay_extension(options.format);
  };
  const auto layer_name = [&](DebugStage stage) {
    return std::string("layers/") + debug_stage_names(stage).stem + "." + overlay_extension(layer_format);
  };
  // An input is never overwritten, even one kept in the debug folder under a name written here.
  if (!options.source.empty()) {
    std::vector<fs::path> targets{dir / "result.svg", dir / "regions.json", dir / "index.html",
                                  dir / "pslg.poly"};
    for (const DebugStage stage : kDebugStages) {
      targets.push_back(dir / overlay_name(stage));
      targets.push_back(dir / layer_name(stage));
    }
    std::error_code ec;
    for (const fs::path& target : targets) {
      if (fs::exists(target, ec) && fs::equivalent(target, options.source, ec)) {
        throw FileError(target, "is the input; refusing to overwrite it with the debug output");
      }
    }
  }
  FolderTransaction folder(dir);
  folder.make_directory(dir);
  folder.make_directory(dir / "layers");

  std::string layers = "[";

  fs::path input_file;
  if (!options.source.empty() && browser_shows(options.source)) {
    input_file = dir / ("input" + lower(options.source.extension().string()));
    // Never recorded as written when it is the input itself: a failure must not remove it.
    if (copy_atomically(options.source, input_file)) folder.wrote(input_file);
  } else {
    input_file = dir / "input.png";
    save_image_png(image, input_file);
    folder.wrote(input_file);
  }
  layers += layer_json("input", "Input", input_file.filename().string(), "", true, 0.55);

  for (const DebugStage stage : kDebugStages) {
    const DebugStageNames names = debug_stage_names(stage);
    OverlayCanvas canvas(image, options.dim);
    draw_debug_stage(canvas, stage, record);
    const std::string overlay = overlay_name(stage);
    const std::string layer = layer_name(stage);
    canvas.save(dir / overlay, options.format, OverlayBackground::dimmed_input);
    folder.wrote(dir / overlay);
    canvas.save(dir / layer, layer_format, OverlayBackground::none);
    folder.wrote(dir / layer);
    const bool visible = stage == DebugStage::cdt;
    layers += "," + layer_json(names.stem, names.title, layer, overlay, visible, 0.85);
  }

  // The PSLG as the cdt tool reads it (Triangle's .poly, coordinates to the bit): the CDT stage can be
  // rerun, benchmarked or checked on its own.
  cdt::io::Pslg pslg;
  pslg.points = record.pslg.points;
  pslg.segments = record.pslg.segments;
  cdt::io::write_poly(dir / "pslg.poly", pslg);
  folder.wrote(dir / "pslg.poly");

  write_file_atomically(dir / "result.svg", svg);
  folder.wrote(dir / "result.svg");
  layers += "," + layer_json("result", "Result SVG", "result.svg", "", false, 1.0) + "]";

  const std::string title = !options.title.empty()    ? options.title
                            : !options.source.empty() ? options.source.filename().string()
                                                      : std::string("image");
  const std::string data = detail::inspector_json(record, image.width, image.height, title, layers);
  write_file_atomically(dir / "regions.json", data);
  folder.wrote(dir / "regions.json");
  write_file_atomically(dir / "index.html", detail::inspector_html(title, data));
  folder.wrote(dir / "index.html");
  return folder.commit();
}

namespace detail {

namespace {

// Up to three decimals, trailing zeros dropped: polygon vertices sit on half-pixels or on split points.
void append_number(std::string& out, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  out += s;
}

} // namespace

std::string inspector_json(const StageRecord& record, int width, int height, std::string_view title,
                           std::string_view layers_json) {
  std::size_t edge_pixels = 0;
  for (const std::uint8_t on : record.edges.on) edge_pixels += on != 0;
  std::size_t constraint_edges = 0;
  for_each_edge(record.triangulation,
                [&](std::size_t k, int i, std::uint32_t, const cdt::Point&, const cdt::Point&) {
                  constraint_edges += k < record.triangulation.segment_of_edge.size() &&
                                      record.triangulation.segment_of_edge[k][i] != cdt::kNone;
                });
  std::string j;
  j.reserve(1024 + record.triangulation.vertices.size() * 24);
  j += "{\"version\":1,\"title\":" + json_escape(title) + ",\"width\":" + std::to_string(width) +
       ",\"height\":" + std::to_string(height);
  j += ",\"counts\":{\"edge_pixels\":" + std::to_string(edge_pixels) +
       ",\"chains\":" + std::to_string(record.chains.size()) +
       ",\"polylines\":" + std::to_string(record.polylines.size()) +
       ",\"points\":" + std::to_string(record.pslg.points.size()) +
       ",\"segments\":" + std::to_string(record.pslg.segments.size()) +
       ",\"triangles\":" + std::to_string(record.triangulation.triangles.size()) +
       ",\"constraint_edges\":" + std::to_string(constraint_edges) +
       ",\"regions\":" + std::to_string(record.regions.regions.size()) + "}";
  j += ",\"layers\":";
  j += layers_json;
  j += ",\"regions\":[";
  // Rings by region id (polygons are in increasing region id; a region may have none).
  std::vector<const RegionPolygon*> polygon_of(record.regions.regions.size(), nullptr);
  for (const RegionPolygon& p : record.polygons) {
    if (p.region < polygon_of.size()) polygon_of[p.region] = &p;
  }
  for (std::size_t id = 0; id < record.regions.regions.size(); ++id) {
    const Region& region = record.regions.regions[id];
    char colour[8];
    const auto byte = [](float v) {
      return static_cast<unsigned>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
    };
    std::snprintf(colour, sizeof colour, "#%02x%02x%02x", byte(region.rgb[0]) & 0xFFu,
                  byte(region.rgb[1]) & 0xFFu, byte(region.rgb[2]) & 0xFFu);
    if (id > 0) j += ",\n";
    j += "{\"id\":" + std::to_string(id) + ",\"colour\":\"" + colour + "\",\"area\":";
    append_number(j, region.area);
    j += ",\"triangles\":" + std::to_string(region.triangle_count) +
         ",\"transparent\":" + (region.transparent ? "true" : "false") + ",\"rings\":[";
    if (const RegionPolygon* polygon = polygon_of[id]; polygon != nullptr) {
      for (std::size_t r = 0; r < polygon->rings.size(); ++r) {
        j += r > 0 ? ",[" : "[";
        const auto& points = polygon->rings[r].points;
        for (std::size_t k = 0; k < points.size(); ++k) {
          if (k > 0) j += ',';
          append_number(j, points[k].x);
          j += ',';
          append_number(j, points[k].y);
        }
        j += ']';
      }
    }
    j += "]}";
  }
  j += "]}\n";
  return j;
}

} // namespace detail

} // namespace vectorize
