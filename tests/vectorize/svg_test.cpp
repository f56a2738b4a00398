#include "vectorize/svg.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "stage_test_util.hpp"
#include "vectorize/trixels.hpp"

namespace {

using trixel_test::triangulate_rectangle;

using vectorize::SvgOptions;

struct Element {
  std::string name;
  std::map<std::string, std::string> attributes;
};

// A small XML well-formedness check (enough for what write_svg emits): an optional declaration, then
// elements with quoted attributes, properly nested under one root, whitespace between them.
// Returns the start tags in document order; adds a failure and returns what it has on an error.
std::vector<Element> parse_xml(const std::string& text) {
  std::vector<Element> elements;
  std::vector<std::string> open;
  std::size_t i = 0;
  bool root_closed = false;
  const auto fail = [&](const std::string& why) {
    ADD_FAILURE() << "not well-formed at offset " << i << ": " << why;
    return elements;
  };
  if (text.rfind("<?xml", 0) == 0) {
    i = text.find("?>");
    if (i == std::string::npos) return fail("unterminated declaration");
    i += 2;
  }
  const auto is_name_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == ':' || c == '_';
  };
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
      continue;
    }
    if (text[i] != '<') return fail("text outside tags");
    ++i;
    const bool closing = i < text.size() && text[i] == '/';
    if (closing) ++i;
    std::string name;
    while (i < text.size() && is_name_char(text[i])) name += text[i++];
    if (name.empty()) return fail("missing element name");
    if (closing) {
      if (open.empty() || open.back() != name) return fail("mismatched </" + name + ">");
      open.pop_back();
      if (i >= text.size() || text[i] != '>') return fail("bad end tag");
      ++i;
      if (open.empty()) root_closed = true;
      continue;
    }
    if (root_closed || (open.empty() && !elements.empty())) return fail("second root element");
    Element element{name, {}};
    for (;;) {
      const std::size_t before = i;
      while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      if (i >= text.size()) return fail("unterminated tag");
      if (text[i] == '>' || text.compare(i, 2, "/>") == 0) break;
      if (i == before) return fail("no space before attribute");
      std::string attribute;
      while (i < text.size() && is_name_char(text[i])) attribute += text[i++];
      if (attribute.empty() || text.compare(i, 2, "=\"") != 0) return fail("bad attribute");
      i += 2;
      const std::size_t end = text.find('"', i);
      if (end == std::string::npos) return fail("unterminated attribute value");
      const std::string value = text.substr(i, end - i);
      if (value.find_first_of("<&") != std::string::npos) return fail("raw < or & in attribute");
      if (!element.attributes.emplace(attribute, value).second) return fail("repeated attribute");
      i = end + 1;
    }
    const bool empty = text[i] == '/';
    i += empty ? 2 : 1;
    if (!empty)
      open.push_back(name);
    else if (open.empty())
      root_closed = true;
    elements.push_back(std::move(element));
  }
  if (!open.empty()) return fail("unclosed <" + open.back() + ">");
  if (elements.empty()) return fail("no root element");
  return elements;
}

// Path data split into command letters and numbers (std::regex is avoided: GCC 12 warns inside it
// under sanitizer builds with -Werror).
std::vector<std::string> path_tokens(const std::string& d) {
  std::vector<std::string> tokens;
  const auto digit = [&](std::size_t i) {
    return i < d.size() && std::isdigit(static_cast<unsigned char>(d[i]));
  };
  for (std::size_t i = 0; i < d.size();) {
    if (std::isalpha(static_cast<unsigned char>(d[i]))) {
      tokens.emplace_back(1, d[i++]);
    } else if (d[i] == '-' || d[i] == '.' || digit(i)) {
      std::size_t end = i + (d[i] == '-' ? 1 : 0);
      while (digit(end)) ++end;
      if (end < d.size() && d[end] == '.') {
        ++end;
        while (digit(end)) ++end;
      }
      tokens.push_back(d.substr(i, end - i));
      i = end;
    } else {
      ++i; // separator
    }
  }
  return tokens;
}

// The numbers of path data, as written.
std::vector<std::string> path_numbers(const std::string& d) {
  std::vector<std::string> out;
  for (const auto& token : path_tokens(d))
    if (!std::isalpha(static_cast<unsigned char>(token[0]))) out.push_back(token);
  return out;
}

