// Rendering against independent ground truth: BRDF and environment sampling against quadrature
// and sums over the map's pixels, Monte Carlo against direct integration over the map's pixels
// with a brute-force visibility test (not Embree), the radiance cache against a converged Monte
// Carlo reference as its records grow denser, and scene files' errors.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <tuple>

#include "basis/brdf/brdf_sampling.h"
#include "basis/core/random.h"
#include "basis/io/image_file.h"
#include "basis/render/direct_lighting.h"
#include "basis/render/image_comparison.h"
#include "basis/render/renderer.h"
#include "basis/study/reference.h"
#include "support/brdf_reference.h"
#include "support/environments.h"
#include "support/temp_dir.h"

namespace basis {
namespace {

using testing::TempDir;
using testing::write_text;

// ---------------------------------------------------------------- sampling

TEST(BrdfSampling, EstimatesTheAlbedoThatQuadratureGives) {
  // E[f cos / pdf] over sample_brdf's draws is the albedo only if pdf is the draws' density.
  const std::vector<Brdf> brdfs = {Lambert{{0.8, 0.8, 0.8}},
                                   Phong{{0.3, 0.3, 0.3}, {0.5, 0.5, 0.5}, 40},
                                   BlinnPhong{{0.2, 0.2, 0.2}, {0.6, 0.6, 0.6}, 100},
                                   Ward{{0.1, 0.1, 0.1}, {0.5, 0.5, 0.5}, 0.15},
                                   Ggx{{0, 0, 0}, {0.9, 0.9, 0.9}, 0.2},
                                   Ggx{{0.2, 0.2, 0.2}, {0.04, 0.04, 0.04}, 0.1}};
  for (const Brdf& brdf : brdfs)
    for (const double degrees : {0.0, 45.0, 70.0}) {
      const double t = degrees * std::numbers::pi / 180;
      const Vec3 wo(std::sin(t), 0, std::cos(t));
      const double reference = testing::reference_albedo(brdf, wo, 0);
      const int n = 200000;
      double sum = 0;
      for (int i = 0; i < n; ++i) {
        const std::uint64_t id = 4 * std::uint64_t(i);
        const BrdfSample s =
            sample_brdf(brdf, wo, unit_random(id), unit_random(id + 1), unit_random(id + 2));
        if (s.pdf > 0 && s.wi.z() > 0) sum += evaluate(brdf, s.wi, wo)[0] * s.wi.z() / s.pdf;
      }
      EXPECT_NEAR(sum / n, reference, 0.015 * reference)
          << model_name(brdf) << " at " << degrees << " degrees";
      // The density integrates to at most 1 over the hemisphere (draws below it are lost).
      const double mass = testing::integrate_around(
          Vec3(-wo.x(), -wo.y(), wo.z()), [&](const Vec3& wi) { return brdf_pdf(brdf, wi, wo); });
      EXPECT_LE(mass, 1.002) << model_name(brdf);
      EXPECT_GT(mass, 0.5) << model_name(brdf);
    }
}

TEST(EnvironmentSampler, DrawsEstimateTheIrradianceThatThePixelsSumTo) {
  const Environment environment(testing::synthetic_sky());
  const EnvironmentSampler sampler(environment);
  // The density integrates to 1 over the sphere (a consistency check of the pixel
  // probabilities; the draws themselves are checked below against the irradiance).
  double mass = 0;
  for (int y = 0; y < environment.height(); ++y)
    environment.for_each_subpixel(y, 0, environment.width(), 1, [&](int, const Vec3& w, double dw) {
      mass += sampler.pdf(w) * dw;
    });
  EXPECT_NEAR(mass, 1, 1e-9);
  for (const Vec3& n : {Vec3(0, 0, 1), Vec3(0.6, 0, 0.8), Vec3(0, -1, 0)}) {
    const Color reference = environment.irradiance(n);
    const int count = 200000;
    double sum = 0;
    for (int i = 0; i < count; ++i) {
      const std::uint64_t id = 4 * std::uint64_t(i);
      const auto s = sampler.sample(unit_random(id), unit_random(id + 1), unit_random(id + 2),
                                    unit_random(id + 3));
      sum += environment.radiance(s.w)[0] * std::max(0.0, s.w.dot(n)) / s.pdf;
    }
    EXPECT_NEAR(sum / count, reference[0], 0.01 * reference[0]) << n.transpose();
  }
}

// ---------------------------------------------------------------- scenes

// Visibility by testing every triangle (Moller-Trumbore), independent of Embree.
class BruteForceScene : public RayScene {
 public:
  explicit BruteForceScene(const TriangleMesh& mesh) : mesh_(mesh) {}
  void trace(std::span<const Ray> rays, std::span<RayHit> hits) const override {
    for (std::size_t i = 0; i < rays.size(); ++i)
      hits[i] = {nearest(rays[i]) < INFINITY, {0, 0, 0}};
  }
  void trace_nearest(std::span<const Ray> rays, std::span<RayHit> hits) const override {
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const double t = nearest(rays[i]);
      hits[i] = {t < INFINITY, {0, 0, 0}, float(t)};
    }
  }
  void intersect(std::span<const Ray>, std::span<RayIntersection>) const override {
    FAIL() << "not used";
  }

