// libFuzzer target: MERL and RGL files (the first byte picks the reader) are parsed; whatever
// parses must evaluate.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "basis/brdf/merl.h"
#include "basis/brdf/rgl.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const basis::Vec3 wi = basis::Vec3(0.3, 0.2, 0.93).normalized();
  const basis::Vec3 wo = basis::Vec3(-0.1, 0.4, 0.91).normalized();
  try {
    if (data[0] & 1) {
      const auto merl = basis::MerlBrdf::parse({data + 1, size - 1}, "input.binary");
      merl->evaluate(wi, wo);
    } else {
      const auto rgl =
          basis::RglBrdf::parse(std::vector<unsigned char>(data + 1, data + size), "input.bsdf");
      rgl->evaluate(wi, wo);
      rgl->sample(wi, 0.3, 0.7);
      rgl->pdf(wi, wo);
    }
  } catch (const basis::FileError&) {
  }
  return 0;
}
