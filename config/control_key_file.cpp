#include "config/control_key_file.h"

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config/input_error.h"

namespace occmap {
namespace {

// libsodium wants sodium_init() before its first use (it seeds its random source); it may be
// called again and from any thread.
[[maybe_unused]] const int sodium_ready = sodium_init();

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string modeText(mode_t mode) {
  char text[8];
  std::snprintf(text, sizeof text, "%04o", static_cast<unsigned>(mode & 07777));
  return text;
}

// Closes a descriptor on every way out.
struct Descriptor {
  int fd;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

ControlKey loadControlKey(const std::filesystem::path& key_file, const KeyFileOrigin& origin) {
  const std::string name = key_file.string();
  auto fail = [&](const std::string& message) -> void {
    throw InputError(origin.file, origin.line, origin.field, message);
  };
  // Opened first and checked through the descriptor, so the file checked is the file read.
  const Descriptor file{::open(key_file.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY)};
  if (file.fd < 0) {
    const int error = errno;
    fail("cannot read the key file " + name + " (" + std::strerror(error) + ")" +
         (error == ENOENT   ? "; make one with `occmap control --make-key " + name + "`"
          : error == EACCES ? "; the service's user must own it: `chown occmap " + name + "`"
                            : ""));
  }
  struct stat info {};
  if (::fstat(file.fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    fail("the key file " + name +
         " is not a regular file; make one with `occmap control "
         "--make-key FILE`");
  }
  if ((info.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    fail("the key file " + name + " has mode " + modeText(info.st_mode) +
         ": its group or others can use it, and whoever reads the key can change this daemon. "
         "Run `chmod 600 " +
         name + "` and `chown occmap " + name +
         "` (only the service's user may read it), and keep the copies of the senders as private");
  }
  char text[260];
  const ssize_t got = ::read(file.fd, text, sizeof text);
  if (got < 0) fail("cannot read the key file " + name + " (" + std::strerror(errno) + ")");
  std::size_t length = static_cast<std::size_t>(got);
  if (length > 0 && text[length - 1] == '\n') --length;
  if (length > 0 && text[length - 1] == '\r') --length;
  ControlKey key;
  const std::string expected =
      "; it must hold 64 to 128 hex digits (a key of 32 to 64 bytes) on "
      "one line, as `occmap control --make-key FILE` writes";
  if (length < 2 * ControlKey::kMinBytes || length > 2 * ControlKey::kMaxBytes || length % 2 != 0) {
    std::memset(text, 0, sizeof text);
    fail("the key file " + name + " holds " + std::to_string(length) + " characters" + expected);
  }
  for (std::size_t i = 0; i < length; i += 2) {
    const int high = hexDigit(text[i]);
    const int low = hexDigit(text[i + 1]);
    if (high < 0 || low < 0) {
      std::memset(text, 0, sizeof text);
      fail("the key file " + name + " holds something other than hex digits" + expected);
    }
    key.bytes[i / 2] = static_cast<std::uint8_t>(high << 4 | low);
  }
  key.size = length / 2;
  std::memset(text, 0, sizeof text);  // the key stays in `key` only
  return key;
}

void writeNewControlKey(const std::filesystem::path& key_file) {
  const std::string name = key_file.string();
  const Descriptor file{
      ::open(key_file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOCTTY, 0600)};
  if (file.fd < 0) {
    const int error = errno;
    if (error == EEXIST) {
      throw InputError(name, 0, "--make-key",
                       "exists; a key in use would be lost: remove it first, or choose another "
                       "file");
    }
    throw std::runtime_error("cannot create " + name + ": " + std::strerror(error));
  }
  // O_CREAT's mode is masked by the umask: make sure of 0600 whatever the umask is.
  if (::fchmod(file.fd, 0600) != 0) {
    throw std::runtime_error("cannot set the mode of " + name + ": " + std::strerror(errno));
  }
  ControlKey key = makeRandomControlKey();
  static constexpr char kHex[] = "0123456789abcdef";
  char text[2 * ControlKey::kMaxBytes + 1];
  for (std::size_t i = 0; i < key.size; ++i) {
    text[2 * i] = kHex[key.bytes[i] >> 4];
    text[2 * i + 1] = kHex[key.bytes[i] & 15];
  }
  text[2 * key.size] = '\n';
  const std::size_t length = 2 * key.size + 1;
  const bool written =
      ::write(file.fd, text, length) == static_cast<ssize_t>(length) && ::fsync(file.fd) == 0;
  std::memset(text, 0, sizeof text);
  key = ControlKey{};
  if (!written) {
    const int error = errno;
    ::unlink(key_file.c_str());
    throw std::runtime_error("cannot write " + name + ": " + std::strerror(error));
  }
}

ControlKey makeRandomControlKey() {
  ControlKey key;
  key.size = ControlKey::kMinBytes;
  randombytes_buf(key.bytes.data(), key.size);
  return key;
}

}  // namespace occmap
