// Binding Cyclone DDS's receive sockets to the interface its configuration selects.
//
// Cyclone 0.10 binds every receive socket (discovery and data, unicast and multicast) to the
// wildcard address (0.0.0.0 or ::), whatever interfaces its configuration (CYCLONEDDS_URI)
// selects, and has no setting that changes this: with a loopback-only configuration, a datagram
// from the network to the host's address at those ports still reaches the participant. Only its
// transmit sockets are bound to the selected interfaces' addresses. After a domain's sockets are
// opened, bind_new_receive_sockets() finds them (the UDP sockets of this process that were not
// there before), takes the interfaces from the transmit sockets' addresses and, where that is one
// interface, binds each wildcard socket to it with SO_BINDTODEVICE: the kernel then refuses a
// datagram that arrives on any other interface (an ICMP port unreachable, as for a closed port).
// Traffic from this host to the interface's own address still counts as that interface's.
//
// Contract: call with the snapshot udp_sockets() took just before the domain was created, from
// the thread that created it, while no other thread of the process opens UDP sockets. Where the
// configuration selects several interfaces (a socket binds to one device), or the kernel refuses
// (unprivileged, before Linux 5.7), nothing is bound and the result says why: a caller reports
// it as a fallback. Never throws.
#pragma once

#include <sys/types.h>

#include <map>
#include <string>

namespace rosguard::dds {

struct ReceiveBinding {
  bool bound = false;  // every receive socket of the domain is bound to one interface
  std::string text;    // what was done, or why not, with the ports: for a log or a manifest
};

// This process's UDP sockets (IPv4 and IPv6) now: socket inode -> file descriptor.
using UdpSockets = std::map<ino_t, int>;
UdpSockets udp_sockets();

// Binds the wildcard UDP sockets opened since `before` (see above). `found_new` is false when no
// socket was opened since (the domain existed already): then nothing is done.
ReceiveBinding bind_new_receive_sockets(const UdpSockets& before, bool& found_new);

}  // namespace rosguard::dds
