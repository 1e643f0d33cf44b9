// control_reply: a control_reply_t as `occmap control` reads it from the reply channel
// (tools/control_command.cpp): decodeControlReply under the client's key. Anyone on the network
// can publish there, so the layout is walked before the mac is checked and before LCM's decoder
// runs. A mutated input almost never carries a valid mac, so each input is also tried signed
// again under the key: that takes every layout the walk lets through on to LCM's decoder.
#include <algorithm>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <occmap/control_reply_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/control_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

namespace {

// What an accepted reply must hold; `bytes` is what was accepted.
void checkAccepted(const occmap::control_reply_t& reply, Input bytes) {
  // Encoded and signed again by the daemon's own encoder, an accepted reply is the same bytes.
  std::vector<std::uint8_t> again;
  encodeControlReply(controlFuzzKey(), reply, again);
  require(std::equal(again.begin(), again.end(), bytes.begin(), bytes.end()),
          "an accepted reply is one whole control_reply_t, signed over every byte before its mac");
  // `occmap control` prints the message to a terminal.
  const std::string shown = terminalText(reply.message);
  require(std::none_of(shown.begin(), shown.end(),
                       [](char c) {
                         const auto byte = static_cast<unsigned char>(c);
                         return byte < 0x20 || byte == 0x7f;
                       }),
          "the message as shown holds no control characters");
}

}  // namespace

bool fuzzControlReply(Input input) {
  std::string why;
  const std::optional<occmap::control_reply_t> reply =
      decodeControlReply(controlFuzzKey(), input.data(), input.size(), &why);
  if (reply) {
    checkAccepted(*reply, input);
    return true;
  }
  require(!why.empty(), "a refused reply says why");
  // The same bytes with a mac that holds: refused now only for their layout, which a signature
  // cannot mend.
  if (input.size() < kControlMacBytes) return false;
  std::vector<std::uint8_t> signed_again(input.begin(), input.end());
  signControlMessage(controlFuzzKey(), signed_again);
  std::string why_signed;
  const std::optional<occmap::control_reply_t> resigned =
      decodeControlReply(controlFuzzKey(), signed_again.data(), signed_again.size(), &why_signed);
  if (resigned) {
    checkAccepted(*resigned, signed_again);
  } else {
    // Refused again, then for its layout ("truncated in the mac" is one), never for the mac
    // itself.
    require(why_signed != "its mac does not match under the key",
            "a reply signed under the key is not refused for its mac");
  }
  return false;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzControlReply)
