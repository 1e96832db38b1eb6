// Line and token scanning for the text formats (PLY headers and ascii bodies, XYZ/PTS, PCD).
//
// Lines end at '\n'; a '\r' before it is dropped, so files written on Windows read the same.
// Numbers go through std::from_chars: locale-independent, no allocation, and the float overload
// rounds correctly, so a float written with std::to_chars's shortest form reads back exactly.
#pragma once

#include <bit>
#include <charconv>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>

namespace sspc::io {

class LineScanner {
 public:
  // `first_line` is the number given to the first line of `text` (so that a body scanned after a
  // header reports the file's line numbers).
  explicit LineScanner(std::string_view text, std::size_t first_line = 1)
      : text_(text), next_line_(first_line) {}

  // The next line without its terminator; false at the end of the text.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const char* begin = text_.data() + pos_;
    const std::size_t left = text_.size() - pos_;
    const void* nl = std::memchr(begin, '\n', left);
    std::size_t len = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - begin) : left;
    pos_ += nl ? len + 1 : len;
    if (len > 0 && begin[len - 1] == '\r') --len;
    line = std::string_view(begin, len);
    line_ = next_line_++;
    return true;
  }

  // Number of the line next() returned last.
  std::size_t line_number() const { return line_; }
  // Offset in the text of the first byte not yet returned.
  std::size_t position() const { return pos_; }
  bool at_end() const { return pos_ >= text_.size(); }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
  std::size_t next_line_;
};

// Splits one line into tokens separated by spaces and tabs (and commas and semicolons when
// `commas` is set, for XYZ exports from spreadsheets and CloudCompare). Runs of separators count
// as one.
class Tokenizer {
 public:
  explicit Tokenizer(std::string_view line, bool commas = false)
      : p_(line.data()), end_(line.data() + line.size()), commas_(commas) {}

  bool next(std::string_view& token) {
    skip_separators();
    if (p_ == end_) return false;
    const char* start = p_;
    while (p_ != end_ && !is_separator(*p_)) ++p_;
    token = std::string_view(start, static_cast<std::size_t>(p_ - start));
    return true;
  }

  // True when only separators are left.
  bool done() {
    skip_separators();
    return p_ == end_;
  }

 private:
  bool is_separator(char c) const {
    return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\r' ||
           (commas_ && (c == ',' || c == ';'));
  }
  void skip_separators() {
    while (p_ != end_ && is_separator(*p_)) ++p_;
  }

  const char* p_;
  const char* end_;
  bool commas_;
};

// Counts the tokens of a line.
inline std::size_t count_tokens(std::string_view line, bool commas = false) {
  Tokenizer t(line, commas);
  std::size_t n = 0;
  std::string_view tok;
  while (t.next(tok)) ++n;
  return n;
}

inline bool is_blank(std::string_view line) {
  return Tokenizer(line).done();
}

namespace text_detail {
// from_chars rejects a leading '+', which some writers emit.
inline std::string_view strip_plus(std::string_view tok) {
  if (tok.size() > 1 && tok[0] == '+' && tok[1] != '-' && tok[1] != '+') tok.remove_prefix(1);
  return tok;
}
}  // namespace text_detail

// A number occupying the whole token. NaN and infinity parse (as "nan", "inf"); callers reject
// them where the model requires finite values, so that the message can say so. Out-of-range
// values ("1e999") fail.
template <typename T>
inline bool parse_number(std::string_view token, T& out) {
  token = text_detail::strip_plus(token);
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  return ec == std::errc() && ptr == end;
}

// A number as the nearest float, exactly as parse_number<float> gives it, and the nearest
// double, from one parse in the common case. Rounding the nearest double to float gives the
// nearest float except when that double lies exactly halfway between two floats (the decimal
// itself may not, and then rounding twice can pick the wrong neighbour). That case, non-zero
// values outside float's normal range and failures are parsed again as float, so that the float,
// and whether the token is accepted, are always those of parse_number<float>.
inline bool parse_float_and_double(std::string_view token, float& f, double& d) {
  const bool have_double = parse_number(token, d);
  if (have_double) {
    const double magnitude = d < 0 ? -d : d;
    // A float's 24-bit significand leaves the low 29 of a double's 52 fraction bits; halfway
    // between two floats, they are 1 followed by 28 zeros.
    constexpr std::uint64_t kDropped = (std::uint64_t{1} << 29) - 1;
    constexpr std::uint64_t kHalfway = std::uint64_t{1} << 28;
    const bool normal = magnitude >= static_cast<double>(std::numeric_limits<float>::min()) &&
                        magnitude <= static_cast<double>(std::numeric_limits<float>::max());
    if (d == 0 || (normal && (std::bit_cast<std::uint64_t>(d) & kDropped) != kHalfway)) {
      f = static_cast<float>(d);
      return true;
    }
  }
  if (!parse_number(token, f)) return false;
  if (!have_double) d = static_cast<double>(f);
  return true;
}

// True when the token is a plain non-negative decimal integer: digits only.
inline bool is_plain_unsigned(std::string_view token) {
  if (token.empty()) return false;
  for (char c : token) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

// A token quoted for an error message, shortened so that a binary blob cannot flood it.
std::string quote_token(std::string_view token);

}  // namespace sspc::io
