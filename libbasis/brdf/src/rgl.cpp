#include "basis/brdf/rgl.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace basis {

namespace {

constexpr double kPi = std::numbers::pi;

// ------------------------------------------------------------------------------------------
// The tensor_file container: a little-endian header of named n-dimensional arrays.

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
constexpr std::size_t kHeaderSize = 18;         // magic, two version bytes, uint32 field count
constexpr std::size_t kMinDescriptorSize = 13;  // name length, ndim, dtype, offset
constexpr std::size_t kMaxDimensions = 8;       // the format's fields have at most 5
constexpr std::uintmax_t kMaxFileSize = std::uintmax_t(1) << 30;

struct Dtype {
  const char* name;
  std::size_t bytes;
};
// Indexed by the file's dtype code; code 0 is invalid.
constexpr std::array<Dtype, 12> kDtypes = {{{"invalid", 0},
                                            {"uint8", 1},
                                            {"int8", 1},
                                            {"uint16", 2},
                                            {"int16", 2},
                                            {"uint32", 4},
                                            {"int32", 4},
                                            {"uint64", 8},
                                            {"int64", 8},
                                            {"float16", 2},
                                            {"float32", 4},
                                            {"float64", 8}}};
constexpr int kUint8 = 1, kFloat32 = 10;

// Unsigned little-endian integer of n bytes at p.
std::uint64_t load_le(const unsigned char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t k = n; k-- > 0;)
    v = (v << 8) | p[k];
  return v;
}

struct Field {
  std::string name;
  int dtype = 0;
  std::uint64_t offset = 0;
  std::vector<std::uint64_t> shape;
  std::uint64_t count = 1;  // product of the shape
};

std::string shape_text(const std::vector<std::uint64_t>& shape) {
  std::string s = "[";
  for (std::size_t k = 0; k < shape.size(); ++k)
    s += (k ? " x " : "") + std::to_string(shape[k]);
  return s + "]";
}

// A parsed tensor_file held in memory; every problem becomes FileError "PATH: problem".
class TensorFile {
 public:
  TensorFile(std::string path, std::vector<unsigned char> bytes)
      : path_(std::move(path)), bytes_(std::move(bytes)) {
    parse_header();
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw FileError(path_ + ": " + problem);
  }

  bool has(const std::string& name) const { return fields_.count(name) != 0; }

  // The field called name, which must exist with this dtype and number of dimensions.
  const Field& get(const std::string& name, int dtype, std::size_t ndim) const {
    const auto it = fields_.find(name);
    if (it == fields_.end()) fail("missing field '" + name + "'");
    const Field& f = it->second;
    if (f.dtype != dtype || f.shape.size() != ndim)
      fail("field '" + name + "' must be a " + std::to_string(ndim) + "-D " +
           kDtypes[std::size_t(dtype)].name + " array, got a " + std::to_string(f.shape.size()) +
           "-D " + kDtypes[std::size_t(f.dtype)].name + " array of shape " + shape_text(f.shape));
    return f;
  }

  // A float32 field's values as doubles; all must be finite.
  std::vector<double> floats(const Field& f) const {
    std::vector<double> values(std::size_t(f.count));
    const unsigned char* p = bytes_.data() + f.offset;
    for (std::size_t k = 0; k < values.size(); ++k) {
      const auto bits = std::uint32_t(load_le(p + 4 * k, 4));
      values[k] = double(std::bit_cast<float>(bits));
      if (!std::isfinite(values[k])) fail("field '" + f.name + "' holds NaN or infinity");
    }
    return values;
  }

  // A uint8 field's bytes.
  std::vector<unsigned char> octets(const Field& f) const {
    const auto* p = bytes_.data() + f.offset;
    return std::vector<unsigned char>(p, p + f.count);
  }

