// BRDF models, specs and MERL files: physical sanity against analytic facts, spec errors that
// name the file, line and field, and a MERL file written here from an analytic BRDF.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <variant>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/merl.h"
#include "basis/brdf/table_lookup.h"
#include "basis/core/projection.h"
#include "support/brdf_reference.h"
#include "support/merl_file.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;

Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Vec3 v(g(rng), g(rng), std::abs(g(rng)) + 1e-3);
  return v.normalized();
}

std::vector<Brdf> analytic_models() {
  return {Lambert{{0.5, 0.6, 0.7}}, Phong{{0.2, 0.2, 0.2}, {0.5, 0.4, 0.3}, 50},
          BlinnPhong{{0.1, 0.1, 0.1}, {0.6, 0.6, 0.6}, 200},
          Ward{{0.3, 0.3, 0.3}, {0.2, 0.2, 0.2}, 0.15}, Ggx{{0.1, 0.1, 0.1}, {0.9, 0.6, 0.5}, 0.3}};
}

TEST(BrdfModels, AreReciprocalAndNonNegative) {
  std::mt19937 rng(5);
  for (const Brdf& b : analytic_models())
    for (int k = 0; k < 2000; ++k) {
      const Vec3 wi = random_direction(rng), wo = random_direction(rng);
      const Color a = evaluate(b, wi, wo), c = evaluate(b, wo, wi);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_GE(a[ch], 0) << model_name(b);
        EXPECT_NEAR(a[ch], c[ch], 1e-9 * (1 + a[ch])) << model_name(b);
      }
      EXPECT_EQ(evaluate(b, Vec3(wi.x(), wi.y(), -wi.z()), wo)[0], 0);
    }
}

TEST(BrdfModels, StayFiniteAndContinuousAtTheHorizon) {
  // Near the horizon GGX tends to a finite limit (G1(z) / z tends to 2 / alpha) and Ward grows
  // as 1 / sqrt(wi.z wo.z). At z = 1e-200 the products wi.z wo.z underflow to 0; the values
  // must still be those the models tend to, checked at z = 1e-12, where nothing underflows.
  // Azimuths as (cos, sin), the last exactly opposite wi's (the mirror direction, h at the
  // normal), which sin(pi) would miss by 1e-16, far more than 1e-200.
  const std::pair<double, double> azimuths[] = {{0.8, 0.6}, {-0.6, 0.8}, {-0.96, 0.28}, {-1, 0}};
  const auto direction = [](std::pair<double, double> azimuth, double z) {
    const double r = std::sqrt(1 - z * z);
    return Vec3(r * azimuth.first, r * azimuth.second, z);
  };
  for (const Brdf& b : analytic_models())
    for (const auto& [cos_azimuth, sin_azimuth] : azimuths) {
      const double near = 1e-12, nearer = 1e-200;
      const Color a =
          evaluate(b, direction({1, 0}, near), direction({cos_azimuth, sin_azimuth}, near));
      Color c =
          evaluate(b, direction({1, 0}, nearer), direction({cos_azimuth, sin_azimuth}, nearer));
      for (int ch = 0; ch < 3; ++ch) {
        ASSERT_TRUE(std::isfinite(c[ch])) << model_name(b) << " " << cos_azimuth;
        // Ward's lobe brought to the scale of z = 1e-12 (its diffuse term does not grow).
        if (const Ward* ward = std::get_if<Ward>(&b)) {
          const double diffuse = ward->kd[ch] / std::numbers::pi;
          c[ch] = diffuse + (c[ch] - diffuse) * (nearer / near);
        }
        EXPECT_NEAR(c[ch], a[ch], 1e-6 * (1 + a[ch])) << model_name(b) << " " << cos_azimuth;
      }
    }
}