 private:
  double nearest(const Ray& r) const {
    double best = INFINITY;
    for (const auto& f : mesh_.triangles) {
      const Vec3 a(mesh_.vertices[f[0]][0], mesh_.vertices[f[0]][1], mesh_.vertices[f[0]][2]);
      const Vec3 b(mesh_.vertices[f[1]][0], mesh_.vertices[f[1]][1], mesh_.vertices[f[1]][2]);
      const Vec3 c(mesh_.vertices[f[2]][0], mesh_.vertices[f[2]][1], mesh_.vertices[f[2]][2]);
      const Vec3 e1 = b - a, e2 = c - a, p = r.direction.cross(e2);
      const double det = e1.dot(p);
      if (std::abs(det) < 1e-12) continue;
      const Vec3 s = r.origin - a;
      const double u = s.dot(p) / det;
      if (u < 0 || u > 1) continue;
      const Vec3 q = s.cross(e1);
      const double v = r.direction.dot(q) / det;
      if (v < 0 || u + v > 1) continue;
      const double t = e2.dot(q) / det;
      if (t > 0 && t < best) best = t;
    }
    return best;
  }
  const TriangleMesh& mesh_;
};

// The Poly Haven sunrise from Debian's blender-data (which the set-up installs), or the
// synthetic sky when it is absent.
std::string sunrise_map() {
  const std::string sunrise = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
  if (std::filesystem::exists(sunrise)) return sunrise;
  std::printf("[  NOTE    ] %s is absent: a generated sky with a sun is used\n", sunrise.c_str());
  return "sky.exr";
}

// The bundled scene under a map (default: the synthetic sky, a sun of one 1.4-degree pixel),
// Lambert + Phong 40, its table small enough to tabulate in a test.
struct BundledScene {
  TempDir dir;
  RenderScene scene;
  explicit BundledScene(int width = 48, int height = 36, bool tables = true,
                        const std::string& map = "sky.exr") {
    write_image(dir.file("sky.exr"), testing::synthetic_sky(2e4f));
    write_text(dir.file("glossy.json"),
               R"({"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 40,
                   "table": {"wo_res": 25, "wi_res": 32}})");
    write_text(dir.file("scene.json"),
               R"({"camera": {"eye": [0, -9, 4], "look_at": [0, 0, 0.7], "up": [0, 0, 1],
                              "fov": 40, "width": )" +
                   std::to_string(width) + R"(, "height": )" + std::to_string(height) + R"(},
                   "environment": {"map": ")" +
                   map + R"(", "rotate": 30},
                   "meshes": [{"obj": ")" +
                   std::string(BASIS_SOURCE_DIR) +
                   R"(/data/scene.obj", "material": "glossy.json"}]})");
    SceneLoadOptions options;
    options.tables = tables;
    scene = load_render_scene(read_scene_file(dir.file("scene.json")), options);
  }
};

