// Status and StatusOr<T>: how every fallible sspc function reports failure.
//
// sspc does not throw across its API. A function that can fail on input it does not control (a
// file, a parameter from a user) returns Status or StatusOr<T>; the message names the file and
// the line or byte offset where that is known, so the command-line tool can print it as is.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace sspc {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,   // a parameter out of its range, an empty cloud where one is needed
  kNotFound,          // a file that does not exist
  kIoError,           // the operating system refused a read or a write
  kParseError,        // a malformed text or header
  kCorrupt,           // a binary file whose bytes disagree with themselves (checksum, bounds)
  kUnsupported,       // a well-formed input using a feature sspc does not implement
  kResourceExhausted, // a request larger than the limits sspc accepts
  kCancelled,
  kInternal,
};

const char* status_code_name(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok_status() { return Status(); }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }

  // "parse error: bunny.ply: line 3: ..." for printing.
  std::string to_string() const;

  // Prepends context ("bunny.ply") to the message of a failed status, joined by exactly one
  // ": ". The one place messages are joined: a context that already ends with the separator
  // ("bunny.ply: ") is trimmed first, an empty context leaves the message as it is, and an
  // empty message becomes the context alone, so no message starts with ": " or holds ": : ".
  Status with_context(const std::string& context) const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status invalid_argument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status not_found(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status io_error(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status parse_error(std::string m) { return {StatusCode::kParseError, std::move(m)}; }
inline Status corrupt(std::string m) { return {StatusCode::kCorrupt, std::move(m)}; }
inline Status unsupported(std::string m) { return {StatusCode::kUnsupported, std::move(m)}; }
inline Status resource_exhausted(std::string m) { return {StatusCode::kResourceExhausted, std::move(m)}; }
inline Status internal_error(std::string m) { return {StatusCode::kInternal, std::move(m)}; }

// A value or the Status that explains why there is none.
template <typename T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(Status status) : data_(std::move(status)) {  // NOLINT: implicit by design
    assert(!std::get<Status>(data_).ok() && "StatusOr built from an ok Status");
  }
  StatusOr(T value) : data_(std::move(value)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(data_); }
  Status status() const { return ok() ? Status() : std::get<Status>(data_); }

  const T& value() const& { return std::get<T>(data_); }
  T& value() & { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  std::variant<Status, T> data_;
};

}  // namespace sspc

#define SSPC_STATUS_CONCAT_INNER(a, b) a##b
#define SSPC_STATUS_CONCAT(a, b) SSPC_STATUS_CONCAT_INNER(a, b)

// Returns from the enclosing function if `expr` (a Status) is not ok.
#define SSPC_RETURN_IF_ERROR(expr)                    \
  do {                                                \
    ::sspc::Status sspc_status_ = (expr);             \
    if (!sspc_status_.ok()) return sspc_status_;      \
  } while (false)

// `SSPC_ASSIGN_OR_RETURN(auto cloud, read_point_cloud(path));`
#define SSPC_ASSIGN_OR_RETURN(lhs, expr) \
  SSPC_ASSIGN_OR_RETURN_IMPL(SSPC_STATUS_CONCAT(sspc_statusor_, __LINE__), lhs, expr)
#define SSPC_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                               \
  if (!tmp.ok()) return tmp.status();              \
  lhs = std::move(tmp).value()
