#include "basis/lighting/capture_inputs.h"

#include <array>
#include <cstdint>
#include <span>

#include "basis/io/checksum.h"

namespace basis {

std::string capture_inputs_checksum(const Environment& environment, const TriangleMesh* scene) {
  // Sizes first, so that pieces of other lengths cannot run together alike.
  const std::array<std::uint64_t, 6> sizes = {
      std::uint64_t(environment.width()),
      std::uint64_t(environment.height()),
      scene ? std::uint64_t(scene->vertices.size()) : 0,
      scene ? std::uint64_t(scene->triangles.size()) : 0,
      scene ? std::uint64_t(scene->emission.size()) : 0,
      scene ? std::uint64_t(scene->corner_normals.size()) : 0};
  const std::span<const std::byte> none;
  return pieces_checksum_hex({std::as_bytes(std::span(sizes)), std::as_bytes(environment.pixels()),
                              scene ? std::as_bytes(std::span(scene->vertices)) : none,
                              scene ? std::as_bytes(std::span(scene->triangles)) : none,
                              scene ? std::as_bytes(std::span(scene->emission)) : none,
                              scene ? std::as_bytes(std::span(scene->corner_normals)) : none});
}

}  // namespace basis
