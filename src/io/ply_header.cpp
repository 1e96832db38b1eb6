#include "io/ply_header.hpp"

#include <array>
#include <utility>

#include "io/reader_common.hpp"
#include "io/text_scanner.hpp"

namespace sspc::io {

namespace {

struct TypeName {
  std::string_view name;
  ScalarType type;
};

// Turk's original names first (what sspc writes), then the sized aliases later tools use.
constexpr std::array<TypeName, 16> kPlyTypes = {{
    {"char", ScalarType::kInt8},
    {"uchar", ScalarType::kUint8},
    {"short", ScalarType::kInt16},
    {"ushort", ScalarType::kUint16},
    {"int", ScalarType::kInt32},
    {"uint", ScalarType::kUint32},
    {"float", ScalarType::kFloat32},
    {"double", ScalarType::kFloat64},
    {"int8", ScalarType::kInt8},
    {"uint8", ScalarType::kUint8},
    {"int16", ScalarType::kInt16},
    {"uint16", ScalarType::kUint16},
    {"int32", ScalarType::kInt32},
    {"uint32", ScalarType::kUint32},
    {"float32", ScalarType::kFloat32},
    {"float64", ScalarType::kFloat64},
}};

constexpr std::size_t kMaxTokens = 8;

// Splits a header line into at most kMaxTokens tokens; returns how many it found (kMaxTokens + 1
// when there were more).
std::size_t split(std::string_view line, std::array<std::string_view, kMaxTokens>& out) {
  Tokenizer t(line);
  std::size_t n = 0;
  std::string_view tok;
  while (t.next(tok)) {
    if (n == kMaxTokens) return kMaxTokens + 1;
    out[n++] = tok;
  }
  return n;
}

// The text after the keyword, for comments (which keep their inner spacing).
std::string_view rest_after_keyword(std::string_view line, std::string_view keyword) {
  std::string_view rest = line.substr(line.find(keyword) + keyword.size());
  while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
  return rest;
}

class HeaderParser {
 public:
  HeaderParser(std::string_view text, std::string_view name) : scanner_(text), name_(name) {}

  StatusOr<PlyHeader> parse() {
    std::string_view line;
    if (!scanner_.next(line) || line != "ply") {
      return error_in(StatusCode::kParseError, name_,
                      "not a PLY file: the first line is not 'ply'");
    }
    bool have_format = false;
    while (scanner_.next(line)) {
      std::array<std::string_view, kMaxTokens> tok{};
      const std::size_t n = split(line, tok);
      if (n == 0) continue;  // tolerate blank lines
      const std::string_view key = tok[0];
      if (key == "comment" || key == "obj_info") {
        header_.comments.emplace_back(rest_after_keyword(line, key));
      } else if (key == "format") {
        if (have_format) return error(StatusCode::kParseError, "a second 'format' line");
        SSPC_RETURN_IF_ERROR(parse_format(tok, n));
        have_format = true;
      } else if (key == "element") {
        SSPC_RETURN_IF_ERROR(parse_element(tok, n));
      } else if (key == "property") {
        SSPC_RETURN_IF_ERROR(parse_property(tok, n));
      } else if (key == "end_header") {
        if (!have_format)
          return error(StatusCode::kParseError, "no 'format' line before end_header");
        header_.body_offset = scanner_.position();
        header_.body_first_line = scanner_.line_number() + 1;
        return std::move(header_);
      } else {
        return error(StatusCode::kParseError,
                     "unknown header keyword " + quote_token(key) +
                         " (expected format, comment, obj_info, element, property or end_header)");
      }
    }
    return error_in(StatusCode::kParseError, name_,
                    "the header has no 'end_header' line (truncated or not a PLY file)");
  }

 private:
  Status error(StatusCode code, std::string_view what) const {
    return error_at_line(code, name_, scanner_.line_number(), what);
  }

