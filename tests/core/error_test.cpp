// Errors and checks: GIMM_CHECK always throws gimm::Error (or the named subclass) whose message
// starts with "gimm: " and shows the bad value.
#include <catch2/catch.hpp>
#include <string>

#include "gimm/core/error.hpp"

using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

void need_at_least_eight(int n) {
  GIMM_CHECK(n >= 8, "fundamental_8pt: need at least 8 correspondences, got " << n);
}

std::string message_of(void (*f)(int), int arg) {
  try {
    f(arg);
  } catch (const gimm::Error& e) {
    return e.what();
  }
  return {};
}

}  // namespace

TEST_CASE("GIMM_CHECK passes silently when the condition holds", "[core][error]") {
  REQUIRE_NOTHROW(need_at_least_eight(8));
  REQUIRE_NOTHROW(need_at_least_eight(1000));
}

TEST_CASE("GIMM_CHECK throws gimm::Error naming the input and the bad value", "[core][error]") {
  REQUIRE_THROWS_AS(need_at_least_eight(3), gimm::Error);
  const std::string what = message_of(&need_at_least_eight, 3);
  CHECK_THAT(what, StartsWith("gimm: "));
  CHECK_THAT(what, Contains("fundamental_8pt"));
  CHECK_THAT(what, Contains("got 3"));
  // The message is the streamed value, not a fixed text.
  CHECK_THAT(message_of(&need_at_least_eight, -17), Contains("got -17"));
  // gimm::Error is a std::runtime_error, so generic handlers catch it too.
  REQUIRE_THROWS_AS(need_at_least_eight(0), std::runtime_error);
}

TEST_CASE("GIMM_CHECK streams any printable value", "[core][error]") {
  const double spacing = -0.25;
  REQUIRE_THROWS_WITH([&] { GIMM_CHECK(spacing > 0, "spacing must be > 0, got " << spacing); }(),
                      "gimm: spacing must be > 0, got -0.25");
  const std::string name = "weird.nii";
  REQUIRE_THROWS_WITH([&] { GIMM_CHECK(name.empty(), "file '" << name << "' rejected"); }(),
                      "gimm: file 'weird.nii' rejected");
}

TEST_CASE("GIMM_CHECK evaluates its message only on failure", "[core][error]") {
  int evaluated = 0;
  auto count = [&] {
    ++evaluated;
    return 1;
  };
  GIMM_CHECK(true, "never " << count());
  CHECK(evaluated == 0);
  CHECK_THROWS([&] { GIMM_CHECK(false, "once " << count()); }());
  CHECK(evaluated == 1);
}

TEST_CASE("GIMM_CHECK_AS throws the named subclass, still a gimm::Error", "[core][error]") {
  const std::string path = "/no/such/file.nii.gz";
  auto io = [&] { GIMM_CHECK_AS(gimm::IoError, false, "cannot open " << path); };
  auto format = [&] { GIMM_CHECK_AS(gimm::FormatError, false, "bad magic in " << path); };
  REQUIRE_THROWS_AS(io(), gimm::IoError);
  REQUIRE_THROWS_AS(format(), gimm::FormatError);
  REQUIRE_THROWS_AS(io(), gimm::Error);
  REQUIRE_THROWS_AS(format(), gimm::Error);
  REQUIRE_THROWS_WITH(io(), "gimm: cannot open /no/such/file.nii.gz");
  // An IoError is not a FormatError.
  bool caught_as_format = false;
  try {
    GIMM_CHECK_AS(gimm::IoError, false, "x");
  } catch (const gimm::FormatError&) {
    caught_as_format = true;
  } catch (const gimm::Error&) {
  }
  CHECK_FALSE(caught_as_format);
}

TEST_CASE("GIMM_FAIL always throws", "[core][error]") {
  REQUIRE_THROWS_WITH(
      [] {
        GIMM_FAIL("mode must be one of a|b, got '"
                  << "c"
                  << "'");
      }(),
      "gimm: mode must be one of a|b, got 'c'");
}

TEST_CASE("Error messages escape control bytes quoted from an input", "[core][error]") {
  // A NUL no longer ends the message where what() is read as a C string; ESC and BEL cannot
  // drive the terminal; newlines and tabs stay.
  const std::string field = std::string("foo") + '\0' + "bar\x1b[31m\x07\x7f";
  try {
    GIMM_CHECK_AS(gimm::FormatError, false, "unknown field '" << field << "'\n\tline 8");
    FAIL("no throw");
  } catch (const gimm::FormatError& e) {
    CHECK(std::string(e.what()) ==
          "gimm: unknown field 'foo\\x00bar\\x1b[31m\\x07\\x7f'\n\tline 8");
  }
  CHECK(gimm::printable("plain \xc3\xa9 text") == "plain \xc3\xa9 text");  // UTF-8 kept
}
