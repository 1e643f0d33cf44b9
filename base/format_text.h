#pragma once
// printf into a std::string of whatever length the result has (a row with a long name must not be
// cut short, losing its newline and running into the next row). Not for hot paths: it allocates.

#include <string>

namespace occmap {

__attribute__((format(printf, 1, 2))) std::string formatText(const char* pattern, ...);

}  // namespace occmap
