// RGL-EPFL measured BRDFs (tensor_file .bsdf): a synthetic file's known values, the sampler
// against pdf, evaluate and the quadrature of the evaluation, albedo bounds, reciprocity, and
// clear errors for malformed files (the evaluation itself is checked against a second
// implementation in python/tests/test_rgl.py). Uses ../shared/data/rgl-bsdf when present, and
// always a synthetic file written here.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/rgl.h"
#include "basis/brdf/table_lookup.h"
#include "basis/core/projection.h"
#include "support/brdf_reference.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;

constexpr double kPi = std::numbers::pi;

// ------------------------------------------------------------------------------------------
// The shared sample files.

// The folder of RGL sample files next to the project (../shared/data/rgl-bsdf), if present.
std::optional<std::filesystem::path> rgl_folder() {
  for (std::filesystem::path p = std::filesystem::current_path(); !p.empty(); p = p.parent_path()) {
    const auto candidate = p / ".." / "shared" / "data" / "rgl-bsdf";
    if (std::filesystem::is_directory(candidate)) return std::filesystem::canonical(candidate);
    if (p == p.root_path()) break;
  }
#ifdef BASIS_SOURCE_DIR
  const auto candidate =
      std::filesystem::path(BASIS_SOURCE_DIR) / ".." / "shared" / "data" / "rgl-bsdf";
  if (std::filesystem::is_directory(candidate)) return std::filesystem::canonical(candidate);
#endif
  return std::nullopt;
}

// Paths of the shared .bsdf files, sorted; empty, with a notice, when the folder is absent.
std::vector<std::string> sample_files() {
  std::vector<std::string> files;
  if (const auto folder = rgl_folder())
    for (const auto& entry : std::filesystem::directory_iterator(*folder))
      if (entry.path().extension() == ".bsdf") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  if (files.empty())
    std::printf(
        "[  NOTE    ] shared folder ../shared/data/rgl-bsdf is absent (or has no .bsdf files): "
        "only the synthetic tensor file is tested\n");
  return files;
}

std::string stem(const std::string& path) {
  return std::filesystem::path(path).stem().string();
}

// ------------------------------------------------------------------------------------------
// A tensor_file writer, independent of the reader: fields at 8-aligned offsets after the header.

struct TensorField {
  std::string name;
  std::uint8_t dtype;  // 1 uint8, 5 uint32, 10 float32, 11 float64
  std::vector<std::uint64_t> shape;
  std::vector<unsigned char> data;  // little-endian
};

void put_le(std::vector<unsigned char>& out, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k)
    out.push_back(static_cast<unsigned char>(v >> (8 * k)));
}

std::vector<unsigned char> float32_data(const std::vector<float>& values) {
  std::vector<unsigned char> out;
  for (float v : values)
    put_le(out, std::bit_cast<std::uint32_t>(v), 4);
  return out;
}

