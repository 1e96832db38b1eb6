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
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "core/check.hpp"
#include "io/point_chunks.hpp"
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

// What the trailing values of six-column lines have looked like so far.
struct SixColumnEvidence {
  bool colours_possible = true;  // every trailing value an integer 0..255
  bool above_one = false;        // some trailing value above 1
};

// The lines of an XYZ file as a PointReader (io/point_chunks.hpp). Six columns are read as
// normals; six_columns_to_colours() turns them into colours once the whole file has been seen.
class XyzReader final : public PointReader {
 public:
  // `wide` receives each position as written when wide.wanted().
  XyzReader(std::span<const std::byte> data, std::string_view name, Progress* progress,
            WidePositions& wide)
      : text_(without_bom(as_text(data))),
        name_(name),
        progress_(progress),
        wide_(wide),
        lines_(text_),
        bom_(data.size() - text_.size()) {}

  Status read(std::size_t max_points, PointCloud& out) override {
    if (columns_) reserve(max_points, out);
    std::string_view line;
    for (std::size_t n = 0; n < max_points;) {
      if (!lines_.next(line)) return finish_text();
      if (is_blank(line) || is_comment(line)) continue;
      std::array<std::string_view, 10> tok;
      const std::size_t columns = split(line, tok);
      if (first_) {
        first_ = false;
        if (columns == 1 && is_plain_unsigned(tok[0])) {
          std::uint64_t count = 0;
          if (!parse_number(tok[0], count)) return error("the point count is out of range");
          declared_ = count;
          declared_line_ = lines_.line_number();
          continue;
        }
      }
      if (!columns_) {
        columns_ = columns_for(columns);
        if (!columns_) {
          return error(std::to_string(columns) +
                       " columns (expected 3 x y z, 4 x y z i, 6 x y z nx ny nz or x y z r g b, "
                       "7 x y z i r g b, or 9 x y z nx ny nz r g b)");
        }
        column_count_ = columns;
        first_line_ = lines_.line_number();
        reserve(max_points - n, out);
      } else if (columns != column_count_) {
        return error(std::to_string(columns) + " columns where the first data line (line " +
                     std::to_string(first_line_) + ") has " + std::to_string(column_count_));
      }
      SSPC_RETURN_IF_ERROR(parse_point(tok, out));
      ++n;
      report_progress();
    }
    return Status();
  }

  bool done() const override { return done_; }
  std::size_t consumed() const override { return bom_ + lines_.position(); }

  // Whether the file's lines have six columns, whose meaning six_columns_to_colours() settles.
  bool six_columns() const { return columns_ == XyzColumns::kXyzNormalsOrRgb; }
  const SixColumnEvidence& evidence() const { return evidence_; }

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

  // The end of the text: a PTS count must match the points.
  Status finish_text() {
    if (declared_ && *declared_ != points_) {
      return error_at_line(StatusCode::kParseError, name_, declared_line_,
                           "the file declares " + std::to_string(*declared_) +
                               " points but holds " + std::to_string(points_));
    }
    progress_advance(progress_, bom_ + text_.size() - reported_);
    reported_ = bom_ + text_.size();
    done_ = true;
    return Status();
  }