TEST(BrdfModels, NormalisedLobesReflectEverythingAtNormalIncidence) {
  // Normalised Phong: the lobe around the normal integrates (with cos) to exactly ks.
  for (double n : {1.0, 10.0, 100.0, 1000.0}) {
    const Brdf phong = Phong{{0.25, 0.25, 0.25}, {0.5, 0.5, 0.5}, n};
    EXPECT_NEAR(testing::reference_albedo(phong, Vec3::UnitZ(), 0), 0.75, 1e-4) << n;
  }
  // GGX: the normal distribution is normalised, integral of D(h) h.z over the hemisphere = 1.
  for (double alpha : {0.02, 0.2, 1.0}) {
    const double a2 = alpha * alpha;
    const double d = testing::integrate_around(Vec3::UnitZ(), [&](const Vec3& h) {
      if (h.z() <= 0) return 0.0;
      const double t = h.z() * h.z() * (a2 - 1) + 1;
      return a2 / (std::numbers::pi * t * t) * h.z();
    });
    EXPECT_NEAR(d, 1, 1e-4) << alpha;
  }
  // Lambert albedo is the albedo.
  EXPECT_NEAR(testing::reference_albedo(Lambert{{0.3, 0.3, 0.3}}, Vec3(0.6, 0, 0.8), 0), 0.3, 1e-4);
}

// The models against a second implementation from their textbook forms, in the angles of
// directions drawn in spherical coordinates (long double): Phong through the angle to the
// mirror direction; Blinn-Phong, Ward and GGX through the half angle theta_h; GGX with Walter
// et al.'s D = 1 / (pi a^2 cos^4 theta_h (1 + tan^2 theta_h / a^2)^2), Smith's
// G1 = 2 / (1 + sqrt(1 + a^2 tan^2 theta)) and Schlick's F through the angle between wi and h.
TEST(BrdfModels, MatchTheirTextbookFormsInAngles) {
  using Real = long double;
  const Real pi = std::numbers::pi_v<long double>;
  struct Angles {
    Real theta, phi;
    Real x() const { return std::sin(theta) * std::cos(phi); }
    Real y() const { return std::sin(theta) * std::sin(phi); }
    Real z() const { return std::cos(theta); }
  };
  auto angle_between = [](Real ax, Real ay, Real az, Real bx, Real by, Real bz) {
    const Real cross =
        std::hypot(std::hypot(ay * bz - az * by, az * bx - ax * bz), ax * by - ay * bx);
    return std::atan2(cross, ax * bx + ay * by + az * bz);
  };
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> theta(0.01, 1.55), phi(0, 2 * std::numbers::pi);
  int compared = 0;
  for (int k = 0; k < 400; ++k) {
    const Angles i{theta(rng), phi(rng)}, o{theta(rng), phi(rng)};
    const Vec3 wi(double(i.x()), double(i.y()), double(i.z()));
    const Vec3 wo(double(o.x()), double(o.y()), double(o.z()));
    // Half vector h = (wi + wo) / |wi + wo|, its polar angle, and the angle between wi and h.
    const Real hx = i.x() + o.x(), hy = i.y() + o.y(), hz = i.z() + o.z();
    const Real theta_h = std::atan2(std::hypot(hx, hy), hz);
    const Real theta_d = angle_between(i.x(), i.y(), i.z(), hx, hy, hz);
    const Real tan2_h = std::tan(theta_h) * std::tan(theta_h);
    // The angle between wi and the mirror of wo about the normal.
    const Real alpha_r = angle_between(i.x(), i.y(), i.z(), -o.x(), -o.y(), o.z());
    const double kd = 0.15, ks = 0.55, f0 = 0.7;
    auto check = [&](const Brdf& brdf, Real expected, const char* name) {
      const double got = evaluate(brdf, wi, wo)[1];
      EXPECT_NEAR(got, double(expected), 1e-9 * double(expected) + 1e-12)
          << name << " at theta_i " << double(i.theta) << ", theta_o " << double(o.theta);
      ++compared;
    };
    for (const double n : {3.0, 40.0, 500.0}) {
      const Real cos_r = std::max(Real(0), std::cos(alpha_r));
      check(Phong{{0, kd, 0}, {0, ks, 0}, n},
            kd / pi + ks * (n + 2) / (2 * pi) * std::pow(cos_r, Real(n)), "phong");
      check(BlinnPhong{{0, kd, 0}, {0, ks, 0}, n},
            kd / pi + ks * (n + 8) / (8 * pi) * std::pow(std::cos(theta_h), Real(n)),
            "blinn-phong");
    }
    for (const double a : {0.05, 0.2, 0.7}) {
      const Real a2 = Real(a) * a;
      check(Ward{{0, kd, 0}, {0, ks, 0}, a},
            kd / pi + ks * std::exp(-tan2_h / a2) / (4 * pi * a2 * std::sqrt(i.z() * o.z())),
            "ward");
      const Real cos4 = std::pow(std::cos(theta_h), Real(4));
      const Real d = 1 / (pi * a2 * cos4 * (1 + tan2_h / a2) * (1 + tan2_h / a2));
      auto g1 = [&](Real polar) {
        const Real t = std::tan(polar);
        return 2 / (1 + std::sqrt(1 + a2 * t * t));
      };
      const Real f = f0 + (1 - f0) * std::pow(1 - std::cos(theta_d), Real(5));
      check(Ggx{{0, kd, 0}, {0, f0, 0}, a},
            kd / pi + d * g1(i.theta) * g1(o.theta) * f / (4 * i.z() * o.z()), "ggx");
    }
  }
  EXPECT_EQ(compared, 400 * 12);
}

