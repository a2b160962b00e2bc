// Little-endian byte writer and bounds-checked reader, private to drtv::formats.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace drtv::detail {

static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big);

template <class T>
T byteSwapIfBig(T v) {
  if constexpr (std::endian::native == std::endian::big && sizeof(T) > 1) {
    uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&v, b, sizeof(T));
  }
  return v;
}

class ByteWriter {
 public:
  explicit ByteWriter(std::vector<uint8_t>& out) : out_(out) {}
  template <class T>
  void put(T v) {
    v = byteSwapIfBig(v);
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    out_.insert(out_.end(), p, p + sizeof(T));
  }
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    out_.insert(out_.end(), b, b + n);
  }
  void zeros(size_t n) { out_.insert(out_.end(), n, 0); }
  size_t size() const { return out_.size(); }

 private:
  std::vector<uint8_t>& out_;
};

// Reads little-endian values; every read checks the remaining length first. After a failed read,
// ok() is false, offset() stays at the failing field and later reads return zeros.
class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> in) : in_(in) {}
  template <class T>
  bool get(T& v) {
    if (!ok_ || in_.size() - pos_ < sizeof(T)) { ok_ = false; v = T{}; return false; }
    std::memcpy(&v, in_.data() + pos_, sizeof(T));
    v = byteSwapIfBig(v);
    pos_ += sizeof(T);
    return true;
  }
  bool bytes(void* dst, size_t n) {
    if (!ok_ || in_.size() - pos_ < n) { ok_ = false; return false; }
    if (n > 0) std::memcpy(dst, in_.data() + pos_, n);  // dst may be null when n is 0 (an empty vector)
    pos_ += n;
    return true;
  }
  bool skip(size_t n) {
    if (!ok_ || in_.size() - pos_ < n) { ok_ = false; return false; }
    pos_ += n;
    return true;
  }
  bool ok() const { return ok_; }
  size_t offset() const { return pos_; }
  size_t remaining() const { return in_.size() - pos_; }

 private:
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace drtv::detail
