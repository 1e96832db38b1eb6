// read_xyz: whitespace- (or comma-) separated text, one point per line, as written by
// CloudCompare, MeshLab, Leica Cyclone (PTS) and countless scripts.
//
// The columns are decided by the first data line and must then stay the same:
//   3  x y z
//   4  x y z intensity              (PTS; the intensity is dropped)
//   6  x y z nx ny nz, or x y z r g b: colours when, over the whole file, every one of the last
//      three values is an integer from 0 to 255 written without a decimal point and at least
//      one exceeds 1. Unit normals never exceed 1, and a file of only 0s and 1s reads as normals
//      (the safer guess: a normal (0 0 1) written by "%g" looks exactly like that).
//   7  x y z intensity r g b        (PTS)
//   9  x y z nx ny nz r g b
// The extensions .xyzn and .xyzrgb (Open3D's) name what six columns hold; colours are then
// either all integers 0..255 or, as Open3D writes them, reals from 0 to 1 (scaled by 255).
// Colours are integers 0..255 (anything else is an error). Lines that are blank or start with
// '#' or '//' are skipped. A PTS file may start with a line holding only the point count; it must
// then agree with the number of points (sspc reads single-scan PTS files only).
#include <algorithm>
#include <array>
#include <string>

#include "io/reader_common.hpp"
#include "io/text_scanner.hpp"
#include "io/wide_positions.hpp"

namespace sspc {

namespace io {

namespace {

enum class XyzColumns { kXyz, kXyzI, kXyzNormalsOrRgb, kXyzIRgb, kXyzNormalsRgb };

std::optional<XyzColumns> columns_for(std::size_t n) {
  switch (n) {
    case 3: return XyzColumns::kXyz;
    case 4: return XyzColumns::kXyzI;
    case 6: return XyzColumns::kXyzNormalsOrRgb;
    case 7: return XyzColumns::kXyzIRgb;
    case 9: return XyzColumns::kXyzNormalsRgb;
    default: return std::nullopt;
  }
}

bool is_comment(std::string_view line) {
  while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
  return line.starts_with('#') || line.starts_with("//");
}

// An integer colour channel written as one (no '.', no exponent): "0" to "255".
bool parse_color_token(std::string_view tok, std::uint8_t& out) {
  unsigned v = 0;
  if (!is_plain_unsigned(tok) || tok.size() > 3 || !parse_number(tok, v) || v > 255) return false;
  out = static_cast<std::uint8_t>(v);
  return true;
}

// Windows tools (Notepad, Excel's CSV export) may open the text with a UTF-8 byte order mark.
std::string_view without_bom(std::string_view text) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  return text;
}

class XyzReader {
 public:
  XyzReader(std::span<const std::byte> data, std::string_view name, const ReadOptions& options,
            XyzSixColumns six)
      : six_(six),
        text_(without_bom(as_text(data))),
        name_(name),
        progress_(options.progress),
        wide_(options, /*stored_wider=*/true),  // decimal text holds any precision
        lines_(text_),
        bom_(data.size() - text_.size()) {}

  StatusOr<PointCloud> read() {
    std::optional<std::uint64_t> declared;
    std::size_t declared_line = 0;
    std::string_view line;
    bool first = true;
    while (lines_.next(line)) {
      if (is_blank(line) || is_comment(line)) continue;
      std::array<std::string_view, 10> tok;
      const std::size_t n = split(line, tok);
      if (first) {
        first = false;
        if (n == 1 && is_plain_unsigned(tok[0])) {
          std::uint64_t count = 0;
          if (!parse_number(tok[0], count)) return error("the point count is out of range");
          declared = count;
          declared_line = lines_.line_number();
          continue;
        }
      }
      if (!columns_) {
        columns_ = columns_for(n);
        if (!columns_) {
          return error(std::to_string(n) +
                       " columns (expected 3 x y z, 4 x y z i, 6 x y z nx ny nz or x y z r g b, "
                       "7 x y z i r g b, or 9 x y z nx ny nz r g b)");
        }
        column_count_ = n;
        prepare(declared);
      } else if (n != column_count_) {
        return error(std::to_string(n) + " columns where the first data line (line " +
                     std::to_string(first_line_) + ") has " + std::to_string(column_count_));
      }
      SSPC_RETURN_IF_ERROR(parse_point(tok));
      report_progress();
    }
    if (declared && *declared != cloud_.size()) {
      return error_at_line(StatusCode::kParseError, name_, declared_line,
                           "the file declares " + std::to_string(*declared) + " points but holds " +
                               std::to_string(cloud_.size()));
    }
    if (columns_ == XyzColumns::kXyzNormalsOrRgb) SSPC_RETURN_IF_ERROR(six_columns_to_colours());
    progress_advance(progress_, bom_ + text_.size() - reported_);
    SSPC_RETURN_IF_ERROR(finish_cloud(cloud_, name_));
    wide_.finish(cloud_);
    return std::move(cloud_);
  }