TEST(MonteCarlo, AgreesWithIntegrationOverTheMapWithIndependentVisibility) {
  const BundledScene bundled(48, 36, false);
  const RenderScene& scene = bundled.scene;
  const BruteForceScene brute(scene.mesh);
  const Camera& camera = scene.file.camera;
  // A lit floor, the floor in a box's shadow, a box's face and the sphere.
  int checked = 0, shadowed = 0;
  for (const auto& [x, y] : {std::pair{6, 32}, std::pair{12, 22}, std::pair{14, 16},
                             std::pair{34, 18}, std::pair{30, 25}}) {
    const Ray ray = camera.ray(x + 0.5, y + 0.5);
    std::vector<RayIntersection> hit(1);
    scene.rays->intersect(std::span(&ray, 1), hit);
    const ShadingPoint p = shading_point(scene, ray, hit[0], camera.pixel_angle());
    ASSERT_TRUE(p.hit) << x << "," << y;
    const int samples = 40000;
    const Color mc = direct_lighting_sum(scene, p, 12345, 0, samples);
    const Color reference =
        reference_reflection(*scene.environment, &brute, p.position, p.frame(),
                             scene.materials[p.material].brdf, p.local_wo(), 1, scene.ray_offset);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(mc[c] / samples, reference[c], 0.02 * reference[c] + 1e-4)
          << "pixel " << x << "," << y << " channel " << c;
    // The sun (2e4 over one pixel) dominates where it is seen: the points span both cases.
    const Vec3 sun = scene.environment->lights()[0].direction;
    std::vector<RayHit> sun_hit(1);
    const Ray to_sun{p.position + p.geometric_normal * scene.ray_offset, sun};
    brute.trace(std::span(&to_sun, 1), sun_hit);
    shadowed += sun_hit[0].hit || sun.dot(p.normal) <= 0;
    ++checked;
  }
  EXPECT_EQ(checked, 5);
  EXPECT_GE(shadowed, 1);
  EXPECT_LE(shadowed, 4);
}

TEST(RadianceCache, ConvergesToTheReferenceAsRecordsGrowDenser) {
  const BundledScene bundled(48, 36, true, sunrise_map());
  RenderOptions reference_options;
  reference_options.method = RenderMethod::monte_carlo;
  reference_options.spp = 4096;
  const RenderResult reference = render(bundled.scene, reference_options);
  std::vector<double> errors;
  std::vector<std::size_t> records;
  // Validity radii of at most 12 and 4 pixels, then half a pixel: a record at every pixel.
  for (const double spacing : {12.0, 4.0, 0.5}) {
    RenderOptions options;
    options.cache.max_spacing = spacing;
    options.cache.min_spacing = std::min(1.5, spacing);
    const RenderResult cached = render(bundled.scene, options);
    errors.push_back(compare_images(cached.image, reference.image, cached.covered).relative_mse);
    records.push_back(cached.records);
  }
  for (std::size_t i = 0; i < errors.size(); ++i)
    std::printf("records %zu: relative MSE %.3g\n", records[i], errors[i]);
  EXPECT_LT(records[0], records[1]);
  EXPECT_LT(records[1], records[2]);
  EXPECT_LT(errors[1], errors[0]);
  EXPECT_LT(errors[2], errors[1]);
  // A record at every pixel leaves the table's and the records' own errors and the reference's
  // noise (about 1e-4 at 4096 samples), 1.9e-4 measured: 3e-4 is an RMS relative error of
  // about 1.7 %.
  EXPECT_LT(errors[2], 3e-4);
}

