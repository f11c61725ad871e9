#include "hw/nodes/rt_node.h"

#include <sys/eventfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

#include "core/error.h"
#include "hw/common/clock.h"

namespace rosguard::hw {

RtRunner::RtRunner(const RtNodeSpec& spec, std::size_t index, SchedClass sched,
                   Topic<RtEventMsg>& topic, Waker& engine_waker, RtThread::ErrorHandler on_error,
                   TimeNs origin, bool trace)
    : spec_(spec),
      index_(index),
      sched_(sched),
      topic_(topic),
      pub_(topic.add_publisher()),
      engine_waker_(engine_waker),
      on_error_(std::move(on_error)),
      origin_(origin),
      track_(spec.name + " jobs"),
      trace_(trace) {
  if (!spec_.workload.is_command()) builtin_ = make_builtin_workload(spec_.workload);
  stop_fd_ = Fd(::eventfd(0, EFD_CLOEXEC));
  if (!stop_fd_.valid()) throw RunError("eventfd: " + errno_text(errno));
  jobs_us_.reserve(static_cast<std::size_t>(spec_.iterations));
  responses_us_.reserve(static_cast<std::size_t>(spec_.iterations));
}

RtRunner::~RtRunner() {
  shutdown();
}

void RtRunner::start() {
  thread_ = std::make_unique<RtThread>(
      ThreadSpec{spec_.name, spec_.core, sched_, prio::kRt}, [this] { main(); }, on_error_);
}

void RtRunner::go() {
  go_.store(true, std::memory_order_release);
  waker_.notify();
}

void RtRunner::shutdown() {
  if (shut_) return;
  shut_ = true;
  stop_.store(true, std::memory_order_release);
  const std::uint64_t one = 1;
  ssize_t n = ::write(stop_fd_.get(), &one, sizeof one);
  (void)n;
  waker_.notify();
  if (thread_) thread_->join();
}

void RtRunner::main() {
  struct DoneSignal {  // the engine hears about the end on every path, errors included
    RtRunner& r;
    ~DoneSignal() {
      r.done_.store(true, std::memory_order_release);
      r.engine_waker_.notify();
    }
  } done_signal{*this};
  while (!go_.load(std::memory_order_acquire)) {
    const auto epoch = waker_.epoch();
    if (stop_.load(std::memory_order_acquire)) return;
    if (go_.load(std::memory_order_acquire)) break;
    waker_.wait(epoch, -1);
  }
  std::vector<std::string> argv;
  if (!builtin_)
    for (const auto& a : spec_.workload.doc.at("command"))
      argv.push_back(a.get<std::string>());
  TimeNs release = now_ns();
  for (int job = 0; job < spec_.iterations && !stop_.load(std::memory_order_acquire); ++job) {
    if (const auto period = spec_.period_ns(); period && job > 0) {
      release += *period;
      sleep_until(release);
    }
    const TimeNs t0 = now_ns();
    topic_.publish(pub_, {index_, true, t0});
    published_.fetch_add(1, std::memory_order_acq_rel);
    if (builtin_) {
      builtin_->run(stop_, work_);
    } else {
      CommandProcess proc(argv, ThreadSpec{spec_.name + "-cmd", spec_.core, sched_, prio::kRt},
                          spec_.workload.doc.value("cwd", ""));
      proc.start();
      if (proc.wait(stop_fd_.get()) &&
          !(WIFEXITED(proc.status()) && WEXITSTATUS(proc.status()) == 0))
        throw RunError("RT node " + spec_.name + ": command '" + argv[0] + "' ended with " +
                       describe_status(proc.status()));
    }
    const TimeNs t1 = now_ns();
    topic_.publish(pub_, {index_, false, t1});
    published_.fetch_add(1, std::memory_order_acq_rel);
    if (stop_.load(std::memory_order_acquire)) break;  // an aborted job is not a measurement
    jobs_us_.push_back(ns_to_us(t1 - t0));
    // Without a period a job is released when it starts (right after the previous one).
    responses_us_.push_back(ns_to_us(t1 - (spec_.period_us ? release : t0)));
    trace_.span(t0 - origin_, t1 - origin_, spec_.core, &track_, "job");
  }
}

}  // namespace rosguard::hw
