#pragma once
// A map from unsigned integer keys to values by linear probing in one array, with room for a given
// number of entries: for the host steps that look up tens of thousands of keys (cells, sites, edges),
// where a node-based map costs an allocation per entry and a sort costs more than the lookups.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace cdt::detail {

/// Key: an unsigned integer type; its largest value marks an empty slot and is never a key.
template <class Key, class Value>
class ProbeMap {
public:
  explicit ProbeMap(std::size_t entries) {
    std::size_t capacity = 16;
    while (capacity < 2 * entries) capacity *= 2;
    keys_.assign(capacity, kEmpty);
    values_.resize(capacity);
    mask_ = capacity - 1;
  }
  /// Sets key's value.
  void set(Key key, const Value& value) {
    const std::size_t i = slot(key);
    keys_[i] = key;
    values_[i] = value;
  }
  /// The value stored under key, or nullptr after storing `value` under it.
  Value* find_or_add(Key key, const Value& value) {
    const std::size_t i = slot(key);
    if (keys_[i] == key) return &values_[i];
    keys_[i] = key;
    values_[i] = value;
    return nullptr;
  }
  /// The value stored under key, or nullptr.
  Value* find(Key key) {
    const std::size_t i = slot(key);
    return keys_[i] == key ? &values_[i] : nullptr;
  }
  const Value* find(Key key) const { return const_cast<ProbeMap*>(this)->find(key); }

private:
  static constexpr Key kEmpty = std::numeric_limits<Key>::max();
  std::size_t slot(Key key) const {
    std::size_t i =
        static_cast<std::size_t>((static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull) >> 32) & mask_;
    while (keys_[i] != key && keys_[i] != kEmpty) i = (i + 1) & mask_;
    return i;
  }
  std::vector<Key> keys_;
  std::vector<Value> values_;
  std::size_t mask_ = 0;
};

} // namespace cdt::detail
