#pragma once
// The key file of control requests (docs/control.md): the shared HMAC key as hex text on one line,
// 64 hex digits (32 bytes) as `occmap control --make-key` writes it, up to 128 (64 bytes). Only
// the service's user may read it: a key that others can read lets them change the daemon.

#include <filesystem>
#include <string>

#include "base/control_key.h"

namespace occmap {

// Where an error about the key file points: the config's line naming it, or the command line.
struct KeyFileOrigin {
  std::string file;   // the config file, or the key file itself
  int line = 0;       // 0 when unknown
  std::string field;  // "control.key_file", "--key-file"
};

// Reads and checks the key file. Throws InputError (exit 2) when it is missing or unreadable, not
// a regular file, readable or writable by its group or others, or not 64 to 128 hex digits on one
// line; the message says what to do.
ControlKey loadControlKey(const std::filesystem::path& key_file, const KeyFileOrigin& origin);

// 32 bytes from the system's random source (libsodium's randombytes_buf): a new key.
ControlKey makeRandomControlKey();

// Writes a new random key to `key_file`, created with mode 0600 (never replacing a file: a key in
// use elsewhere would be lost). Throws InputError when it exists, std::runtime_error when it cannot
// be written.
void writeNewControlKey(const std::filesystem::path& key_file);

}  // namespace occmap
