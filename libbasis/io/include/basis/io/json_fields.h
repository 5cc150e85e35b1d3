// Reading the fields of small JSON files (BRDF specs, scene files) with errors that name the
// file, the line of the field and the field: "PATH:LINE: field 'camera.fov': problem".
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

#include "basis/core/color.h"
#include "basis/core/file_error.h"

namespace basis {

class JsonFields {
 public:
  // `text` is the file's contents and `name` its path in errors; both must outlive the reader.
  JsonFields(const std::string& text, const std::string& name) : text_(text), name_(name) {}

  // The text parsed; a syntax error is a FileError naming its line.
  nlohmann::json parse() const;

  // Throws FileError "NAME:LINE: field 'FIELD': problem" (no field: "NAME:1: problem").
  [[noreturn]] void fail(const std::string& field, const std::string& problem) const;
  // The line where a field's key appears ("a.b": key b after key a), 1 when not found.
  int line_of(const std::string& field) const;

  // object[key], a finite number in [lo, hi]; `path` names the field in errors.
  double number(const nlohmann::json& object, const std::string& key, const std::string& path,
                double lo, double hi) const;
  // object[key], a number (grey) or [r, g, b], each in [0, hi]; fallback when absent, if given.
  Color color(const nlohmann::json& object, const std::string& key, const std::string& path,
              double hi, std::optional<Color> fallback = std::nullopt) const;
  // object[key], a string.
  std::string string(const nlohmann::json& object, const std::string& key,
                     const std::string& path) const;
  // Fails on any key of `object` not in `allowed` (`where` names the object, "" for the root).
  void only(const nlohmann::json& object, const std::set<std::string>& allowed,
            const std::string& where) const;

  static std::string show(double x);

 private:
  const std::string& text_;
  const std::string& name_;
};

}  // namespace basis
