// The DDS transport: ROS 2 names and types, delivery that wakes the subscriber's futex (no
// polling), the three message kinds across the wire, and a plain Cyclone DDS subscriber (C API,
// ROS 2 topic and type names written out here, not taken from rosguard's helpers) that receives
// the samples, commands and enable / disable signals of a `rosguard run` in another process.
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "hw/common/clock.h"
#include "hw/nodes/messages.h"
#include "hw/topic/dds/cyclone_log.h"
#include "hw/topic/dds/dds.h"
#include "hw/topic/dds_topic.h"

using namespace rosguard;
using namespace rosguard::hw;

namespace {

// A namespace of this process alone: parallel tests on the same domain never meet.
std::string test_ns(const char* what) {
  return std::string("/rosguard_test_") + what + "_" + std::to_string(::getpid());
}

}  // namespace

TEST_CASE("dds: ROS 2 names: rt/ prefix, dds_ type names, names checked", "[hw][dds]") {
  CHECK(dds::dds_topic_name("/rosguard/nrt0/pmc") == "rt/rosguard/nrt0/pmc");
  CHECK(dds::dds_type_name("std_msgs/msg/Bool") == "std_msgs::msg::dds_::Bool_");
  CHECK(dds::pmc_topic("", "nrt0") == "/rosguard/nrt0/pmc");
  CHECK(dds::active_topic("/lab1", "planner") == "/lab1/rosguard/planner/active");
  CHECK(dds::command_topic("", "nrt_1") == "/rosguard/nrt_1/command");
  CHECK_THROWS_AS(dds::command_topic("", "nrt-1"), dds::DdsError);  // '-' is not ROS
  CHECK_THROWS_AS(dds::dds_topic_name("rosguard/x"), dds::DdsError);
  CHECK_THROWS_AS(dds::dds_topic_name("/rosguard//x"), dds::DdsError);
  CHECK_THROWS_AS(dds::dds_topic_name("/rosguard/0x"), dds::DdsError);
  CHECK_THROWS_AS(dds::pmc_topic("lab", "x"), dds::DdsError);
  // The generated descriptors carry exactly the names rmw_cyclonedds_cpp gives these messages.
  CHECK(std::string(dds::MsgTraits<dds::BoolMsg>::descriptor()->m_typename) ==
        "std_msgs::msg::dds_::Bool_");
  CHECK(std::string(dds::MsgTraits<dds::PmcSampleMsg>::descriptor()->m_typename) ==
        "rosguard_msgs::msg::dds_::PmcSample_");
  CHECK(std::string(dds::MsgTraits<dds::CommandMsg>::descriptor()->m_typename) ==
        "rosguard_msgs::msg::dds_::Command_");
  for (auto [ros, desc] : {std::pair{dds::MsgTraits<dds::BoolMsg>::ros_type,
                                     dds::MsgTraits<dds::BoolMsg>::descriptor()},
                           std::pair{dds::MsgTraits<dds::PmcSampleMsg>::ros_type,
                                     dds::MsgTraits<dds::PmcSampleMsg>::descriptor()},
                           std::pair{dds::MsgTraits<dds::CommandMsg>::ros_type,
                                     dds::MsgTraits<dds::CommandMsg>::descriptor()}})
    CHECK(dds::dds_type_name(ros) == desc->m_typename);
}

TEST_CASE("dds: ROS 2 node names: any text becomes a name token, rosguard's namespace",
          "[hw][dds]") {
  CHECK(dds::ros_node_name("run_two-core both") == "run_two_core_both");
  CHECK(dds::ros_node_name("7nodes") == "_7nodes");
  CHECK(dds::ros_node_name("") == "_");
  CHECK(dds::rosguard_node_namespace("") == "/rosguard");
  CHECK(dds::rosguard_node_namespace("/lab1") == "/lab1/rosguard");
  CHECK_THROWS_AS(dds::rosguard_node_namespace("lab1"), dds::DdsError);
  CHECK(std::string(rmw_dds_common_msg_dds__ParticipantEntitiesInfo__desc.m_typename) ==
        "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_");
  CHECK_THROWS_AS(dds::Participant(std::nullopt, nullptr, dds::RosNode{"/rosguard", "a-b"}),
                  dds::DdsError);
}