 private:
  template <std::size_t N>
  static std::size_t split(std::string_view line, std::array<std::string_view, N>& out) {
    Tokenizer t(line, /*commas=*/true);
    std::size_t n = 0;
    std::string_view tok;
    while (t.next(tok)) {
      if (n < N) out[n] = tok;
      ++n;
    }
    return n;
  }

  Status error(std::string_view what) const {
    return error_at_line(StatusCode::kParseError, name_, lines_.line_number(), what);
  }

  void prepare(std::optional<std::uint64_t> declared) {
    first_line_ = lines_.line_number();
    // The shortest point line ("0 0 0\n") has 6 bytes: the text bounds the reserve whatever a
    // PTS count claims.
    std::size_t bound = (text_.size() - std::min(text_.size(), lines_.position())) / 6 + 1;
    if (declared) bound = std::min<std::size_t>(bound, static_cast<std::size_t>(*declared));
    const bool normals =
        *columns_ == XyzColumns::kXyzNormalsOrRgb || *columns_ == XyzColumns::kXyzNormalsRgb;
    const bool colours =
        *columns_ == XyzColumns::kXyzIRgb || *columns_ == XyzColumns::kXyzNormalsRgb;
    cloud_.reserve(bound, normals, colours);
  }

  Status not_a_number(std::size_t column, std::string_view what, std::string_view tok) const {
    return error("column " + std::to_string(column + 1) + " (" + std::string(what) +
                 "): " + quote_token(tok) + " is not a number");
  }

  Status parse_floats(const std::array<std::string_view, 10>& tok, std::size_t first, Vec3f& out,
                      std::string_view what) const {
    for (std::size_t k = 0; k < 3; ++k) {
      if (!parse_number(tok[first + k], out[static_cast<Eigen::Index>(k)])) {
        return not_a_number(first + k, what, tok[first + k]);
      }
    }
    return Status();
  }

  Status parse_colours(const std::array<std::string_view, 10>& tok, std::size_t first) {
    std::uint8_t c[3];
    for (std::size_t k = 0; k < 3; ++k) {
      if (!parse_color_token(tok[first + k], c[k])) {
        return error("column " + std::to_string(first + k + 1) + " (colour): " +
                     quote_token(tok[first + k]) + " is not an integer from 0 to 255");
      }
    }
    cloud_.colours.push_back(Rgb8{c[0], c[1], c[2]});
    return Status();
  }

  // The position, also in double when the file's own values are wanted.
  Status parse_position(const std::array<std::string_view, 10>& tok) {
    if (!wide_.wanted()) {
      Vec3f p;
      SSPC_RETURN_IF_ERROR(parse_floats(tok, 0, p, "position"));
      cloud_.positions.push_back(p);
      return Status();
    }
    Vec3f p;
    Vec3d stored;
    for (std::size_t k = 0; k < 3; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      if (!parse_float_and_double(tok[k], p[i], stored[i])) {
        return not_a_number(k, "position", tok[k]);
      }
    }
    cloud_.positions.push_back(p);
    if (p.allFinite()) wide_.add(stored, p);  // a non-finite one is refused below
    return Status();
  }

