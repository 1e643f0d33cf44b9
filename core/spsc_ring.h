#pragma once

#include <atomic>
#include <cstddef>
#include <new>
#include <vector>

namespace occmap {

// A single-producer, single-consumer ring of pre-built slots (after rigtorp/SPSCQueue): the
// producer fills a slot in place and publishes it, the consumer reads it in place and releases it.
// Nothing is allocated, copied or locked after construction. The two indices live on separate cache
// lines and each side caches the other's index, so in the common case neither touches the other's
// line.
//
// One thread may call writeSlot()/commitWrite(), one other thread front()/pop(); no others.
template <typename T>
class SpscRing {
 public:
  // `capacity` usable slots, each made once by `make()`.
  template <typename Make>
  SpscRing(std::size_t capacity, Make make) {
    slots_.reserve(capacity + 1);  // one slot stays empty to tell full from empty
    for (std::size_t i = 0; i < capacity + 1; ++i) slots_.push_back(make());
  }
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;
  SpscRing(SpscRing&&) = delete;
  SpscRing& operator=(SpscRing&&) = delete;

  std::size_t capacity() const { return slots_.size() - 1; }

  // Producer: the slot to fill next, or nullptr when the ring is full (the consumer is behind).
  [[nodiscard]] T* writeSlot() noexcept {
    const std::size_t write = write_index_.load(std::memory_order_relaxed);
    const std::size_t next = advance(write);
    if (next == cached_read_index_) {
      cached_read_index_ = read_index_.load(std::memory_order_acquire);
      if (next == cached_read_index_) return nullptr;
    }
    return &slots_[write];
  }
  // Producer: publishes the slot writeSlot() returned (which must not have been nullptr).
  void commitWrite() noexcept {
    write_index_.store(advance(write_index_.load(std::memory_order_relaxed)),
                       std::memory_order_release);
  }

  // Consumer: the oldest published slot, or nullptr when there is none.
  [[nodiscard]] T* front() noexcept {
    const std::size_t read = read_index_.load(std::memory_order_relaxed);
    if (read == cached_write_index_) {
      cached_write_index_ = write_index_.load(std::memory_order_acquire);
      if (read == cached_write_index_) return nullptr;
    }
    return &slots_[read];
  }
  // Consumer: hands the slot front() returned back to the producer.
  void pop() noexcept {
    read_index_.store(advance(read_index_.load(std::memory_order_relaxed)),
                      std::memory_order_release);
  }
  // Consumer: published slots waiting, front() included.
  std::size_t size() const noexcept {
    const std::size_t write = write_index_.load(std::memory_order_acquire);
    const std::size_t read = read_index_.load(std::memory_order_relaxed);
    return write >= read ? write - read : write + slots_.size() - read;
  }

 private:
  std::size_t advance(std::size_t index) const noexcept {
    return index + 1 == slots_.size() ? 0 : index + 1;
  }

  static constexpr std::size_t kCacheLine = 64;
  std::vector<T> slots_;
  alignas(kCacheLine) std::atomic<std::size_t> write_index_{0};
  alignas(kCacheLine) std::size_t cached_read_index_ = 0;  // producer's view of read_index_
  alignas(kCacheLine) std::atomic<std::size_t> read_index_{0};
  alignas(kCacheLine) std::size_t cached_write_index_ = 0;  // consumer's view of write_index_
  char padding_[kCacheLine - sizeof(std::size_t)] = {};
};

}  // namespace occmap
