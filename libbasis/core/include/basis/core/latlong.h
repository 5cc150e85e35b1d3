// Latitude-longitude environment maps, z up. Pixel (column i, row j from the top) of a W x H
// image covers phi in [2 pi i / W, 2 pi (i+1) / W) and theta in [pi j / H, pi (j+1) / H).
#pragma once

#include "basis/core/vector.h"

namespace basis {

// Image coordinates (x in [0, W), y in [0, H), in pixels) to a unit direction:
// theta = pi y / H, phi = 2 pi x / W, w = (sin theta cos phi, sin theta sin phi, cos theta).
Vec3 latlong_to_direction(const Vec2& pixel, int width, int height);

// Unit direction to image coordinates in pixels, x in [0, W), y in [0, H].
Vec2 direction_to_latlong(const Vec3& w, int width, int height);

// Exact solid angle of any pixel of row j: (2 pi / W) (cos(pi j / H) - cos(pi (j+1) / H)).
double latlong_pixel_solid_angle(int row, int width, int height);

// Solid angle per unit pixel area at image row coordinate y: (2 pi / W)(pi / H) sin(pi y / H).
double latlong_to_direction_jacobian(double y, int width, int height);

}  // namespace basis
