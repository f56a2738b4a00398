#include "vectorize/errors.hpp"

namespace vectorize {

FileError::FileError(std::filesystem::path path, const std::string& reason)
    : Error(path.string() + ": " + reason), path_(std::move(path)), reason_(reason) {}

} // namespace vectorize