// Compact: digits with an optional fraction that does not end in 0, no leading zero (but "0" itself),
// no "-0", at most `decimals` decimals.
bool is_compact(const std::string& n, int decimals) {
  const std::size_t start = n.rfind('-', 0) == 0 ? 1 : 0;
  const std::size_t point = n.find('.');
  const std::string whole = n.substr(start, point == std::string::npos ? std::string::npos : point - start);
  const std::string fraction = point == std::string::npos ? "" : n.substr(point + 1);
  if (whole.empty() && fraction.empty()) return false;
  if (point != std::string::npos && (fraction.empty() || fraction.back() == '0')) return false;
  if (!whole.empty() && whole[0] == '0' && (whole.size() > 1 || !fraction.empty() || start == 1))
    return false;
  if (static_cast<int>(fraction.size()) > decimals) return false;
  const auto digits = [](const std::string& s) {
    return std::all_of(s.begin(), s.end(),
                       [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
  };
  return digits(whole) && digits(fraction);
}

// Path data back to absolute rings (M, l, h, v, z with implied repeats, as write_svg writes them).
std::vector<std::vector<cdt::Point>> parse_path(const std::string& d) {
  const std::vector<std::string> tokens = path_tokens(d);
  std::vector<std::vector<cdt::Point>> rings;
  char command = 0;
  double x = 0;
  double y = 0;
  for (std::size_t k = 0; k < tokens.size();) {
    if (std::isalpha(static_cast<unsigned char>(tokens[k][0]))) {
      command = tokens[k++][0];
      if (command == 'z' || command == 'Z') command = 0;
      continue;
    }
    const auto next = [&] { return std::stod(tokens.at(k++)); };
    switch (command) {
    case 'M':
      x = next();
      y = next();
      rings.push_back({{x, y}});
      command = 'L';
      break;
    case 'L':
      x = next();
      y = next();
      rings.back().push_back({x, y});
      break;
    case 'l':
      x += next();
      y += next();
      rings.back().push_back({x, y});
      break;
    case 'h':
      x += next();
      rings.back().push_back({x, y});
      break;
    case 'v':
      y += next();
      rings.back().push_back({x, y});
      break;
    default:
      ADD_FAILURE() << "number without a command in " << d;
      return rings;
    }
  }
  return rings;
}

double signed_area(const std::vector<cdt::Point>& ring) {
  double twice = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const auto& p = ring[i];
    const auto& q = ring[(i + 1) % ring.size()];
    twice += p.x * q.y - q.x * p.y;
  }
  return twice / 2;
}

std::vector<Element> paths_of(const std::vector<Element>& elements) {
  std::vector<Element> out;
  for (const auto& e : elements)
    if (e.name == "path") out.push_back(e);
  return out;
}

struct Scene {
  cdt::Triangulation t;
  vectorize::Regions regions;
  std::vector<vectorize::RegionPolygon> polygons;
};

// A random mesh with regions of a few colours (and optionally transparent ones), through stages 8-9.
Scene random_scene(unsigned seed, bool with_transparent) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0, 30);
  std::uniform_real_distribution<double> y(0, 20);
  std::vector<cdt::Point> points;
  for (int i = 0; i < 120; ++i) points.push_back({x(rng), y(rng)});
  Scene scene{triangulate_rectangle(30, 20, points), {}, {}};
  std::uniform_int_distribution<int> pick(0, with_transparent ? 3 : 2);
  const std::array<std::array<float, 4>, 4> palette = {
      {{1, 0, 0, 1}, {0.1f, 0.2f, 0.3f, 1}, {0, 1, 0, 1}, {0, 0, 0, 0}}};
  vectorize::TrixelColours trixels(scene.t.triangles.size());
  for (auto& trixel : trixels) {
    trixel.rgba = palette[pick(rng)];
    trixel.area = 1;
  }
  vectorize::GroupingOptions options;
  options.min_region_area = 0;
  scene.regions = vectorize::group_trixels(scene.t, trixels, options);
  scene.polygons = vectorize::trace_polygons(scene.t, scene.regions);
  return scene;
}

std::string to_svg(const Scene& scene, const SvgOptions& options = {}) {
  std::ostringstream out;
  vectorize::write_svg(out, scene.polygons, scene.regions, 30, 20, options);
  return out.str();
}

