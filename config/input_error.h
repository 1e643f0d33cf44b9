#pragma once

#include <stdexcept>
#include <string>

namespace occmap {

// Invalid user input: a config or calibration file that cannot be used as written. what() reads
// like a compiler message, "FILE:LINE: FIELD: MESSAGE", leaving out what is unknown, so that a user
// can jump to the place; the message says what is wrong and what to do. Programs exit with
// kExitInvalidInput.
class InputError : public std::runtime_error {
 public:
  // `line` is 1-based, 0 when unknown; `field` names the setting ("cameras[2].threshold",
  // "Intrinsic.focal"), empty when the error concerns the whole file.
  InputError(std::string file, int line, std::string field, std::string message);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& field() const { return field_; }
  // The message alone, without the location.
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  int line_;
  std::string field_;
  std::string message_;
};

}  // namespace occmap
