// Ascii PLY bodies (Turk's PLY description): the element items in header order, values separated
// by whitespace. Every writer in use puts one item per line, and sspc relies on that to report
// the line of a problem; blank lines are ignored.
#include <algorithm>
#include <memory>
#include <string>

#include "io/ply_body.hpp"
#include "io/reader_common.hpp"
#include "io/text_scanner.hpp"

namespace sspc::io {

namespace {

class AsciiBodyReader final : public PointReader {
 public:
  AsciiBodyReader(std::span<const std::byte> file, const PlyHeader& header,
                  const PlyVertexLayout& layout, std::string_view name, const PlyBodySinks& sinks)
      : header_(header),
        layout_(layout),
        name_(name),
        progress_(sinks.progress),
        wide_(*sinks.wide),
        text_(as_text(file)),
        lines_(text_.substr(std::min(header.body_offset, text_.size())), header.body_first_line) {}

  Status read(std::size_t max_points, PointCloud& out) override {
    for (; element_ < header_.elements.size(); ++element_, item_ = 0) {
      const PlyElement& element = header_.elements[element_];
      if (element.properties.empty()) continue;  // such items occupy no text
      const bool is_vertex = element_ == layout_.element;
      if (is_vertex) SSPC_RETURN_IF_ERROR(prepare_vertices(element, max_points, out));
      for (std::size_t n = 0; item_ < element.count; ++item_, ++n) {
        if (n == max_points) return Status();  // resume here
        std::string_view line;
        if (!next_data_line(line)) {
          return error_at_line(StatusCode::kParseError, name_, lines_.line_number() + 1,
                               "the file ends after " + std::to_string(item_) + " of the " +
                                   std::to_string(element.count) + " items of element " +
                                   quote_token(element.name));
        }
        SSPC_RETURN_IF_ERROR(parse_item(element, is_vertex, line));
        if (is_vertex) SSPC_RETURN_IF_ERROR(store_vertex(element, out));
        report_progress();
      }
    }
    std::string_view line;
    if (next_data_line(line)) {
      return error_at_line(StatusCode::kParseError, name_, lines_.line_number(),
                           "data after the last element (the header's counts are wrong)");
    }
    progress_advance(progress_, text_.size() - reported_);
    reported_ = text_.size();
    done_ = true;
    return Status();
  }

  bool done() const override { return done_; }
  std::size_t consumed() const override {
    return std::min(header_.body_offset, text_.size()) + lines_.position();
  }

 private:
  bool next_data_line(std::string_view& line) {
    while (lines_.next(line)) {
      if (!is_blank(line)) return true;
    }
    return false;
  }

  void report_progress() {
    const std::size_t at = header_.body_offset + lines_.position();
    if (at - reported_ >= (std::size_t{1} << 20)) {
      progress_advance(progress_, at - reported_);
      reported_ = at;
    }
  }

  Status error(std::string_view what) const {
    return error_at_line(StatusCode::kParseError, name_, lines_.line_number(), what);
  }

  Status prepare_vertices(const PlyElement& vertex, std::size_t max_points, PointCloud& out) {
    if (item_ == 0) {
      // Each value takes at least one character and one separator (the last line may lack its
      // newline), so the text left bounds the number of items; a header claiming more fails
      // here instead of reserving memory for it.
      const std::size_t left = text_.size() - std::min(text_.size(), header_.body_offset);
      const std::size_t min_item = 2 * vertex.properties.size();
      if (vertex.count > (left + 1) / min_item) {
        return error_at_line(StatusCode::kParseError, name_, vertex.line,
                             "element 'vertex' declares " + std::to_string(vertex.count) +
                                 " items, more than the " + std::to_string(left) +
                                 " bytes of the body can hold");
      }
    }
    const auto n =
        static_cast<std::size_t>(std::min<std::uint64_t>(vertex.count - item_, max_points));
    out.reserve(out.size() + n, layout_.normals, layout_.colours);
    return Status();
  }

  // Parses one item; for the vertex element the values of the mapped properties land in v_.
  Status parse_item(const PlyElement& element, bool is_vertex, std::string_view line) {
    Tokenizer tokens(line);
    std::string_view tok;
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const PlyProperty& prop = element.properties[p];
      if (!tokens.next(tok)) {
        return error("the line ends before property " + quote_token(prop.name) + " of element " +
                     quote_token(element.name));
      }
      if (prop.is_list) {
        std::uint64_t n = 0;
        if (!is_plain_unsigned(tok) || !parse_number(tok, n)) {
          return error("length of list " + quote_token(prop.name) + ": " + quote_token(tok) +
                       " is not a non-negative integer");
        }
        for (std::uint64_t k = 0; k < n; ++k) {
          if (!tokens.next(tok)) {
            return error("list " + quote_token(prop.name) + " declares " + std::to_string(n) +
                         " entries but the line holds " + std::to_string(k));
          }
        }
        continue;
      }
      const int slot = is_vertex ? layout_.slot[p] : kSkipProperty;
      if (slot == kSkipProperty) continue;
      bool ok = false;
      if (prop.type == ScalarType::kFloat32) {
        // Parsed as float directly: going through double could round twice and break the exact
        // round trip of shortest-form floats.
        float f = 0;
        ok = parse_number(tok, f);
        v_[slot] = static_cast<double>(f);
      } else {
        ok = parse_number(tok, v_[slot]);
      }
      if (!ok) {
        return error("property " + quote_token(prop.name) + ": " + quote_token(tok) +
                     " is not a number");
      }
    }
    if (!tokens.done()) {
      return error("more values than element " + quote_token(element.name) + " declares (" +
                   std::to_string(element.properties.size()) + " properties)");
    }
    return Status();
  }

  Status store_vertex(const PlyElement& vertex, PointCloud& cloud) {
    const auto f = [&](PlySlot s) { return narrow_to_float(v_[s]); };
    cloud.positions.emplace_back(f(kX), f(kY), f(kZ));
    if (layout_.normals) cloud.normals.emplace_back(f(kNx), f(kNy), f(kNz));
    if (layout_.colours) {
      const auto channel = [&](PlySlot s) {
        return colour_channel(v_[s], vertex.properties[*layout_.property[s]].type);
      };
      cloud.colours.push_back(Rgb8{channel(kRed), channel(kGreen), channel(kBlue)});
    }
    const std::size_t idx = cloud.size() - 1;
    if (!cloud.positions[idx].allFinite() || (layout_.normals && !cloud.normals[idx].allFinite())) {
      return non_finite_error(name_, cloud, idx, "line " + std::to_string(lines_.line_number()),
                              points_ - idx);
    }
    if (wide_.wanted()) wide_.add(Vec3d(v_[kX], v_[kY], v_[kZ]), cloud.positions[idx]);
    ++points_;
    return Status();
  }

  const PlyHeader& header_;
  const PlyVertexLayout& layout_;
  std::string_view name_;
  Progress* progress_;
  WidePositions& wide_;
  std::string_view text_;
  LineScanner lines_;
  double v_[kSlotCount] = {};
  std::size_t reported_ = 0;
  std::size_t element_ = 0;  // the element being read
  std::uint64_t item_ = 0;   // its next item
  std::size_t points_ = 0;   // vertices read so far, for messages that number them
  bool done_ = false;
};

}  // namespace

std::unique_ptr<PointReader> make_ply_ascii_body(std::span<const std::byte> file,
                                                 const PlyHeader& header,
                                                 const PlyVertexLayout& layout,
                                                 std::string_view name, const PlyBodySinks& sinks) {
  return std::make_unique<AsciiBodyReader>(file, header, layout, name, sinks);
}

}  // namespace sspc::io
