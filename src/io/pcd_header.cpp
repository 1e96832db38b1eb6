#include "io/pcd_header.hpp"

#include <limits>
#include <string>
#include <utility>

#include "io/reader_common.hpp"
#include "io/text_scanner.hpp"

namespace sspc::io {

namespace {

// Fields and counts far beyond any real file (PCL's largest descriptors have a few hundred
// values): the limits keep every size computation below far from overflow.
constexpr std::size_t kMaxFields = 4096;
constexpr std::uint64_t kMaxCount = 1u << 20;

std::optional<ScalarType> pcd_type(char type, std::uint64_t size) {
  switch (type) {
    case 'I':
      if (size == 1) return ScalarType::kInt8;
      if (size == 2) return ScalarType::kInt16;
      if (size == 4) return ScalarType::kInt32;
      if (size == 8) return ScalarType::kInt64;
      return std::nullopt;
    case 'U':
      if (size == 1) return ScalarType::kUint8;
      if (size == 2) return ScalarType::kUint16;
      if (size == 4) return ScalarType::kUint32;
      if (size == 8) return ScalarType::kUint64;
      return std::nullopt;
    case 'F':
      if (size == 4) return ScalarType::kFloat32;
      if (size == 8) return ScalarType::kFloat64;
      return std::nullopt;
    default: return std::nullopt;
  }
}

class PcdHeaderParser {
 public:
  PcdHeaderParser(std::string_view text, std::string_view name) : scanner_(text), name_(name) {}

  StatusOr<PcdHeader> parse() {
    std::string_view line;
    while (scanner_.next(line)) {
      Tokenizer tokens(line);
      std::string_view key;
      if (!tokens.next(key) || key.front() == '#') continue;
      std::vector<std::string_view> args;
      std::string_view tok;
      while (tokens.next(tok)) {
        if (args.size() > kMaxFields) return error("too many values on one header line");
        args.push_back(tok);
      }
      if (key == "VERSION") {
        // Every version PCL has written (0.5 to 0.7) reads the same for the keywords below.
      } else if (key == "FIELDS" || key == "COLUMNS") {
        SSPC_RETURN_IF_ERROR(once(have_fields_, key));
        if (args.empty()) return error("FIELDS names no field");
        names_.assign(args.begin(), args.end());
      } else if (key == "SIZE") {
        SSPC_RETURN_IF_ERROR(once(have_size_, key));
        SSPC_RETURN_IF_ERROR(numbers(key, args, sizes_));
      } else if (key == "TYPE") {
        SSPC_RETURN_IF_ERROR(once(have_type_, key));
        types_.assign(args.begin(), args.end());
      } else if (key == "COUNT") {
        SSPC_RETURN_IF_ERROR(once(have_count_, key));
        SSPC_RETURN_IF_ERROR(numbers(key, args, counts_));
      } else if (key == "WIDTH") {
        SSPC_RETURN_IF_ERROR(once(have_width_, key));
        SSPC_RETURN_IF_ERROR(single_number(key, args, header_.width));
      } else if (key == "HEIGHT") {
        SSPC_RETURN_IF_ERROR(once(have_height_, key));
        SSPC_RETURN_IF_ERROR(single_number(key, args, header_.height));
      } else if (key == "POINTS") {
        SSPC_RETURN_IF_ERROR(once(have_points_, key));
        SSPC_RETURN_IF_ERROR(single_number(key, args, points_));
        points_line_ = scanner_.line_number();
      } else if (key == "VIEWPOINT") {
        // The sensor pose: sspc clouds carry none, so it is only checked for shape.
        if (args.size() != 7) return error("VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz)");
      } else if (key == "DATA") {
        if (args.size() != 1) return error("expected 'DATA ascii|binary|binary_compressed'");
        if (args[0] == "ascii") {
          header_.data = PcdData::kAscii;
        } else if (args[0] == "binary") {
          header_.data = PcdData::kBinary;
        } else if (args[0] == "binary_compressed") {
          header_.data = PcdData::kBinaryCompressed;
        } else {
          return error(StatusCode::kUnsupported, "unknown DATA encoding " + quote_token(args[0]));
        }
        header_.data_line = scanner_.line_number();
        header_.body_offset = scanner_.position();
        header_.body_first_line = scanner_.line_number() + 1;
        SSPC_RETURN_IF_ERROR(finish());
        return std::move(header_);
      } else {
        return error("unknown header keyword " + quote_token(key) +
                     " (expected VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, "
                     "POINTS or DATA)");
      }
    }
    return error_in(StatusCode::kParseError, name_,
                    "the header has no DATA line (truncated or not a PCD file)");
  }

