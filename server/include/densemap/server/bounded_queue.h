// A bounded multi-producer queue with a configurable overflow policy: the producer waits for room, or the
// oldest item is dropped (and handed back so the caller can count and report it).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string_view>
#include "densemap/server/stage_options.h"

namespace densemap::server {

std::string_view toString(OverflowPolicy p);
std::optional<OverflowPolicy> parseOverflowPolicy(std::string_view s);

template <class T>
class BoundedQueue {
 public:
  /// `keep`: items the drop policy never drops (commands among scans); a full queue of them grows.
  BoundedQueue(std::size_t capacity, OverflowPolicy policy, std::function<bool(const T&)> keep = {})
      : capacity_(capacity == 0 ? 1 : capacity), policy_(policy), keep_(std::move(keep)) {}

  /// Adds an item. Under kDropOldest a full queue drops its oldest droppable item, which is returned.
  /// Under kWait the call blocks while the queue is full; once the queue is closed the item itself is
  /// returned unqueued.
  std::optional<T> push(T item) {
    std::unique_lock lock(mutex_);
    if (policy_ == OverflowPolicy::kWait) {
      not_full_.wait(lock, [&] { return items_.size() < capacity_ || closed_; });
    }
    if (closed_) return item;
    std::optional<T> dropped;
    if (items_.size() >= capacity_) {
      for (auto it = items_.begin(); it != items_.end(); ++it) {
        if (keep_ && keep_(*it)) continue;
        dropped = std::move(*it);
        items_.erase(it);
        break;
      }
    }
    items_.push_back(std::move(item));
    lock.unlock();
    not_empty_.notify_one();
    return dropped;
  }

  /// Removes the oldest item without waiting.
  std::optional<T> tryPop() {
    std::unique_lock lock(mutex_);
    return takeFront(lock);
  }

  /// Waits up to `timeout` for an item; nullopt on timeout or when closed and empty.
  template <class Rep, class Period>
  std::optional<T> pop(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock lock(mutex_);
    not_empty_.wait_for(lock, timeout, [&] { return !items_.empty() || closed_; });
    return takeFront(lock);
  }

  /// Wakes every waiter; producers stop waiting, consumers drain what is left.
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    not_full_.notify_all();
    not_empty_.notify_all();
  }

  bool closedAndEmpty() const {
    std::lock_guard lock(mutex_);
    return closed_ && items_.empty();
  }

  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }
  std::size_t capacity() const { return capacity_; }
  OverflowPolicy policy() const { return policy_; }

 private:
  /// Removes the front item (if any) under `lock`, then releases the lock and wakes one producer.
  std::optional<T> takeFront(std::unique_lock<std::mutex>& lock) {
    if (items_.empty()) return std::nullopt;
    std::optional<T> item(std::move(items_.front()));
    items_.pop_front();
    lock.unlock();
    not_full_.notify_one();
    return item;
  }

  const std::size_t capacity_;
  const OverflowPolicy policy_;
  const std::function<bool(const T&)> keep_;
  mutable std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::deque<T> items_;
  bool closed_ = false;
};

}  // namespace densemap::server
