#pragma once

#include <memory>
#include <string>
#include <string_view>

#include <libxml/globals.h>
#include <libxml/tree.h>

namespace occmap {

// XML as calibration files bring it (Tsai's ETISEO/PETS layout, OpenCV's FileStorage), parsed
// safely: nothing is fetched from the network and no external entity is read, and libxml2 prints
// nothing; a file that is not well-formed is an InputError with libxml2's line and reason.
struct XmlDocumentFree {
  void operator()(xmlDoc* document) const { xmlFreeDoc(document); }
};
using XmlDocument = std::unique_ptr<xmlDoc, XmlDocumentFree>;
struct XmlTextFree {
  void operator()(xmlChar* text) const { xmlFree(text); }
};

// `line_offset` is added to libxml2's line numbers: the lines left out before `text` starts.
XmlDocument parseXmlDocument(std::string_view text, const std::string& file, int line_offset = 0);

inline const char* plainText(const xmlChar* text) { return reinterpret_cast<const char*>(text); }
inline const xmlChar* xmlText(const char* text) { return reinterpret_cast<const xmlChar*>(text); }

}  // namespace occmap