 private:
  void parse_header() {
    const std::size_t size = bytes_.size();
    if (size == 0) fail("empty file");
    if (size >= sizeof kMagic && std::memcmp(bytes_.data(), kMagic, sizeof kMagic) != 0)
      fail("not a tensor_file (the first 12 bytes are not \"tensor_file\\0\")");
    if (size < kHeaderSize)
      fail("too short for a tensor_file header (" + std::to_string(size) + " of " +
           std::to_string(kHeaderSize) + " bytes)");
    if (bytes_[12] != 1 || bytes_[13] != 0)
      fail("unsupported tensor_file version " + std::to_string(bytes_[12]) + "." +
           std::to_string(bytes_[13]) + " (expected 1.0)");
    const std::uint64_t n_fields = load_le(&bytes_[14], 4);
    if (n_fields > (size - kHeaderSize) / kMinDescriptorSize)
      fail("header declares " + std::to_string(n_fields) + " fields, more than its " +
           std::to_string(size) + " bytes can hold");

    std::size_t pos = kHeaderSize;
    // The next n bytes of the header, or an error naming the descriptor being read.
    auto take = [&](std::size_t n, std::uint64_t index) -> const unsigned char* {
      if (n > size - pos)
        fail("truncated header (field descriptor " + std::to_string(index + 1) + " of " +
             std::to_string(n_fields) + " ends past the end of the file)");
      const unsigned char* p = bytes_.data() + pos;
      pos += n;
      return p;
    };
    for (std::uint64_t index = 0; index < n_fields; ++index) {
      Field f;
      const auto name_length = std::size_t(load_le(take(2, index), 2));
      const unsigned char* name = take(name_length, index);
      f.name.assign(reinterpret_cast<const char*>(name), name_length);
      const auto ndim = std::size_t(load_le(take(2, index), 2));
      f.dtype = *take(1, index);
      f.offset = load_le(take(8, index), 8);
      if (ndim > kMaxDimensions)
        fail("field '" + f.name + "' has " + std::to_string(ndim) + " dimensions (at most " +
             std::to_string(kMaxDimensions) + " are supported)");
      if (f.dtype < 1 || f.dtype >= int(kDtypes.size()))
        fail("field '" + f.name + "' has invalid dtype code " + std::to_string(f.dtype));
      const unsigned char* dims = take(8 * ndim, index);
      for (std::size_t k = 0; k < ndim; ++k)
        f.shape.push_back(load_le(dims + 8 * k, 8));

      // Size of the data block, without overflow, and within the file.
      std::uint64_t n_bytes = kDtypes[std::size_t(f.dtype)].bytes;
      bool overflow = false;
      for (std::uint64_t d : f.shape) {
        if (d != 0 && f.count > std::numeric_limits<std::uint64_t>::max() / d) overflow = true;
        f.count = overflow ? 0 : f.count * d;
      }
      if (!overflow && f.count > std::numeric_limits<std::uint64_t>::max() / n_bytes)
        overflow = true;
      if (overflow)
        fail("field '" + f.name + "' has an impossibly large shape " + shape_text(f.shape));
      n_bytes *= f.count;
      if (n_bytes > size || f.offset > size - n_bytes)
        fail("field '" + f.name + "' data (" + std::to_string(n_bytes) + " bytes at offset " +
             std::to_string(f.offset) + ") lies outside the file (" + std::to_string(size) +
             " bytes)");
      const std::string key = f.name;
      if (!fields_.emplace(key, std::move(f)).second)
        fail("field '" + key + "' appears twice in the header");
    }
  }

  std::string path_;
  std::vector<unsigned char> bytes_;
  std::map<std::string, Field> fields_;
};

// ------------------------------------------------------------------------------------------
// Warp2D: a bilinear function on [0,1]^2 over an nx x ny grid (x the contiguous axis), blended
// linearly across up to three parameter grids; optionally a normalised density with
// trapezoid-rule CDFs that samples rows (marginal) then columns (conditional), and inverts that.

constexpr std::size_t kMaxParams = 3;
constexpr double kOneMinusEpsilon = 0.999999940395355225;  // the float just below 1

// x clamped to [lo, hi]; NaN goes to lo.
double clamp_nan_low(double x, double lo, double hi) {
  return x > lo ? (x < hi ? x : hi) : lo;
}