TEST(SvgNumbers, CompactDecimal) {
  EXPECT_EQ(vectorize::compact_decimal(150, 2), "1.5");
  EXPECT_EQ(vectorize::compact_decimal(-25, 2), "-.25");
  EXPECT_EQ(vectorize::compact_decimal(0, 2), "0");
  EXPECT_EQ(vectorize::compact_decimal(300, 2), "3");
  EXPECT_EQ(vectorize::compact_decimal(-1, 3), "-.001");
  EXPECT_EQ(vectorize::compact_decimal(1203, 3), "1.203");
  EXPECT_EQ(vectorize::compact_decimal(-7, 0), "-7");
  EXPECT_EQ(vectorize::compact_decimal(10, 0), "10");
  // Random values: compact and exact (read back to the same grid value).
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::int64_t> units(-2'000'000, 2'000'000);
  for (int i = 0; i < 2000; ++i) {
    const std::int64_t u = units(rng) / (i % 3 == 0 ? 1000 : 1);
    const int decimals = i % 5;
    const std::string n = vectorize::compact_decimal(u, decimals);
    EXPECT_TRUE(is_compact(n, decimals)) << n;
    EXPECT_EQ(std::llround(std::stod(n) * std::pow(10.0, decimals)), u) << n;
  }
}

// The checker the SVG tests rely on must itself reject what is not compact.
TEST(SvgNumbers, CompactChecker) {
  for (const char* good : {"0", "10", "-3", ".5", "-.25", "1.203"}) EXPECT_TRUE(is_compact(good, 3)) << good;
  for (const char* bad : {"0.5", "1.50", "-0", "01", "1.", "", "-", "1.2345", "-0.5"})
    EXPECT_FALSE(is_compact(bad, 3)) << bad;
}

TEST(SvgNumbers, Colour) {
  EXPECT_EQ(vectorize::svg_colour({1, 0, 0}), "#f00");
  EXPECT_EQ(vectorize::svg_colour({0.1f, 0.2f, 0.3f}), "#1a334d");
  EXPECT_EQ(vectorize::svg_colour({-1, 2, 0.5f}), "#00ff80");
}

TEST(Svg, WellFormedWithOnePathPerOpaqueRegion) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(seed);
    const auto scene = random_scene(seed, true);
    const auto elements = parse_xml(to_svg(scene));
    ASSERT_FALSE(elements.empty());
    EXPECT_EQ(elements[0].name, "svg");
    EXPECT_EQ(elements[0].attributes.at("viewBox"), "0 0 30 20");
    EXPECT_EQ(elements[0].attributes.at("width"), "30");
    EXPECT_EQ(elements[0].attributes.at("height"), "20");
    EXPECT_EQ(elements[0].attributes.at("xmlns"), "http://www.w3.org/2000/svg");
    std::size_t opaque = 0;
    for (const auto& region : scene.regions.regions) opaque += !region.transparent;
    ASSERT_LT(opaque, scene.regions.regions.size()) << "the scene should have transparent regions";
    EXPECT_EQ(paths_of(elements).size(), opaque);
  }
}

// Compact: no trailing zeros, no leading zero before the point, no "-0", at most `precision` decimals.
TEST(Svg, NumbersAreCompact) {
  const auto scene = random_scene(4, false);
  for (int precision : {0, 2, 4}) {
    SvgOptions options;
    options.precision = precision;
    const auto paths = paths_of(parse_xml(to_svg(scene, options)));
    ASSERT_FALSE(paths.empty());
    for (const auto& path : paths)
      for (const auto& n : path_numbers(path.attributes.at("d"))) EXPECT_TRUE(is_compact(n, precision)) << n;
  }
}

// The relative path data decode to the rounded vertices, and the decoded regions still tile the image.
TEST(Svg, PathDataDecodeToTheRoundedRings) {
  const auto scene = random_scene(5, false);
  const auto paths = paths_of(parse_xml(to_svg(scene)));
  ASSERT_EQ(paths.size(), scene.polygons.size());
  double total = 0;
  std::size_t rings = 0;
  for (const auto& path : paths) {
    for (const auto& ring : parse_path(path.attributes.at("d"))) {
      total += signed_area(ring);
      ++rings;
      for (const auto& p : ring) {
        EXPECT_NEAR(p.x * 100, std::round(p.x * 100), 1e-6); // on the 0.01 grid
        EXPECT_NEAR(p.y * 100, std::round(p.y * 100), 1e-6);
      }
    }
  }
  std::size_t expected_rings = 0;
  for (const auto& polygon : scene.polygons) expected_rings += polygon.rings.size();
  EXPECT_EQ(rings, expected_rings);
  EXPECT_NEAR(total, 600.0, 1e-6);
}

