#include "sspc/status.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace sspc {
namespace {

StatusOr<int> parse_positive(int v) {
  if (v <= 0) return invalid_argument("not positive: " + std::to_string(v));
  return v;
}

Status doubles(int v, int* out) {
  SSPC_ASSIGN_OR_RETURN(const int x, parse_positive(v));
  *out = 2 * x;
  return Status();
}

TEST(Status, DefaultIsOk) {
  Status s;
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kOk);
}

TEST(Status, CarriesCodeAndContext) {
  Status s = parse_error("line 3: bad token").with_context("bunny.ply");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kParseError);
  EXPECT_EQ(s.message(), "bunny.ply: line 3: bad token");
  EXPECT_EQ(s.to_string(), "parse error: bunny.ply: line 3: bad token");
}

// A caller that ends its context with the separator, or has none to give, must not produce
// "bunny.ply: : ..." or ": ...".
TEST(Status, ContextJoinsWithExactlyOneSeparator) {
  EXPECT_EQ(parse_error("line 3: bad").with_context("bunny.ply: ").message(),
            "bunny.ply: line 3: bad");
  EXPECT_EQ(parse_error("line 3: bad").with_context("bunny.ply:").message(),
            "bunny.ply: line 3: bad");
  EXPECT_EQ(parse_error("line 3: bad").with_context("").message(), "line 3: bad");
  EXPECT_EQ(parse_error("line 3: bad").with_context(": ").message(), "line 3: bad");
  EXPECT_EQ(parse_error("").with_context("bunny.ply").message(), "bunny.ply");
  EXPECT_EQ(parse_error("bad").with_context("a").with_context("b: ").message(), "b: a: bad");
  EXPECT_TRUE(Status().with_context("bunny.ply").message().empty());
}

TEST(StatusOr, AssignOrReturnPropagates) {
  int out = 0;
  EXPECT_TRUE(doubles(4, &out).ok());
  EXPECT_EQ(out, 8);
  Status s = doubles(-1, &out);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(out, 8);
}

TEST(StatusOr, HoldsMoveOnlyValues) {
  StatusOr<std::unique_ptr<int>> p = std::make_unique<int>(7);
  ASSERT_TRUE(p.ok());
  std::unique_ptr<int> v = std::move(p).value();
  EXPECT_EQ(*v, 7);
}

}  // namespace
}  // namespace sspc