  void reserve(std::size_t max_points, PointCloud& out) const {
    // The shortest point line ("0 0 0\n") has 6 bytes: the text bounds the reserve whatever a
    // PTS count claims.
    std::size_t bound = (text_.size() - std::min(text_.size(), lines_.position())) / 6 + 1;
    if (declared_) bound = std::min<std::size_t>(bound, static_cast<std::size_t>(*declared_));
    const bool normals =
        *columns_ == XyzColumns::kXyzNormalsOrRgb || *columns_ == XyzColumns::kXyzNormalsRgb;
    const bool colours =
        *columns_ == XyzColumns::kXyzIRgb || *columns_ == XyzColumns::kXyzNormalsRgb;
    out.reserve(out.size() + std::min(bound, max_points), normals, colours);
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

  Status parse_colours(const std::array<std::string_view, 10>& tok, std::size_t first,
                       PointCloud& out) const {
    std::uint8_t c[3];
    for (std::size_t k = 0; k < 3; ++k) {
      if (!parse_color_token(tok[first + k], c[k])) {
        return error("column " + std::to_string(first + k + 1) + " (colour): " +
                     quote_token(tok[first + k]) + " is not an integer from 0 to 255");
      }
    }
    out.colours.push_back(Rgb8{c[0], c[1], c[2]});
    return Status();
  }

  // The position, also in double when the file's own values are wanted.
  Status parse_position(const std::array<std::string_view, 10>& tok, PointCloud& out) {
    if (!wide_.wanted()) {
      Vec3f p;
      SSPC_RETURN_IF_ERROR(parse_floats(tok, 0, p, "position"));
      out.positions.push_back(p);
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
    out.positions.push_back(p);
    if (p.allFinite()) wide_.add(stored, p);  // a non-finite one is refused below
    return Status();
  }

  Status parse_point(const std::array<std::string_view, 10>& tok, PointCloud& out) {
    SSPC_RETURN_IF_ERROR(parse_position(tok, out));
    switch (*columns_) {
      case XyzColumns::kXyz:
      case XyzColumns::kXyzI: break;  // the intensity is not part of the model
      case XyzColumns::kXyzNormalsOrRgb: {
        Vec3f v;
        SSPC_RETURN_IF_ERROR(parse_floats(tok, 3, v, "normal or colour"));
        out.normals.push_back(v);
        for (std::size_t k = 3; k < 6; ++k) {
          std::uint8_t c = 0;
          if (!parse_color_token(tok[k], c)) {
            evidence_.colours_possible = false;
          } else if (c > 1) {
            evidence_.above_one = true;
          }
        }
        break;
      }
      case XyzColumns::kXyzIRgb: SSPC_RETURN_IF_ERROR(parse_colours(tok, 4, out)); break;
      case XyzColumns::kXyzNormalsRgb: {
        Vec3f v;
        SSPC_RETURN_IF_ERROR(parse_floats(tok, 3, v, "normal"));
        out.normals.push_back(v);
        SSPC_RETURN_IF_ERROR(parse_colours(tok, 6, out));
        break;
      }
    }
    const std::size_t i = out.size() - 1;
    // Six columns may yet turn out to be colours, which are finite by construction.
    const bool check_normal = out.has_normals() && *columns_ != XyzColumns::kXyzNormalsOrRgb;
    const bool bad_normal = (check_normal || (six_columns() && !evidence_.colours_possible)) &&
                            !out.normals[i].allFinite();
    if (!out.positions[i].allFinite() || bad_normal) {
      return non_finite_error(name_, out, i, "line " + std::to_string(lines_.line_number()),
                              points_ - i);
    }
    ++points_;
    return Status();
  }

  void report_progress() {
    const std::size_t at = lines_.position();
    if (at - reported_ >= (std::size_t{1} << 20)) {
      progress_advance(progress_, at - reported_);
      reported_ = at;
    }
  }

  std::string_view text_;
  std::string_view name_;
  Progress* progress_;
  WidePositions& wide_;
  LineScanner lines_;
  std::size_t bom_;
  std::optional<XyzColumns> columns_;
  std::size_t column_count_ = 0;
  std::size_t first_line_ = 0;
  bool first_ = true;  // no data line or count line seen yet
  std::optional<std::uint64_t> declared_;
  std::size_t declared_line_ = 0;
  SixColumnEvidence evidence_;
  std::size_t points_ = 0;
  std::size_t reported_ = 0;
  bool done_ = false;
};

// Open3D's colours: reals from 0 to 1. `first`: the number in the file of the cloud's point 0.
Status unit_colours(PointCloud& cloud, std::size_t first, std::string_view name) {
  cloud.colours.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& v = cloud.normals[i];
    if (!((v.array() >= 0).all() && (v.array() <= 1).all())) {
      return error_in(StatusCode::kParseError, name,
                      "point " + std::to_string(first + i) +
                          ": colours of an .xyzrgb file are all integers from 0 to 255 or all "
                          "reals from 0 to 1, and this one is neither");
    }
    const Vec3f c = (v * 255.0f).array().round();
    cloud.colours[i] = Rgb8{static_cast<std::uint8_t>(c.x()), static_cast<std::uint8_t>(c.y()),
                            static_cast<std::uint8_t>(c.z())};
  }
  cloud.normals = {};
  return Status();
}

// The six-column rule of the file comment, with the evidence of the whole file, applied to the
// whole cloud or to a chunk of it whose point 0 is point `first` of the file.
Status six_columns_to_colours(XyzSixColumns six, const SixColumnEvidence& evidence,
                              PointCloud& cloud, std::size_t first, std::string_view name) {
  if (six == XyzSixColumns::kNormals) return Status();
  const bool integer_colours = evidence.colours_possible && evidence.above_one;
  if (six == XyzSixColumns::kColours && !integer_colours) return unit_colours(cloud, first, name);
  if (!integer_colours) return Status();
  cloud.colours.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3f& v = cloud.normals[i];
    cloud.colours[i] = Rgb8{static_cast<std::uint8_t>(v.x()), static_cast<std::uint8_t>(v.y()),
                            static_cast<std::uint8_t>(v.z())};
  }
  cloud.normals = {};
  return Status();
}