std::vector<unsigned char> tensor_bytes(const std::vector<TensorField>& fields) {
  std::size_t header = 18;
  for (const TensorField& f : fields)
    header += 13 + f.name.size() + 8 * f.shape.size();
  auto align = [](std::size_t n) { return (n + 7) / 8 * 8; };
  std::vector<unsigned char> out;
  const char magic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
  out.insert(out.end(), magic, magic + 12);
  out.push_back(1);
  out.push_back(0);
  put_le(out, fields.size(), 4);
  std::size_t offset = align(header);
  for (const TensorField& f : fields) {
    put_le(out, f.name.size(), 2);
    out.insert(out.end(), f.name.begin(), f.name.end());
    put_le(out, f.shape.size(), 2);
    out.push_back(f.dtype);
    put_le(out, offset, 8);
    for (std::uint64_t d : f.shape)
      put_le(out, d, 8);
    offset = align(offset + f.data.size());
  }
  for (const TensorField& f : fields) {
    out.resize(align(out.size()), 0);  // no padding after the last block
    out.insert(out.end(), f.data.begin(), f.data.end());
  }
  return out;
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

// The synthetic material: constant ndf and sigma, uniform vndf and luminance and a constant
// rgb, so that f(wi, wo) cos(theta_o) = rgb * ndf / (4 sigma) everywhere, and (both warps
// being the identity) the sampling density is 1 / (2 pi^2 u_theta_m sin(theta_m) 4 wi.wm).
constexpr float kNdf = 0.5f, kSigma = 0.25f;
constexpr float kRgb[3] = {0.1f, 0.2f, 0.3f};
constexpr char kSyntheticDescription[] = "synthetic constant material";

std::vector<TensorField> synthetic_fields(std::uint8_t jacobian = 1) {
  const std::size_t n_theta = 3, n_half = 8, n_sample = 4;
  std::vector<float> rgb;
  for (std::size_t t = 0; t < n_theta; ++t)
    for (float c : kRgb)
      rgb.insert(rgb.end(), n_sample * n_sample, c);
  std::vector<unsigned char> version;
  put_le(version, 1, 4);
  put_le(version, 0, 4);
  const std::string text = kSyntheticDescription;
  return {
      {"version", 5, {2}, version},
      {"description", 1, {text.size()}, std::vector<unsigned char>(text.begin(), text.end())},
      {"phi_i", 10, {1}, float32_data({0.0f})},
      {"theta_i", 10, {n_theta}, float32_data({0.0f, float(kPi / 4), float(kPi / 2)})},
      {"sigma", 10, {2, n_half}, float32_data(std::vector<float>(2 * n_half, kSigma))},
      {"ndf", 10, {2, n_half}, float32_data(std::vector<float>(2 * n_half, kNdf))},
      {"vndf",
       10,
       {1, n_theta, n_half, n_half},
       float32_data(std::vector<float>(n_theta * n_half * n_half, 1.0f))},
      {"luminance",
       10,
       {1, n_theta, n_sample, n_sample},
       float32_data(std::vector<float>(n_theta * n_sample * n_sample, 1.0f))},
      {"rgb", 10, {1, n_theta, 3, n_sample, n_sample}, float32_data(rgb)},
      {"jacobian", 1, {1}, {jacobian}},
      {"valid",
       1,
       {n_theta * n_sample * n_sample / 8},
       std::vector<unsigned char>(n_theta * n_sample * n_sample / 8, 0)},
  };
}

TensorField& field_named(std::vector<TensorField>& fields, const std::string& name) {
  for (TensorField& f : fields)
    if (f.name == name) return f;
  throw std::invalid_argument("no synthetic field " + name);
}

std::string write_synthetic(const TempDir& dir, const std::string& name,
                            const std::vector<TensorField>& fields) {
  const std::string path = dir.file(name);
  write_bytes(path, tensor_bytes(fields));
  return path;
}

// ------------------------------------------------------------------------------------------
// Directions and estimates.

Vec3 direction(double theta_degrees, double phi_degrees) {
  const double t = theta_degrees * kPi / 180, p = phi_degrees * kPi / 180;
  return Vec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

// A random direction with z >= min_z.
Vec3 random_direction_above(std::mt19937& rng, double min_z = 1e-3) {
  std::normal_distribution<double> g;
  for (;;) {
    const Vec3 v = Vec3(g(rng), g(rng), std::abs(g(rng))).normalized();
    if (v.z() >= min_z) return v;
  }
}

struct Albedo {
  Color mean{0, 0, 0};
  Color standard_error{0, 0, 0};
};

// Directional albedo through the sampler: n x n stratified samples, failed samples count 0.
Albedo sampled_albedo(const RglBrdf& brdf, const Vec3& wi, int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> jitter(0, 1);
  Color sum{0, 0, 0}, sum2{0, 0, 0};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const RglBrdf::Sample s = brdf.sample(wi, (i + jitter(rng)) / n, (j + jitter(rng)) / n);
      if (!s.valid) continue;
      for (int c = 0; c < 3; ++c) {
        sum[c] += s.weight[c];
        sum2[c] += s.weight[c] * s.weight[c];
      }
    }
  Albedo a;
  const double count = double(n) * n;
  for (int c = 0; c < 3; ++c) {
    a.mean[c] = sum[c] / count;
    a.standard_error[c] = std::sqrt(std::max(0.0, sum2[c] / count - a.mean[c] * a.mean[c]) / count);
  }
  return a;
}

double relative_difference(double a, double b) {
  const double scale = std::max(std::abs(a), std::abs(b));
  return scale > 0 ? std::abs(a - b) / scale : 0;
}

// The read error for path, which must start with "PATH: ".
std::string read_error(const std::string& path) {
  try {
    RglBrdf::read(path);
  } catch (const FileError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    return what.substr(std::min(what.size(), path.size() + 2));
  }
  ADD_FAILURE() << path << ": no FileError";
  return "no error";
}

// ------------------------------------------------------------------------------------------

TEST(RglBrdf, SyntheticFileEvaluatesToItsConstantFormula) {
  TempDir dir;
  const auto brdf = RglBrdf::read(write_synthetic(dir, "synthetic.bsdf", synthetic_fields()));
  EXPECT_EQ(brdf->format(), "rgl");
  EXPECT_EQ(brdf->channels(), 3);
  EXPECT_EQ(brdf->description(), kSyntheticDescription);
  const auto plain = RglBrdf::read(write_synthetic(dir, "plain.bsdf", synthetic_fields(0)));

  std::mt19937 rng(11);
  for (int k = 0; k < 2000; ++k) {
    const Vec3 wi = random_direction_above(rng), wo = random_direction_above(rng);
    const Color f = brdf->evaluate_parametrised(wi, wo), g = plain->evaluate_parametrised(wi, wo);
    for (int c = 0; c < 3; ++c) {
      // jacobian = 1: rgb D / (4 sigma) / cos(theta_o); jacobian = 0: rgb / cos(theta_o).
      const double expected = double(kRgb[c]) * kNdf / (4 * double(kSigma)) / wo.z();
      EXPECT_NEAR(f[c], expected, 1e-9 * expected);
      EXPECT_NEAR(g[c], double(kRgb[c]) / wo.z(), 1e-9 * g[c]);
    }
    // Both warps are the identity: the density is the half-vector Jacobian alone.
    const Vec3 wm = (wi + wo).normalized();
    const double theta_m = std::atan2(std::hypot(wm.x(), wm.y()), wm.z());
    const double u_theta = std::sqrt(2 * theta_m / kPi);
    const double jacobian =
        std::max(2 * kPi * kPi * u_theta * std::sin(theta_m), 1e-6) * 4 * wi.dot(wm);
    EXPECT_NEAR(brdf->pdf(wi, wo), 1 / jacobian, 1e-6 / jacobian);
    EXPECT_EQ(brdf->evaluate_parametrised(Vec3(wi.x(), wi.y(), -wi.z()), wo)[0], 0);
    EXPECT_EQ(brdf->evaluate_parametrised(wi, Vec3(wo.x(), wo.y(), -wo.z()))[1], 0);
    EXPECT_EQ(brdf->pdf(wi, Vec3(wo.x(), wo.y(), -wo.z())), 0);
  }

  // Albedo: integral over the hemisphere of the constant f cos = 2 pi rgb D / (4 sigma).
  for (double theta : {0.0, 30.0, 60.0, 80.0}) {
    const Albedo a = sampled_albedo(*brdf, direction(theta, 20), 64, rng);
    for (int c = 0; c < 3; ++c) {
      const double expected = 2 * kPi * double(kRgb[c]) * kNdf / (4 * double(kSigma));
      EXPECT_NEAR(a.mean[c], expected, 0.01 * expected + 5 * a.standard_error[c]) << theta;
    }
  }
  EXPECT_FALSE(brdf->sample(Vec3(0.3, 0, -0.9).normalized(), 0.5, 0.5).valid);
}

TEST(RglBrdf, ReadsEverySampleFile) {
  const auto files = sample_files();
  if (files.empty()) GTEST_SKIP() << "no shared .bsdf files to read";
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    const auto brdf = RglBrdf::read(path);
    EXPECT_EQ(brdf->format(), "rgl");
    EXPECT_FALSE(brdf->description().empty());
    for (char ch : brdf->description())
      EXPECT_TRUE(ch >= 32 && ch < 127) << int(ch);
    std::mt19937 rng(3);
    int positive = 0;
    for (int k = 0; k < 3000; ++k) {
      const Vec3 wi = random_direction_above(rng), wo = random_direction_above(rng);
      const Color f = brdf->evaluate_parametrised(wi, wo);
      for (int c = 0; c < 3; ++c) {
        ASSERT_TRUE(std::isfinite(f[c])) << wi.transpose() << " | " << wo.transpose();
        ASSERT_GE(f[c], 0) << wi.transpose() << " | " << wo.transpose();
      }
      positive += f[0] + f[1] + f[2] > 0;
      const double p = brdf->pdf(wi, wo);
      ASSERT_TRUE(std::isfinite(p) && p >= 0) << p;
      EXPECT_EQ(brdf->evaluate_parametrised(Vec3(wi.x(), wi.y(), -wi.z()), wo)[2], 0);
    }
    // Zero where every channel of the rgb table is zero or clamped (no measurement there).
    std::printf("[  INFO    ] %s: f > 0 for %d of 3000 random direction pairs\n",
                stem(path).c_str(), positive);
    EXPECT_GT(positive, 1000);
  }
  if (files.empty()) {  // the same checks on the synthetic file
    TempDir dir;
    const auto brdf = RglBrdf::read(write_synthetic(dir, "s.bsdf", synthetic_fields()));
    std::mt19937 rng(3);
    for (int k = 0; k < 1000; ++k) {
      const Color f =
          brdf->evaluate_parametrised(random_direction_above(rng), random_direction_above(rng));
      for (double v : f)
        EXPECT_TRUE(std::isfinite(v) && v > 0) << v;
    }
  }
}

