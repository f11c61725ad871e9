// ros2_peer: a plain rclcpp program that meets rosguard as any ROS 2 node would (tests/ros2/).
//
//   ros2_peer listen [--ns NS] [--active NAME]... [--pmc NAME]... [--command NAME]... --seconds S
//       subscribes to /NS/rosguard/NAME/{active,pmc,command} (std_msgs/msg/Bool,
//       rosguard_msgs/msg/PmcSample, rosguard_msgs/msg/Command) and prints one JSON line per
//       message, after a first line {"event": "ready"}; ends after S seconds or on SIGTERM.
//   ros2_peer signal [--ns NS] --name NAME [--jobs N] [--job-ms MS] [--gap-ms MS]
//                    [--wait-ms MS] [--subscribers K] [--die-in-job K] [--node NODE]
//       plays an RT node: waits until /NS/rosguard/NAME/active has K subscribers (default 1:
//       the controller; more where other programs listen to the topic too), then publishes
//       std_msgs/msg/Bool true / false around each of N jobs of MS each (a JSON line per message);
//       --die-in-job K: SIGKILLs itself right after job K's true (1-based), as a crash would.
//   ros2_peer graph [--ns NS] [--expect-topic NAME]... [--expect-node NAME]... --seconds S
//       prints the ROS 2 graph as this node sees it (get_topic_names_and_types(),
//       get_node_names(), and each expected node's publishers and subscriptions, as
//       `ros2 node info` shows them) as JSON, once every expected topic and node is there
//       (exit 0) or after S seconds (exit 1). Nodes are named in full: /ns/name.
//
// Every command takes ROS 2's own arguments after --ros-args (e.g. --enclave /planner), and
// ROS 2's environment (ROS_DOMAIN_ID, RMW_IMPLEMENTATION, ROS_SECURITY_*).
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <rclcpp/rclcpp.hpp>
#include <rosguard_msgs/msg/command.hpp>
#include <rosguard_msgs/msg/pmc_sample.hpp>
#include <set>
#include <std_msgs/msg/bool.hpp>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

struct Args {
  std::string command;
  std::string ns;
  std::string node;
  std::vector<std::string> active, pmc, cmd, expect_topics, expect_nodes;
  std::string name;
  int jobs = 1, job_ms = 100, gap_ms = 100, wait_ms = 10000, die_in_job = 0, subscribers = 1;
  double seconds = 10;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr, "ros2_peer: %s (see the comment at the top of ros2_peer.cpp)\n",
               why.c_str());
  std::exit(2);
}

Args parse(const std::vector<std::string>& argv) {
  if (argv.size() < 2) usage("name a command: listen, signal or graph");
  Args a;
  a.command = argv[1];
  for (std::size_t i = 2; i < argv.size(); ++i) {
    const std::string& k = argv[i];
    if (i + 1 >= argv.size()) usage("'" + k + "' needs a value");
    const std::string& v = argv[++i];
    const auto num = [&] { return std::atoi(v.c_str()); };
    if (k == "--ns")
      a.ns = v;
    else if (k == "--node")
      a.node = v;
    else if (k == "--active")
      a.active.push_back(v);
    else if (k == "--pmc")
      a.pmc.push_back(v);
    else if (k == "--command")
      a.cmd.push_back(v);
    else if (k == "--expect-topic")
      a.expect_topics.push_back(v);
    else if (k == "--expect-node")
      a.expect_nodes.push_back(v);
    else if (k == "--name")
      a.name = v;
    else if (k == "--jobs")
      a.jobs = num();
    else if (k == "--job-ms")
      a.job_ms = num();
    else if (k == "--gap-ms")
      a.gap_ms = num();
    else if (k == "--wait-ms")
      a.wait_ms = num();
    else if (k == "--die-in-job")
      a.die_in_job = num();
    else if (k == "--subscribers")
      a.subscribers = num();
    else if (k == "--seconds")
      a.seconds = std::atof(v.c_str());
    else
      usage("unknown option '" + k + "'");
  }
  return a;
}