std::string write_spec(const TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.file(name);
  std::ofstream(path) << text;
  return path;
}

std::string spec_error(const TempDir& dir, const std::string& text) {
  const std::string path = write_spec(dir, "spec.json", text);
  try {
    read_brdf_spec(path);
  } catch (const FileError& e) {
    return std::string(e.what()).substr(path.size());
  }
  return "no error";
}

TEST(BrdfSpec, ReadsEveryModel) {
  TempDir dir;
  const BrdfSpec phong = read_brdf_spec(
      write_spec(dir, "p.json",
                 R"({"model": "phong", "kd": [0.5, 0.4, 0.3], "ks": 0.2, "exponent": 40,
          "table": {"wo_res": 9, "wi_res": 32, "tolerance": 0.02}})"));
  ASSERT_TRUE(std::holds_alternative<Phong>(phong.brdf));
  EXPECT_EQ(std::get<Phong>(phong.brdf).kd, (Color{0.5, 0.4, 0.3}));
  EXPECT_EQ(std::get<Phong>(phong.brdf).ks, (Color{0.2, 0.2, 0.2}));
  EXPECT_EQ(std::get<Phong>(phong.brdf).exponent, 40);
  EXPECT_EQ(phong.wo_resolution, 9);
  EXPECT_EQ(phong.wi_resolution, 32);
  EXPECT_EQ(phong.tolerance, 0.02);
  EXPECT_EQ(channel_count(phong.brdf), 3);
  const BrdfSpec ggx =
      read_brdf_spec(write_spec(dir, "g.json", R"({"model": "ggx", "f0": 0.04, "alpha": 0.2})"));
  EXPECT_EQ(std::get<Ggx>(ggx.brdf).kd, (Color{0, 0, 0}));
  EXPECT_EQ(channel_count(ggx.brdf), 1);
  EXPECT_TRUE(std::holds_alternative<Lambert>(
      read_brdf_spec(write_spec(dir, "l.json", R"({"model": "lambert", "albedo": 0.8})")).brdf));
  EXPECT_TRUE(std::holds_alternative<Ward>(
      read_brdf_spec(write_spec(dir, "w.json", R"({"model": "ward", "ks": 0.2, "alpha": 0.1})"))
          .brdf));
  EXPECT_TRUE(std::holds_alternative<BlinnPhong>(
      read_brdf_spec(
          write_spec(dir, "b.json", R"({"model": "blinn-phong", "ks": 0.2, "exponent": 8})"))
          .brdf));
}

