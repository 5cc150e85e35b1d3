// libFuzzer target: capture-set manifests, written to a scratch file and read back. Whatever
// reads must describe shards that tile the run's points in order.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "basis/format/qt_manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("basis_fuzz_" + std::to_string(::getpid()) + ".qtm"))
                               .string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  }
  try {
    const basis::CaptureManifest m = basis::read_manifest(path);
    std::uint64_t next = 0;
    for (std::size_t k = 0; k < m.shards.size(); ++k) {
      const basis::PointRange r = m.shard_points(k);
      if (r.first != next || r.count != m.shards[k].points) std::abort();
      next = r.end();
    }
    if (next != m.total_points) std::abort();
    (void)basis::manifest_json(m);
  } catch (const basis::FileError&) {
  }
  ::unlink(path.c_str());
  return 0;
}
