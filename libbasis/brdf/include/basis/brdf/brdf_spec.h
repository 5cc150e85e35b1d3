// BRDF specs: JSON files naming a model and its parameters, with optional table settings.
//   {"model": "phong", "kd": [0.5, 0.5, 0.5], "ks": 0.4, "exponent": 100,
//    "table": {"wo_res": 16, "wi_res": 64, "tolerance": 0.05}}
#pragma once

#include <optional>
#include <string>

#include "basis/brdf/brdf.h"
#include "basis/core/file_error.h"

namespace basis {

struct BrdfSpec {
  Brdf brdf;
  std::string model;      // as written in the spec
  std::string text;       // the spec file's contents
  std::string data_file;  // a measured model's data file, as read (empty for analytic models)
  // Optional "table" block.
  std::optional<int> wo_resolution;
  std::optional<int> wi_resolution;
  std::optional<double> tolerance;
};

// Reads and validates a spec file. Models and fields (colours are [r, g, b] or one number):
//   lambert: albedo            phong, blinn-phong: kd, ks, exponent
//   ward: kd, ks, alpha        ggx: kd, f0, alpha
//   merl: file (a MERL binary), rgl: file (an RGL .bsdf tensor file); relative to the spec's
//   folder
// Every error is a FileError "PATH:LINE: problem" naming the field.
BrdfSpec read_brdf_spec(const std::string& path);

// Same from text already in memory; `name` stands for the file in errors and `folder` resolves
// relative data paths.
BrdfSpec parse_brdf_spec(const std::string& text, const std::string& name,
                         const std::string& folder);

}  // namespace basis
