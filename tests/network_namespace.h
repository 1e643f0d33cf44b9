#pragma once
// A private network for tests that use LCM's UDP multicast: this process (and every child it
// starts) moves into a new network namespace whose only interface is its own loopback, with the
// multicast route on it. Nothing sent there can reach another machine or the host's networks.
// Needs root or CAP_SYS_ADMIN; without, the test skips and says why.

#include <cerrno>
#include <cstring>
#include <string>

#include <arpa/inet.h>
#include <net/if.h>
#include <net/route.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

namespace occmap::testing {

namespace detail {

inline std::string setUpPrivateNetwork() {
  if (::unshare(CLONE_NEWNET) != 0) {
    return std::string(
               "cannot make a private network namespace for LCM's UDP multicast "
               "(unshare(CLONE_NEWNET): ") +
           std::strerror(errno) + "); run the test as root or with CAP_SYS_ADMIN";
  }
  // From here on the process is in the new namespace, whatever fails below.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return std::string("no socket in the new namespace: ") + std::strerror(errno);
  std::string problem;
  ifreq interface {};
  std::strncpy(interface.ifr_name, "lo", IFNAMSIZ - 1);
  if (::ioctl(fd, SIOCGIFFLAGS, &interface) != 0) {
    problem = std::string("cannot read the loopback's flags: ") + std::strerror(errno);
  } else {
    interface.ifr_flags = static_cast<short>(interface.ifr_flags | IFF_UP);
    if (::ioctl(fd, SIOCSIFFLAGS, &interface) != 0) {
      problem = std::string("cannot bring the loopback up: ") + std::strerror(errno);
    }
  }
  if (problem.empty()) {
    // ip route add 224.0.0.0/4 dev lo
    rtentry route{};
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(0xE0000000u);
    std::memcpy(&route.rt_dst, &address, sizeof address);
    address.sin_addr.s_addr = htonl(0xF0000000u);
    std::memcpy(&route.rt_genmask, &address, sizeof address);
    char device[] = "lo";
    route.rt_dev = device;
    route.rt_flags = RTF_UP;
    if (::ioctl(fd, SIOCADDRT, &route) != 0) {
      problem =
          std::string("cannot add the multicast route to the loopback: ") + std::strerror(errno);
    }
  }
  ::close(fd);
  // Belt and braces: the namespace must hold nothing but the loopback.
  if (problem.empty()) {
    if (struct if_nameindex* names = ::if_nameindex()) {
      for (struct if_nameindex* n = names; n->if_index != 0; ++n) {
        if (std::strcmp(n->if_name, "lo") != 0) {
          problem = std::string("the new network namespace has an interface other than lo: ") +
                    n->if_name;
        }
      }
      ::if_freenameindex(names);
    }
  }
  return problem;
}

}  // namespace detail

// "" once this process is in its private network (the first call moves it there), else why not.
inline const std::string& enterPrivateNetwork() {
  static const std::string problem = detail::setUpPrivateNetwork();
  return problem;
}

}  // namespace occmap::testing