 private:
  Status error(std::string_view what) const { return error(StatusCode::kParseError, what); }
  Status error(StatusCode code, std::string_view what) const {
    return error_at_line(code, name_, scanner_.line_number(), what);
  }

  Status once(bool& seen, std::string_view key) const {
    if (seen) return error("a second " + std::string(key) + " line");
    seen = true;
    return Status();
  }

  Status single_number(std::string_view key, const std::vector<std::string_view>& args,
                       std::uint64_t& out) const {
    if (args.size() != 1 || !is_plain_unsigned(args[0]) || !parse_number(args[0], out)) {
      return error(std::string(key) + " needs one non-negative integer");
    }
    return Status();
  }

  Status numbers(std::string_view key, const std::vector<std::string_view>& args,
                 std::vector<std::uint64_t>& out) const {
    out.clear();
    for (std::string_view a : args) {
      std::uint64_t v = 0;
      if (!is_plain_unsigned(a) || !parse_number(a, v)) {
        return error(std::string(key) + " value " + quote_token(a) +
                     " is not a non-negative integer");
      }
      out.push_back(v);
    }
    return Status();
  }

  // Cross-checks the keywords once DATA has ended the header; errors point at the DATA line.
  Status finish() {
    if (!have_fields_) return error("no FIELDS line before DATA");
    if (!have_size_ || !have_type_) return error("no SIZE or no TYPE line before DATA");
    if (!have_width_) return error("no WIDTH line before DATA");
    const std::size_t n = names_.size();
    if (sizes_.size() != n || types_.size() != n || (have_count_ && counts_.size() != n)) {
      return error("FIELDS, SIZE, TYPE and COUNT list different numbers of fields (" +
                   std::to_string(n) + " fields, " + std::to_string(sizes_.size()) + " sizes, " +
                   std::to_string(types_.size()) + " types" +
                   (have_count_ ? ", " + std::to_string(counts_.size()) + " counts)" : ")"));
    }
    for (std::size_t i = 0; i < n; ++i) {
      PcdField f;
      f.name = std::string(names_[i]);
      const std::optional<ScalarType> t =
          types_[i].size() == 1 ? pcd_type(types_[i][0], sizes_[i]) : std::nullopt;
      if (!t) {
        return error(StatusCode::kUnsupported,
                     "field " + quote_token(names_[i]) + " has TYPE " + quote_token(types_[i]) +
                         " and SIZE " + std::to_string(sizes_[i]) +
                         " (expected I or U with 1, 2, 4, 8 or F with 4, 8)");
      }
      f.type = *t;
      const std::uint64_t count = have_count_ ? counts_[i] : 1;
      if (count == 0 || count > kMaxCount) {
        return error("field " + quote_token(names_[i]) + " has COUNT " + std::to_string(count));
      }
      f.count = static_cast<std::size_t>(count);
      header_.point_size += f.bytes();
      header_.values_per_point += f.count;
      header_.fields.push_back(std::move(f));
    }
    if (header_.height == 0 && header_.width != 0) return error("HEIGHT is 0");
    // Both are below 2^64; their product is checked before it is formed.
    if (header_.height != 0 &&
        header_.width > std::numeric_limits<std::uint64_t>::max() / header_.height) {
      return error("WIDTH x HEIGHT overflows");
    }
    header_.points = header_.width * header_.height;
    if (have_points_ && points_ != header_.points) {
      return error_at_line(
          StatusCode::kParseError, name_, points_line_,
          "POINTS " + std::to_string(points_) +
              " disagrees with WIDTH x HEIGHT = " + std::to_string(header_.points));
    }
    return Status();
  }

  LineScanner scanner_;
  std::string_view name_;
  PcdHeader header_;
  std::vector<std::string_view> names_, types_;
  std::vector<std::uint64_t> sizes_, counts_;
  std::uint64_t points_ = 0;
  std::size_t points_line_ = 0;
  bool have_fields_ = false, have_size_ = false, have_type_ = false, have_count_ = false;
  bool have_width_ = false, have_height_ = false, have_points_ = false;
};

}  // namespace

std::optional<std::size_t> PcdHeader::find(std::string_view field_name) const {
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (fields[i].name == field_name) return i;
  }
  return std::nullopt;
}

std::size_t PcdHeader::offset_of(std::size_t index) const {
  std::size_t offset = 0;
  for (std::size_t i = 0; i < index; ++i) offset += fields[i].bytes();
  return offset;
}

StatusOr<PcdHeader> parse_pcd_header(std::string_view text, std::string_view name) {
  return PcdHeaderParser(text, name).parse();
}

}  // namespace sspc::io