// The evaluation of the shared files is checked against a second implementation of the
// format, written in NumPy from the format's definition (python/tests/rgl_reference.py, run by
// python/tests/test_rgl.py). Here: the synthetic file's known value, and isotropy.
TEST(RglBrdf, SyntheticValueAndIsotropy) {
  TempDir dir;
  const auto synthetic = RglBrdf::read(write_synthetic(dir, "s.bsdf", synthetic_fields()));
  for (const auto& [wi_theta, wi_phi, wo_theta, wo_phi] :
       {std::array<double, 4>{0, 0, 30, 0}, {60, 0, 20, 90}, {45, 0, 45, 180}}) {
    const Vec3 wo = direction(wo_theta, wo_phi);
    const Color f = synthetic->evaluate_parametrised(direction(wi_theta, wi_phi), wo);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(f[c] * wo.z(), double(kRgb[c]) * kNdf / (4 * double(kSigma)), 1e-9);
  }
  // Isotropy: rotating both directions about the normal changes nothing.
  for (const std::string& path : sample_files()) {
    const auto brdf = RglBrdf::read(path);
    const Color a = brdf->evaluate_parametrised(direction(45, 0), direction(45, 180));
    const Color b = brdf->evaluate_parametrised(direction(45, 90), direction(45, 270));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(a[c], b[c], 1e-3 * a[c] + 1e-6) << path;
  }
}