  Status parse_format(const std::array<std::string_view, kMaxTokens>& tok, std::size_t n) {
    if (n != 3) return error(StatusCode::kParseError, "expected 'format <encoding> 1.0'");
    if (tok[1] == "ascii") {
      header_.format = PlyFormat::kAscii;
    } else if (tok[1] == "binary_little_endian") {
      header_.format = PlyFormat::kBinaryLittleEndian;
    } else if (tok[1] == "binary_big_endian") {
      header_.format = PlyFormat::kBinaryBigEndian;
    } else {
      return error(StatusCode::kUnsupported, "unknown PLY format " + quote_token(tok[1]));
    }
    double version = 0;
    if (!parse_number(tok[2], version)) {
      return error(StatusCode::kParseError, "bad format version " + quote_token(tok[2]));
    }
    if (version != 1.0) {
      return error(StatusCode::kUnsupported,
                   "PLY version " + std::string(tok[2]) + " (only 1.0 is defined)");
    }
    return Status();
  }

  Status parse_element(const std::array<std::string_view, kMaxTokens>& tok, std::size_t n) {
    if (n != 3) return error(StatusCode::kParseError, "expected 'element <name> <count>'");
    std::uint64_t count = 0;
    if (!is_plain_unsigned(tok[2]) || !parse_number(tok[2], count)) {
      return error(StatusCode::kParseError,
                   "element count " + quote_token(tok[2]) + " is not a non-negative integer");
    }
    for (const PlyElement& e : header_.elements) {
      if (e.name == tok[1]) {
        return error(StatusCode::kParseError, "element " + quote_token(tok[1]) +
                                                  " declared twice (first on line " +
                                                  std::to_string(e.line) + ")");
      }
    }
    PlyElement element;
    element.name = std::string(tok[1]);
    element.count = count;
    element.line = scanner_.line_number();
    header_.elements.push_back(std::move(element));
    return Status();
  }

  StatusOr<ScalarType> type(std::string_view token) const {
    const std::optional<ScalarType> t = ply_type_from_name(token);
    if (!t) return error(StatusCode::kUnsupported, "unknown property type " + quote_token(token));
    return *t;
  }

  Status parse_property(const std::array<std::string_view, kMaxTokens>& tok, std::size_t n) {
    if (header_.elements.empty()) {
      return error(StatusCode::kParseError, "'property' before any 'element'");
    }
    PlyElement& element = header_.elements.back();
    PlyProperty prop;
    prop.line = scanner_.line_number();
    if (n >= 2 && tok[1] == "list") {
      if (n != 5) {
        return error(StatusCode::kParseError,
                     "expected 'property list <count type> <item type> <name>'");
      }
      SSPC_ASSIGN_OR_RETURN(prop.count_type, type(tok[2]));
      SSPC_ASSIGN_OR_RETURN(prop.type, type(tok[3]));
      if (scalar_is_float(prop.count_type)) {
        return error(StatusCode::kParseError,
                     "list count type " + quote_token(tok[2]) + " is not an integer type");
      }
      prop.is_list = true;
      prop.name = std::string(tok[4]);
    } else {
      if (n != 3) return error(StatusCode::kParseError, "expected 'property <type> <name>'");
      SSPC_ASSIGN_OR_RETURN(prop.type, type(tok[1]));
      prop.name = std::string(tok[2]);
    }
    if (const auto prior = element.find(prop.name)) {
      return error(StatusCode::kParseError,
                   "property " + quote_token(prop.name) + " declared twice in element " +
                       quote_token(element.name) + " (first on line " +
                       std::to_string(element.properties[*prior].line) + ")");
    }
    element.properties.push_back(std::move(prop));
    return Status();
  }

  LineScanner scanner_;
  std::string_view name_;
  PlyHeader header_;
};

}  // namespace

std::string_view ply_type_name(ScalarType t) {
  for (const TypeName& tn : kPlyTypes) {
    if (tn.type == t) return tn.name;
  }
  return "?";
}

std::optional<ScalarType> ply_type_from_name(std::string_view name) {
  for (const TypeName& tn : kPlyTypes) {
    if (tn.name == name) return tn.type;
  }
  return std::nullopt;
}

std::optional<std::size_t> PlyElement::fixed_stride() const {
  std::size_t stride = 0;
  for (const PlyProperty& p : properties) {
    if (p.is_list) return std::nullopt;
    stride += scalar_size(p.type);
  }
  return stride;
}

std::optional<std::size_t> PlyElement::find(std::string_view property_name) const {
  for (std::size_t i = 0; i < properties.size(); ++i) {
    if (properties[i].name == property_name) return i;
  }
  return std::nullopt;
}

StatusOr<PlyHeader> parse_ply_header(std::string_view text, std::string_view name) {
  return HeaderParser(text, name).parse();
}

}  // namespace sspc::io
