#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace occmap {

// Numbers as users write them in config and calibration files, read the same way on every locale
// (std::strtod would read "0,5" in a German locale and stop at "0.5"). The whole text must be the
// number, apart from surrounding blanks; a leading '+' is allowed. "nan" and "inf" parse, so that
// the caller can say "not finite" rather than "not a number".
std::optional<double> parseReal(std::string_view text);
// A decimal integer, no fraction and no exponent ("512", "-3", "+7").
std::optional<long long> parseInteger(std::string_view text);

std::string_view trimBlanks(std::string_view text);

// A number for a message, with enough digits to tell values apart and '.' on every locale.
std::string formatReal(double value);

// Text for a message, in quotes, cut after 40 characters ("...").
std::string inQuotes(std::string_view text);

// The largest image side a calibration may give, in pixels.
inline constexpr int kMaxImageSide = 65536;

}  // namespace occmap
