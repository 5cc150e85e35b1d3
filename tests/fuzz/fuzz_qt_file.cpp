// libFuzzer target: .qt buffers are loaded and verified, as given and then with their checksum
// sealed (so that changed bytes reach the checks past the checksum); whatever loads must
// convolve, and a capture set's lights must be readable and valid.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "basis/core/convolution.h"
#include "basis/core/projection.h"
#include "basis/format/qt_file.h"

namespace {

void load_and_use(std::span<const std::byte> bytes) {
  try {
    const basis::QtFile file = basis::QtFile::from_bytes(bytes, "input.qt");
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
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> given(reinterpret_cast<const std::byte*>(data), size);
  load_and_use(given);
  std::vector<std::byte> sealed(given.begin(), given.end());
  if (basis::seal_qt_checksum(sealed) && !std::equal(sealed.begin(), sealed.end(), given.begin()))
    load_and_use(sealed);
  return 0;
}