TEST(RadianceCache, DenseRecordsGiveTheQuadtreeRecordsResults) {
  // The same records and lookups with dense grids: a second implementation of the products.
  const BundledScene bundled(48, 36, true, sunrise_map());
  RenderOptions options;
  const RenderResult trees = render(bundled.scene, options);
  options.method = RenderMethod::cache_dense;
  const RenderResult dense = render(bundled.scene, options);
  EXPECT_EQ(trees.records, dense.records);
  const ImageErrors e = compare_images(trees.image, dense.image, trees.covered);
  // The records' trees are cut at 5 % of their mean; the products differ by far less.
  EXPECT_LT(e.relative_mse, 1e-4);
  EXPECT_GT(e.pixels, 1000u);
}

TEST(Renderer, ImagesAreTheSameForAnyThreadCount) {
  const BundledScene bundled(32, 24);
  for (const RenderMethod method : {RenderMethod::monte_carlo, RenderMethod::cache}) {
    RenderOptions options;
    options.method = method;
    options.spp = 8;
    std::vector<float> first;
    for (const int threads : {1, 2}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      const RenderResult r = render(bundled.scene, options);
      if (first.empty())
        first = r.image.pixels;
      else
        EXPECT_EQ(first, r.image.pixels);
    }
  }
}

TEST(Renderer, MonteCarloWithABudgetRendersWholeSamplesThatFit) {
  const BundledScene bundled(32, 24, false);
  RenderOptions options;
  options.method = RenderMethod::monte_carlo;
  options.time_budget = 0.3;
  const RenderResult r = render(bundled.scene, options);
  EXPECT_GE(r.spp, 1);
  // Passes stop once the next would not fit; the last may overrun by its own length at most
  // (generous: sanitizer builds and a busy machine time unevenly).
  EXPECT_LT(r.timings.total, 3.0);
}

TEST(ImageComparison, RelativeErrorsAreThoseOfTheDefinition) {
  // 100 covered pixels of reference 1 (eps = 0.01), one of them off by 0.5 in every channel,
  // two more off by 0.1 in red only; a pixel that is not covered differs and does not count.
  Image reference(11, 10, 3), image(11, 10, 3);
  std::fill(reference.pixels.begin(), reference.pixels.end(), 1.f);
  image.pixels = reference.pixels;
  std::vector<std::uint8_t> covered(110, 1);
  for (int y = 0; y < 10; ++y)
    covered[std::size_t(y) * 11 + 10] = 0;
  image.at(10, 3, 0) = 9;
  for (int c = 0; c < 3; ++c)
    image.at(2, 2, c) = 1.5f;
  image.at(5, 5, 0) = image.at(6, 5, 0) = 1.1f;
  const ImageErrors e = compare_images(image, reference, covered);
  EXPECT_EQ(e.pixels, 100u);
  const double big = 0.25 / 1.01, small = 0.01 / 1.01;
  EXPECT_NEAR(e.relative_mse, (3 * big + 2 * small) / 300, 1e-9);
  EXPECT_NEAR(e.rmse, std::sqrt((3 * 0.25 + 2 * 0.01) / 300), 1e-7);
  // Sorted per-pixel errors: 97 zeros, two of sqrt(small / 3), one of sqrt(big); the 99th
  // (index 99) is the largest.
  EXPECT_NEAR(e.p99_relative_error, std::sqrt(big), 1e-7);
}

// ---------------------------------------------------------------- files