// Largest i in [0, n - 2] such that i == 0 or pred(i), for pred true on a prefix of 0 .. n-1.
template <typename Pred>
std::size_t find_interval(std::size_t n, const Pred& pred) {
  std::size_t first = 1, count = n - 2;
  while (count > 0) {
    const std::size_t half = count / 2, middle = first + half;
    if (pred(middle)) {
      first = middle + 1;
      count -= half + 1;
    } else {
      count = half;
    }
  }
  return std::min(first - 1, n - 2);
}

// t in [0, 1] with integral_0^t ((1 - s) a + s b) ds = u, for a linear density from a to b.
double invert_linear_segment(double a, double b, double u) {
  if (!(a + b > 0)) return 0;
  double t;
  if (std::abs(a - b) < 1e-4 * (a + b))
    t = 2 * u / (a + b);
  else
    t = (a - std::sqrt(std::max(0.0, a * a - 2 * u * (a - b)))) / (a - b);
  return clamp_nan_low(t, 0, 1);
}

class Warp2D {
 public:
  struct Point {
    Vec2 pos;
    double pdf;
  };

  Warp2D() = default;
  // values: [P0]..[P(D-1)][ny][nx] row-major; grids: the D increasing parameter grids;
  // density: normalise and build CDFs (for sampling) rather than keep the raw interpolant.
  Warp2D(const std::vector<double>& values, std::size_t nx, std::size_t ny,
         std::vector<std::vector<double>> grids, bool density)
      : nx_(nx), ny_(ny), grids_(std::move(grids)), density_(density) {
    if (nx_ < 2 || ny_ < 2 || grids_.size() > kMaxParams)
      throw std::invalid_argument("needs at least 2 x 2 entries per slice");
    std::size_t slices = 1;
    strides_.assign(grids_.size(), 0);
    for (std::size_t k = grids_.size(); k-- > 0;) {
      if (grids_[k].empty()) throw std::invalid_argument("empty parameter grid");
      strides_[k] = grids_[k].size() > 1 ? slices : 0;
      slices *= grids_[k].size();
    }
    const std::size_t n = nx_ * ny_;
    if (values.size() != slices * n) throw std::invalid_argument("shape does not match the grids");
    data_ = values;
    if (!density_) return;

    conditional_.assign(slices * n, 0.0);
    marginal_.assign(slices * ny_, 0.0);
    for (std::size_t slice = 0; slice < slices; ++slice) {
      double* d = &data_[slice * n];
      double* c = &conditional_[slice * n];
      double* m = &marginal_[slice * ny_];
      for (std::size_t y = 0; y < ny_; ++y) {
        double sum = 0;
        for (std::size_t x = 0; x + 1 < nx_; ++x) {
          sum += 0.5 * (d[y * nx_ + x] + d[y * nx_ + x + 1]);
          c[y * nx_ + x + 1] = sum;
        }
      }
      double sum = 0;
      for (std::size_t y = 0; y + 1 < ny_; ++y) {
        sum += 0.5 * (c[y * nx_ + nx_ - 1] + c[(y + 1) * nx_ + nx_ - 1]);
        m[y + 1] = sum;
      }
      const double scale = 1 / sum;
      if (!(sum > 0) || !std::isfinite(scale))
        throw std::invalid_argument("slice " + std::to_string(slice) + " has no positive mass");
      for (std::size_t k = 0; k < n; ++k) {
        d[k] *= scale;
        c[k] *= scale;
      }
      for (std::size_t y = 0; y < ny_; ++y)
        m[y] *= scale;
    }
  }

  // The interpolated value at pos (a density in the unit square when built as one).
  double eval(const Vec2& pos, std::span<const double> params) const {
    const Blend b = blend(params);
    const Cell c = locate(pos);
    const double v00 = data(c.iy, c.ix, b), v10 = data(c.iy, c.ix + 1, b);
    const double v01 = data(c.iy + 1, c.ix, b), v11 = data(c.iy + 1, c.ix + 1, b);
    const double v =
        (1 - c.fy) * ((1 - c.fx) * v00 + c.fx * v10) + c.fy * ((1 - c.fx) * v01 + c.fx * v11);
    return density_ ? v * cells() : v;
  }

