#include "hw/topic/dds/receive_binding.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <set>
#include <vector>

namespace rosguard::dds {

namespace {

bool is_wildcard(const sockaddr_storage& a) {
  if (a.ss_family == AF_INET)
    return reinterpret_cast<const sockaddr_in&>(a).sin_addr.s_addr == htonl(INADDR_ANY);
  const auto& a6 = reinterpret_cast<const sockaddr_in6&>(a);
  return IN6_IS_ADDR_UNSPECIFIED(&a6.sin6_addr);
}

int port_of(const sockaddr_storage& a) {
  return ntohs(a.ss_family == AF_INET ? reinterpret_cast<const sockaddr_in&>(a).sin_port
                                      : reinterpret_cast<const sockaddr_in6&>(a).sin6_port);
}

std::string address_text(const sockaddr_storage& a) {
  char buf[INET6_ADDRSTRLEN] = {};
  const void* p = a.ss_family == AF_INET
                      ? static_cast<const void*>(&reinterpret_cast<const sockaddr_in&>(a).sin_addr)
                      : &reinterpret_cast<const sockaddr_in6&>(a).sin6_addr;
  ::inet_ntop(a.ss_family, p, buf, sizeof buf);
  return buf;
}

// The interface that holds address `a`, or "".
std::string interface_of(const sockaddr_storage& a) {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return {};
  std::string name;
  for (const ifaddrs* i = list; i && name.empty(); i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != a.ss_family) continue;
    const bool same =
        a.ss_family == AF_INET
            ? reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr.s_addr ==
                  reinterpret_cast<const sockaddr_in&>(a).sin_addr.s_addr
            : std::memcmp(&reinterpret_cast<const sockaddr_in6*>(i->ifa_addr)->sin6_addr,
                          &reinterpret_cast<const sockaddr_in6&>(a).sin6_addr,
                          sizeof(in6_addr)) == 0;
    if (same) name = i->ifa_name;
  }
  ::freeifaddrs(list);
  return name;
}

std::string join(const std::set<std::string>& items) {
  std::string s;
  for (const auto& i : items)
    s += (s.empty() ? "" : ", ") + i;
  return s;
}

}  // namespace

UdpSockets udp_sockets() {
  UdpSockets out;
  DIR* dir = ::opendir("/proc/self/fd");
  if (!dir) return out;
  const int own = ::dirfd(dir);
  while (const dirent* e = ::readdir(dir)) {
    char* end = nullptr;
    const long fd = std::strtol(e->d_name, &end, 10);
    if (*end != '\0' || end == e->d_name || fd == own) continue;
    struct stat st {};
    if (::fstat(static_cast<int>(fd), &st) != 0 || !S_ISSOCK(st.st_mode)) continue;
    int type = 0, domain = 0;
    socklen_t len = sizeof type;
    if (::getsockopt(static_cast<int>(fd), SOL_SOCKET, SO_TYPE, &type, &len) != 0 ||
        type != SOCK_DGRAM)
      continue;
    len = sizeof domain;
    if (::getsockopt(static_cast<int>(fd), SOL_SOCKET, SO_DOMAIN, &domain, &len) != 0 ||
        (domain != AF_INET && domain != AF_INET6))
      continue;
    out.emplace(st.st_ino, static_cast<int>(fd));
  }
  ::closedir(dir);
  return out;
}

ReceiveBinding bind_new_receive_sockets(const UdpSockets& before, bool& found_new) {
  std::vector<int> receive;
  std::set<int> ports;
  std::set<std::string> interfaces, unknown;
  for (const auto& [inode, fd] : udp_sockets()) {
    if (before.count(inode)) continue;
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) continue;
    if (is_wildcard(a)) {
      receive.push_back(fd);
      ports.insert(port_of(a));
    } else if (const std::string i = interface_of(a); !i.empty()) {
      interfaces.insert(i);
    } else {
      unknown.insert(address_text(a));
    }
  }
  found_new = !receive.empty() || !interfaces.empty() || !unknown.empty();
  if (receive.empty()) return {true, "Cyclone opened no wildcard receive socket"};
  std::string port_list;
  for (int p : ports)
    port_list += (port_list.empty() ? "" : ", ") + std::to_string(p);
  const std::string sockets = "Cyclone's " + std::to_string(receive.size()) +
                              " receive socket(s) (UDP port(s) " + port_list + ")";
  const std::string open = sockets + " listen on every interface: ";
  if (!unknown.empty())
    return {false, open + "its transmit socket is bound to " + join(unknown) +
                       ", an address no interface holds now"};
  if (interfaces.size() != 1)
    return {false, open + (interfaces.empty()
                               ? std::string("no transmit socket names the interface it selected")
                               : "its configuration selects " + std::to_string(interfaces.size()) +
                                     " interfaces (" + join(interfaces) +
                                     ") and a socket binds to one; select one in CYCLONEDDS_URI")};
  const std::string& device = *interfaces.begin();
  for (int fd : receive)
    if (::setsockopt(fd, SOL_SOCKET, SO_BINDTODEVICE, device.c_str(),
                     static_cast<socklen_t>(device.size())) != 0)
      return {false,
              open + "binding to " + device + " (SO_BINDTODEVICE) failed: " + std::strerror(errno)};
  return {true, sockets + " bound to " + device +
                    ", the one interface its configuration selects: datagrams that arrive on "
                    "any other interface are refused"};
}

}  // namespace rosguard::dds
