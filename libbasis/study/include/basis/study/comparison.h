// The speed-versus-accuracy study behind qtbench: one BRDF slice and one light, given as texel
// grids, approximated in every basis (quadtree, dense grids, spherical harmonics, Haar
// wavelets), each convolution timed and compared with a ground truth computed elsewhere.
#pragma once

#include <string>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/grid.h"

namespace basis {

// The functions of one comparison: texel averages over the cosine-weighted concentric map at
// the finest resolution studied (a power of two), and the converged reflected radiance.
struct ComparisonCase {
  std::string brdf;   // panel name, e.g. phong100
  std::string light;  // e.g. sun, sun+occluder
  Grid brdf_grid;     // f(wi, wo) for the case's wo
  Grid light_grid;    // L(wi) V(wi)
  Color truth;        // integral of f L V cos over the hemisphere, independent of any basis
};

// One measured point of the chart.
struct ComparisonRow {
  std::string method;  // quadtree, quadtree_targeted, dense_naive, dense_simd, sh, haar
  std::string param;   // resolution@tolerance[~accuracy], grid size, SH order, kept coefficients
  std::string brdf, light;
  double bytes = 0;       // storage of the light's representation
  double project_ns = 0;  // projecting the light from its finest texels
  double convolve_ns = 0;
  double rel_error = 0;  // |Y(result) - Y(truth)| / Y(truth), Y the luminance
};

struct ComparisonOptions {
  std::vector<int> quadtree_resolutions{32, 64, 128, 256};
  std::vector<double> quadtree_tolerances{0.01, 0.05, 0.2, 1.0};
  // Accuracy targets of the quadtree_targeted method (ConvolutionOptions::accuracy), each at
  // every resolution and the one tolerance below (the default of the tools).
  std::vector<double> quadtree_accuracies{0.01, 0.05, 0.2};
  double quadtree_targeted_tolerance = 0.05;
  std::vector<int> dense_resolutions{8, 16, 32, 64, 128, 256};
  std::vector<int> sh_orders{2, 3, 4, 6, 8, 12, 16};
  std::vector<std::size_t> haar_kept{16, 32, 64, 128, 256, 512, 1024};
  double seconds_per_timing = 0.02;  // each timing repeats its kernel this long, five times
};

// Every method at every parameter on one case.
std::vector<ComparisonRow> compare_methods(const ComparisonCase& c,
                                           const ComparisonOptions& options);

}  // namespace basis