// The albedo at wi, the integral of f(wi, wo) cos(theta_o) over wo, by quadrature of the
// evaluation (itself checked against a second implementation, see above).
Color quadrature_albedo(const RglBrdf& brdf, const Vec3& wi) {
  const Vec3 mirror(-wi.x(), -wi.y(), wi.z());
  Color albedo;
  for (int c = 0; c < 3; ++c)
    albedo[c] = testing::integrate_around(
        mirror,
        [&](const Vec3& wo) {
          return wo.z() > 0 ? brdf.evaluate_parametrised(wi, wo)[c] * wo.z() : 0.0;
        },
        256);
  return albedo;
}

// The file's own sampler (its luminance and visible-normal warps) against the quadrature of
// the evaluation, at theta_i = 0 and 45 degrees, 40,000 stratified samples each.
TEST(RglBrdf, SampledAlbedoMatchesQuadratureOfTheEvaluation) {
  const auto files = sample_files();
  // The synthetic file's albedo is checked in the first test.
  if (files.empty()) GTEST_SKIP() << "no shared .bsdf files to sample";
  std::mt19937 rng(17);
  for (const std::string& path : files) {
    const auto brdf = RglBrdf::read(path);
    for (double theta : {0.0, 45.0}) {
      const Albedo a = sampled_albedo(*brdf, direction(theta, 0), 200, rng);
      const Color expected = quadrature_albedo(*brdf, direction(theta, 0));
      std::printf(
          "[  INFO    ] %s theta_i %2.0f: sampled albedo %.4f %.4f %.4f, quadrature %.4f %.4f "
          "%.4f\n",
          stem(path).c_str(), theta, a.mean[0], a.mean[1], a.mean[2], expected[0], expected[1],
          expected[2]);
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(a.mean[c], expected[c], 0.003 * expected[c] + 5 * a.standard_error[c])
            << stem(path) << " theta_i " << theta << " channel " << c;
    }
  }
}

