// Publish-subscribe topics between nodes: the interface (Topic<T>) and the in-process transport
// (InprocTopic<T>); the DDS transport (DdsTopic<T>, hw/topic/dds_topic.h) implements the same
// interface over Cyclone DDS with ROS 2 naming.
//
// Contract (every transport):
// - Wiring first: add_publisher() and subscribe() are called on the engine's thread before any
//   node thread starts; the set of publishers and subscribers is then fixed.
// - publish(p, msg) may be called only by publisher p's thread; take(s, msg) only by subscriber
//   s's thread.
// - Delivery wakes the subscriber through its Waker (futex); a subscriber may share one Waker
//   between several topics and sleep on all of them at once. No transport sleep-polls.
// - A message that cannot be delivered (full ring, failed DDS write) is counted (dropped()) and
//   publish() returns false (the engine fails a point whose control topic dropped anything).
// - A message a subscriber does not accept (DDS: another process's writer on a topic of this
//   run, an undecodable message) is counted (ignored()) and skipped by take().
//
// InprocTopic: each (publisher, subscriber) pair has its own single-producer single-consumer
// ring, so a publisher preempted mid-publish (e.g. by the THR spinner of its own core) never
// blocks another publisher's messages, and no lock can cause priority inversion. Rings are sized
// so that a full one does not happen in a run.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "hw/topic/waker.h"

namespace rosguard::hw {

template <class T, std::size_t Capacity = 1024>
class SpscRing {
  static_assert((Capacity & (Capacity - 1)) == 0, "capacity must be a power of two");

 public:
  bool push(const T& v) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_.load(std::memory_order_acquire) == Capacity) return false;
    slots_[tail & (Capacity - 1)] = v;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }
  bool pop(T& v) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return false;
    v = slots_[head & (Capacity - 1)];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

 private:
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
  std::array<T, Capacity> slots_{};
};

template <class T>
class Topic {
 public:
  virtual ~Topic() = default;
  // Returns the publisher's slot (0, 1, ... in call order).
  virtual std::size_t add_publisher() = 0;
  virtual std::size_t subscribe(Waker& waker) = 0;
  virtual bool publish(std::size_t publisher, const T& msg) = 0;
  // Takes one message for `subscriber`; false when none is pending.
  virtual bool take(std::size_t subscriber, T& msg) = 0;
  virtual std::uint64_t dropped() const = 0;
  virtual std::uint64_t ignored() const = 0;
};

template <class T>
class InprocTopic final : public Topic<T> {
 public:
  std::size_t add_publisher() override {
    ++publishers_;
    rebuild();
    return publishers_ - 1;
  }
  std::size_t subscribe(Waker& waker) override {
    wakers_.push_back(&waker);
    next_.push_back(0);
    rebuild();
    return wakers_.size() - 1;
  }

  bool publish(std::size_t publisher, const T& msg) override {
    bool ok = true;
    for (std::size_t s = 0; s < wakers_.size(); ++s) {
      if (!ring(publisher, s).push(msg)) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        ok = false;
      }
      wakers_[s]->notify();
    }
    return ok;
  }

  // Takes one message for `subscriber`, visiting publishers round robin.
  bool take(std::size_t subscriber, T& msg) override {
    for (std::size_t i = 0; i < publishers_; ++i) {
      const std::size_t p = (next_[subscriber] + i) % publishers_;
      if (ring(p, subscriber).pop(msg)) {
        next_[subscriber] = (p + 1) % publishers_;
        return true;
      }
    }
    return false;
  }

  std::uint64_t dropped() const override { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t ignored() const override { return 0; }

 private:
  SpscRing<T>& ring(std::size_t p, std::size_t s) { return *rings_[p * wakers_.size() + s]; }
  void rebuild() {
    rings_.clear();
    for (std::size_t i = 0; i < publishers_ * wakers_.size(); ++i)
      rings_.push_back(std::make_unique<SpscRing<T>>());
  }

  std::size_t publishers_ = 0;
  std::vector<Waker*> wakers_;
  std::vector<std::size_t> next_;
  std::vector<std::unique_ptr<SpscRing<T>>> rings_;
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace rosguard::hw
