// libFuzzer target: .qt buffers are loaded and verified; whatever loads must convolve, and a
// capture set's lights must be readable and valid.
#include <cstddef>
#include <cstdint>

#include "basis/core/convolution.h"
#include "basis/core/projection.h"
#include "basis/format/qt_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const basis::QtFile file =
        basis::QtFile::from_bytes({reinterpret_cast<const std::byte*>(data), size}, "input.qt");
    basis::Grid one(2, 1);
    for (float& t : one.texels)
      t = 1;
    const basis::PackedTree probe = basis::pack(basis::project(one));
    for (std::size_t i = 0; i < file.trees().size(); ++i)
      for (const double accuracy : {0.0, 0.01})
        basis::convolve(file.trees().tree(i), probe.view(), {.accuracy = accuracy});
    if (file.kind() == basis::QtKind::brdf_table) {
      const basis::BrdfTableView table = file.brdf_table();
      for (std::size_t i = 0; i < table.tilt.size(); ++i)
        basis::convolve_groups(table.tilt.tree(i), probe.view());
    }
    if (file.kind() == basis::QtKind::capture_set) {
      // Every capture's lights are readable and their values were verified.
      const basis::CaptureSetView captures = file.captures();
      for (std::size_t k = 0; k < captures.size(); ++k)
        for (const basis::DirectionalLight& light : captures.lights_of(k))
          if (!(light.direction.z() > 0) || !(light.energy[0] >= 0)) __builtin_trap();
    }
  } catch (const basis::FileError&) {
  }
  return 0;
}
