// libFuzzer target: OBJ scenes and point files (the first byte picks the reader), written to a
// scratch file and read back.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "basis/lighting/capture.h"
#include "basis/lighting/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string path =
      (std::filesystem::temp_directory_path() /
       ("basis_fuzz_" + std::to_string(::getpid()) + (data[0] & 1 ? ".obj" : ".csv")))
          .string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  }
  try {
    if (data[0] & 1) {
      const basis::TriangleMesh mesh = basis::read_obj(path);
      basis::sample_surface(mesh, 4, 1);
    } else {
      basis::read_points(path);
    }
  } catch (const basis::FileError&) {
  }
  ::unlink(path.c_str());
  return 0;
}
