// The paper's experiments 1-3 (PMC callback, self-sampling overhead, activation delay) on
// rclcpp, in one process: an nRT node streaming bandwidth_read over 64 MB under an NrtGuard on
// the last usable CPU, a Controller on the first, and an RT node's RtJob. Prints one JSON object.
//
//   middleware_bench --sampling self|external --period-us N --seconds S
//                    --mode regulate|monitor|none [--costs]
//
// regulate: policy interval, threshold 20 % of the node's own rate measured alone just before
//           (its reference), regulation period max(5 ms, 5 sampling periods); RT jobs of 100 ms
//           with 20 ms between them, so THR comes often: activation delays.
// monitor:  policy monitor (sampling, no throttling), one RT job over the whole measurement:
//           the node's rate while sampled and the PMC thread's CPU time per period (overhead).
// none:     no controller, no RT job, no sampling timer: the node's baseline rate.
// --costs (regulate, self-sampling): also "costs_us", every sample of the sim's middleware costs
//           as rclcpp pays them here, keyed as a platform's "costs" (rosguard calibrate
//           --transport rclcpp reads them): pmc_callback (the counter read in the PMC callback),
//           publish (the callback's publish), message_latency (a sample's transit to the
//           controller's callback, less the median publish), controller_callback (the
//           controller's sample callback to its commands published), throttle_activation (CFB
//           took THR -> the THR callback entered, through the zero-time timer).
//
// The PMC thread's CPU time is read from /proc/self/task/<tid>/schedstat (the thread NrtGuard
// names "<name>-pmc"); NrtGuard does not expose it.
#include <dirent.h>
#include <rosguard/hw/common/clock.h>
#include <rosguard/hw/common/sys.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "rosguard_rclcpp/controller.hpp"
#include "rosguard_rclcpp/nrt_guard.hpp"
#include "rosguard_rclcpp/rt_job.hpp"
#include "rosguard_rclcpp/workload.hpp"
#include "stream_node.hpp"

namespace {

namespace hw = rosguard::hw;
using namespace rosguard_rclcpp;

bool wait_for(const std::function<bool()>& done, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

std::string stats_json(const std::vector<double>& v) {
  std::ostringstream o;
  o << "{\"p50\": " << quantile(v, 0.5) << ", \"min\": " << quantile(v, 0.0)
    << ", \"max\": " << quantile(v, 1.0) << ", \"n\": " << v.size() << "}";
  return o.str();
}

// The id of this process's thread named `name` (-1: none).
long find_thread(const std::string& name) {
  DIR* d = ::opendir("/proc/self/task");
  if (!d) return -1;
  long found = -1;
  while (auto* e = ::readdir(d)) {
    if (e->d_name[0] == '.') continue;
    std::ifstream f(std::string("/proc/self/task/") + e->d_name + "/comm");
    std::string comm;
    std::getline(f, comm);
    if (comm == name) {
      found = std::stol(e->d_name);
      break;
    }
  }
  ::closedir(d);
  return found;
}

// The thread's time on a CPU (ns; -1: unknown).
long long thread_cpu_ns(long tid) {
  if (tid < 0) return -1;
  std::ifstream f("/proc/self/task/" + std::to_string(tid) + "/schedstat");
  long long ns = -1;
  if (!(f >> ns)) return -1;
  return ns;
}

struct Args {
  std::string sampling = "self", mode = "regulate";
  bool costs = false;
  std::int64_t period_us = 1000;
  double seconds = 5.0;
};

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "middleware_bench: " << why
            << "\nusage: middleware_bench --sampling self|external --period-us N --seconds S "
               "--mode regulate|monitor|none [--costs]\n";
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--costs") {
      a.costs = true;
      continue;
    }
    if (i + 1 >= argc) usage("missing value of " + k);
    const std::string v = argv[++i];
    try {
      if (k == "--sampling")
        a.sampling = v;
      else if (k == "--mode")
        a.mode = v;
      else if (k == "--period-us")
        a.period_us = std::stoll(v);
      else if (k == "--seconds")
        a.seconds = std::stod(v);
      else
        usage("unknown option " + k);
    } catch (const std::logic_error&) {
      usage("bad value of " + k + ": " + v);
    }
  }
  if (a.sampling != "self" && a.sampling != "external") usage("--sampling: self or external");
  if (a.mode != "regulate" && a.mode != "monitor" && a.mode != "none")
    usage("--mode: regulate, monitor or none");
  if (a.period_us <= 0 || a.seconds <= 0) usage("--period-us and --seconds must be positive");
  if (a.costs && (a.mode != "regulate" || a.sampling != "self"))
    usage("--costs: with --mode regulate --sampling self");
  return a;
}

