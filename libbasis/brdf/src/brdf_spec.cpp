#include "basis/brdf/brdf_spec.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "basis/brdf/merl.h"
#include "basis/brdf/rgl.h"
#include "basis/core/file_error.h"

namespace basis {

namespace {

using nlohmann::json;

// Errors name the spec, the line of the field (found in the text) and the field.
class SpecReader {
 public:
  SpecReader(const std::string& text, const std::string& name) : text_(text), name_(name) {}

  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw FileError(name_ + ":" + std::to_string(line_of(field)) + ": " +
                    (field.empty() ? problem : "field '" + field + "': " + problem));
  }

  int line_of(const std::string& field) const {
    if (field.empty()) return 1;
    const std::string key = "\"" + field.substr(field.rfind('.') + 1) + "\"";
    std::size_t at = text_.find(key);
    if (field.find('.') != std::string::npos) {  // nested: after the parent's key
      const std::size_t parent = text_.find("\"" + field.substr(0, field.find('.')) + "\"");
      if (parent != std::string::npos) at = text_.find(key, parent);
    }
    if (at == std::string::npos) return 1;
    return 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(at), '\n'));
  }

  double number(const json& object, const std::string& key, const std::string& path, double lo,
                double hi) const {
    if (!object.contains(key))
      fail(path, "missing (a number from " + show(lo) + " to " + show(hi) + ")");
    const json& v = object.at(key);
    if (!v.is_number()) fail(path, "must be a number, got " + std::string(v.type_name()));
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < lo || x > hi)
      fail(path, "must be from " + show(lo) + " to " + show(hi) + ", got " + show(x));
    return x;
  }

  Color color(const json& object, const std::string& key, const std::string& path, double hi,
              std::optional<Color> fallback = std::nullopt) const {
    if (!object.contains(key)) {
      if (fallback) return *fallback;
      fail(path, "missing (a number or [r, g, b] from 0 to " + show(hi) + ")");
    }
    const json& v = object.at(key);
    if (v.is_number()) {
      const double x = number(object, key, path, 0, hi);
      return {x, x, x};
    }
    if (!v.is_array() || v.size() != 3)
      fail(path, "must be a number or an array [r, g, b] of three numbers");
    Color c;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number()) fail(path, "must hold three numbers");
      c[i] = v[i].get<double>();
      if (!std::isfinite(c[i]) || c[i] < 0 || c[i] > hi)
        fail(path, "components must be from 0 to " + show(hi) + ", got " + show(c[i]));
    }
    return c;
  }

  void only(const json& object, const std::set<std::string>& allowed,
            const std::string& where) const {
    for (const auto& [key, value] : object.items())
      if (!allowed.count(key)) {
        std::string list;
        for (const std::string& a : allowed)
          list += (list.empty() ? "" : ", ") + a;
        fail(where.empty() ? key : where + "." + key,
             "unknown field (expected one of: " + list + ")");
      }
  }

  static std::string show(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }

 private:
  const std::string& text_;
  const std::string& name_;
};

}  // namespace

BrdfSpec parse_brdf_spec(const std::string& text, const std::string& name,
                         const std::string& folder) {
  SpecReader r(text, name);
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    const std::size_t at = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    const int line = 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
    std::string what = e.what();
    const std::size_t colon = what.find(": ", what.find("parse error"));
    throw FileError(name + ":" + std::to_string(line) + ": invalid JSON: " +
                    (colon == std::string::npos ? what : what.substr(colon + 2)));
  } catch (const json::out_of_range&) {
    // A number too large for a double, e.g. 1e400 (found by fuzzing).
    throw FileError(name + ": invalid JSON: a number is out of range");
  }
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
    if (file.is_relative() && !folder.empty()) file = std::filesystem::path(folder) / file;
    if (m == "merl")
      spec.brdf = std::shared_ptr<const MeasuredBrdf>(MerlBrdf::read(file.string()));
    else
      spec.brdf = std::shared_ptr<const MeasuredBrdf>(RglBrdf::read(file.string()));
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
  }
  return spec;
}

BrdfSpec read_brdf_spec(const std::string& path) {
  if (std::filesystem::is_directory(path)) throw FileError(path + ": is a directory, not a spec");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw FileError(path + ": cannot read");
  if (text.str().size() > (1 << 20)) throw FileError(path + ": larger than 1 MiB, not a BRDF spec");
  return parse_brdf_spec(text.str(), path, std::filesystem::path(path).parent_path().string());
}

}  // namespace basis
