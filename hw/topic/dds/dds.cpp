#include "hw/topic/dds/dds.h"

#include <dlfcn.h>
#include <time.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>

namespace rosguard::dds {

namespace {

std::string fail_text(std::string_view what, std::string_view topic, dds_return_t rc) {
  std::string s(what);
  if (!topic.empty()) s += " (" + std::string(topic) + ")";
  s += ": ";
  s += dds_strretcode(rc);
  return s;
}

std::int64_t clock_ns(clockid_t id) {
  timespec ts{};
  ::clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// QoS of ROS 2's default profile: reliable, keep last `depth`, volatile.
struct Qos {
  explicit Qos(int depth) : q(dds_create_qos()) {
    dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  }
  ~Qos() { dds_delete_qos(q); }
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  dds_qos_t* q;
};

void check_ros_name(std::string_view name, std::string_view what) {
  const auto bad = [&](const char* why) {
    throw DdsError(std::string(what) + " '" + std::string(name) + "' is not a ROS 2 name: " + why);
  };
  if (name.empty() || name.front() != '/') bad("it must start with '/'");
  if (name.size() > 1 && name.back() == '/') bad("it must not end with '/'");
  for (std::size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (c == '/') {
      if (i + 1 < name.size() && name[i + 1] == '/') bad("empty token ('//')");
      if (i + 1 < name.size() && std::isdigit(static_cast<unsigned char>(name[i + 1])))
        bad("a token starts with a digit");
    } else if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) {
      bad("only letters, digits, '_' and '/' are allowed");
    }
  }
}

std::string rosguard_topic(std::string_view ns, std::string_view node, std::string_view leaf) {
  if (!ns.empty()) check_ros_name(ns, "namespace");
  std::string name = std::string(ns) + "/rosguard/" + std::string(node) + "/" + std::string(leaf);
  check_ros_name(name, "topic");
  return name;
}

}  // namespace

std::string dds_topic_name(std::string_view ros_name) {
  check_ros_name(ros_name, "topic");
  return "rt" + std::string(ros_name);
}

std::string dds_type_name(std::string_view ros_type) {
  // pkg/msg/Type -> pkg::msg::dds_::Type_
  const auto a = ros_type.find('/');
  const auto b = ros_type.rfind('/');
  if (a == std::string_view::npos || a == b)
    throw DdsError("'" + std::string(ros_type) + "' is not a ROS 2 type name (pkg/msg/Type)");
  return std::string(ros_type.substr(0, a)) +
         "::" + std::string(ros_type.substr(a + 1, b - a - 1)) +
         "::dds_::" + std::string(ros_type.substr(b + 1)) + "_";
}

std::string ros_node_name(std::string_view text) {
  std::string out;
  if (text.empty() || std::isdigit(static_cast<unsigned char>(text.front()))) out = "_";
  for (char c : text)
    out += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return out;
}

std::string rosguard_node_namespace(std::string_view ns) {
  if (!ns.empty()) check_ros_name(ns, "namespace");
  return std::string(ns) + "/rosguard";
}

std::string active_topic(std::string_view ns, std::string_view node) {
  return rosguard_topic(ns, node, "active");
}
std::string pmc_topic(std::string_view ns, std::string_view node) {
  return rosguard_topic(ns, node, "pmc");
}
std::string command_topic(std::string_view ns, std::string_view node) {
  return rosguard_topic(ns, node, "command");
}

std::uint32_t default_domain_id() {
  const char* env = std::getenv("ROS_DOMAIN_ID");
  if (!env || !*env) return 0;
  char* end = nullptr;
  const long v = std::strtol(env, &end, 10);
  // 232: the largest domain whose default UDP ports stay below 65535 (ROS 2's limit on Linux).
  if (*end != '\0' || v < 0 || v > 232)
    throw DdsError(std::string("ROS_DOMAIN_ID='") + env + "' is not a domain id in 0..232");
  return static_cast<std::uint32_t>(v);
}

namespace {

// Where Cyclone's security plugins are: beside libddsc, or in Debian's libddsc0debian/ there.
std::string security_plugin(const char* name) {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&dds_create_participant), &info) && info.dli_fname) {
    const std::string lib = info.dli_fname;
    const std::string dir = lib.substr(0, lib.rfind('/'));
    for (const std::string& d : {dir + "/libddsc0debian", dir}) {
      const std::string p = d + "/lib" + name + ".so";
      if (::access(p.c_str(), R_OK) == 0) return p;
    }
  }
  return name;  // found by name on the library path, or Cyclone says it is missing
}