std::string topic(const Args& a, const std::string& node, const char* leaf) {
  return a.ns + "/rosguard/" + node + "/" + leaf;
}

void line(const std::string& json) {
  std::printf("%s\n", json.c_str());
  std::fflush(stdout);
}

// CLOCK_MONOTONIC in ns (as rosguard's stamps), for a message's arrival.
std::string now_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::to_string(static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec);
}

std::string q(const std::string& s) {
  return "\"" + s + "\"";
}

// Every message as rosguard sent it, so that reliable delivery loses none.
rclcpp::QoS listen_qos() {
  return rclcpp::QoS(rclcpp::KeepLast(10000)).reliable();
}

int listen(const Args& a, const rclcpp::Node::SharedPtr& node) {
  std::vector<rclcpp::SubscriptionBase::SharedPtr> subs;
  for (const auto& n : a.active)
    subs.push_back(node->create_subscription<std_msgs::msg::Bool>(
        topic(a, n, "active"), listen_qos(), [n](const std_msgs::msg::Bool& m) {
          line("{\"topic\": \"active\", \"t_ns\": " + now_ns() + ", \"node\": " + q(n) +
               ", \"data\": " + (m.data ? "true" : "false") + "}");
        }));
  for (const auto& n : a.pmc)
    subs.push_back(node->create_subscription<rosguard_msgs::msg::PmcSample>(
        topic(a, n, "pmc"), listen_qos(), [n](const rosguard_msgs::msg::PmcSample& m) {
          std::string v;
          for (std::size_t i = 0; i < m.count && i < m.value.size(); ++i)
            v += (i ? ", " : "") + std::to_string(m.value[i]);
          line("{\"topic\": \"pmc\", \"t_ns\": " + now_ns() + ", \"node\": " + q(n) +
               ", \"entity\": " + std::to_string(m.entity) +
               ", \"stamp_ns\": " + std::to_string(m.stamp_ns) +
               ", \"count\": " + std::to_string(m.count) + ", \"value\": [" + v + "]}");
        }));
  for (const auto& n : a.cmd)
    subs.push_back(node->create_subscription<rosguard_msgs::msg::Command>(
        topic(a, n, "command"), listen_qos(), [n](const rosguard_msgs::msg::Command& m) {
          line("{\"topic\": \"command\", \"t_ns\": " + now_ns() + ", \"node\": " + q(n) +
               ", \"command\": " + std::to_string(m.command) +
               ", \"cause_ns\": " + std::to_string(m.cause_ns) + "}");
        }));
  line("{\"event\": \"ready\"}");
  rclcpp::executors::SingleThreadedExecutor exec;
  exec.add_node(node);
  const auto end = Clock::now() + std::chrono::duration<double>(a.seconds);
  while (rclcpp::ok() && Clock::now() < end)
    exec.spin_once(20ms);
  return 0;
}

