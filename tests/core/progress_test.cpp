// ProgressLine: into a file (not a terminal) whole lines, the first update and then one per
// interval, the last state at the end; never a carriage return.
#include <catch2/catch.hpp>
#include <cstdio>
#include <string>

#include "gimm/core/progress.hpp"

namespace {
std::string contents(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string s;
  for (int c; (c = std::fgetc(f)) != EOF;) s += char(c);
  return s;
}
}  // namespace

TEST_CASE("Progress line: whole lines per interval in a log file", "[core][progress]") {
  std::FILE* log = std::tmpfile();
  REQUIRE(log);
  {
    gimm::ProgressLine p(false, 3600.0, log);
    p.show("1/3");
    p.show("2/3");
    p.log("a warning");
    p.show("3/3");
    p.finish();
  }
  CHECK(contents(log) == "1/3\na warning\n3/3\n");
  std::fclose(log);

  std::FILE* every = std::tmpfile();
  gimm::ProgressLine q(false, 0.0, every);
  q.show("1/2");
  q.show("2/2");
  q.finish();
  CHECK(contents(every) == "1/2\n2/2\n");  // nothing pending: no repeat at the end
  std::fclose(every);

  std::FILE* quiet = std::tmpfile();
  gimm::ProgressLine r(true, 0.0, quiet);
  r.show("1/1");
  r.log("an error");
  r.finish();
  CHECK(contents(quiet) == "an error\n");
  std::fclose(quiet);
}