std::string file_uri(const std::string& path, const char* what) {
  if (::access(path.c_str(), R_OK) != 0)
    throw DdsError(std::string("DDS Security: the ") + what + " '" + path +
                   "' cannot be read: " + std::strerror(errno));
  return "file:" + path;
}

}  // namespace

Participant::Participant(std::optional<std::uint32_t> domain_id, const Security* security,
                         std::optional<RosNode> node)
    : domain_(domain_id ? *domain_id : default_domain_id()), node_(std::move(node)) {
  if (node_) {
    check_ros_name(node_->ns, "node namespace");
    check_ros_name("/" + node_->name, "node name");
  }
  dds_qos_t* qos = dds_create_qos();
  // ROS 2's participant USER_DATA (rmw_cyclonedds_cpp): the security enclave, "/" by default.
  // ROS 2 programs count a participant into their graph by it.
  static constexpr char kEnclave[] = "enclave=/;";
  dds_qset_userdata(qos, kEnclave, sizeof kEnclave - 1);
  if (security) {
    const auto prop = [&](const char* k, const std::string& v) {
      dds_qset_prop(qos, k, v.c_str());
    };
    try {
      prop("dds.sec.auth.library.path", security_plugin("dds_security_auth"));
      prop("dds.sec.auth.library.init", "init_authentication");
      prop("dds.sec.auth.library.finalize", "finalize_authentication");
      prop("dds.sec.crypto.library.path", security_plugin("dds_security_crypto"));
      prop("dds.sec.crypto.library.init", "init_crypto");
      prop("dds.sec.crypto.library.finalize", "finalize_crypto");
      prop("dds.sec.access.library.path", security_plugin("dds_security_ac"));
      prop("dds.sec.access.library.init", "init_access_control");
      prop("dds.sec.access.library.finalize", "finalize_access_control");
      prop("dds.sec.auth.identity_ca", file_uri(security->identity_ca, "identity CA"));
      prop("dds.sec.auth.identity_certificate",
           file_uri(security->identity_certificate, "identity certificate"));
      prop("dds.sec.auth.private_key", file_uri(security->private_key, "private key"));
      prop("dds.sec.access.permissions_ca", file_uri(security->permissions_ca, "permissions CA"));
      prop("dds.sec.access.governance", file_uri(security->governance, "governance"));
      prop("dds.sec.access.permissions", file_uri(security->permissions, "permissions"));
    } catch (...) {
      dds_delete_qos(qos);
      throw;
    }
  }
  // Cyclone opens a domain's sockets with its first participant; later participants of the
  // domain share them, and the binding found then.
  static std::mutex bindings_lock;
  static std::map<std::uint32_t, ReceiveBinding> bindings;
  const std::lock_guard lock(bindings_lock);
  const UdpSockets before = udp_sockets();
  handle_ = dds_create_participant(domain_, qos, nullptr);
  dds_delete_qos(qos);
  if (handle_ < 0)
    throw DdsError(fail_text("dds_create_participant on domain " + std::to_string(domain_) +
                                 (security ? " with DDS Security (a certificate, key or signed "
                                             "document that does not verify?)"
                                           : ""),
                             "", handle_));
  bool found_new = false;
  binding_ = bind_new_receive_sockets(before, found_new);
  if (found_new)
    bindings[domain_] = binding_;
  else if (const auto it = bindings.find(domain_); it != bindings.end())
    binding_ = it->second;
  else
    binding_.text = "the domain's sockets were opened before, by no Participant of rosguard's";
  if (node_) {
    // As rmw_cyclonedds_cpp's discovery writer: reliable, transient-local, keep last 1, so a
    // ROS 2 program that starts later still learns of the node.
    discovery_topic_ =
        dds_create_topic(handle_, &rmw_dds_common_msg_dds__ParticipantEntitiesInfo__desc,
                         "ros_discovery_info", nullptr, nullptr);
    dds_qos_t* dq = dds_create_qos();
    dds_qset_reliability(dq, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(dq, DDS_HISTORY_KEEP_LAST, 1);
    dds_qset_durability(dq, DDS_DURABILITY_TRANSIENT_LOCAL);
    discovery_writer_ = discovery_topic_ < 0
                            ? discovery_topic_
                            : dds_create_writer(handle_, discovery_topic_, dq, nullptr);
    dds_delete_qos(dq);
    if (discovery_writer_ < 0) {
      const dds_return_t rc = discovery_writer_;
      dds_delete(handle_);
      throw DdsError(fail_text("the ROS 2 discovery writer", "ros_discovery_info", rc));
    }
    const std::lock_guard g(graph_lock_);
    announce();
  }
}

Participant::~Participant() {
  if (handle_ > 0) dds_delete(handle_);
}

namespace {

rmw_dds_common_msg_dds__Gid_ gid_of(const dds_guid_t& guid) {
  // Humble's rmw_cyclonedds_cpp: the GUID's 16 bytes, the rest of the 24 zero.
  rmw_dds_common_msg_dds__Gid_ g{};
  static_assert(sizeof g.data >= sizeof guid.v);
  std::memcpy(g.data, guid.v, sizeof guid.v);
  return g;
}

}  // namespace

void Participant::add_entity(const dds_guid_t& guid, bool writer) {
  if (!node_) return;
  const std::lock_guard g(graph_lock_);
  (writer ? writers_ : readers_).push_back(gid_of(guid));
  announce();
}

void Participant::remove_entity(const dds_guid_t& guid, bool writer) {
  if (!node_) return;
  const std::lock_guard g(graph_lock_);
  auto& v = writer ? writers_ : readers_;
  const rmw_dds_common_msg_dds__Gid_ gid = gid_of(guid);
  for (auto it = v.begin(); it != v.end(); ++it)
    if (std::memcmp(it->data, gid.data, sizeof gid.data) == 0) {
      v.erase(it);
      break;
    }
  announce();
}

void Participant::announce() {
  rmw_dds_common_msg_dds__NodeEntitiesInfo_ n{};
  std::snprintf(n.node_namespace, sizeof n.node_namespace, "%s", node_->ns.c_str());
  std::snprintf(n.node_name, sizeof n.node_name, "%s", node_->name.c_str());
  // Cyclone only reads the buffers while it serialises the sample in dds_write.
  const auto seq = [](std::vector<rmw_dds_common_msg_dds__Gid_>& v) {
    dds_sequence_rmw_dds_common_msg_dds__Gid_ s{};
    s._length = s._maximum = static_cast<std::uint32_t>(v.size());
    s._buffer = v.data();
    return s;
  };
  n.reader_gid_seq = seq(readers_);
  n.writer_gid_seq = seq(writers_);
  rmw_dds_common_msg_dds__ParticipantEntitiesInfo_ m{};
  dds_guid_t self{};
  dds_get_guid(handle_, &self);
  m.gid = gid_of(self);
  m.node_entities_info_seq._length = m.node_entities_info_seq._maximum = 1;
  m.node_entities_info_seq._buffer = &n;
  // A graph notice that fails to go out leaves ROS 2 tools with a stale node list, nothing
  // more: the topics themselves are unaffected, so it is not an error of the caller's.
  (void)dds_write(discovery_writer_, &m);
}

Endpoint::Endpoint(Participant& p, std::string ros_topic, const dds_topic_descriptor_t* desc,
                   bool writer, int depth, std::function<void()> on_data)
    : participant_(p),
      ros_topic_(std::move(ros_topic)),
      writer_(writer),
      on_data_(std::move(on_data)) {
  const std::string name = dds_topic_name(ros_topic_);
  // The descriptor's type name is the DDS form already (rosguard_msgs::msg::dds_::PmcSample_).
  topic_ = dds_create_topic(p.handle(), desc, name.c_str(), nullptr, nullptr);
  if (topic_ < 0) throw DdsError(fail_text("dds_create_topic", ros_topic_, topic_));
  Qos qos(depth);
  if (writer_) {
    entity_ = dds_create_writer(p.handle(), topic_, qos.q, nullptr);
  } else {
    dds_listener_t* l = nullptr;
    if (on_data_) {
      l = dds_create_listener(this);
      dds_lset_data_available(l, &Endpoint::on_data_available);
      dds_lset_subscription_matched(l, &Endpoint::on_matched);
    }
    entity_ = dds_create_reader(p.handle(), topic_, qos.q, l);
    if (l) dds_delete_listener(l);  // the reader keeps a copy
  }
  if (entity_ < 0) {
    const dds_return_t rc = entity_;
    entity_ = 0;
    dds_delete(topic_);
    throw DdsError(fail_text(writer_ ? "dds_create_writer" : "dds_create_reader", ros_topic_, rc));
  }
  dds_get_guid(entity_, &guid_);
  participant_.add_entity(guid_, writer_);
}

Endpoint::~Endpoint() {
  participant_.remove_entity(guid_, writer_);
  // Deleting the reader waits for a listener call in progress, so `this` outlives it.
  if (entity_ > 0) dds_delete(entity_);
  if (topic_ > 0) dds_delete(topic_);
}

void Endpoint::on_data_available(dds_entity_t, void* arg) {
  static_cast<Endpoint*>(arg)->on_data_();
}

void Endpoint::on_matched(dds_entity_t, dds_subscription_matched_status_t, void* arg) {
  static_cast<Endpoint*>(arg)->on_data_();
}

dds_instance_handle_t Endpoint::instance_handle() const {
  dds_instance_handle_t h = 0;
  const dds_return_t rc = dds_get_instance_handle(entity_, &h);
  if (rc < 0) throw DdsError(fail_text("dds_get_instance_handle", ros_topic_, rc));
  return h;
}

std::vector<dds_instance_handle_t> Endpoint::matched_writers() const {
  std::vector<dds_instance_handle_t> out(16);
  while (true) {
    const dds_return_t n = dds_get_matched_publications(entity_, out.data(), out.size());
    if (n < 0) throw DdsError(fail_text("dds_get_matched_publications", ros_topic_, n));
    if (static_cast<std::size_t>(n) <= out.size()) {
      out.resize(static_cast<std::size_t>(n));
      return out;
    }
    out.resize(static_cast<std::size_t>(n));  // more than we had room for: ask again
  }
}

std::string Endpoint::writer_guid(dds_instance_handle_t writer) const {
  dds_builtintopic_endpoint_t* e = dds_get_matched_publication_data(entity_, writer);
  if (!e) return {};
  static const char* hex = "0123456789abcdef";
  std::string s = "0x";
  for (unsigned char b : e->key.v) {
    s += hex[b >> 4];
    s += hex[b & 15];
  }
  dds_builtintopic_free_endpoint(e);
  return s;
}
std::uint32_t Endpoint::matched() const {
  if (writer_) {
    dds_publication_matched_status_t st{};
    if (dds_get_publication_matched_status(entity_, &st) < 0) return 0;
    return st.current_count;
  }
  dds_subscription_matched_status_t st{};
  if (dds_get_subscription_matched_status(entity_, &st) < 0) return 0;
  return st.current_count;
}

bool Endpoint::take_raw(void* sample, SampleOrigin* origin) {
  void* samples[1] = {sample};
  dds_sample_info_t info{};
  // Fixed-size types: the sample is filled in place, nothing to return to Cyclone.
  while (true) {
    const dds_return_t n = dds_take(entity_, samples, &info, 1, 1);
    if (n < 0) throw DdsError(fail_text("dds_take", ros_topic_, n));
    if (n == 0) return false;
    if (!info.valid_data) continue;  // a lifecycle notice (writer gone), not a message
    if (origin) *origin = {info.source_timestamp, info.publication_handle};
    return true;
  }
}

void Endpoint::write_raw(const void* sample) {
  const dds_return_t rc = dds_write(entity_, sample);
  if (rc < 0) throw DdsError(fail_text("dds_write", ros_topic_, rc));
}

std::int64_t realtime_to_monotonic_ns(std::int64_t realtime_ns) {
  const std::int64_t mono = clock_ns(CLOCK_MONOTONIC);
  const std::int64_t real = clock_ns(CLOCK_REALTIME);
  return realtime_ns - (real - mono);
}

}  // namespace rosguard::dds
