// The libFuzzer entry point, built once per function of tests/fuzz/fuzz_inputs.h with
// SERVOKIT_FUZZ_TARGET naming it (tests/fuzz/CMakeLists.txt). A servokit::Error is the clear
// message a user would get; any other exception escapes and aborts, which libFuzzer reports as
// a crash and saves with its input.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "base/errors.h"
#include "tests/fuzz/fuzz_inputs.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    servokit::fuzz::SERVOKIT_FUZZ_TARGET(
        std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const servokit::Error&) {
  }
  return 0;
}