  // Warps a uniform point u of the unit square to this density; returns the point and its
  // density in the unit square. Only for tables built as densities.
  Point sample(const Vec2& u_in, std::span<const double> params) const {
    const Blend b = blend(params);
    double ux = clamp_nan_low(u_in.x(), 1 - kOneMinusEpsilon, kOneMinusEpsilon);
    double uy = clamp_nan_low(u_in.y(), 1 - kOneMinusEpsilon, kOneMinusEpsilon);

    const std::size_t row = find_interval(ny_, [&](std::size_t j) { return marginal(j, b) < uy; });
    uy -= marginal(row, b);
    const double r0 = conditional(row, nx_ - 1, b), r1 = conditional(row + 1, nx_ - 1, b);
    const double fy = invert_linear_segment(r0, r1, uy);

    ux *= (1 - fy) * r0 + fy * r1;
    auto row_cdf = [&](std::size_t x) {
      return (1 - fy) * conditional(row, x, b) + fy * conditional(row + 1, x, b);
    };
    const std::size_t col = find_interval(nx_, [&](std::size_t i) { return row_cdf(i) < ux; });
    ux -= row_cdf(col);
    const double c0 = (1 - fy) * data(row, col, b) + fy * data(row + 1, col, b);
    const double c1 = (1 - fy) * data(row, col + 1, b) + fy * data(row + 1, col + 1, b);
    const double fx = invert_linear_segment(c0, c1, ux);

    return {Vec2((double(col) + fx) / double(nx_ - 1), (double(row) + fy) / double(ny_ - 1)),
            ((1 - fx) * c0 + fx * c1) * cells()};
  }

  // The exact inverse of sample: the uniform point that lands on pos, and the density at pos.
  Point invert(const Vec2& pos, std::span<const double> params) const {
    const Blend b = blend(params);
    const Cell c = locate(pos);
    const double c0 = (1 - c.fy) * data(c.iy, c.ix, b) + c.fy * data(c.iy + 1, c.ix, b);
    const double c1 = (1 - c.fy) * data(c.iy, c.ix + 1, b) + c.fy * data(c.iy + 1, c.ix + 1, b);
    const double pdf = ((1 - c.fx) * c0 + c.fx * c1) * cells();

    double ux = c.fx * (c0 + 0.5 * c.fx * (c1 - c0));
    ux += (1 - c.fy) * conditional(c.iy, c.ix, b) + c.fy * conditional(c.iy + 1, c.ix, b);
    const double r0 = conditional(c.iy, nx_ - 1, b), r1 = conditional(c.iy + 1, nx_ - 1, b);
    const double row_total = (1 - c.fy) * r0 + c.fy * r1;
    ux = row_total > 0 ? ux / row_total : 0;
    const double uy = c.fy * (r0 + 0.5 * c.fy * (r1 - r0)) + marginal(c.iy, b);
    return {Vec2(ux, uy), pdf};
  }

 private:
  // The parameter slices around a parameter point and their multilinear weights.
  struct Blend {
    std::array<std::size_t, std::size_t(1) << kMaxParams> slice{};
    std::array<double, std::size_t(1) << kMaxParams> weight{};
    std::size_t count = 0;
  };
  // The grid cell holding a point of the unit square (clamped into it).
  struct Cell {
    std::size_t ix, iy;
    double fx, fy;
  };

  double cells() const { return double(nx_ - 1) * double(ny_ - 1); }

