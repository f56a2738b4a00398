#pragma once
// The input files of a peer CDT library's test suite (tests/data/cdt/artem-ogre-CDT: crossings,
// overlaps, hanging edges, duplicates), for tests that run every one of them.

#include <filesystem>
#include <string>

#include "cdt/io.hpp"

namespace trixel_test {

inline constexpr int kArtemOgreFiles = 36;

/// Calls f(name, pslg) for every file, name being the file's name; returns how many there were.
template <class F>
int for_each_artem_ogre_file(F&& f) {
  const std::filesystem::path dir = std::filesystem::path(TRIXEL_TEST_DATA_DIR) / "cdt" / "artem-ogre-CDT";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".txt") continue;
    ++files;
    f(entry.path().filename().string(), cdt::io::read_edge_list(entry.path()));
  }
  return files;
}

} // namespace trixel_test