  Status parse_point(const std::array<std::string_view, 10>& tok) {
    SSPC_RETURN_IF_ERROR(parse_position(tok));
    switch (*columns_) {
      case XyzColumns::kXyz:
      case XyzColumns::kXyzI: break;  // the intensity is not part of the model
      case XyzColumns::kXyzNormalsOrRgb: {
        Vec3f v;
        SSPC_RETURN_IF_ERROR(parse_floats(tok, 3, v, "normal or colour"));
        cloud_.normals.push_back(v);
        for (std::size_t k = 3; k < 6; ++k) {
          std::uint8_t c = 0;
          if (!parse_color_token(tok[k], c)) {
            colours_possible_ = false;
          } else if (c > 1) {
            above_one_ = true;
          }
        }
        break;
      }
      case XyzColumns::kXyzIRgb: SSPC_RETURN_IF_ERROR(parse_colours(tok, 4)); break;
      case XyzColumns::kXyzNormalsRgb: {
        Vec3f v;
        SSPC_RETURN_IF_ERROR(parse_floats(tok, 3, v, "normal"));
        cloud_.normals.push_back(v);
        SSPC_RETURN_IF_ERROR(parse_colours(tok, 6));
        break;
      }
    }
    const std::size_t i = cloud_.size() - 1;
    // Six columns may yet turn out to be colours, which are finite by construction.
    const bool check_normal = cloud_.has_normals() && *columns_ != XyzColumns::kXyzNormalsOrRgb;
    if (!cloud_.positions[i].allFinite() || (check_normal && !cloud_.normals[i].allFinite())) {
      return non_finite_error(name_, cloud_, i, "line " + std::to_string(lines_.line_number()));
    }
    if (*columns_ == XyzColumns::kXyzNormalsOrRgb && !colours_possible_ &&
        !cloud_.normals[i].allFinite()) {
      return non_finite_error(name_, cloud_, i, "line " + std::to_string(lines_.line_number()));
    }
    return Status();
  }

  // The six-column rule of the file comment, applied once the whole file has been seen.
  Status six_columns_to_colours() {
    if (six_ == XyzSixColumns::kNormals) return Status();
    if (six_ == XyzSixColumns::kColours && !(colours_possible_ && above_one_)) {
      return unit_colours();
    }
    if (!colours_possible_ || !above_one_) return Status();
    cloud_.colours.resize(cloud_.size());
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      const Vec3f& v = cloud_.normals[i];
      cloud_.colours[i] = Rgb8{static_cast<std::uint8_t>(v.x()), static_cast<std::uint8_t>(v.y()),
                              static_cast<std::uint8_t>(v.z())};
    }
    cloud_.normals = {};
    return Status();
  }

  // Open3D's colours: reals from 0 to 1.
  Status unit_colours() {
    cloud_.colours.resize(cloud_.size());
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      const Vec3f& v = cloud_.normals[i];
      if (!((v.array() >= 0).all() && (v.array() <= 1).all())) {
        return error_in(StatusCode::kParseError, name_,
                        "point " + std::to_string(i) +
                            ": colours of an .xyzrgb file are all integers from 0 to 255 or all "
                            "reals from 0 to 1, and this one is neither");
      }
      const Vec3f c = (v * 255.0f).array().round();
      cloud_.colours[i] = Rgb8{static_cast<std::uint8_t>(c.x()), static_cast<std::uint8_t>(c.y()),
                              static_cast<std::uint8_t>(c.z())};
    }
    cloud_.normals = {};
    return Status();
  }

  void report_progress() {
    const std::size_t at = lines_.position();
    if (at - reported_ >= (std::size_t{1} << 20)) {
      progress_advance(progress_, at - reported_);
      reported_ = at;
    }
  }

  XyzSixColumns six_;
  std::string_view text_;
  std::string_view name_;
  Progress* progress_;
  WidePositions wide_;
  LineScanner lines_;
  PointCloud cloud_;
  std::optional<XyzColumns> columns_;
  std::size_t column_count_ = 0;
  std::size_t first_line_ = 0;
  bool colours_possible_ = true;  // six columns: every trailing value so far an integer 0..255
  bool above_one_ = false;       // six columns: some trailing value above 1
  std::size_t bom_;
  std::size_t reported_ = 0;
};

}  // namespace

StatusOr<PointCloud> read_xyz_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  return XyzReader(data, name, options, XyzSixColumns::kGuess).read();
}

StatusOr<PointCloud> read_xyz_columns(std::span<const std::byte> data, std::string_view name,
                                      const ReadOptions& options, XyzSixColumns six) {
  return XyzReader(data, name, options, six).read();
}

}  // namespace io

StatusOr<PointCloud> read_xyz(std::span<const std::byte> data, std::string_view name) {
  return io::read_xyz_with_options(data, name, {});
}

}  // namespace sspc
