// Encoding values into a Buffer and back, for jobs and chunk results (distributor.h). Numbers
// are copied byte for byte, so doubles arrive bit-identical; every rank runs the same binary
// (same byte order and type sizes), as under `mpirun`.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "vinci/parallel/distributor.h"

namespace vinci::parallel {

/// Appends values to a Buffer.
class Writer {
 public:
  explicit Writer(Buffer* out) : out_(out) {}
  /// A trivially copyable value (number, bool, enum), its bytes as in memory.
  template <class T>
  void Put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "Put: trivially copyable values only");
    out_->append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  /// A string: its length (uint64) and bytes.
  void PutString(const std::string& s) {
    Put<std::uint64_t>(s.size());
    out_->append(s);
  }

 private:
  Buffer* out_;
};

/// Reads values in the order they were written. Reading past the end throws std::logic_error
/// (the two sides disagree on the format: a bug).
class Reader {
 public:
  explicit Reader(const Buffer& in) : in_(&in) {}
  template <class T>
  T Get() {
    static_assert(std::is_trivially_copyable_v<T>, "Get: trivially copyable values only");
    Need(sizeof(T));
    T v;
    std::memcpy(&v, in_->data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string GetString() {
    const auto n = Get<std::uint64_t>();
    Need(n);
    std::string s = in_->substr(pos_, n);
    pos_ += n;
    return s;
  }
  bool done() const { return pos_ == in_->size(); }

 private:
  void Need(std::uint64_t n) const {
    if (n > in_->size() - pos_)
      throw std::logic_error("parallel::Reader: message too short (" + std::to_string(n) +
                             " bytes wanted, " + std::to_string(in_->size() - pos_) + " left)");
  }
  const Buffer* in_;
  std::size_t pos_ = 0;
};

}  // namespace vinci::parallel