TEST_CASE(
    "dds: a participant announces its ROS 2 node on ros_discovery_info as rmw_cyclonedds "
    "does, with its readers and writers, again as they come and go",
    "[hw][dds]") {
  const std::string ns = test_ns("graph");
  dds::Participant p(std::nullopt, nullptr, dds::RosNode{dds::rosguard_node_namespace(ns), "n1"});
  // ROS 2's participant user data.
  dds_qos_t* q = dds_create_qos();
  REQUIRE(dds_get_qos(p.handle(), q) == DDS_RETCODE_OK);
  void* ud = nullptr;
  size_t udsz = 0;
  REQUIRE(dds_qget_userdata(q, &ud, &udsz));
  CHECK(std::string(static_cast<char*>(ud), udsz) == "enclave=/;");
  dds_free(ud);
  dds_delete_qos(q);

  // A reader as a ROS 2 program's: reliable, transient-local, on its own participant.
  const dds_entity_t other = dds_create_participant(p.domain_id(), nullptr, nullptr);
  REQUIRE(other > 0);
  const dds_entity_t topic =
      dds_create_topic(other, &rmw_dds_common_msg_dds__ParticipantEntitiesInfo__desc,
                       "ros_discovery_info", nullptr, nullptr);
  dds_qos_t* rq = dds_create_qos();
  dds_qset_reliability(rq, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(rq, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(rq, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t reader = dds_create_reader(other, topic, rq, nullptr);
  dds_delete_qos(rq);
  REQUIRE(reader > 0);
  dds_guid_t self{};
  dds_get_guid(p.handle(), &self);
  // The latest announcement of participant p (others on the domain are skipped).
  const auto latest = [&](std::size_t readers, std::size_t writers) {
    for (int i = 0; i < 400; ++i) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info{};
      bool found = false;
      while (dds_take(reader, samples, &info, 1, 1) == 1) {
        auto* m = static_cast<rmw_dds_common_msg_dds__ParticipantEntitiesInfo_*>(samples[0]);
        if (info.valid_data && std::memcmp(m->gid.data, self.v, sizeof self.v) == 0 &&
            m->node_entities_info_seq._length == 1) {
          const auto& n = m->node_entities_info_seq._buffer[0];
          found = n.reader_gid_seq._length == readers && n.writer_gid_seq._length == writers &&
                  std::string(n.node_namespace) == dds::rosguard_node_namespace(ns) &&
                  std::string(n.node_name) == "n1";
        }
        dds_return_loan(reader, samples, 1);
        if (found) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  };
  // (Whether the GIDs are the endpoints' own, as ROS 2 maps them to topics per node, is checked
  // against rclcpp in tests/ros2/graph.sh.)
  CHECK(latest(0, 0));  // the node alone, kept for a late reader (transient-local)
  {
    dds::Writer<dds::BoolMsg> w(p, dds::active_topic(ns, "planner"));
    dds::Reader<dds::CommandMsg> r(p, dds::command_topic(ns, "nrt0"));
    CHECK(latest(1, 1));
  }
  CHECK(latest(0, 0));  // gone again with its endpoints
  dds_delete(other);
}

TEST_CASE("dds: a participant binds its domain's receive sockets to the one configured interface",
          "[hw][dds]") {
  // Domain 230: a domain of this test alone, created here with the loopback configuration.
  const char* old = std::getenv("CYCLONEDDS_URI");
  const std::string saved = old ? old : "";
  const std::string uri =
      std::string("file://") + ROSGUARD_TEST_SOURCE_DIR + "/tests/hw/cyclonedds-loopback.xml";
  ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  const dds::UdpSockets before = dds::udp_sockets();
  {
    dds::Participant first(230);
    const dds::ReceiveBinding& b = first.receive_binding();
    INFO(b.text);
    CHECK(b.bound);
    CHECK(b.text.find("bound to lo") != std::string::npos);
    int wildcard = 0;
    for (const auto& [inode, fd] : dds::udp_sockets()) {
      if (before.count(inode)) continue;
      sockaddr_in a{};
      socklen_t len = sizeof a;
      REQUIRE(::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0);
      if (a.sin_family != AF_INET || a.sin_addr.s_addr != htonl(INADDR_ANY)) continue;
      ++wildcard;
      char device[IFNAMSIZ] = {};
      len = sizeof device;
      REQUIRE(::getsockopt(fd, SOL_SOCKET, SO_BINDTODEVICE, device, &len) == 0);
      CHECK(std::string(device) == "lo");
    }
    CHECK(wildcard >= 2);  // discovery and data
    // A second participant shares the domain's sockets, and says what was done to them.
    dds::Participant second(230);
    CHECK(second.receive_binding().bound);
    CHECK(second.receive_binding().text == b.text);
  }
  if (old)
    ::setenv("CYCLONEDDS_URI", saved.c_str(), 1);
  else
    ::unsetenv("CYCLONEDDS_URI");
}

TEST_CASE("dds: Cyclone's log lines of one kind are written at most once per interval",
          "[hw][dds]") {
  std::vector<std::string> lines;
  dds::LimitedCycloneLog log([&](const std::string& l) { lines.push_back(l); }, 10 * kNsPerS);
  // Junk datagrams: one kind whatever their dumps and numbers.
  for (int i = 0; i <= 500; ++i)
    log.take("q_receive.c", 2910,
             "malformed packet received from vendor 0.1 state parse:INFO_DST <5254 " +
                 std::to_string(i) + "> smid 0x" + std::to_string(i % 9),
             i * kNsPerMs);
  // A refused handshake: a kind per certificate subject.
  log.take("fsm.c", 7, "Begin handshake reply failed; subject: /CN=alpha", kNsPerS);
  log.take("fsm.c", 7, "Begin handshake reply failed; subject: /CN=beta", kNsPerS);
  log.take("fsm.c", 7, "Begin handshake reply failed; subject: /CN=beta", 2 * kNsPerS);
  REQUIRE(lines.size() == 3);
  CHECK(lines[0].rfind("cyclone: malformed packet received from vendor 0.1", 0) == 0);
  CHECK(lines[1] == "cyclone: Begin handshake reply failed; subject: /CN=alpha");
  CHECK(lines[2] == "cyclone: Begin handshake reply failed; subject: /CN=beta");
  log.take("q_receive.c", 2910,
           "malformed packet received from vendor 0.1 state parse:INFO_DST <00> smid 0x1",
           11 * kNsPerS);
  REQUIRE(lines.size() == 4);
  CHECK(lines[3] ==
        "cyclone: malformed packet received from vendor 0.1 state parse:INFO_DST <00> smid 0x1 "
        "(and 500 more like it in the last 11 s, not logged)");
  // Many kinds at once: at most kBurst lines per interval over all of them (the interval that
  // began with the line above, at 11 s).
  for (int i = 0; i < 50; ++i)
    log.take("fsm.c", 7,
             "subject: /CN=" + std::string(1, static_cast<char>('a' + i % 26)) +
                 std::string(1, static_cast<char>('a' + i / 26)),
             12 * kNsPerS);
  CHECK(lines.size() == 3 + dds::LimitedCycloneLog::kBurst);
  CHECK(log.written() == lines.size());
  CHECK(log.left_out() == 500 + 1 + 50 - (dds::LimitedCycloneLog::kBurst - 1));  // + beta again
}

TEST_CASE("dds: a topic wakes its subscriber's futex and carries every message kind",
          "[hw][dds][topic]") {
  dds::Participant participant;
  const std::string ns = test_ns("topic");
  DdsTopic<ControlMsg> control(participant, ns, {{"nrt0", 0}});
  DdsTopic<SampleMsg> samples(participant, ns, {{"nrt0", 0}, {"nrt1", 1}});
  DdsTopic<RtEventMsg> rt(participant, ns, {{"rt0", 0}, {"outside", 1}});
  CHECK(samples.ros_topic(1) == ns + "/rosguard/nrt1/pmc");
  Waker w;
  const auto cs = control.subscribe(w);
  const auto ss = samples.subscribe(w);
  const auto rs = rt.subscribe(w);
  const auto cp = control.add_publisher();
  const auto sp0 = samples.add_publisher();
  const auto sp1 = samples.add_publisher();
  const auto rp = rt.add_publisher();
  DdsTopic<ControlMsg> one_slot(participant, ns, {{"solo", 0}});
  one_slot.add_publisher();
  CHECK_THROWS_AS(one_slot.add_publisher(), RunError);

  // A subscriber thread asleep on the futex (no deadline: only a notify can wake it).
  std::atomic<int> got{0};
  std::vector<ControlMsg> commands;
  std::thread sub([&] {
    while (got.load() < 6) {
      const auto e = w.epoch();
      ControlMsg m;
      bool any = false;
      while (control.take(cs, m)) {
        commands.push_back(m);
        ++got;
        any = true;
      }
      if (!any) w.wait(e, -1);
    }
  });
  for (Command c : {Command::On, Command::Thr, Command::Replenish, Command::Off}) {
    CHECK(control.publish(cp, {ControlMsg::Kind::Command, c, 1234}));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // the subscriber goes to sleep
  }
  CHECK(control.publish(cp, {ControlMsg::Kind::Keepalive, Command::On, 0}));
  CHECK(control.publish(cp, {ControlMsg::Kind::Command, Command::Off, 0}));
  sub.join();
  REQUIRE(commands.size() == 6);
  CHECK(commands[0].command == Command::On);
  CHECK(commands[1].command == Command::Thr);
  CHECK(commands[1].t_cause == 1234);
  CHECK(commands[2].command == Command::Replenish);
  CHECK(commands[3].command == Command::Off);
  CHECK(commands[4].kind == ControlMsg::Kind::Keepalive);
  CHECK(control.dropped() == 0);

  SampleMsg s;
  s.entity = 1;
  s.t_published = 777;
  s.count = 2;
  s.counters[0] = {100, 5, 4};
  s.counters[1] = {200, 6, 6};
  CHECK(samples.publish(sp1, s));
  s.entity = 0;
  CHECK(samples.publish(sp0, s));
  std::vector<SampleMsg> got_samples;
  SampleMsg m;
  while (samples.take(ss, m))
    got_samples.push_back(m);
  REQUIRE(got_samples.size() == 2);
  for (const auto& g : got_samples) {
    CHECK(g.t_published == 777);
    CHECK(g.count == 2);
    CHECK(g.counters[0].value == 100);
    CHECK(g.counters[0].time_running_ns == 4);
    CHECK(g.counters[1].value == 200);
  }

  // The slot's key is the RT index; t is the publisher's stamp (DDS source time) on this host's
  // CLOCK_MONOTONIC.
  const TimeNs before = now_ns();
  CHECK(rt.publish(rp, {0, true, before}));
  const TimeNs after = now_ns();
  RtEventMsg ev;
  REQUIRE(rt.take(rs, ev));
  CHECK(ev.rt == 0);
  CHECK(ev.started);
  CHECK(ev.t >= before - 100 * kNsPerUs);  // two clock reads apart
  CHECK(ev.t <= after + 100 * kNsPerUs);

  // Another writer (another process in the field) on the second slot's topic: index 1.
  dds::Writer<dds::BoolMsg> outside(participant, ns + "/rosguard/outside/active");
  outside.write(dds::BoolMsg{false});
  REQUIRE(rt.take(rs, ev));
  CHECK(ev.rt == 1);
  CHECK_FALSE(ev.started);
}

namespace {

struct Collected {
  std::mutex mu;
  std::vector<rosguard_msgs_msg_dds__PmcSample_> pmc;
  std::vector<std::uint8_t> commands;
  std::vector<bool> active;
};

// Listener callbacks of the plain subscriber: take everything there is.
template <class Msg, class Store>
void take_all(dds_entity_t reader, Store store) {
  Msg m{};
  void* buf[1] = {&m};
  dds_sample_info_t info;
  while (dds_take(reader, buf, &info, 1, 1) > 0)
    if (info.valid_data) store(m);
}

void on_pmc(dds_entity_t reader, void* arg) {
  auto* c = static_cast<Collected*>(arg);
  take_all<rosguard_msgs_msg_dds__PmcSample_>(reader, [&](const auto& m) {
    std::lock_guard lock(c->mu);
    c->pmc.push_back(m);
  });
}
void on_command(dds_entity_t reader, void* arg) {
  auto* c = static_cast<Collected*>(arg);
  take_all<rosguard_msgs_msg_dds__Command_>(reader, [&](const auto& m) {
    std::lock_guard lock(c->mu);
    c->commands.push_back(m.command);
  });
}
void on_active(dds_entity_t reader, void* arg) {
  auto* c = static_cast<Collected*>(arg);
  take_all<std_msgs_msg_dds__Bool_>(reader, [&](const auto& m) {
    std::lock_guard lock(c->mu);
    c->active.push_back(m.data);
  });
}

}  // namespace

TEST_CASE("dds: a plain Cyclone DDS subscriber with ROS 2 names receives a run's samples",
          "[hw][dds][integration]") {
  namespace fs = std::filesystem;
  const std::string ns = test_ns("plain");
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-dds-plain-" + std::to_string(getpid()));
  fs::create_directories(dir);
  // 3 RT jobs released every 400 ms: discovery between the two processes takes a few ms to
  // tens of ms, so the later jobs' traffic is seen whole.
  const std::string scenario = (dir / "plain.json").string();
  std::ofstream(scenario) << R"({
  "$schema": ")" << ROSGUARD_TEST_SOURCE_DIR
                          << R"(/scenarios/schema/scenario.schema.json",
  "name": "hw-test-dds-plain", "platform": "vm-2core", "backend": "hw", "repetitions": 1,
  "nodes": {
    "controller": { "core": 1 },
    "rt": [ { "name": "rt0", "core": 0, "iterations": 3, "period_us": 400000,
              "workload": { "name": "bandwidth_read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 30 } } } ],
    "nrt": [ { "name": "nrt0", "core": 1,
               "workload": { "name": "bandwidth_read_64m", "hw": { "kernel": "bandwidth_read", "working_set_kb": 65536, "passes": 5 } } } ]
  },
  "regulation": { "policy": "interval", "sampling": "self", "sampling_period_us": 1000,
                  "regulation_period_us": 5000, "threshold_pct": 2 },
  "hw": { "pmc_source": "auto", "baseline_repetitions": 1, "transport": "dds",
          "dds": { "namespace": ")"
                          << ns << R"(" } }
})";

  // Both processes on the loopback interface with unicast discovery (no multicast needed); the
  // child inherits the variable.
  const std::string uri =
      std::string("file://") + ROSGUARD_TEST_SOURCE_DIR + "/tests/hw/cyclonedds-loopback.xml";
  ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  // The subscriber: Cyclone's C API only, names spelled out as a ROS 2 user would see them.
  Collected got;
  const dds_entity_t participant = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
  REQUIRE(participant > 0);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  const auto reader = [&](const dds_topic_descriptor_t* desc, const std::string& topic,
                          dds_on_data_available_fn fn) {
    const dds_entity_t t = dds_create_topic(participant, desc, topic.c_str(), nullptr, nullptr);
    REQUIRE(t > 0);
    dds_listener_t* l = dds_create_listener(&got);
    dds_lset_data_available(l, fn);
    const dds_entity_t r = dds_create_reader(participant, t, qos, l);
    dds_delete_listener(l);
    REQUIRE(r > 0);
  };
  const std::string dds_ns = "rt" + ns;  // "/x" -> "rt/x"
  REQUIRE(std::string(rosguard_msgs_msg_dds__PmcSample__desc.m_typename) ==
          "rosguard_msgs::msg::dds_::PmcSample_");
  reader(&rosguard_msgs_msg_dds__PmcSample__desc, dds_ns + "/rosguard/nrt0/pmc", on_pmc);
  reader(&rosguard_msgs_msg_dds__Command__desc, dds_ns + "/rosguard/nrt0/command", on_command);
  reader(&std_msgs_msg_dds__Bool__desc, dds_ns + "/rosguard/rt0/active", on_active);
  dds_delete_qos(qos);

  const std::string cmd = std::string(ROSGUARD_BINARY) + " run '" + scenario + "' --out '" +
                          (dir / "out").string() + "' --quiet > '" + (dir / "log").string() +
                          "' 2>&1";
  const int rc = std::system(cmd.c_str());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the last acknowledgements
  dds_delete(participant);  // waits for listener calls in progress
  std::ifstream log(dir / "log");
  const std::string log_text((std::istreambuf_iterator<char>(log)), {});
  INFO("rosguard run: " << log_text);
  REQUIRE(rc == 0);

  std::lock_guard lock(got.mu);
  WARN("plain subscriber got " << got.pmc.size() << " PmcSample, " << got.commands.size()
                               << " Command, " << got.active.size() << " Bool messages");
  // Self-sampling at 1 ms over 3 regulated jobs of about 100 ms (none while throttled, one or two
  // per 5 ms regulation period at least): many.
  REQUIRE(got.pmc.size() >= 20);
  for (std::size_t i = 0; i < got.pmc.size(); ++i) {
    const auto& p = got.pmc[i];
    CHECK(p.entity == 0);
    CHECK(p.count >= 1);
    CHECK(p.count <= 8);
    CHECK(p.stamp_ns > 0);
    if (i > 0) {
      CHECK(p.stamp_ns > got.pmc[i - 1].stamp_ns);   // one writer, reliable: in order
      CHECK(p.value[0] >= got.pmc[i - 1].value[0]);  // cumulative counters
    }
  }
  // ON, THR (threshold 2 %), OFF all appear; nothing outside the .msg constants.
  const auto has = [&](std::uint8_t c) {
    return std::find(got.commands.begin(), got.commands.end(), c) != got.commands.end();
  };
  CHECK(has(dds::command::kOn));
  CHECK(has(dds::command::kThr));
  CHECK(has(dds::command::kOff));
  for (auto c : got.commands)
    CHECK((c <= dds::command::kReplenish || c == dds::command::kKeepalive));
  CHECK(std::count(got.active.begin(), got.active.end(), true) >= 2);
  CHECK(std::count(got.active.begin(), got.active.end(), false) >= 2);
  fs::remove_all(dir);
}
