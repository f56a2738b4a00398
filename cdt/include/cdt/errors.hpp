#pragma once
// Typed errors of the CDT engine. Each carries the offending data so callers can report or repair it.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

namespace cdt {

/// Base of every error the engine throws.
class Error : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// The input violates a precondition (non-finite coordinate, index out of range, ...).
class InvalidInputError : public Error {
public:
  enum class Kind {
    non_finite_coordinate,
    coordinate_out_of_range,
    index_out_of_range,
    degenerate_segment,
    too_few_points,
    all_collinear,
  };
  InvalidInputError(Kind kind, std::uint64_t item, const std::string& message)
      : Error(message), kind_(kind), item_(item) {}
  Kind kind() const noexcept { return kind_; }
  /// The index of the offending point or segment.
  std::uint64_t item() const noexcept { return item_; }

private:
  Kind kind_;
  std::uint64_t item_;
};

/// Two input segments cross and the policy is CrossingSegments::reject.
class CrossingSegmentsError : public Error {
public:
  CrossingSegmentsError(std::uint32_t first, std::uint32_t second, const std::string& message)
      : Error(message), first_(first), second_(second) {}
  std::uint32_t first() const noexcept { return first_; }
  std::uint32_t second() const noexcept { return second_; }

private:
  std::uint32_t first_;
  std::uint32_t second_;
};

/// A malformed input file; line() is 1-based, 0 when the problem is not tied to one line.
class FileError : public Error {
public:
  FileError(std::string path, std::uint64_t line, const std::string& message)
      : Error(message), path_(std::move(path)), line_(line) {}
  const std::string& path() const noexcept { return path_; }
  std::uint64_t line() const noexcept { return line_; }

private:
  std::string path_;
  std::uint64_t line_;
};

/// The GPU backend failed: no device, not enough device memory, or a CUDA runtime error.
class DeviceError : public Error {
public:
  using Error::Error;
};

} // namespace cdt
