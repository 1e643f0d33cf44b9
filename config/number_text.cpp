#include "config/number_text.h"

#include <charconv>
#include <iomanip>
#include <limits>
#include <locale>
#include <sstream>
#include <system_error>

namespace occmap {
namespace {

std::string_view withoutPlus(std::string_view text) {
  // std::from_chars refuses a leading '+', which people and some writers put on exponents'
  // mantissas.
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+') {
    text.remove_prefix(1);
  }
  return text;
}

}  // namespace

std::string_view trimBlanks(std::string_view text) {
  constexpr std::string_view kBlanks = " \t\r\n";
  const std::size_t first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) return {};
  const std::size_t last = text.find_last_not_of(kBlanks);
  return text.substr(first, last - first + 1);
}

std::optional<double> parseReal(std::string_view text) {
  text = withoutPlus(trimBlanks(text));
  if (text.empty()) return std::nullopt;
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  // from_chars gives no value when the number is out of double's range. Overflow ("1e400") is
  // infinite, which callers refuse as "not finite" with the text shown; underflow ("1e-400") is
  // zero.
  if (error == std::errc::result_out_of_range && end == text.data() + text.size()) {
    const bool negative = text.front() == '-';
    const std::size_t exponent = text.find_first_of("eE");
    const bool underflow = exponent != std::string_view::npos
                               ? text.substr(exponent + 1).starts_with('-')
                               : text.find_first_not_of("+-0.") > text.find('.');
    const double magnitude = underflow ? 0.0 : std::numeric_limits<double>::infinity();
    return negative ? -magnitude : magnitude;
  }
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::string formatReal(double value) {
  std::ostringstream text;
  text.imbue(std::locale::classic());
  text << std::setprecision(12) << value;
  return text.str();
}

std::optional<long long> parseInteger(std::string_view text) {
  text = withoutPlus(trimBlanks(text));
  if (text.empty()) return std::nullopt;
  long long value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::string inQuotes(std::string_view text) {
  constexpr std::size_t kShown = 40;
  if (text.size() > kShown) return "\"" + std::string(text.substr(0, kShown)) + "...\"";
  return "\"" + std::string(text) + "\"";
}

}  // namespace occmap
