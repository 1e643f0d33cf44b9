// The Python example receiving 512 x 512 raw maps live: 262 307 bytes in five fragments, which
// need a receive buffer larger than Linux's default (net.core.rmem_max caps what recv_buf_size can
// get). A binary of its own, because a stock rmem_max (212 992) makes it skip, and a skipped case
// marks its whole binary Skipped: python_example_test's other cases stay reported as passed.
#include <fstream>

#include <gtest/gtest.h>

#include "python_example.h"

namespace occmap {
namespace {

using testing::PythonExampleLive;

TEST_F(PythonExampleLive, ReceivesLargeRawMapsWithALargeReceiveBuffer) {
  std::ifstream rmem_max("/proc/sys/net/core/rmem_max");
  long bytes = 0;
  rmem_max >> bytes;
  if (bytes < 4194304) {
    GTEST_SKIP() << "net.core.rmem_max is " << bytes << "; raw 512 x 512 maps need a 4 MiB "
                 << "receive buffer (sysctl -w net.core.rmem_max=4194304), which this test does "
                 << "not change for the machine";
  }
  const std::string out = receive("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304", 15,
                                  {{"--count", "15", "--rate", "15", "--encoding", "raw"}});
  EXPECT_NE(out.find("maps 15, lost 0 (seq gaps), undecodable 0"), std::string::npos) << out;
}

}  // namespace
}  // namespace occmap