StatusOr<PointCloud> read_whole(std::span<const std::byte> data, std::string_view name,
                                const ReadOptions& options, XyzSixColumns six) {
  WidePositions wide(options, /*stored_wider=*/true);  // decimal text holds any precision
  XyzReader reader(data, name, options.progress, wide);
  PointCloud cloud;
  SSPC_RETURN_IF_ERROR(reader.read(std::numeric_limits<std::size_t>::max(), cloud));
  SSPC_DCHECK(reader.done());
  if (reader.six_columns()) {
    SSPC_RETURN_IF_ERROR(six_columns_to_colours(six, reader.evidence(), cloud, 0, name));
  }
  SSPC_RETURN_IF_ERROR(finish_cloud(cloud, name));
  wide.finish(cloud);
  return cloud;
}

}  // namespace

StatusOr<PointCloud> read_xyz_with_options(std::span<const std::byte> data, std::string_view name,
                                           const ReadOptions& options) {
  return read_whole(data, name, options, XyzSixColumns::kGuess);
}

StatusOr<PointCloud> read_xyz_columns(std::span<const std::byte> data, std::string_view name,
                                      const ReadOptions& options, XyzSixColumns six) {
  return read_whole(data, name, options, six);
}

Status read_xyz_chunks(const ChunkedRead& in, XyzSixColumns six) {
  const std::span<const std::byte> data = in.file.bytes();
  // The origin depends on every position, what six columns hold on every line, and a PTS count
  // must match the points: a first pass gathers them and finds every parse error.
  WidePositions stats(ReadOptions{}, /*stored_wider=*/true);
  XyzReader scan(data, in.name, in.options.progress, stats);
  SSPC_ASSIGN_OR_RETURN(const std::size_t points,
                        run_pass(in, Pass::kScan, scan, [&](PointCloud&, std::size_t) {
                          stats.forget_added();
                          return Status();
                        }));
  if (points == 0) return finish_cloud(PointCloud(), in.name);
  const std::optional<Vec3d> origin = stats.origin();

  WidePositions wide(ReadOptions{}, /*stored_wider=*/origin.has_value());
  XyzReader reader(data, in.name, in.options.progress, wide);
  return run_pass(in, Pass::kRead, reader,
                  [&](PointCloud& chunk, std::size_t first) {
                    if (scan.six_columns()) {
                      SSPC_RETURN_IF_ERROR(
                          six_columns_to_colours(six, scan.evidence(), chunk, first, in.name));
                    }
                    if (origin) {
                      wide.narrow_added(*origin, chunk.positions);
                      chunk.origin = *origin;
                    }
                    return in.sink(std::move(chunk));
                  })
      .status();
}

}  // namespace io

StatusOr<PointCloud> read_xyz(std::span<const std::byte> data, std::string_view name) {
  return io::read_xyz_with_options(data, name, {});
}

}  // namespace sspc
