#pragma once
// Whether text is one JSON value as RFC 8259 defines it (UTF-8, no raw control characters in
// strings), for checking what `occmap status --json` prints whatever the daemon's answer held.

#include <cstddef>
#include <string_view>

namespace occmap::fuzz {

class JsonCheck {
 public:
  // True when `text` is exactly one JSON value, optionally surrounded by blanks.
  static bool isJson(std::string_view text) {
    JsonCheck check(text);
    check.blanks();
    if (!check.value(0)) return false;
    check.blanks();
    return check.at_ == text.size();
  }

 private:
  explicit JsonCheck(std::string_view text) : text_(text) {}

  static constexpr int kMaxDepth = 64;

  bool more() const { return at_ < text_.size(); }
  char peek() const { return more() ? text_[at_] : '\0'; }
  bool take(char c) {
    if (peek() != c) return false;
    ++at_;
    return true;
  }
  void blanks() {
    while (more() && (peek() == ' ' || peek() == '\t' || peek() == '\n' || peek() == '\r')) ++at_;
  }
  bool word(std::string_view w) {
    if (text_.substr(at_, w.size()) != w) return false;
    at_ += w.size();
    return true;
  }
  bool digits() {
    const std::size_t start = at_;
    while (more() && peek() >= '0' && peek() <= '9') ++at_;
    return at_ > start;
  }
  bool number() {
    take('-');
    if (!take('0') && !digits()) return false;
    if (take('.') && !digits()) return false;
    if (peek() == 'e' || peek() == 'E') {
      ++at_;
      if (!take('+')) take('-');
      if (!digits()) return false;
    }
    return true;
  }
  // One UTF-8 sequence of a code point (no overlong forms, no surrogates, at most U+10FFFF).
  bool utf8() {
    const auto byte = [this](std::size_t k) {
      return at_ + k < text_.size() ? static_cast<unsigned char>(text_[at_ + k]) : 0u;
    };
    const unsigned lead = byte(0);
    auto continuation = [&](std::size_t k) { return (byte(k) & 0xC0u) == 0x80u; };
    std::size_t length = 0;
    if (lead < 0x80) {
      length = 1;
    } else if (lead >= 0xC2 && lead <= 0xDF) {
      length = 2;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      const unsigned second = byte(1);
      if ((lead == 0xE0 && second < 0xA0) || (lead == 0xED && second > 0x9F)) return false;
      length = 3;
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      const unsigned second = byte(1);
      if ((lead == 0xF0 && second < 0x90) || (lead == 0xF4 && second > 0x8F)) return false;
      length = 4;
    } else {
      return false;
    }
    for (std::size_t k = 1; k < length; ++k) {
      if (!continuation(k)) return false;
    }
    at_ += length;
    return true;
  }
  bool string() {
    if (!take('"')) return false;
    while (more()) {
      const auto c = static_cast<unsigned char>(peek());
      if (c == '"') {
        ++at_;
        return true;
      }
      if (c < 0x20) return false;
      if (c == '\\') {
        ++at_;
        const char escape = peek();
        ++at_;
        if (escape == 'u') {
          for (int k = 0; k < 4; ++k) {
            const char h = peek();
            if (!((h >= '0' && h <= '9') || (h >= 'a' && h <= 'f') || (h >= 'A' && h <= 'F'))) {
              return false;
            }
            ++at_;
          }
        } else if (std::string_view("\"\\/bfnrt").find(escape) == std::string_view::npos ||
                   escape == '\0') {
          return false;
        }
      } else if (!utf8()) {
        return false;
      }
    }
    return false;
  }
  bool value(int depth) {
    if (depth > kMaxDepth) return false;
    blanks();
    switch (peek()) {
      case '{':
        ++at_;
        blanks();
        if (take('}')) return true;
        do {
          blanks();
          if (!string()) return false;
          blanks();
          if (!take(':') || !value(depth + 1)) return false;
          blanks();
        } while (take(','));
        return take('}');
      case '[':
        ++at_;
        blanks();
        if (take(']')) return true;
        do {
          if (!value(depth + 1)) return false;
          blanks();
        } while (take(','));
        return take(']');
      case '"':
        return string();
      case 't':
        return word("true");
      case 'f':
        return word("false");
      case 'n':
        return word("null");
      default:
        return number();
    }
  }

  std::string_view text_;
  std::size_t at_ = 0;
};

}  // namespace occmap::fuzz