int run(const Args& a) {
  const auto cpus = hw::usable_cpus();
  if (cpus.size() < 2) {
    std::cerr << "middleware_bench: needs two usable CPUs\n";
    return 2;
  }
  const int control = cpus.front(), nrt = cpus.back();
  const auto sampling =
      a.sampling == "self" ? rosguard::Sampling::Self : rosguard::Sampling::External;
  const std::string ns = "/rgbench_" + std::to_string(::getpid());
  // none: no sampling at all (external: NrtGuard starts no PMC timer).
  StreamNode stream(ns, nrt, "auto", a.mode == "none" ? rosguard::Sampling::External : sampling,
                    a.period_us);
  if (!wait_for([&] { return stream.lines() > 0; }, std::chrono::seconds(10))) {
    std::cerr << "middleware_bench: the nRT node did not start\n";
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // warm up
  const auto rate_of = [&](std::chrono::milliseconds d) {
    const double l0 = stream.lines();
    const auto t0 = hw::now_ns();
    std::this_thread::sleep_for(d);
    return (stream.lines() - l0) / static_cast<double>(hw::now_ns() - t0);  // lines per ns
  };
  const auto mbps = [](double lines_per_ns) {
    return lines_per_ns * 64.0 * 1e9 / rosguard::kBytesPerMb;
  };
  const auto window = std::chrono::milliseconds(static_cast<long long>(a.seconds * 1000.0));

  std::ostringstream out;
  out << "{\"sampling\": \"" << a.sampling << "\", \"period_us\": " << a.period_us
      << ", \"mode\": \"" << a.mode << "\", \"seconds\": " << a.seconds << ", \"pmc_source\": \""
      << stream.guard->pmc_source() << "\"";

  if (a.mode == "none") {
    const double rate = rate_of(window);
    stream.stop();
    out << ", \"rate_mbps\": " << mbps(rate) << "}";
    std::cout << out.str() << std::endl;
    return 0;
  }

  const double alone = rate_of(std::chrono::milliseconds(300));
  ControllerOptions co;
  co.ns = ns;
  co.core = control;
  co.rt_nodes = {"rt"};
  co.nrt_nodes = {"stream"};
  co.policy = a.mode == "monitor" ? "monitor" : "interval";
  co.sampling = sampling;
  co.sampling_period_us = a.period_us;
  co.regulation_period_us = std::max<std::int64_t>(5000, 5 * a.period_us);
  co.threshold_pct = 20.0;
  co.reference_mbps = mbps(alone);
  auto cnode = std::make_shared<rclcpp::Node>("rosguard_controller", ns.substr(1));
  Controller controller(cnode, co);
  if (sampling == rosguard::Sampling::External)
    controller.set_counters(0, stream.guard->counters());
  controller.start();
  auto rnode = std::make_shared<rclcpp::Node>("rt", ns.substr(1));
  RtJob job(*rnode, "rt", ns);
  if (!wait_for([&] { return rnode->count_subscribers(job.topic()) > 0; },
                std::chrono::seconds(10)) ||
      !wait_for(
          [&] { return cnode->count_subscribers(rosguard_topic(ns, "stream", "command")) > 0; },
          std::chrono::seconds(10))) {
    std::cerr << "middleware_bench: the topics did not match\n";
    return 1;
  }
  const long pmc_tid = find_thread("stream-pmc");
  double rate = 0.0;
  long long pmc_cpu_ns = -1;
  double measured_ns = 0.0;
  std::uint64_t jobs = 0;
  if (a.mode == "monitor") {
    job.start();
    ++jobs;
    if (!wait_for([&] { return stream.guard->state() == rosguard::NodeState::On; },
                  std::chrono::seconds(5))) {
      std::cerr << "middleware_bench: the nRT node did not turn ON\n";
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const long long c0 = thread_cpu_ns(pmc_tid);
    const double l0 = stream.lines();
    const auto t0 = hw::now_ns();
    std::this_thread::sleep_for(window);
    const double l1 = stream.lines();
    const auto t1 = hw::now_ns();
    const long long c1 = thread_cpu_ns(pmc_tid);
    job.end();
    measured_ns = static_cast<double>(t1 - t0);
    rate = (l1 - l0) / measured_ns;
    if (c0 >= 0 && c1 >= 0) pmc_cpu_ns = c1 - c0;
  } else {
    const long long c0 = thread_cpu_ns(pmc_tid);
    const double l0 = stream.lines();
    const auto t0 = hw::now_ns();
    const auto end = t0 + static_cast<std::int64_t>(a.seconds * 1e9);
    while (hw::now_ns() < end) {
      {
        auto scope = job.scope();
        ++jobs;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const auto t1 = hw::now_ns();
    const double l1 = stream.lines();
    const long long c1 = thread_cpu_ns(pmc_tid);
    measured_ns = static_cast<double>(t1 - t0);
    rate = (l1 - l0) / measured_ns;
    if (c0 >= 0 && c1 >= 0) pmc_cpu_ns = c1 - c0;
  }
  wait_for([&] { return controller.counts().rt_ends == jobs; }, std::chrono::seconds(5));
  controller.stop();
  stream.stop();
  const auto s = stream.guard->stats();
  const auto c = controller.counts();
  const double periods = measured_ns / (static_cast<double>(a.period_us) * 1e3);
  out << ", \"alone_mbps\": " << mbps(alone) << ", \"rate_mbps\": " << mbps(rate)
      << ", \"pmc_callback_us\": " << stats_json(s.pmc_callbacks_us)
      << ", \"pmc_read_us\": " << stats_json(s.pmc_reads_us)
      << ", \"activation_delay_us\": " << stats_json(s.activation_delays_us)
      << ", \"sample_transit_us\": " << stats_json(controller.sample_latencies_us());
  if (pmc_cpu_ns >= 0 && sampling == rosguard::Sampling::Self)
    out << ", \"pmc_thread_cpu_us_per_period\": "
        << static_cast<double>(pmc_cpu_ns) / 1e3 / periods;
  else
    out << ", \"pmc_thread_cpu_us_per_period\": null";
  out << ", \"jobs\": " << jobs << ", \"thr\": " << c.thr << ", \"throttles\": " << s.throttles
      << ", \"samples\": " << c.samples;
  std::string fb;
  for (const auto& f : stream.guard->fallbacks())
    fb += (fb.empty() ? "" : "; ") + f;
  for (const auto& f : controller.fallbacks())
    fb += (fb.empty() ? "" : "; ") + f;
  std::string esc;
  for (char ch : fb) {
    if (ch == '"' || ch == '\\') esc += '\\';
    esc += ch;
  }
  out << ", \"fallbacks\": \"" << esc << "\"";
  if (a.costs) {
    const auto array = [](const std::vector<double>& v) {
      std::ostringstream o;
      o << "[";
      for (std::size_t i = 0; i < v.size(); ++i)
        o << (i ? ", " : "") << v[i];
      o << "]";
      return o.str();
    };
    std::vector<double> publish;
    for (std::size_t i = 0; i < s.pmc_callbacks_us.size() && i < s.pmc_reads_us.size(); ++i)
      publish.push_back(std::max(0.0, s.pmc_callbacks_us[i] - s.pmc_reads_us[i]));
    const double publish_p50 = quantile(publish, 0.5);
    std::vector<double> latency;
    for (double t : controller.sample_latencies_us())
      latency.push_back(std::max(0.0, t - publish_p50));
    out << ", \"costs_us\": {\"pmc_callback\": " << array(s.pmc_reads_us)
        << ", \"publish\": " << array(publish) << ", \"message_latency\": " << array(latency)
        << ", \"controller_callback\": " << array(controller.sample_callbacks_us())
        << ", \"throttle_activation\": " << array(s.thr_activations_us) << "}";
  }
  out << "}";
  std::cout << out.str() << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  rclcpp::init(argc, argv, rclcpp::InitOptions(), rclcpp::SignalHandlerOptions::None);
  int rc = 1;
  try {
    rc = run(a);
  } catch (const std::exception& e) {
    std::cerr << "middleware_bench: " << e.what() << "\n";
    rc = 1;
  }
  rclcpp::shutdown();
  return rc;
}
