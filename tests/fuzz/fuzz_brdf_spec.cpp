// libFuzzer target: BRDF specs (JSON) are parsed and validated; whatever parses must evaluate.
#include <cstddef>
#include <cstdint>
#include <string>

#include "basis/brdf/brdf_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    // Data files named by specs resolve inside a folder that does not exist.
    const basis::BrdfSpec spec = basis::parse_brdf_spec(text, "spec.json", "/nonexistent-folder");
    const basis::Color f = basis::evaluate(spec.brdf, basis::Vec3(0.3, 0.2, 0.93).normalized(),
                                           basis::Vec3(-0.1, 0.4, 0.91).normalized());
    static_cast<void>(f);
  } catch (const basis::FileError&) {
  }
  return 0;
}