TEST(BrdfSpec, ErrorsNameFileLineAndField) {
  TempDir dir;
  EXPECT_EQ(spec_error(dir, "{\n  \"model\": \"phong\",\n  \"ks\": 0.4\n}"),
            ":1: field 'exponent': missing (a number from 0 to 1e+06)");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"phong\",\n\"ks\": 0.4,\n\"exponent\": -3}"),
            ":3: field 'exponent': must be from 0 to 1e+06, got -3");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"phong\", \"ks\": [1, 2], \"exponent\": 3}"),
            ":1: field 'ks': must be a number or an array [r, g, b] of three numbers");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"glass\"}"),
            ":1: field 'model': unknown model 'glass' (lambert, phong, blinn-phong, ward, ggx, "
            "merl, rgl)");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"lambert\",\n \"albedo\": 0.5,\n \"albeedo\": 1}"),
            ":3: field 'albeedo': unknown field (expected one of: albedo, model, name, table)");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"ggx\", \"f0\": 0.04, \"alpha\": \"rough\"}"),
            ":1: field 'alpha': must be a number, got string");
  EXPECT_EQ(spec_error(dir, "{\"model\": \"ggx\", \"f0\": 0.04, \"alpha\": 0}"),
            ":1: field 'alpha': must be from 0.001 to 1, got 0");
  EXPECT_EQ(
      spec_error(dir, "{\"model\": \"lambert\", \"albedo\": 0.5,\n \"table\": {\"wi_res\": 3.5}}"),
      ":2: field 'table.wi_res': must be a whole number");
  const std::string bad_json = spec_error(dir, "{\"model\": \"lambert\",\n \"albedo\": NaN}");
  EXPECT_EQ(bad_json.rfind(":2: invalid JSON: ", 0), 0u) << bad_json;
  EXPECT_EQ(spec_error(dir, "{\"model\": \"phong\", \"ks\": 0.4, \"exponent\": 1e400}"),
            ": invalid JSON: a number is out of range");
  EXPECT_EQ(spec_error(dir, "[1, 2]"), ":1: a BRDF spec is a JSON object {\"model\": ..., ...}");
  // A key given twice in one object: refused, not the last one taken (the same keys in objects
  // of an array, as a scene's meshes, are read as before: RenderScene tests).
  EXPECT_EQ(spec_error(dir, "{\"model\": \"lambert\", \"albedo\": 0.5, \"albedo\": 0.9}"),
            ": invalid JSON: key 'albedo' given twice in one object");
  EXPECT_EQ(spec_error(dir,
                       "{\"model\": \"lambert\", \"albedo\": 0.5,\n \"table\": {\"wi_res\": "
                       "16, \"wi_res\": 32}}"),
            ": invalid JSON: key 'wi_res' given twice in one object");
  EXPECT_THROW(read_brdf_spec(dir.file("missing.json")), FileError);
  EXPECT_THROW(read_brdf_spec(dir.path()), FileError);
}

// A MERL file written from an analytic BRDF: the value at every bin centre, through the
// half/difference parametrisation inverted here independently of the reader.
void write_merl(const std::string& path, const Brdf& brdf, bool mark_missing = false) {
  const int nh = 90, nd = 90, np = 180;
  std::vector<double> samples(3 * std::size_t(nh) * nd * np);
  for (int i = 0; i < nh; ++i)
    for (int j = 0; j < nd; ++j)
      for (int k = 0; k < np; ++k) {
        const double theta_h = std::pow((i + 0.5) / nh, 2) * std::numbers::pi / 2;
        const double theta_d = (j + 0.5) / nd * std::numbers::pi / 2;
        const double phi_d = (k + 0.5) / np * std::numbers::pi;
        const Vec3 h(std::sin(theta_h), 0, std::cos(theta_h));
        const Vec3 d(std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d),
                     std::cos(theta_d));
        // wi = R_y(theta_h) d (phi_h = 0), wo its mirror about h.
        const Vec3 wi(d.x() * std::cos(theta_h) + d.z() * std::sin(theta_h), d.y(),
                      -d.x() * std::sin(theta_h) + d.z() * std::cos(theta_h));
        const Vec3 wo = 2 * wi.dot(h) * h - wi;
        const Color f = evaluate(brdf, wi, wo);
        const std::size_t index = (std::size_t(i) * nd + j) * np + k;
        const bool missing = mark_missing && (index % 7 == 0);
        for (int c = 0; c < 3; ++c)
          samples[c * std::size_t(nh) * nd * np + index] =
              missing ? -1.0 : f[c] / MerlBrdf::kScale[c];
      }
  testing::write_merl_samples(path, samples);
}

// The half vector of a MERL lookup near the horizon: wi and wo at z = 1e-200 on opposite sides
// (the mirror direction, h at the normal) read the bins they read at z = 1e-12, where |wi + wo|^2
// does not underflow.
TEST(MerlBrdf, HalfVectorHoldsAtTheHorizon) {
  TempDir dir;
  write_merl(dir.file("lobe.binary"), BlinnPhong{{0.1, 0.1, 0.1}, {0.8, 0.8, 0.8}, 40});
  const auto merl = MerlBrdf::read(dir.file("lobe.binary"));
  const auto pair = [&](double z) {
    const double r = std::sqrt(1 - z * z);
    return merl->evaluate(Vec3(r, 0, z), Vec3(-r, 0, z));
  };
  const Color near = pair(1e-12), nearer = pair(1e-200);
  EXPECT_GT(near[0], 1.0);  // the lobe's peak, not its tail
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(nearer[c], near[c]) << c;
}

