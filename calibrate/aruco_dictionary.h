#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace occmap {

// OpenCV 4.6's predefined ArUco dictionaries by the names its documentation uses ("DICT_4X4_50"):
// the cv::aruco::PREDEFINED_DICTIONARY_NAME value, or nothing for a name OpenCV does not know.
std::optional<int> arucoDictionary(std::string_view name);
// Every name, comma-separated, for messages that say what to write.
std::string arucoDictionaryNames();

}  // namespace occmap