  Blend blend(std::span<const double> params) const {
    Blend b;
    b.slice[0] = 0;
    b.weight[0] = 1;
    b.count = 1;
    for (std::size_t k = 0; k < grids_.size(); ++k) {
      const std::vector<double>& g = grids_[k];
      if (g.size() == 1) continue;  // a single slice: weight 1, no search
      const double p = k < params.size() ? params[k] : g.front();
      const std::size_t i = find_interval(g.size(), [&](std::size_t j) { return g[j] <= p; });
      const double t = clamp_nan_low((p - g[i]) / (g[i + 1] - g[i]), 0, 1);
      Blend next;
      for (std::size_t c = 0; c < b.count; ++c) {
        if (1 - t > 0) {
          next.slice[next.count] = b.slice[c] + strides_[k] * i;
          next.weight[next.count++] = b.weight[c] * (1 - t);
        }
        if (t > 0) {
          next.slice[next.count] = b.slice[c] + strides_[k] * (i + 1);
          next.weight[next.count++] = b.weight[c] * t;
        }
      }
      b = next;
    }
    return b;
  }

  // Entry e of a per-slice array (slice_length entries per slice), blended across slices.
  static double lookup(const std::vector<double>& a, std::size_t slice_length, std::size_t e,
                       const Blend& b) {
    double v = 0;
    for (std::size_t c = 0; c < b.count; ++c)
      v += b.weight[c] * a[b.slice[c] * slice_length + e];
    return v;
  }
  double data(std::size_t y, std::size_t x, const Blend& b) const {
    return lookup(data_, nx_ * ny_, y * nx_ + x, b);
  }
  double conditional(std::size_t y, std::size_t x, const Blend& b) const {
    return lookup(conditional_, nx_ * ny_, y * nx_ + x, b);
  }
  double marginal(std::size_t y, const Blend& b) const { return lookup(marginal_, ny_, y, b); }

  Cell locate(const Vec2& pos) const {
    const double px = clamp_nan_low(pos.x(), 0, 1) * double(nx_ - 1);
    const double py = clamp_nan_low(pos.y(), 0, 1) * double(ny_ - 1);
    const std::size_t ix = std::min(std::size_t(px), nx_ - 2);
    const std::size_t iy = std::min(std::size_t(py), ny_ - 2);
    return {ix, iy, px - double(ix), py - double(iy)};
  }

  std::size_t nx_ = 2, ny_ = 2;
  std::vector<std::vector<double>> grids_;
  std::vector<std::size_t> strides_;
  std::vector<double> data_, conditional_, marginal_;
  bool density_ = false;
};

// ------------------------------------------------------------------------------------------
// Angles and their unit-square coordinates: u_theta = sqrt(2 theta / pi), u_phi = (phi + pi) / 2pi.

// Angle from +z of a unit vector, accurate near the pole.
double elevation(const Vec3& d) {
  return 2 * std::asin(std::min(1.0, 0.5 * (d - Vec3::UnitZ()).norm()));
}
double theta_to_u(double theta) {
  return std::sqrt(std::max(0.0, 2 * theta / kPi));
}
double phi_to_u(double phi) {
  return (phi + kPi) / (2 * kPi);
}
double u_to_theta(double u) {
  return 0.5 * kPi * u * u;
}
double u_to_phi(double u) {
  return (2 * u - 1) * kPi;
}

// The table parameters of an incident direction.
struct Incident {
  double theta, phi;
  Vec2 u;                        // (u_theta, u_phi), where sigma is looked up
  std::array<double, 2> params;  // (phi_i, theta_i), the vndf and luminance parameters
};

Incident incident(const Vec3& wi) {
  const double theta = elevation(wi), phi = std::atan2(wi.y(), wi.x());
  return {theta, phi, Vec2(theta_to_u(theta), phi_to_u(phi)), {phi, theta}};
}

// (u_theta, u_phi) of a half vector, its azimuth taken relative to phi_i and wrapped to [0, 1).
Vec2 half_vector_u(const Vec3& wm, double phi_i) {
  double u_phi = phi_to_u(std::atan2(wm.y(), wm.x()) - phi_i);
  u_phi -= std::floor(u_phi);
  return Vec2(theta_to_u(elevation(wm)), u_phi);
}

// Solid-angle Jacobian of the half vector in the u-square times the reflection Jacobian.
double half_vector_jacobian(double u_theta, double sin_theta_m, double wi_dot_wm) {
  return std::max(2 * kPi * kPi * u_theta * sin_theta_m, 1e-6) * 4 * wi_dot_wm;
}