TEST(RglBrdf, SamplerPdfAgreesWithEvaluate) {
  TempDir dir;
  std::vector<std::string> files = sample_files();
  files.push_back(write_synthetic(dir, "synthetic.bsdf", synthetic_fields()));
  for (const std::string& path : files) {
    const auto brdf = RglBrdf::read(path);
    std::mt19937 rng(23);
    std::uniform_real_distribution<double> uniform(0, 1);
    int valid = 0, total = 0, pdf_outliers = 0, value_outliers = 0;
    double worst_pdf = 0, worst_value = 0;
    for (double theta : {0.0, 20.0, 45.0, 70.0, 85.0})
      for (int k = 0; k < 2000; ++k) {
        const Vec3 wi = direction(theta, 360 * uniform(rng));
        const RglBrdf::Sample s = brdf->sample(wi, uniform(rng), uniform(rng));
        ++total;
        if (!s.valid) {
          EXPECT_EQ(s.pdf, 0);
          continue;
        }
        ++valid;
        ASSERT_GT(s.pdf, 0);
        ASSERT_GT(s.wo.z(), 0);
        EXPECT_NEAR(s.wo.norm(), 1, 1e-9);
        const double pdf_error = relative_difference(brdf->pdf(wi, s.wo), s.pdf);
        const Color f = brdf->evaluate_parametrised(wi, s.wo);
        double value_error = 0;
        for (int c = 0; c < 3; ++c) {
          const double a = s.weight[c] * s.pdf, b = f[c] * s.wo.z();
          if (std::max(a, b) > 1e-9) value_error = std::max(value_error, relative_difference(a, b));
        }
        worst_pdf = std::max(worst_pdf, pdf_error);
        worst_value = std::max(worst_value, value_error);
        pdf_outliers += pdf_error > 1e-6;
        value_outliers += value_error > 1e-6;
      }
    std::printf("[  INFO    ] %s: %d of %d samples valid; worst relative pdf %.2g, value %.2g\n",
                stem(path).c_str(), valid, total, worst_pdf, worst_value);
    // Sampling fails only when wo leaves the hemisphere: a few percent of the samples for
    // the measured files (note, section 6.1), but about a third for the synthetic file, whose
    // uniform half-vector density sends many reflections below the horizon.
    const double min_valid = stem(path) == "synthetic" ? 0.3 : 0.85;
    EXPECT_GT(valid, min_valid * total) << path;
    // sample and pdf/evaluate share the warps; the round trip through wo only adds roundoff,
    // except (rarely) where the relative azimuth wraps at 0 / 1.
    EXPECT_LE(pdf_outliers, total / 1000) << path;
    EXPECT_LE(value_outliers, total / 1000) << path;
  }
}

