#include "config/storage_node.h"

#include <algorithm>
#include <climits>
#include <memory>
#include <utility>

#include <libxml/tree.h>
#include <yaml-cpp/yaml.h>

#include "config/input_error.h"
#include "config/text_file.h"
#include "config/xml_document.h"

namespace occmap {
namespace {

// An OpenCV calibration nests three deep (a matrix's data in the matrix in the file); far deeper is
// no calibration, and recursion stays bounded whatever the parsers allow.
constexpr int kMaxDepth = 64;

[[noreturn]] void tooDeep(const std::string& file, int line) {
  throw InputError(file, line, "",
                   "nests values deeper than " + std::to_string(kMaxDepth) +
                       " levels; an OpenCV calibration holds numbers, lists and matrices");
}

int yamlLine(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? 0 : mark.line + 1;
}

StorageNode fromYaml(const YAML::Node& yaml, const std::string& file, int depth) {
  StorageNode node;
  node.line = yamlLine(yaml);
  if (depth > kMaxDepth) tooDeep(file, node.line);
  if (yaml.IsScalar()) {
    node.kind = StorageNode::Kind::kScalar;
    node.scalar = yaml.Scalar();
    // A quoted scalar ("640") is text in YAML even when it reads like a number.
    node.quoted = yaml.Tag() == "!" || yaml.Tag() == "tag:yaml.org,2002:str";
  } else if (yaml.IsSequence()) {
    node.kind = StorageNode::Kind::kList;
    node.items.reserve(yaml.size());
    for (const YAML::Node& item : yaml) node.items.push_back(fromYaml(item, file, depth + 1));
  } else if (yaml.IsMap()) {
    node.kind = StorageNode::Kind::kMapping;
    for (const auto& field : yaml) {
      const std::string key = field.first.IsScalar() ? field.first.Scalar() : std::string();
      node.fields.push_back({key, fromYaml(field.second, file, depth + 1)});
    }
  }
  return node;
}

int xmlLine(const xmlNode* element, int line_offset) {
  const long line = xmlGetLineNo(element);
  return line > 0 ? static_cast<int>(std::min(line, static_cast<long>(INT_MAX / 2))) + line_offset
                  : 0;
}

bool isElement(const xmlNode* node) { return node->type == XML_ELEMENT_NODE; }

// An element's text as cv::FileStorage writes a value: one token is a scalar, several (separated
// by blanks) a list; each token's line is the element's plus the line breaks before it.
StorageNode fromXmlText(const xmlNode* element, int line, bool always_list) {
  const std::unique_ptr<xmlChar, XmlTextFree> content(xmlNodeGetContent(element));
  const std::string_view text = content ? plainText(content.get()) : "";
  constexpr std::string_view kBlanks = " \t\r\n";
  StorageNode list;
  list.kind = StorageNode::Kind::kList;
  list.line = line;
  int token_line = line;
  std::size_t at = 0;
  while (at < text.size()) {
    if (kBlanks.find(text[at]) != std::string_view::npos) {
      if (text[at] == '\n') ++token_line;
      ++at;
      continue;
    }
    const std::size_t end = std::min(text.find_first_of(kBlanks, at), text.size());
    StorageNode token;
    token.kind = StorageNode::Kind::kScalar;
    token.line = token_line;
    token.scalar = std::string(text.substr(at, end - at));
    // cv::FileStorage quotes a string that would read as something else.
    if (token.scalar.size() >= 2 && token.scalar.front() == '"' && token.scalar.back() == '"') {
      token.scalar = token.scalar.substr(1, token.scalar.size() - 2);
      token.quoted = true;
    }
    list.items.push_back(std::move(token));
    at = end;
  }
  if (list.items.empty()) return StorageNode{StorageNode::Kind::kNone, {}, false, line, {}, {}};
  if (list.items.size() == 1 && !always_list) return std::move(list.items.front());
  return list;
}

StorageNode fromXml(const xmlNode* element, const std::string& file, int line_offset, int depth) {
  const int line = xmlLine(element, line_offset);
  if (depth > kMaxDepth) tooDeep(file, line);
  bool has_children = false;
  bool all_unnamed = true;  // cv::FileStorage writes a list's items as <_> elements
  for (const xmlNode* child = element->children; child != nullptr; child = child->next) {
    if (!isElement(child)) continue;
    has_children = true;
    all_unnamed = all_unnamed && std::string_view(plainText(child->name)) == "_";
  }
  if (!has_children) {
    // A matrix's data is a list even when it holds one number.
    const bool matrix_data = std::string_view(plainText(element->name)) == "data" &&
                             element->parent != nullptr &&
                             xmlHasProp(element->parent, xmlText("type_id")) != nullptr;
    return fromXmlText(element, line, matrix_data);
  }
  StorageNode node;
  node.line = line;
  node.kind = all_unnamed ? StorageNode::Kind::kList : StorageNode::Kind::kMapping;
  for (const xmlNode* child = element->children; child != nullptr; child = child->next) {
    if (!isElement(child)) continue;
    StorageNode value = fromXml(child, file, line_offset, depth + 1);
    if (all_unnamed) {
      node.items.push_back(std::move(value));
    } else {
      node.fields.push_back({plainText(child->name), std::move(value)});
    }
  }
  return node;
}

}  // namespace

const StorageNode* StorageNode::find(std::string_view key) const {
  for (const auto& [name, value] : fields) {
    if (name == key) return &value;
  }
  return nullptr;
}

StorageNode readYamlStorage(std::string_view text, const std::string& file) {
  try {
    return fromYaml(YAML::Load(std::string(text)), file, 0);
  } catch (const YAML::Exception& error) {
    throw InputError(file, error.mark.is_null() ? 0 : error.mark.line + 1, "",
                     "is not valid YAML: " + error.msg + "; fix the YAML syntax");
  }
}

StorageNode readXmlStorage(std::string_view text, const std::string& file) {
  // XML allows nothing before its declaration, but a file that starts with a blank line is
  // clearly meant as XML: read it from the declaration and keep the file's line numbers.
  int skipped_lines = 0;
  const std::string_view content = firstContent(text);
  if (content.starts_with("<?xml") && content.size() != text.size()) {
    const std::string_view skipped = text.substr(0, text.size() - content.size());
    skipped_lines = static_cast<int>(std::count(skipped.begin(), skipped.end(), '\n'));
    text = content;
  }
  const XmlDocument document = parseXmlDocument(text, file, skipped_lines);
  const xmlNode* root = xmlDocGetRootElement(document.get());
  if (root == nullptr)
    throw InputError(file, 0, "", "has no XML element; expected <opencv_storage>");
  const std::string root_name = plainText(root->name);
  if (root_name != "opencv_storage") {
    throw InputError(file, xmlLine(root, skipped_lines), "",
                     "root element is <" + root_name +
                         ">; an OpenCV calibration in XML is <opencv_storage>, as "
                         "cv::FileStorage writes it" +
                         (root_name == "Camera" ? " (<Camera> is a Tsai calibration: give it as "
                                                  "the camera's calibration file on its own)"
                                                : ""));
  }
  StorageNode node = fromXml(root, file, skipped_lines, 0);
  if (node.kind == StorageNode::Kind::kNone) {
    node.kind = StorageNode::Kind::kMapping;  // an empty <opencv_storage/>: its fields are missing
  }
  return node;
}

}  // namespace occmap
