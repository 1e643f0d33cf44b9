#include "config/xml_document.h"

#include <algorithm>
#include <climits>
#include <new>

#include <libxml/parser.h>
#include <libxml/xmlerror.h>

#include "config/input_error.h"
#include "config/number_text.h"

namespace occmap {
namespace {

struct XmlParserFree {
  void operator()(xmlParserCtxt* parser) const { xmlFreeParserCtxt(parser); }
};

void initialiseLibxml2() {
  // libxml2 wants its global state set up once before threads use it; loading may run on a reload
  // thread while another part of the program reads XML.
  static const bool initialised = [] {
    xmlInitParser();
    return true;
  }();
  (void)initialised;
}

// Some libxml2 errors (an encoding that does not convert) bypass the parser context and print on
// stderr through the thread's generic handler; the context reports them too, so the handler is
// silenced while a file is parsed (it is per thread: other threads' libxml2 use is unaffected).
class QuietLibxml2 {
 public:
  QuietLibxml2() : handler_(xmlGenericError), context_(xmlGenericErrorContext) {
    xmlSetGenericErrorFunc(nullptr, &ignore);
  }
  ~QuietLibxml2() { xmlSetGenericErrorFunc(context_, handler_); }
  QuietLibxml2(const QuietLibxml2&) = delete;
  QuietLibxml2& operator=(const QuietLibxml2&) = delete;

 private:
  static void ignore(void*, const char*, ...) {}

  xmlGenericErrorFunc handler_;
  void* context_;
};

}  // namespace

XmlDocument parseXmlDocument(std::string_view text, const std::string& file, int line_offset) {
  initialiseLibxml2();
  if (text.size() > static_cast<std::size_t>(INT_MAX)) {
    throw InputError(file, 0, "", "is too large to be a calibration file");
  }
  const QuietLibxml2 quiet;
  const std::unique_ptr<xmlParserCtxt, XmlParserFree> parser(xmlNewParserCtxt());
  if (!parser) throw std::bad_alloc();
  // NONET: a calibration file never makes the daemon fetch anything. Without NOENT and DTDLOAD no
  // external entity is read either. Errors come back through the context, not on stderr.
  const int options =
      XML_PARSE_NONET | XML_PARSE_NOERROR | XML_PARSE_NOWARNING | XML_PARSE_BIG_LINES;
  XmlDocument document(xmlCtxtReadMemory(parser.get(), text.data(), static_cast<int>(text.size()),
                                         file.c_str(), nullptr, options));
  if (!document) {
    const xmlError* error = xmlCtxtGetLastError(parser.get());
    std::string reason = error != nullptr && error->message != nullptr
                             ? std::string(trimBlanks(error->message))
                             : "unknown libxml2 error";
    std::replace(reason.begin(), reason.end(), '\n', ' ');  // one message, one line
    throw InputError(file, error != nullptr && error->line > 0 ? error->line + line_offset : 0, "",
                     "is not well-formed XML: " + reason + "; fix the XML syntax");
  }
  return document;
}

}  // namespace occmap
