// Bounds-checked little-endian reading of a record-structured file (the bag and MCAP readers): every
// read checks the bytes left first, and a refusal names the file and the offset.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "pl/common/error.hpp"

namespace pl::bag {

class ByteReader {
 public:
  // `base`: the offset of bytes[0] in the file, for messages (a chunk's decompressed bytes: 0, and
  // `where` says "chunk at offset N").
  ByteReader(std::string_view bytes, const std::string& name, std::uint64_t base = 0, std::string where = {})
      : b_(bytes), name_(name), base_(base), where_(std::move(where)) {}

  std::size_t pos() const { return pos_; }
  std::size_t left() const { return b_.size() - pos_; }
  bool done() const { return pos_ >= b_.size(); }
  void seek(std::size_t p) {
    if (p > b_.size()) fail("offset " + std::to_string(p) + " lies beyond the end (" + std::to_string(b_.size()) + " bytes)");
    pos_ = p;
  }

  template <typename T>
  T get(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));  // the host is little-endian (x86-64, arm64)
    pos_ += sizeof(T);
    return v;
  }
  std::uint8_t u8(const char* what) { return get<std::uint8_t>(what); }
  std::uint16_t u16(const char* what) { return get<std::uint16_t>(what); }
  std::uint32_t u32(const char* what) { return get<std::uint32_t>(what); }
  std::uint64_t u64(const char* what) { return get<std::uint64_t>(what); }
  std::int64_t i64(const char* what) { return get<std::int64_t>(what); }
  std::string_view bytes(std::uint64_t n, const char* what) {
    need(n, what);
    std::string_view v = b_.substr(pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return v;
  }
  void need(std::uint64_t n, const char* what) const {
    if (n > left())
      fail(std::string(what) + " needs " + std::to_string(n) + " bytes, " + std::to_string(left()) +
           " are left (the file is truncated or a length is damaged)");
  }
  // "FILE: offset N[ in WHERE]: PROBLEM"
  [[noreturn]] void fail(const std::string& problem) const { fail_at_offset(pos_, problem); }
  [[noreturn]] void fail_at_offset(std::size_t p, const std::string& problem) const {
    throw Error(name_ + ": offset " + std::to_string(base_ + p) + (where_.empty() ? "" : " in " + where_) + ": " + problem);
  }

 private:
  std::string_view b_;
  std::string name_;
  std::uint64_t base_;
  std::string where_;
  std::size_t pos_ = 0;
};

}  // namespace pl::bag