bool above_horizon(const Vec3& w) {
  return w.allFinite() && w.z() > 0;
}

}  // namespace

// ------------------------------------------------------------------------------------------

struct RglBrdf::Tables {
  std::string description;
  bool jacobian = true;
  Warp2D ndf, sigma;  // plain interpolants on (u_theta, u_phi)
  Warp2D vndf;        // density on (u_theta_m, relative u_phi_m), parameters (phi_i, theta_i)
  Warp2D luminance;   // density on the sample square, parameters (phi_i, theta_i)
  Warp2D rgb;         // plain, on the sample square, parameters (phi_i, theta_i, channel)

  // f cos(theta_o) per channel for an incident direction, a sample-square point s and the
  // half vector's u-square point um.
  Color reflectance(const Incident& in, const Vec2& s, const Vec2& um) const {
    const double scale = jacobian ? ndf.eval(um, {}) / (4 * sigma.eval(in.u, {})) : 1.0;
    Color value;
    for (int c = 0; c < 3; ++c) {
      const std::array<double, 3> params = {in.phi, in.theta, double(c)};
      value[std::size_t(c)] = std::max(0.0, rgb.eval(s, params)) * scale;
    }
    return value;
  }
};

RglBrdf::RglBrdf(std::unique_ptr<const Tables> tables) : tables_(std::move(tables)) {}

RglBrdf::~RglBrdf() = default;

std::shared_ptr<const RglBrdf> RglBrdf::read(const std::string& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw FileError(path + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": " + std::strerror(errno));
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) throw FileError(path + ": " + error.message());
  if (size > kMaxFileSize)
    throw FileError(path + ": too large for an RGL BRDF (" + std::to_string(size) + " bytes)");
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (std::uintmax_t(in.gcount()) != size)
    throw FileError(path + ": could not read the whole file (" + std::to_string(in.gcount()) +
                    " of " + std::to_string(size) + " bytes)");
  return parse(std::move(bytes), path);
}