// Material files are read beside the OBJ (a relative name from its folder, an absolute one as
// it is), their emission taken per face; one that is not there is a warning naming it, and its
// faces emit nothing.
TEST(TriangleMesh, MaterialFilesAreReadBesideTheObjOrWhereAnAbsoluteNameSays) {
  TempDir dir;
  std::filesystem::create_directories(dir.file("scenes"));
  std::filesystem::create_directories(dir.file("elsewhere"));
  write_text(dir.file("scenes/lamp.mtl"), "newmtl glow\nKe 2 3 4\n");
  write_text(dir.file("elsewhere/far.mtl"), "newmtl glow\nKe 5 6 7\n");
  write_text(dir.file("up.mtl"), "newmtl glow\nKe 1 0.5 0.25\n");
  const std::string face = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glow\nf 1 2 3\n";
  const std::string absolute = std::filesystem::absolute(dir.file("elsewhere/far.mtl")).string();
  for (const auto& [name, library, emission] :
       {std::tuple<std::string, std::string, Color>{"beside", "lamp.mtl", {2, 3, 4}},
        {"absolute", absolute, {5, 6, 7}},
        {"up", "../up.mtl", {1, 0.5f, 0.25f}},
        {"missing", "gone.mtl", {0, 0, 0}}}) {
    write_text(dir.file("scenes/" + name + ".obj"), "mtllib " + library + "\n" + face);
    const TriangleMesh mesh = read_obj(dir.file("scenes/" + name + ".obj"));
    ASSERT_EQ(mesh.emission.size(), 1u) << name;
    EXPECT_EQ(mesh.emission[0], emission) << name;
    const bool warned = std::any_of(mesh.reader_warnings.begin(), mesh.reader_warnings.end(),
                                    [&](const std::string& w) {
                                      return w.find("[ gone.mtl ] not found") != std::string::npos;
                                    });
    EXPECT_EQ(warned, name == "missing") << name;
  }
}

TEST(TriangleMesh, VertexNormalsAreInterpolatedAcrossTriangles) {
  TempDir dir;
  write_text(dir.file("t.obj"),
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 1 0 1\nvn 0 1 1\nf 1//1 2//2 3//3\n");
  const TriangleMesh mesh = read_obj(dir.file("t.obj"));
  ASSERT_EQ(mesh.corner_normals.size(), 1u);
  const Vec3 expected =
      (Vec3(0, 0, 1) + Vec3(1, 0, 1).normalized() + Vec3(0, 1, 1).normalized()).normalized();
  EXPECT_LT((mesh.shading_normal(0, 1.0 / 3, 1.0 / 3) - expected).norm(), 1e-6);
  EXPECT_LT((mesh.shading_normal(0, 1, 0) - Vec3(1, 0, 1).normalized()).norm(), 1e-6);
  write_text(dir.file("flat.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const TriangleMesh flat = read_obj(dir.file("flat.obj"));
  EXPECT_TRUE(flat.corner_normals.empty());
  EXPECT_LT((flat.shading_normal(0, 0.2, 0.2) - Vec3(0, 0, 1)).norm(), 1e-12);
  // Scenes are built by appending meshes to an empty one: the first keeps its normals (they
  // were dropped, and a scene of one smooth mesh rendered flat), a flat one after it gets its
  // face normals per corner, and a smooth one after a flat one turns the flat one's into them.
  TriangleMesh scene;
  scene.append(mesh);
  ASSERT_EQ(scene.corner_normals.size(), 1u);
  EXPECT_LT((scene.shading_normal(0, 1, 0) - Vec3(1, 0, 1).normalized()).norm(), 1e-6);
  scene.append(flat);
  ASSERT_EQ(scene.corner_normals.size(), 2u);
  EXPECT_LT((scene.shading_normal(1, 0.2, 0.2) - Vec3(0, 0, 1)).norm(), 1e-6);
  EXPECT_LT((scene.shading_normal(0, 1, 0) - Vec3(1, 0, 1).normalized()).norm(), 1e-6);
  TriangleMesh flat_first;
  flat_first.append(flat);
  EXPECT_TRUE(flat_first.corner_normals.empty());
  flat_first.append(mesh);
  ASSERT_EQ(flat_first.corner_normals.size(), 2u);
  EXPECT_LT((flat_first.shading_normal(0, 0.2, 0.2) - Vec3(0, 0, 1)).norm(), 1e-6);
  EXPECT_LT((flat_first.shading_normal(1, 1, 0) - Vec3(1, 0, 1).normalized()).norm(), 1e-6);
}

// The message of the FileError a scene text raises.
std::string scene_error(const std::string& text) {
  try {
    parse_scene_file(text, "s.json", "");
  } catch (const FileError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SceneFile, ProblemsNameTheFileTheLineAndTheField) {
  const std::string good_camera =
      R"("camera": {"eye": [0, -6, 2], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 40,
                   "width": 320, "height": 240})";
  const std::string good_rest = R"("environment": {"constant": [1, 1, 1]},
      "meshes": [{"obj": "a.obj", "material": "m.json"}])";
  const SceneFile ok = parse_scene_file("{" + good_camera + ",\n" + good_rest + "}", "s.json", "f");
  EXPECT_EQ(ok.camera.width, 320);
  EXPECT_EQ(ok.meshes.at(0).obj, "f/a.obj");
  EXPECT_EQ(ok.meshes.at(0).material, "f/m.json");

  EXPECT_EQ(scene_error("{" + good_camera + "}"),
            "s.json:1: field 'environment': missing or not an object {\"map\": FILE, \"rotate\": "
            "DEGREES} or {\"constant\": [r, g, b]}");
  const std::string nowhere = R"({"camera": {"eye": [1, 1, 1],
      "look_at": [1, 1, 1], "fov": 40, "width": 8, "height": 8}, )" +
                              good_rest + "}";
  EXPECT_EQ(scene_error(nowhere),
            "s.json:2: field 'camera.look_at': looks nowhere: look_at is the eye");
  const std::string zero = R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0],
      "fov": 40, "width": 0, "height": 8}, )" +
                           good_rest + "}";
  EXPECT_EQ(scene_error(zero), "s.json:2: field 'camera.width': must be from 1 to 16384, got 0");
  const std::string huge = R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0],
      "fov": 40, "width": 16384, "height": 16384}, )" +
                           good_rest + "}";
  EXPECT_NE(scene_error(huge).find("larger than the limit"), std::string::npos);
  const std::string up = R"({"camera": {"eye": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 0, 1],
      "fov": 40, "width": 8, "height": 8}, )" +
                         good_rest + "}";
  EXPECT_EQ(scene_error(up), "s.json:1: field 'camera.up': up is along the direction of view");
  const std::string second_mesh = "{" + good_camera + R"(, "environment": {"constant": 1},
      "meshes": [{"obj": "a.obj", "material": "m.json"},
                 {"obj": "b.obj", "material": "m.png"}]})";
  EXPECT_EQ(scene_error(second_mesh),
            "s.json:4: field 'meshes[1].material': must be a BRDF spec (.json) or a BRDF table "
            "(.qt), got 'm.png'");
  EXPECT_EQ(scene_error("{" + good_camera + ", \"lights\": 3}"),
            "s.json:2: field 'lights': unknown field (expected one of: camera, environment, "
            "meshes, name)");
  EXPECT_NE(scene_error("{\"camera\": [}").find("s.json:1: invalid JSON"), std::string::npos);
}

