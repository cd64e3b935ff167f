#pragma once
/// The engine's activations kept from one pair to the next. A Tensor's storage goes back to
/// this pool when the tensor dies, and a new Tensor takes the smallest kept buffer that fits
/// (and is at most twice its size). A kept buffer's pages are mapped already: from the second
/// pair on, the engine writes its activations without faulting their pages in again, which at
/// 256^2 was much of a pair's time (docs/performance.md, "Matcher"). Only buffers from 16 KB up
/// to the huge-page size (core/huge_pages.hpp, 8 MB) are kept: smaller ones cost the allocator
/// nothing, larger ones sit on huge pages (one fault per 2 MB) and keeping them doubled the peak
/// memory at 512^2 for no time. Bounded (256 MB by default; set_limit_bytes, 0 = keep nothing),
/// thread-safe; release() frees what it keeps.
#include <cstddef>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "gimm/core/huge_pages.hpp"

namespace gimm::nn {

class TensorPool {
 public:
  static constexpr std::size_t kMinFloats = 4096;  ///< 16 KB: smaller buffers are not kept
  /// Buffers of this many floats or more (on huge pages) are not kept either.
  static constexpr std::size_t kMaxFloats = kHugePageAdviceMinBytes / sizeof(float);

  /// The process's pool, the one every Tensor uses. Never destroyed: a static Tensor may die
  /// after any other static.
  static TensorPool& instance() {
    static TensorPool* pool = new TensorPool;
    return *pool;
  }

  /// An empty vector whose capacity is at least n (a kept buffer at most 2n), or an empty
  /// vector without storage when none fits.
  std::vector<float> take(std::size_t n) {
    if (n < kMinFloats || n >= kMaxFloats) return {};
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = kept_.lower_bound(n);
    if (it == kept_.end() || it->first > 2 * n) return {};
    std::vector<float> v = std::move(it->second);
    kept_.erase(it);
    bytes_ -= v.capacity() * sizeof(float);
    v.clear();
    return v;
  }

  /// Keeps `v`'s storage if it is large enough and fits under the limit; frees it otherwise
  /// (also when keeping it fails: called from destructors, it never throws).
  void give(std::vector<float>&& v) noexcept {
    const std::size_t cap = v.capacity();
    if (cap < kMinFloats || cap >= kMaxFloats) return;
    try {
      std::vector<float> kept = std::move(v);
      std::lock_guard<std::mutex> lock(mutex_);
      if (bytes_ + cap * sizeof(float) > limit_) return;  // `kept` frees its storage
      kept_.emplace(cap, std::move(kept));
      bytes_ += cap * sizeof(float);
    } catch (...) {
    }
  }

  /// Frees every kept buffer.
  void release() {
    std::multimap<std::size_t, std::vector<float>> gone;
    std::lock_guard<std::mutex> lock(mutex_);
    gone.swap(kept_);
    bytes_ = 0;
  }

  /// The most the pool keeps, in bytes; lowering it frees what is over.
  void set_limit_bytes(std::size_t limit) {
    std::lock_guard<std::mutex> lock(mutex_);
    limit_ = limit;
    while (bytes_ > limit_ && !kept_.empty()) {
      const auto largest = std::prev(kept_.end());
      bytes_ -= largest->first * sizeof(float);
      kept_.erase(largest);
    }
  }

  std::size_t bytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return bytes_;
  }

 private:
  TensorPool() = default;
  mutable std::mutex mutex_;
  std::multimap<std::size_t, std::vector<float>> kept_;  ///< by capacity (floats)
  std::size_t bytes_ = 0;
  std::size_t limit_ = std::size_t{256} << 20;
};

}  // namespace gimm::nn
