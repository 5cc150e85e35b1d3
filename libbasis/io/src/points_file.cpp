#include "basis/io/points_file.h"

#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/io/text_file.h"

namespace basis {

std::vector<SurfacePoint> read_points(const std::string& path) {
  // Read whole, from a file or a pipe (--points <(...)): at most about 200 bytes a point.
  std::istringstream in(read_text_file(path, kMaxSurfacePoints * 200, "a points file"));
  std::vector<SurfacePoint> points;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string content = line.substr(0, line.find('#'));
    if (content.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream fields(content);
    double v[6];
    for (int k = 0; k < 6; ++k) {
      char comma = ',';
      if (!(fields >> v[k]) || (k < 5 && !(fields >> comma)) || comma != ',' ||
          !std::isfinite(v[k]))
        throw FileError(path + ":" + std::to_string(number) +
                        ": expected six finite numbers x,y,z,nx,ny,nz");
    }
    if (!(fields >> std::ws).eof())
      throw FileError(path + ":" + std::to_string(number) + ": more than six values");
    const Vec3 n = unit_direction(Vec3(v[3], v[4], v[5]));
    if (n == Vec3::Zero())
      throw FileError(path + ":" + std::to_string(number) + ": the normal is zero");
    if (points.size() >= kMaxSurfacePoints)
      throw FileError(path + ":" + std::to_string(number) + ": more than " +
                      std::to_string(kMaxSurfacePoints) + " points");
    points.push_back({Vec3(v[0], v[1], v[2]), n});
  }
  if (points.empty()) throw FileError(path + ": no points");
  return points;
}

}  // namespace basis