TEST(RenderScene, AMissingMeshOrMaterialNamesTheSceneLineAndTheFile) {
  TempDir dir;
  write_text(dir.file("m.json"), R"({"model": "lambert", "albedo": 0.5})");
  const std::string camera =
      R"({"camera": {"eye": [0, -6, 2], "look_at": [0, 0, 0.5], "fov": 40, "width": 8, "height": 8},
  "environment": {"constant": 1},
  "meshes": [)";
  write_text(dir.file("a.json"), camera + R"({"obj": "missing.obj", "material": "m.json"}]})");
  SceneLoadOptions no_tables;
  no_tables.tables = false;
  try {
    load_render_scene(read_scene_file(dir.file("a.json")), no_tables);
    FAIL();
  } catch (const FileError& e) {
    EXPECT_EQ(std::string(e.what()), dir.file("a.json") + ":3: mesh 0: " + dir.file("missing.obj") +
                                         ": No such file or directory");
  }
  write_text(dir.file("b.json"), camera + R"({"obj": ")" + std::string(BASIS_SOURCE_DIR) +
                                     R"(/data/scene.obj", "material": "nope.json"}]})");
  try {
    load_render_scene(read_scene_file(dir.file("b.json")), no_tables);
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(
        std::string(e.what()).find(dir.file("b.json") + ":3: mesh 0: " + dir.file("nope.json")),
        std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace basis