std::shared_ptr<const RglBrdf> RglBrdf::parse(std::vector<unsigned char> bytes,
                                              const std::string& path) {
  if (bytes.size() > kMaxFileSize)
    throw FileError(path + ": too large for an RGL BRDF (" + std::to_string(bytes.size()) +
                    " bytes)");
  const TensorFile file(path, std::move(bytes));
  if (file.has("wavelengths") || file.has("spectra"))
    file.fail("spectral files are not supported (only RGB files with an 'rgb' field)");

  auto tables = std::make_unique<Tables>();
  {
    const std::vector<unsigned char> text = file.octets(file.get("description", kUint8, 1));
    tables->description.assign(text.begin(), text.end());
  }

  // Incident grids: phi_i (one entry, or two, for isotropic files) and theta_i, increasing.
  const Field& phi_field = file.get("phi_i", kFloat32, 1);
  const Field& theta_field = file.get("theta_i", kFloat32, 1);
  const std::vector<double> phi_grid = file.floats(phi_field);
  const std::vector<double> theta_grid = file.floats(theta_field);
  if (phi_grid.empty()) file.fail("field 'phi_i' is empty");
  if (theta_grid.empty()) file.fail("field 'theta_i' is empty");
  if (phi_grid.size() > 2)
    file.fail("anisotropic files are not supported (phi_i has " + std::to_string(phi_grid.size()) +
              " entries)");
  for (const auto* grid : {&phi_grid, &theta_grid})
    for (std::size_t k = 1; k < grid->size(); ++k)
      if (!((*grid)[k] > (*grid)[k - 1]))
        file.fail(std::string("field '") + (grid == &phi_grid ? "phi_i" : "theta_i") +
                  "' is not strictly increasing");
  const std::uint64_t n_phi = phi_grid.size(), n_theta = theta_grid.size();

  // Builds a warp from a field, reporting construction problems against the field.
  auto warp = [&](const std::string& name, const std::vector<double>& values, std::uint64_t nx,
                  std::uint64_t ny, std::vector<std::vector<double>> grids,
                  bool density) -> Warp2D {
    try {
      return Warp2D(values, std::size_t(nx), std::size_t(ny), std::move(grids), density);
    } catch (const std::invalid_argument& e) {
      file.fail("field '" + name + "': " + e.what());
    }
  };
  auto at_least_2x2 = [&](const Field& f) {
    const std::size_t n = f.shape.size();
    if (f.shape[n - 1] < 2 || f.shape[n - 2] < 2)
      file.fail("field '" + f.name + "' needs at least 2 x 2 entries per slice, got shape " +
                shape_text(f.shape));
  };
  auto incident_dims = [&](const Field& f) {
    if (f.shape[0] != n_phi || f.shape[1] != n_theta)
      file.fail("field '" + f.name + "' has shape " + shape_text(f.shape) + " but phi_i and " +
                "theta_i have " + std::to_string(n_phi) + " and " + std::to_string(n_theta) +
                " entries");
  };
  auto non_negative = [&](const std::string& name, const std::vector<double>& values) {
    for (double v : values)
      if (v < 0) file.fail("field '" + name + "' holds negative values");
  };

  // ndf and sigma: plain interpolants on (x = u_theta, y = u_phi).
  const Field& ndf_field = file.get("ndf", kFloat32, 2);
  const Field& sigma_field = file.get("sigma", kFloat32, 2);
  at_least_2x2(ndf_field);
  at_least_2x2(sigma_field);
  const std::vector<double> ndf = file.floats(ndf_field);
  const std::vector<double> sigma = file.floats(sigma_field);
  non_negative("ndf", ndf);
  for (double v : sigma)
    if (!(v > 0)) file.fail("field 'sigma' holds values that are not positive");
  tables->ndf = warp("ndf", ndf, ndf_field.shape[1], ndf_field.shape[0], {}, false);
  tables->sigma = warp("sigma", sigma, sigma_field.shape[1], sigma_field.shape[0], {}, false);

  // vndf: [phi_i][theta_i][u_phi_m][u_theta_m], a density per incident direction.
  const Field& vndf_field = file.get("vndf", kFloat32, 4);
  incident_dims(vndf_field);
  at_least_2x2(vndf_field);
  const std::vector<double> vndf = file.floats(vndf_field);
  non_negative("vndf", vndf);
  tables->vndf =
      warp("vndf", vndf, vndf_field.shape[3], vndf_field.shape[2], {phi_grid, theta_grid}, true);

  // luminance: [phi_i][theta_i][y][x] on the square sample grid, a density per direction.
  const Field& luminance_field = file.get("luminance", kFloat32, 4);
  incident_dims(luminance_field);
  at_least_2x2(luminance_field);
  if (luminance_field.shape[2] != luminance_field.shape[3])
    file.fail("field 'luminance' is not square: shape " + shape_text(luminance_field.shape));
  const std::vector<double> luminance = file.floats(luminance_field);
  non_negative("luminance", luminance);
  tables->luminance = warp("luminance", luminance, luminance_field.shape[3],
                           luminance_field.shape[2], {phi_grid, theta_grid}, true);

  // rgb: [phi_i][theta_i][channel][y][x], on the same grid as luminance.
  const Field& rgb_field = file.get("rgb", kFloat32, 5);
  incident_dims(rgb_field);
  if (rgb_field.shape[2] != 3 || rgb_field.shape[3] != luminance_field.shape[2] ||
      rgb_field.shape[4] != luminance_field.shape[3])
    file.fail("field 'rgb' has shape " + shape_text(rgb_field.shape) + ", expected [" +
              std::to_string(n_phi) + " x " + std::to_string(n_theta) + " x 3 x " +
              std::to_string(luminance_field.shape[2]) + " x " +
              std::to_string(luminance_field.shape[3]) + "]");
  tables->rgb = warp("rgb", file.floats(rgb_field), rgb_field.shape[4], rgb_field.shape[3],
                     {phi_grid, theta_grid, {0.0, 1.0, 2.0}}, false);

  // jacobian: one byte; when set the value is rgb * D / (4 sigma), else rgb alone.
  const Field& jacobian_field = file.get("jacobian", kUint8, 1);
  if (jacobian_field.count != 1)
    file.fail("field 'jacobian' must hold one byte, got shape " + shape_text(jacobian_field.shape));
  tables->jacobian = file.octets(jacobian_field)[0] != 0;
  // 'valid' and 'version' are not used by the reference evaluation; their bounds were checked.

  return std::shared_ptr<const RglBrdf>(new RglBrdf(std::move(tables)));
}