TEST(Svg, SeamStrokesLargestFirstAndCanBeTurnedOff) {
  const auto scene = random_scene(6, false);
  SvgOptions stroke;
  stroke.seams = vectorize::Seams::stroke;
  const auto elements = parse_xml(to_svg(scene, stroke));
  const auto paths = paths_of(elements);
  ASSERT_GE(paths.size(), 2u);
  bool group_found = false;
  for (const auto& e : elements)
    if (e.name == "g") {
      group_found = true;
      EXPECT_EQ(e.attributes.at("stroke-linejoin"), "round");
      EXPECT_EQ(e.attributes.at("stroke-width"), ".5");
    }
  EXPECT_TRUE(group_found);
  // Paths in decreasing area: compare each fill with the regions sorted by area.
  std::vector<const vectorize::Region*> by_area;
  for (const auto& polygon : scene.polygons) by_area.push_back(&scene.regions.regions[polygon.region]);
  std::stable_sort(by_area.begin(), by_area.end(), [](auto* a, auto* b) { return a->area > b->area; });
  for (std::size_t k = 0; k < paths.size(); ++k) {
    EXPECT_EQ(paths[k].attributes.at("stroke"), paths[k].attributes.at("fill"));
    EXPECT_EQ(paths[k].attributes.at("fill"), vectorize::svg_colour(by_area[k]->rgb));
  }

  SvgOptions options;
  options.seams = vectorize::Seams::none;
  const std::string plain = to_svg(scene, options);
  EXPECT_EQ(plain.find("stroke"), std::string::npos);
  EXPECT_EQ(plain.find("<use"), std::string::npos);
  EXPECT_EQ(paths_of(parse_xml(plain)).size(), paths.size());
}

// The default underlay: one <use> per path, in the same order, inside a group that strokes them in
// their own colour 3 px wide; the paths themselves are not stroked.
TEST(Svg, UnderlayDrawsEveryPathTwiceInOrder) {
  const auto scene = random_scene(6, false);
  const auto elements = parse_xml(to_svg(scene));
  const auto paths = paths_of(elements);
  ASSERT_GE(paths.size(), 2u);
  std::vector<std::string> uses;
  for (const auto& e : elements) {
    if (e.name == "g") {
      EXPECT_EQ(e.attributes.at("stroke"), "currentColor");
      EXPECT_EQ(e.attributes.at("stroke-width"), "3");
    }
    if (e.name == "use") uses.push_back(e.attributes.at("href"));
  }
  ASSERT_EQ(uses.size(), paths.size());
  std::set<std::string> ids;
  for (std::size_t k = 0; k < paths.size(); ++k) {
    EXPECT_EQ(uses[k], "#" + paths[k].attributes.at("id"));
    EXPECT_EQ(paths[k].attributes.at("color"), paths[k].attributes.at("fill"));
    EXPECT_EQ(paths[k].attributes.count("stroke"), 0u);
    ids.insert(paths[k].attributes.at("id"));
  }
  EXPECT_EQ(ids.size(), paths.size());
  EXPECT_EQ(vectorize::parse_seams("stroke"), vectorize::Seams::stroke);
  EXPECT_THROW(vectorize::parse_seams("thick"), std::invalid_argument);
}

// A translucent region (alpha from 0.5 to 0.75) is drawn with its opacity and left out of the underlay.
TEST(Svg, TranslucentRegionsKeepTheirOpacityAndStayOutOfTheUnderlay) {
  auto scene = random_scene(6, false);
  ASSERT_GE(scene.polygons.size(), 2u);
  const std::uint32_t translucent = scene.polygons[0].region;
  scene.regions.regions[translucent].alpha = 0.7f;
  const auto elements = parse_xml(to_svg(scene));
  const auto paths = paths_of(elements);
  std::size_t with_opacity = 0;
  std::string translucent_id;
  for (const auto& p : paths)
    if (p.attributes.count("opacity")) {
      ++with_opacity;
      EXPECT_EQ(p.attributes.at("opacity"), ".7");
      translucent_id = "#" + p.attributes.at("id");
    }
  EXPECT_EQ(with_opacity, 1u);
  std::size_t uses = 0;
  for (const auto& e : elements) {
    if (e.name != "use") continue;
    ++uses;
    EXPECT_NE(e.attributes.at("href"), translucent_id);
  }
  EXPECT_EQ(uses, paths.size() - 1);
}

// A region as translucent, but reaching into a solid pixel (a rim region averaging solid and
// anti-aliased pixels), is drawn solid: with opacity, the background would show through that pixel.
TEST(Svg, RegionsCoveringSolidPixelsAreDrawnSolid) {
  auto scene = random_scene(6, false);
  ASSERT_GE(scene.polygons.size(), 2u);
  auto& region = scene.regions.regions[scene.polygons[0].region];
  region.alpha = 0.6f;
  region.covers_solid = true;
  const auto elements = parse_xml(to_svg(scene));
  const auto paths = paths_of(elements);
  for (const auto& p : paths) EXPECT_EQ(p.attributes.count("opacity"), 0u);
  std::size_t uses = 0;
  for (const auto& e : elements) uses += e.name == "use" ? 1 : 0;
  EXPECT_EQ(uses, paths.size()); // in the underlay too
}

