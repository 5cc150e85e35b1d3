// What a capture saw of its inputs, as a checksum: captures whose inputs check alike saw the
// same light and scene, whatever their files are called, so that the shards of one run, and a
// reference traced again from the recorded inputs, can be told apart from a run whose map or
// scene changed in between.
#pragma once

#include <string>

#include "basis/lighting/environment.h"
#include "basis/lighting/mesh.h"

namespace basis {

// The XXH3-128 (32 hex digits, as checksum_hex) of the map's size and texels as read, repairs
// applied (a constant environment: its radiance), and of the scene's vertices, triangles,
// emission and corner normals as read (nothing without a scene). Any change to what a capture
// sees changes it, with odds of 2^-128 of missing one; renaming a file does not.
std::string capture_inputs_checksum(const Environment& environment, const TriangleMesh* scene);

}  // namespace basis