// The albedo of the tabulated quadtrees (a BRDF table made from an {"model": "rgl"} spec, looked
// up with a constant unit light) against a Monte Carlo estimate that importance-samples the
// same evaluator through the file's own warps, with the viewing direction as the parameter.
TEST(RglBrdf, TabulatedAlbedoMatchesTheFilesOwnSampler) {
  auto files = sample_files();
  TempDir dir;
  if (files.empty()) files.push_back(write_synthetic(dir, "synthetic.bsdf", synthetic_fields()));
  Grid one(2, 1);
  for (float& t : one.texels)
    t = 1;
  const PackedTree light = pack(project(one));
  std::mt19937 rng(41);
  for (const std::string& path : files) {
    std::ofstream(dir.file("spec.json")) << "{\"model\": \"rgl\", \"file\": \"" << path << "\"}";
    const BrdfSpec spec = read_brdf_spec(dir.file("spec.json"));
    ASSERT_EQ(model_name(spec.brdf), "rgl");
    const auto& rgl =
        dynamic_cast<const RglBrdf&>(*std::get<std::shared_ptr<const MeasuredBrdf>>(spec.brdf));
    BrdfTableOptions options;
    options.wi_resolution = 32;  // texel averages integrate exactly whatever the resolution
    // The entries of a 9 x 9 table at 0, 28, 53 and 74 degrees, tabulated and projected as
    // brdf2qt does (only these four, to keep the test short), so that interpolation does not
    // enter.
    for (int i = 4; i < 8; ++i) {
      const Vec3 wo = table_outgoing(i, 4, 9);
      const PackedTree entry =
          pack(project(tabulate_entry(spec.brdf, wo, options), options.projection));
      // The square's integral of f L is the hemisphere's integral of f L cos over pi.
      Convolution tabulated = convolve(entry.view(), light.view());
      for (float& v : tabulated.value)
        v *= float(kPi);
      const Albedo sampled = sampled_albedo(rgl, wo, 200, rng);
      double largest = 0;  // the largest difference in standard errors
      for (int c = 0; c < 3; ++c) {
        if (sampled.mean[c] < 0.01) continue;  // near-black channels: relative terms mislead
        EXPECT_NEAR(tabulated.value[c], sampled.mean[c],
                    0.005 * sampled.mean[c] + 4 * sampled.standard_error[c])
            << stem(path) << " wo " << std::acos(wo.z()) * 180 / kPi << " channel " << c;
        largest = std::max(
            largest, std::abs(tabulated.value[c] - sampled.mean[c]) / sampled.standard_error[c]);
      }
      std::printf(
          "[  TABLE   ] %s at %4.1f deg: tabulated %.4f %.4f %.4f, sampled %.4f %.4f %.4f, "
          "differences at most %.1f standard errors\n",
          stem(path).c_str(), std::acos(wo.z()) * 180 / kPi, tabulated.value[0], tabulated.value[1],
          tabulated.value[2], sampled.mean[0], sampled.mean[1], sampled.mean[2], largest);
    }
  }
}

TEST(RglBrdf, DirectionalAlbedoInUnitRange) {
  auto files = sample_files();
  TempDir dir;
  if (files.empty()) files.push_back(write_synthetic(dir, "synthetic.bsdf", synthetic_fields()));
  std::mt19937 rng(29);
  for (const std::string& path : files) {
    const auto brdf = RglBrdf::read(path);
    for (int theta = 0; theta <= 80; theta += 10) {
      const Albedo a = sampled_albedo(*brdf, direction(theta, 30), 100, rng);
      std::printf("[  INFO    ] %s theta_i %2d: albedo %.4f %.4f %.4f\n", stem(path).c_str(), theta,
                  a.mean[0], a.mean[1], a.mean[2]);
      // Measured data is not energy-conserving everywhere: satin_rosaline reaches about 1.11
      // at 80 degrees (note, pitfall 11), hence 1.15 rather than 1.
      for (int c = 0; c < 3; ++c) {
        EXPECT_GT(a.mean[c], 0) << path << " theta_i " << theta << " channel " << c;
        EXPECT_LE(a.mean[c], 1.15) << path << " theta_i " << theta << " channel " << c;
      }
      EXPECT_GT((a.mean[0] + a.mean[1] + a.mean[2]) / 3, 0.005) << path;
    }
  }
}