int signal_jobs(const Args& a, const rclcpp::Node::SharedPtr& node) {
  if (a.name.empty()) usage("signal needs --name");
  auto pub = node->create_publisher<std_msgs::msg::Bool>(topic(a, a.name, "active"),
                                                         rclcpp::QoS(10).reliable());
  const auto deadline = Clock::now() + std::chrono::milliseconds(a.wait_ms);
  while (pub->get_subscription_count() < static_cast<std::size_t>(a.subscribers)) {
    if (Clock::now() > deadline || !rclcpp::ok()) {
      line("{\"event\": \"unmatched\", \"waited_ms\": " + std::to_string(a.wait_ms) + "}");
      return 1;
    }
    std::this_thread::sleep_for(5ms);
  }
  line("{\"event\": \"matched\", \"subscribers\": " +
       std::to_string(pub->get_subscription_count()) + "}");
  int sent = 0;
  for (int j = 1; j <= a.jobs && rclcpp::ok(); ++j) {
    std_msgs::msg::Bool m;
    m.data = true;
    pub->publish(m);
    ++sent;
    line("{\"event\": \"sent\", \"job\": " + std::to_string(j) + ", \"data\": true}");
    if (j == a.die_in_job) {
      pub->wait_for_all_acked(1s);  // the true is delivered; then a crash, no false
      line("{\"event\": \"killing itself\", \"job\": " + std::to_string(j) + "}");
      std::raise(SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(a.job_ms));
    m.data = false;
    pub->publish(m);
    ++sent;
    line("{\"event\": \"sent\", \"job\": " + std::to_string(j) + ", \"data\": false}");
    if (j < a.jobs) std::this_thread::sleep_for(std::chrono::milliseconds(a.gap_ms));
  }
  // Reliable delivery of the last message before the writer goes away.
  const bool acked = pub->wait_for_all_acked(2s);
  line("{\"event\": \"done\", \"sent\": " + std::to_string(sent) +
       ", \"acked\": " + (acked ? "true" : "false") + "}");
  return 0;
}

std::string names_and_types(const std::map<std::string, std::vector<std::string>>& m) {
  std::string out;
  for (const auto& [name, types] : m) {
    std::string ts;
    for (const auto& ty : types)
      ts += (ts.empty() ? "" : ", ") + q(ty);
    out += (out.empty() ? "" : ", ") + q(name) + ": [" + ts + "]";
  }
  return "{" + out + "}";
}

int graph(const Args& a, const rclcpp::Node::SharedPtr& node) {
  const auto end = Clock::now() + std::chrono::duration<double>(a.seconds);
  std::map<std::string, std::vector<std::string>> topics;
  std::vector<std::string> nodes;
  bool all = false;
  while (rclcpp::ok()) {
    topics = node->get_topic_names_and_types();
    nodes = node->get_node_names();
    const std::set<std::string> node_set(nodes.begin(), nodes.end());
    all = true;
    for (const auto& t : a.expect_topics)
      all = all && topics.count(t) > 0;
    for (const auto& n : a.expect_nodes)
      all = all && node_set.count(n) > 0;
    if (all || Clock::now() > end) break;
    std::this_thread::sleep_for(50ms);
  }
  std::string n;
  for (const auto& name : nodes)
    n += (n.empty() ? "" : ", ") + q(name);
  // What `ros2 node info` shows of each expected node: its topics, by the node's own GIDs.
  std::string info;
  auto graph = node->get_node_graph_interface();
  for (const auto& full : a.expect_nodes) {
    const auto slash = full.rfind('/');
    const std::string nns = slash == 0 ? "/" : full.substr(0, slash);
    const std::string nname = full.substr(slash + 1);
    std::string pubs = "{}", subs = "{}";
    try {
      pubs = names_and_types(graph->get_publisher_names_and_types_by_node(nname, nns));
      subs = names_and_types(graph->get_subscriber_names_and_types_by_node(nname, nns));
    } catch (const std::exception&) {
      // not in the graph (yet): left empty
    }
    info += (info.empty() ? "" : ", ") + q(full) + ": {\"publishers\": " + pubs +
            ", \"subscribers\": " + subs + "}";
  }
  line("{\"complete\": " + std::string(all ? "true" : "false") + ", \"topics\": " +
       names_and_types(topics) + ", \"nodes\": [" + n + "], \"node_info\": {" + info + "}}");
  return all ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args = rclcpp::init_and_remove_ros_arguments(argc, argv);
  const Args a = parse(args);
  const std::string name =
      a.node.empty() ? "rosguard_test_peer_" + std::to_string(::getpid()) : a.node;
  auto node = std::make_shared<rclcpp::Node>(name);
  int rc = 2;
  if (a.command == "listen")
    rc = listen(a, node);
  else if (a.command == "signal")
    rc = signal_jobs(a, node);
  else if (a.command == "graph")
    rc = graph(a, node);
  else
    usage("unknown command '" + a.command + "'");
  node.reset();
  rclcpp::shutdown();
  return rc;
}
