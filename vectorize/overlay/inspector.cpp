// The inspector page: inspector.html (embedded at configure time) with the title and data filled in.
#include <string>
#include <string_view>

#include "vectorize/debug_overlays.hpp"

namespace vectorize::detail {

extern const char* const kInspectorPage; // inspector_page.cpp, generated from inspector.html

namespace {

std::string html_escape(std::string_view s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
    case '&':
      out += "&amp;";
      break;
    case '<':
      out += "&lt;";
      break;
    case '>':
      out += "&gt;";
      break;
    case '"':
      out += "&quot;";
      break;
    default:
      out += c;
    }
  }
  return out;
}

void replace_once(std::string& page, std::string_view placeholder, std::string_view value) {
  const auto at = page.find(placeholder);
  if (at != std::string::npos) page.replace(at, placeholder.size(), value);
}

} // namespace

std::string inspector_html(std::string_view title, std::string_view data_json) {
  std::string page = kInspectorPage;
  // The data placeholder comes after the title's in the page: filling it first means that neither
  // value can be taken for the other's placeholder.
  replace_once(page, "{{DATA}}", data_json);
  replace_once(page, "{{TITLE}}", html_escape(title));
  return page;
}

} // namespace vectorize::detail