// A BRDF whose values are finite doubles beyond the float range (made in memory: the MERL
// reader refuses such files) stops tabulation with an error that names the direction.
TEST(MerlBrdf, ValuesBeyondFloatsStopTabulationNamingWo) {
  const Brdf huge =
      std::make_shared<const MerlBrdf>(std::vector<double>(testing::kMerlSamples, 1e300));
  BrdfTableOptions options;
  options.wo_resolution = 2;
  options.wi_resolution = 4;
  try {
    tabulate_brdf(huge, options);
    FAIL() << "tabulated";
  } catch (const std::overflow_error& e) {
    EXPECT_NE(std::string(e.what()).find("the BRDF's values at wo = ("), std::string::npos)
        << e.what();
  }
}

TEST(MerlBrdf, FileFromAnalyticBrdfReproducesItsAlbedo) {
  TempDir dir;
  const Brdf analytic = BlinnPhong{{0.3, 0.2, 0.1}, {0.5, 0.5, 0.5}, 30};
  write_merl(dir.file("analytic.binary"), analytic);
  std::ofstream(dir.file("merl.json")) << R"({"model": "merl", "file": "analytic.binary"})";
  const BrdfSpec spec = read_brdf_spec(dir.file("merl.json"));  // relative to the spec
  ASSERT_EQ(model_name(spec.brdf), "merl");
  BrdfTableOptions options;
  options.wo_resolution = 9;
  options.wi_resolution = 32;
  options.tilt_derivatives = false;
  const BrdfTable table = tabulate_brdf(spec.brdf, options);
  Grid one(2, 1);
  for (float& t : one.texels)
    t = 1;
  const PackedTree light = pack(project(one));
  // At table entries (s = 0, 0.25, 0.5, 0.75 on the 9 x 9 grid: 0, 28, 53 and 74 degrees), so
  // that the interpolation between entries (tested elsewhere) does not enter.
  for (int i = 4; i < 8; ++i) {
    const Vec3 wo = table_outgoing(i, 4, 9);
    const double theta = std::acos(wo.z()) * 180 / std::numbers::pi;
    const Convolution c = reflect(table.view(), light.view(), wo);
    for (int ch = 0; ch < 3; ++ch) {
      const double expected = testing::reference_albedo(analytic, wo, ch);
      EXPECT_NEAR(c.value[ch], expected, 0.02 * expected) << theta << " channel " << ch;
    }
  }
}

TEST(MerlBrdf, MissingSamplesCountAsZeroAndBadFilesAreErrors) {
  TempDir dir;
  const Brdf analytic = Lambert{{0.5, 0.5, 0.5}};
  write_merl(dir.file("holes.binary"), analytic, true);
  const auto merl = MerlBrdf::read(dir.file("holes.binary"));
  EXPECT_NEAR(merl->missing_fraction(), 1.0 / 7, 1e-3);
  std::mt19937 rng(1);
  int zeros = 0;
  for (int k = 0; k < 5000; ++k) {
    const Color f = merl->evaluate(random_direction(rng), random_direction(rng));
    if (f[0] == 0) {
      ++zeros;
    } else {
      EXPECT_NEAR(f[0], 0.5 / std::numbers::pi, 1e-9);
    }
  }
  EXPECT_NEAR(zeros / 5000.0, 1.0 / 7, 0.03);

  {
    std::ofstream bad(dir.file("header.binary"), std::ios::binary);
    const std::int32_t dims[3] = {90, 90, 360};
    bad.write(reinterpret_cast<const char*>(dims), sizeof dims);
  }
  try {
    MerlBrdf::read(dir.file("header.binary"));
    FAIL();
  } catch (const FileError& e) {
    EXPECT_EQ(std::string(e.what()), dir.file("header.binary") +
                                         ": not a MERL BRDF (dimensions 90 x 90 x 360, "
                                         "expected 90 x 90 x 180)");
  }
  {
    std::ofstream s(dir.file("short.binary"), std::ios::binary);
    const std::int32_t dims[3] = {90, 90, 180};
    s.write(reinterpret_cast<const char*>(dims), sizeof dims);
    s << "only a few bytes";
  }
  try {
    MerlBrdf::read(dir.file("short.binary"));
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated MERL file"), std::string::npos) << e.what();
  }
  std::ofstream(dir.file("tiny.binary")) << "x";
  EXPECT_THROW(MerlBrdf::read(dir.file("tiny.binary")), FileError);
}

}  // namespace
}  // namespace basis
