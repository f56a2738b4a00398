#pragma once
// Errors of the vectorize pipeline. Every message names the file it is about and the reason.

#include <filesystem>
#include <stdexcept>
#include <string>

namespace vectorize {

/// Base of every error the pipeline throws.
class Error : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// The reason given for an image whose conversion ran out of memory.
inline constexpr const char* kOutOfMemory =
    "out of memory (a conversion needs about 64 bytes a pixel; --max-pixels refuses larger images)";

/// A file that cannot be read, decoded or written; what() is "<path>: <reason>".
class FileError : public Error {
public:
  FileError(std::filesystem::path path, const std::string& reason);
  const std::filesystem::path& path() const noexcept { return path_; }
  const std::string& reason() const noexcept { return reason_; }

private:
  std::filesystem::path path_;
  std::string reason_;
};

} // namespace vectorize
