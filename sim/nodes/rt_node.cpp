#include "nodes/rt_node.h"

#include "nodes/controller.h"

namespace rosguard::sim {

RtNodeModel::RtNodeModel(const sc_core::sc_module_name& name, RtNodeConfig config,
                         const WorkloadProfile& profile, const CostParams& costs,
                         std::uint64_t seed, Core& core, MessageBus& bus, Controller* controller,
                         Runtime& rt, Recorder& rec)
    : sc_core::sc_module(name),
      cfg_(std::move(config)),
      core_(core),
      bus_(bus),
      controller_(controller),
      rt_(rt),
      rec_(rec),
      latency_(controller ? costs.message_latency_between(core.id(), controller->core())
                          : costs.message_latency,
               stream_seed(seed, cfg_.name + "->controller")),
      link_(bus.add_link()),
      run_(profile),
      release_timer_("release", rt, [this](TimeNs t) { release(t); }) {}

void RtNodeModel::start(TimeNs now) {
  release(now);
}

void RtNodeModel::release(TimeNs now) {
  if (!running_) begin_job(now);
}

void RtNodeModel::begin_job(TimeNs now) {
  running_ = true;
  current_ = JobStats{};
  // Job k > 0 of a periodic node is released at k x period (the release timer's times); it
  // starts later when the previous job overran.
  current_.release =
      cfg_.period_ns && next_job_ > 0 ? static_cast<TimeNs>(next_job_) * *cfg_.period_ns : now;
  current_.start = now;
  start_pmu_ = core_.pmu();
  if (on_job_start_) on_job_start_(now);
  if (controller_) {
    Controller* ctl = controller_;
    const std::size_t rt = cfg_.index;
    bus_.send(link_, now, latency_.draw_ns(),
              [ctl, rt, from = core_.id()](TimeNs at) { ctl->enable(rt, at, from); });
  }
  run_.restart();
  core_.start_work(&run_, [this](TimeNs t) { job_done(t); });
}

void RtNodeModel::job_done(TimeNs now) {
  const Pmu& pmu = core_.pmu();
  current_.end = now;
  current_.cycles = pmu[PmuEvent::CpuCycles] - start_pmu_[PmuEvent::CpuCycles];
  current_.instructions = pmu[PmuEvent::InstRetired] - start_pmu_[PmuEvent::InstRetired];
  current_.l3_accesses = pmu.l3_accesses() - start_pmu_.l3_accesses();
  jobs_.push_back(current_);
  running_ = false;
  core_.stop_work();
  if (rec_.trace)
    rec_.trace->span(current_.start, now, core_.id(), cfg_.name + " jobs",
                     "job " + std::to_string(jobs_.size() - 1));
  if (controller_) {
    Controller* ctl = controller_;
    const std::size_t rt = cfg_.index;
    bus_.send(link_, now, latency_.draw_ns(),
              [ctl, rt, from = core_.id()](TimeNs at) { ctl->disable(rt, at, from); });
  }
  ++next_job_;
  if (next_job_ >= cfg_.iterations) {
    done_ = true;
    if (on_done_) on_done_(now);
    return;
  }
  const TimeNs next = cfg_.period_ns ? static_cast<TimeNs>(next_job_) * *cfg_.period_ns : now;
  if (next <= now)
    begin_job(now);
  else
    release_timer_.set(next);
}

}  // namespace rosguard::sim