// With transparent regions, the underlay is masked off them: the mask is white, with each transparent
// region's polygon black, and the opaque paths are unchanged.
TEST(Svg, UnderlayIsMaskedOffTransparentRegions) {
  auto scene = random_scene(3, true);
  scene.polygons = vectorize::trace_polygons(scene.t, scene.regions, vectorize::TransparentRegions::include);
  std::size_t transparent = 0;
  for (const auto& polygon : scene.polygons)
    transparent += scene.regions.regions[polygon.region].transparent && !polygon.rings.empty();
  ASSERT_GT(transparent, 0u);
  const auto elements = parse_xml(to_svg(scene));
  std::size_t mask_paths = 0;
  std::size_t drawn_paths = 0;
  bool mask = false;
  bool masked_group = false;
  for (const auto& e : elements) {
    if (e.name == "mask") mask = true;
    if (e.name == "g" && e.attributes.count("mask")) {
      masked_group = true;
      EXPECT_EQ(e.attributes.at("mask"), "url(#opaque)");
    }
    if (e.name == "path") (e.attributes.count("fill") ? drawn_paths : mask_paths) += 1;
  }
  EXPECT_TRUE(mask);
  EXPECT_TRUE(masked_group);
  EXPECT_EQ(mask_paths, transparent);
  EXPECT_EQ(drawn_paths, scene.polygons.size() - transparent);
}

TEST(Svg, RejectsBadOptions) {
  const auto scene = random_scene(7, false);
  SvgOptions options;
  options.precision = 7;
  EXPECT_THROW(to_svg(scene, options), std::invalid_argument);
  options.precision = 2;
  options.seam_width = -1;
  EXPECT_THROW(to_svg(scene, options), std::invalid_argument);
}

// Stages 7-10 on a flat two-colour image whose colour boundary is a constraint: exactly two regions,
// each half the image, and an SVG with a red and a blue path.
TEST(SvgPipeline, TwoColourImageEndToEnd) {
  const int width = 20;
  const int height = 12;
  vectorize::Image image;
  image.width = width;
  image.height = height;
  image.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      float* p = image.pixel(x, y);
      p[0] = x < width / 2 ? 1.0f : 0.0f;
      p[1] = 0.0f;
      p[2] = x < width / 2 ? 0.0f : 1.0f;
      p[3] = 1.0f;
    }
  // The colour boundary, plus a few interior points so that each half has several triangles.
  std::vector<cdt::Point> points = {{10, 0}, {10, 12}, {3, 4}, {6, 9}, {14, 3}, {17, 8}, {12.5, 6.5}};
  const auto t = triangulate_rectangle(width, height, points, {{0, 1}});
  const auto trixels = vectorize::colour_trixels(image, t);
  const auto regions = vectorize::group_trixels(t, trixels);
  ASSERT_EQ(regions.regions.size(), 2u);
  const auto polygons = vectorize::trace_polygons(t, regions);
  ASSERT_EQ(polygons.size(), 2u);
  for (const auto& polygon : polygons) {
    double area = 0;
    for (const auto& ring : polygon.rings) area += ring.signed_area;
    EXPECT_NEAR(area, width * height / 2.0, 1e-9);
    EXPECT_NEAR(regions.regions[polygon.region].area, width * height / 2.0, 1e-9);
  }
  std::ostringstream out;
  vectorize::write_svg(out, polygons, regions, width, height);
  const std::string svg = out.str();
  const auto paths = paths_of(parse_xml(svg));
  ASSERT_EQ(paths.size(), 2u);
  std::vector<std::string> fills = {paths[0].attributes.at("fill"), paths[1].attributes.at("fill")};
  std::sort(fills.begin(), fills.end());
  EXPECT_EQ(fills, (std::vector<std::string>{"#00f", "#f00"}));

  // A second opinion on well-formedness where libxml2's xmllint is installed.
  if (std::filesystem::exists("/usr/bin/xmllint")) {
    trixel_test::ScratchDir dir;
    std::ofstream(dir / "out.svg") << svg;
    const auto result =
        trixel_test::run("/usr/bin/xmllint --noout " + trixel_test::shell_quote(dir / "out.svg"));
    EXPECT_EQ(result.exit_code, 0) << result.output;
  }
}

} // namespace
