// An anonymous memory mapping advised to use transparent huge pages: the scan evidence is touched all over
// every scan, and 4 KiB pages make nearly every block access a TLB miss.
#pragma once

#include <cstddef>

namespace densemap::util {

class HugePageBuffer {
 public:
  HugePageBuffer() = default;
  /// Maps `bytes` (rounded up to 2 MiB) of zeroed memory; throws std::bad_alloc when the mapping fails.
  explicit HugePageBuffer(std::size_t bytes);
  ~HugePageBuffer();
  HugePageBuffer(HugePageBuffer&& o) noexcept;
  HugePageBuffer& operator=(HugePageBuffer&& o) noexcept;
  HugePageBuffer(const HugePageBuffer&) = delete;
  HugePageBuffer& operator=(const HugePageBuffer&) = delete;

  void* data() const { return data_; }
  std::size_t size() const { return size_; }

 private:
  void* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace densemap::util