TEST(RglBrdf, ReciprocityWithinMeasuredTolerance) {
  const auto files = sample_files();
  if (files.empty()) {
    // The synthetic f cos(theta_o) is constant, so f(wi, wo) cos(theta_o) is symmetric.
    TempDir dir;
    const auto brdf = RglBrdf::read(write_synthetic(dir, "s.bsdf", synthetic_fields()));
    std::mt19937 rng(31);
    for (int k = 0; k < 500; ++k) {
      const Vec3 wi = random_direction_above(rng, 0.1), wo = random_direction_above(rng, 0.1);
      EXPECT_NEAR(brdf->evaluate_parametrised(wi, wo)[0] * wo.z(),
                  brdf->evaluate_parametrised(wo, wi)[0] * wi.z(), 1e-12);
    }
    return;
  }
  for (const std::string& path : files) {
    const auto brdf = RglBrdf::read(path);
    std::mt19937 rng(31);
    std::vector<double> differences;
    for (int k = 0; k < 4000; ++k) {
      const Vec3 wi = random_direction_above(rng, 0.1), wo = random_direction_above(rng, 0.1);
      const Color a = brdf->evaluate_parametrised(wi, wo), b = brdf->evaluate_parametrised(wo, wi);
      const double sa = a[0] + a[1] + a[2], sb = b[0] + b[1] + b[2];
      if (sa + sb > 1e-9) differences.push_back(std::abs(sa - sb) / (0.5 * (sa + sb)));
    }
    ASSERT_FALSE(differences.empty()) << path;
    std::sort(differences.begin(), differences.end());
    const double median = differences[differences.size() / 2];
    const double p90 = differences[differences.size() * 9 / 10];
    std::printf(
        "[  INFO    ] %s: |f(wi,wo) - f(wo,wi)| relative: median %.3f, 90th percentile %.3f\n",
        stem(path).c_str(), median, p90);
    // The tables are interpolated measurements with one direction as their parameter, so f is
    // only approximately reciprocal. Measured medians: 0.02 to 0.04 for paper, paint,
    // sunflower and satin, 0.18 for golden yellow, 0.26 and 0.32 for the two glossy wraps
    // (their highlights differ most between the two orders); 90th percentiles 0.12 to 1.25.
    EXPECT_LT(median, 0.35) << path;
  }
}

