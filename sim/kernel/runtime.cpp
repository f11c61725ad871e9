#include "kernel/runtime.h"

#include <algorithm>
#include <cstdlib>

namespace rosguard::sim {

using sc_core::sc_time;

TimeNs now_ns() {
  return static_cast<TimeNs>(sc_core::sc_time_stamp().value() / 1000);
}

sc_time to_sc(TimeNs ns) {
  return sc_time(static_cast<double>(ns), sc_core::SC_NS);
}

Runtime::Runtime() {
  // Info reports (sc_stop's "Simulation stopped by user.") would land on the worker's stdout.
  sc_core::sc_report_handler::set_actions(sc_core::SC_INFO, sc_core::SC_DO_NOTHING);
}

void Runtime::stop() {
  if (stopped_) return;
  stopped_ = true;
  sc_core::sc_stop();
}

void Runtime::fail(std::exception_ptr e) {
  if (!failed_) error_ = e;
  failed_ = true;
  stop();
}

bool Runtime::run(TimeNs limit_ns) {
  sc_core::sc_start(to_sc(limit_ns));
  if (error_) std::rethrow_exception(error_);
  return stopped_;
}

Timer::Timer(const sc_core::sc_module_name& name, Runtime& rt, Fn fn)
    : sc_core::sc_module(name), rt_(rt), fn_(std::move(fn)) {
  SC_METHOD(fire);
  sensitive << ev_;
  dont_initialize();
}

void Timer::set(TimeNs at) {
  const TimeNs now = now_ns();
  at = std::max(at, now);
  ev_.cancel();
  at_ = at;
  if (at == now)
    ev_.notify(sc_core::SC_ZERO_TIME);
  else
    ev_.notify(to_sc(at - now));
}

void Timer::cancel() {
  ev_.cancel();
  at_ = -1;
}

void Timer::fire() {
  rt_.guarded([&] {
    const TimeNs now = now_ns();
    if (at_ < 0 || now < at_) return;  // cancelled, or superseded
    at_ = -1;
    fn_(now);
  });
}

MessageBus::MessageBus(const sc_core::sc_module_name& name, Runtime& rt)
    : sc_core::sc_module(name), rt_(rt) {
  SC_METHOD(deliver);
  sensitive << ev_;
  dont_initialize();
}

int MessageBus::add_link() {
  last_arrival_.push_back(0);
  return static_cast<int>(last_arrival_.size()) - 1;
}

TimeNs MessageBus::send(int link, TimeNs depart, TimeNs latency, Deliver deliver) {
  auto& last = last_arrival_.at(static_cast<std::size_t>(link));
  const TimeNs at = std::max(depart + latency, last);
  last = at;
  queue_.push({at, seq_++, std::move(deliver)});
  if (armed_ < 0 || at < armed_) {
    const TimeNs now = now_ns();
    ev_.cancel();
    armed_ = at;
    ev_.notify(at > now ? to_sc(at - now) : sc_core::SC_ZERO_TIME);
  }
  return at;
}

void MessageBus::deliver() {
  rt_.guarded([&] {
    const TimeNs now = now_ns();
    armed_ = -1;
    while (!queue_.empty() && queue_.top().at <= now) {
      Deliver d = std::move(const_cast<Item&>(queue_.top()).deliver);
      queue_.pop();
      d(now);
    }
    if (!queue_.empty()) {
      armed_ = queue_.top().at;
      ev_.notify(to_sc(armed_ - now));
    }
  });
}

}  // namespace rosguard::sim
