#include "basis/brdf/brdf_spec.h"

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "basis/brdf/merl.h"
#include "basis/brdf/rgl.h"
#include "basis/core/file_error.h"
#include "basis/core/grid.h"
#include "basis/io/json_fields.h"
#include "basis/io/text_file.h"

namespace basis {

using nlohmann::json;

BrdfSpec parse_brdf_spec(const std::string& text, const std::string& name,
                         const std::string& folder) {
  const JsonFields r(text, name);
  const json root = r.parse();
  if (!root.is_object()) r.fail("", "a BRDF spec is a JSON object {\"model\": ..., ...}");
  if (!root.contains("model") || !root["model"].is_string())
    r.fail("model", "missing or not a string (lambert, phong, blinn-phong, ward, ggx, merl, rgl)");

  BrdfSpec spec;
  spec.text = text;
  spec.model = root["model"].get<std::string>();
  const std::string& m = spec.model;
  const double kMaxExponent = 1e6;
  if (m == "lambert") {
    r.only(root, {"model", "name", "albedo", "table"}, "");
    spec.brdf = Lambert{r.color(root, "albedo", "albedo", 1)};
  } else if (m == "phong" || m == "blinn-phong") {
    r.only(root, {"model", "name", "kd", "ks", "exponent", "table"}, "");
    const Color kd = r.color(root, "kd", "kd", 1, Color{0, 0, 0});
    const Color ks = r.color(root, "ks", "ks", 1);
    const double n = r.number(root, "exponent", "exponent", 0, kMaxExponent);
    if (m == "phong")
      spec.brdf = Phong{kd, ks, n};
    else
      spec.brdf = BlinnPhong{kd, ks, n};
  } else if (m == "ward") {
    r.only(root, {"model", "name", "kd", "ks", "alpha", "table"}, "");
    spec.brdf = Ward{r.color(root, "kd", "kd", 1, Color{0, 0, 0}), r.color(root, "ks", "ks", 1),
                     r.number(root, "alpha", "alpha", 1e-3, 1)};
  } else if (m == "ggx") {
    r.only(root, {"model", "name", "kd", "f0", "alpha", "table"}, "");
    spec.brdf = Ggx{r.color(root, "kd", "kd", 1, Color{0, 0, 0}), r.color(root, "f0", "f0", 1),
                    r.number(root, "alpha", "alpha", 1e-3, 1)};
  } else if (m == "merl" || m == "rgl") {
    r.only(root, {"model", "name", "file", "table"}, "");
    if (!root.contains("file") || !root["file"].is_string())
      r.fail("file", m == "merl" ? "missing or not a string (path of a MERL .binary file)"
                                 : "missing or not a string (path of an RGL .bsdf file)");
    std::filesystem::path file = root["file"].get<std::string>();
    if (file.empty()) r.fail("file", "must name a file");
    if (file.is_relative() && !folder.empty()) file = std::filesystem::path(folder) / file;
    spec.data_file = file.string();
    // The data file's own error, with the spec and the field that named it.
    try {
      if (m == "merl")
        spec.brdf = std::shared_ptr<const MeasuredBrdf>(MerlBrdf::read(file.string()));
      else
        spec.brdf = std::shared_ptr<const MeasuredBrdf>(RglBrdf::read(file.string()));
    } catch (const FileError& e) {
      r.fail("file", e.what());
    }
  } else {
    r.fail("model",
           "unknown model '" + m + "' (lambert, phong, blinn-phong, ward, ggx, merl, rgl)");
  }
  if (root.contains("name") && !root["name"].is_string()) r.fail("name", "must be a string");

  if (root.contains("table")) {
    const json& t = root["table"];
    if (!t.is_object())
      r.fail("table", "must be an object {\"wo_res\", \"wi_res\", \"tolerance\"}");
    r.only(t, {"wo_res", "wi_res", "tolerance"}, "table");
    if (t.contains("wo_res"))
      spec.wo_resolution = int(r.number(t, "wo_res", "table.wo_res", 2, 256));
    if (t.contains("wi_res"))
      spec.wi_resolution = int(r.number(t, "wi_res", "table.wi_res", 2, 512));
    if (t.contains("tolerance"))
      spec.tolerance = r.number(t, "tolerance", "table.tolerance", 0, 1e6);
    if (spec.wo_resolution && double(*spec.wo_resolution) != t["wo_res"].get<double>())
      r.fail("table.wo_res", "must be a whole number");
    if (spec.wi_resolution && double(*spec.wi_resolution) != t["wi_res"].get<double>())
      r.fail("table.wi_res", "must be a whole number");
    if (spec.wi_resolution && !is_valid_resolution(*spec.wi_resolution))
      r.fail("table.wi_res",
             "must be a power of two from 2 to 512, got " + std::to_string(*spec.wi_resolution));
  }
  return spec;
}

BrdfSpec read_brdf_spec(const std::string& path) {
  const std::string text = read_text_file(path, std::size_t(1) << 20, "a BRDF spec");
  return parse_brdf_spec(text, path, std::filesystem::path(path).parent_path().string());
}

}  // namespace basis
