// base/option_check.h: the one check of an options field, with its message "Owner::field =
// value: rule" (numbers by FormatNumber, tests/base/number_format_test.cpp).
#include "base/option_check.h"

#include <catch2/catch.hpp>

namespace servokit {
namespace {

TEST_CASE("a field that holds its rule passes", "[base]") {
  CHECK_NOTHROW(RequireOption(true, "SomeOptions", "tolerance", -1.0, "must be > 0"));
}

TEST_CASE("a broken rule names the owner, the field, the value and the rule", "[base]") {
  CHECK_THROWS_WITH(RequireOption(false, "SomeOptions", "tolerance", 2.0, "must be < 1"),
                    "SomeOptions::tolerance = 2: must be < 1");
  CHECK_THROWS_WITH(RequireOption(false, "SomeOptions", "tolerance", 1e-15, "must be >= 1e-14"),
                    "SomeOptions::tolerance = 1e-15: must be >= 1e-14");
  CHECK_THROWS_WITH(RequireOption(false, "SomeOptions", "count", -3, "must be >= 0"),
                    "SomeOptions::count = -3: must be >= 0");
  CHECK_THROWS_WITH(RequireOption(false, "SomeOptions", "points", 10000000000L, "must be <= 1000"),
                    "SomeOptions::points = 10000000000: must be <= 1000");
  CHECK_THROWS_WITH(RequireOption(false, "SomeSystem", "matrix", "3 x 2", "must be 3 x 3"),
                    "SomeSystem::matrix = 3 x 2: must be 3 x 3");
  CHECK_THROWS_WITH(RequireOption(false, "SomeOptions", "start", Eigen::Vector3d(1, 0.25, -1e-300),
                                  "must have 2 values"),
                    "SomeOptions::start = [1, 0.25, -1e-300]: must have 2 values");
}

TEST_CASE("an option error is a usage error that keeps the owner and the field", "[base]") {
  try {
    RequireOption(false, "SomeOptions", "rank_tolerance", 0.0, "must be > 0");
    FAIL("RequireOption did not throw");
  } catch (const OptionError& error) {
    CHECK(error.owner() == "SomeOptions");
    CHECK(error.field() == "rank_tolerance");
    const UsageError& usage = error;  // exit status 2, like every bad option
    CHECK(std::string(usage.what()) == "SomeOptions::rank_tolerance = 0: must be > 0");
  }
}

}  // namespace
}  // namespace servokit