std::string RglBrdf::description() const {
  return tables_->description;
}

Color RglBrdf::evaluate_cosine(const Vec3& wi_in, const Vec3& wo_in) const {
  if (!above_horizon(wi_in) || !above_horizon(wo_in)) return {0, 0, 0};
  const Vec3 wi = wi_in.normalized(), wo = wo_in.normalized();
  const Vec3 wm = (wi + wo).normalized();
  const Incident in = incident(wi);
  const Vec2 um = half_vector_u(wm, in.phi);
  const Vec2 s = tables_->vndf.invert(um, in.params).pos;
  return tables_->reflectance(in, s, um);
}

Color RglBrdf::evaluate_parametrised(const Vec3& parameter, const Vec3& free) const {
  Color f = evaluate_cosine(parameter, free);
  if (f[0] == 0 && f[1] == 0 && f[2] == 0) return f;
  const double cos_free = free.z() / free.norm();
  for (double& v : f)
    v /= cos_free;
  return f;
}

Color RglBrdf::evaluate(const Vec3& wi, const Vec3& wo) const {
  return evaluate_parametrised(wo, wi);
}

double RglBrdf::pdf(const Vec3& wi_in, const Vec3& wo_in) const {
  if (!above_horizon(wi_in) || !above_horizon(wo_in)) return 0;
  const Vec3 wi = wi_in.normalized(), wo = wo_in.normalized();
  const Vec3 wm = (wi + wo).normalized();
  const Incident in = incident(wi);
  const Vec2 um = half_vector_u(wm, in.phi);
  const Warp2D::Point p = tables_->vndf.invert(um, in.params);
  const double luminance_pdf = tables_->luminance.eval(p.pos, in.params);
  const double sin_theta_m = std::hypot(wm.x(), wm.y());
  return p.pdf * luminance_pdf / half_vector_jacobian(um.x(), sin_theta_m, wi.dot(wm));
}

RglBrdf::Sample RglBrdf::sample(const Vec3& wi_in, double u1, double u2) const {
  const Sample failed{Vec3(0, 0, 0), {0, 0, 0}, 0, false};
  if (!above_horizon(wi_in)) return failed;
  const Vec3 wi = wi_in.normalized();
  const Incident in = incident(wi);
  // As the reference does, the second variate drives the first (x) coordinate.
  const Warp2D::Point s = tables_->luminance.sample(Vec2(u2, u1), in.params);
  const Warp2D::Point um = tables_->vndf.sample(s.pos, in.params);
  const double theta_m = u_to_theta(um.pos.x()), phi_m = u_to_phi(um.pos.y()) + in.phi;
  const double sin_theta_m = std::sin(theta_m);
  const Vec3 wm(std::cos(phi_m) * sin_theta_m, std::sin(phi_m) * sin_theta_m, std::cos(theta_m));
  const double wi_dot_wm = wi.dot(wm);
  if (!(wi_dot_wm > 0)) return failed;
  const Vec3 wo = 2 * wi_dot_wm * wm - wi;
  if (!(wo.z() > 0)) return failed;
  const double pdf = um.pdf * s.pdf / half_vector_jacobian(um.pos.x(), sin_theta_m, wi_dot_wm);
  if (!(pdf > 0) || !std::isfinite(pdf)) return failed;
  const Color value = tables_->reflectance(in, s.pos, um.pos);
  return {wo, {value[0] / pdf, value[1] / pdf, value[2] / pdf}, pdf, true};
}

}  // namespace basis