TEST(RglBrdf, MalformedFilesAreClearErrors) {
  TempDir dir;
  std::vector<std::string> originals = {write_synthetic(dir, "synthetic.bsdf", synthetic_fields())};
  const auto files = sample_files();
  if (!files.empty()) originals.push_back(files.front());

  int case_number = 0;
  auto variant = [&](const std::vector<unsigned char>& bytes) {
    const std::string path = dir.file("case" + std::to_string(++case_number) + ".bsdf");
    write_bytes(path, bytes);
    return path;
  };
  for (const std::string& original : originals) {
    SCOPED_TRACE(original);
    const std::vector<unsigned char> bytes = read_bytes(original);
    ASSERT_GT(bytes.size(), 64u);
    ASSERT_NO_THROW(RglBrdf::read(original));

    // Layout of the first descriptor, and where the header and the first data block end.
    const std::size_t name_length = bytes[18] | std::size_t(bytes[19]) << 8;
    const std::size_t ndim_at = 20 + name_length, dtype_at = 22 + name_length,
                      offset_at = 23 + name_length, shape_at = 31 + name_length;
    std::uint64_t first_offset = 0;
    for (int k = 7; k >= 0; --k)
      first_offset = first_offset << 8 | bytes[offset_at + k];
    std::size_t header_end = 18;
    const std::uint32_t n_fields =
        bytes[14] | bytes[15] << 8 | bytes[16] << 16 | std::uint32_t(bytes[17]) << 24;
    for (std::uint32_t f = 0; f < n_fields; ++f) {
      const std::size_t n = bytes[header_end] | std::size_t(bytes[header_end + 1]) << 8;
      const std::size_t d = bytes[header_end + 2 + n] | std::size_t(bytes[header_end + 3 + n]) << 8;
      header_end += 13 + n + 8 * d;
    }

    // Truncated copies.
    for (std::size_t length : {std::size_t(1), std::size_t(11), std::size_t(17), std::size_t(18),
                               std::size_t(25), header_end - 1, header_end,
                               std::size_t(first_offset + 3), bytes.size() / 2, bytes.size() - 1}) {
      if (length == 0 || length >= bytes.size()) continue;
      const std::string path = variant(
          std::vector<unsigned char>(bytes.begin(), bytes.begin() + std::ptrdiff_t(length)));
      const std::string problem = read_error(path);
      EXPECT_NE(problem, "no error") << "truncated to " << length << " bytes";
    }
    auto mutated = [&](std::size_t at, std::uint64_t value, int width) {
      std::vector<unsigned char> b = bytes;
      for (int k = 0; k < width; ++k)
        b[at + k] = static_cast<unsigned char>(value >> (8 * k));
      return read_error(variant(b));
    };
    EXPECT_NE(mutated(0, 'T', 1).find("not a tensor_file"), std::string::npos);
    EXPECT_NE(mutated(12, 2, 1).find("version 2.0"), std::string::npos);
    EXPECT_NE(mutated(13, 1, 1).find("version 1.1"), std::string::npos);
    EXPECT_NE(mutated(14, 0xffffffff, 4).find("fields"), std::string::npos);
    EXPECT_NE(mutated(offset_at, 0xfffffffffffffff0ull, 8).find("outside the file"),
              std::string::npos);
    EXPECT_NE(mutated(dtype_at, 0, 1).find("dtype"), std::string::npos);
    EXPECT_NE(mutated(dtype_at, 12, 1).find("dtype"), std::string::npos);
    EXPECT_NE(mutated(ndim_at, 0xffff, 2).find("dimensions"), std::string::npos);
    EXPECT_NE(mutated(shape_at, std::uint64_t(1) << 62, 8).find("large"), std::string::npos);
    EXPECT_NE(mutated(shape_at, std::uint64_t(1) << 40, 8).find("outside the file"),
              std::string::npos);
  }

  // Files that are not tensor files at all.
  std::ofstream(dir.file("empty.bsdf")).flush();
  EXPECT_EQ(read_error(dir.file("empty.bsdf")), "empty file");
  std::ofstream(dir.file("foreign.bsdf")) << "# a text file that only looks like a BRDF\n";
  EXPECT_NE(read_error(dir.file("foreign.bsdf")).find("not a tensor_file"), std::string::npos);
  EXPECT_EQ(read_error(dir.path()), "is a directory");
  EXPECT_NE(read_error(dir.file("missing.bsdf")), "no error");

  // Well-formed containers with the wrong content (synthetic variants).
  auto content_error = [&](std::vector<TensorField> fields) {
    return read_error(
        write_synthetic(dir, "content" + std::to_string(++case_number) + ".bsdf", fields));
  };
  {
    auto fields = synthetic_fields();
    fields.erase(fields.begin() + 4);  // sigma
    EXPECT_EQ(content_error(fields), "missing field 'sigma'");
  }
  {
    auto fields = synthetic_fields();
    TensorField& ndf = field_named(fields, "ndf");
    ndf.dtype = 11;
    ndf.data.resize(ndf.data.size() * 2, 0);
    EXPECT_NE(content_error(fields).find("'ndf' must be a 2-D float32"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    TensorField& rgb = field_named(fields, "rgb");
    rgb.shape[2] = 4;
    rgb.data.resize(rgb.data.size() / 3 * 4, 0);
    EXPECT_NE(content_error(fields).find("field 'rgb' has shape"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    TensorField& vndf = field_named(fields, "vndf");
    vndf.shape[1] = 2;
    vndf.data.resize(vndf.data.size() / 3 * 2);
    EXPECT_NE(content_error(fields).find("field 'vndf' has shape"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    std::vector<float> ndf(16, kNdf);
    ndf[5] = std::numeric_limits<float>::quiet_NaN();
    field_named(fields, "ndf").data = float32_data(ndf);
    EXPECT_NE(content_error(fields).find("NaN or infinity"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    TensorField& phi = field_named(fields, "phi_i");
    phi.shape = {4};
    phi.data = float32_data({0.0f, 0.5f, 1.0f, 1.5f});
    EXPECT_NE(content_error(fields).find("anisotropic"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    fields.push_back({"wavelengths", 10, {3}, float32_data({450.0f, 550.0f, 650.0f})});
    EXPECT_NE(content_error(fields).find("spectral"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    TensorField& theta = field_named(fields, "theta_i");
    theta.data = float32_data({0.0f, 1.0f, 0.5f});
    EXPECT_NE(content_error(fields).find("strictly increasing"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    TensorField& luminance = field_named(fields, "luminance");
    std::fill(luminance.data.begin(), luminance.data.end(), 0);
    EXPECT_NE(content_error(fields).find("no positive mass"), std::string::npos);
  }
  {
    auto fields = synthetic_fields();
    fields.push_back(fields.front());  // "version" twice
    EXPECT_NE(content_error(fields).find("appears twice"), std::string::npos);
  }
}

}  // namespace
}  // namespace basis
