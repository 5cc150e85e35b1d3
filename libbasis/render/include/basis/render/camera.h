// Pinhole cameras: the primary ray through any point of the image plane.
#pragma once

#include <string>

#include "basis/lighting/ray_scene.h"

namespace basis {

struct Camera {
  Vec3 eye{0, -6, 2};
  Vec3 look_at{0, 0, 0.5};
  Vec3 up{0, 0, 1};
  double fov_degrees = 40;  // vertical field of view
  int width = 320;
  int height = 240;

  // The ray from the eye through image point (x, y) in pixels from the top left corner: pixel
  // (i, j)'s centre is (i + 0.5, j + 0.5).
  Ray ray(double x, double y) const;
  // The angle a pixel subtends at the image's centre, in radians.
  double pixel_angle() const;
};

// Largest image accepted, per side and in pixels.
inline constexpr int kMaxImageSide = 16384;
// (kMaxImagePixels, image_file.h, is what an image file may hold.)
inline constexpr long long kMaxRenderPixels = 1LL << 26;

// Why a camera cannot render (eye at look_at, up along the view, a field of view outside
// (0, 180) degrees, a size of 0 or beyond the limits, a value not finite), or empty when it can.
std::string camera_problem(const Camera& camera);

}  // namespace basis
