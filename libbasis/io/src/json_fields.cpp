#include "basis/io/json_fields.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "basis/core/file_error.h"

namespace basis {

using nlohmann::json;

json JsonFields::parse() const {
  // The parser takes a NUL byte for the end of its input and would ignore what follows.
  if (const std::size_t nul = text_.find('\0'); nul != std::string::npos) {
    const int line = 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(nul), '\n'));
    throw FileError(name_ + ":" + std::to_string(line) + ": invalid JSON: a NUL byte");
  }
  try {
    // A key given twice in one object is refused: the parser would keep the last silently.
    std::vector<std::set<std::string>> keys;  // of each object being read, outermost first
    std::string repeated;
    auto check_keys = [&](int, json::parse_event_t event, json& parsed) {
      if (event == json::parse_event_t::object_start) keys.emplace_back();
      if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
      if (event == json::parse_event_t::key && !keys.empty() &&
          !keys.back().insert(parsed.get<std::string>()).second && repeated.empty())
        repeated = parsed.get<std::string>();
      return true;
    };
    json parsed = json::parse(text_, check_keys);
    if (!repeated.empty())
      throw FileError(name_ + ": invalid JSON: key '" + repeated + "' given twice in one object");
    return parsed;
  } catch (const json::parse_error& e) {
    const std::size_t at = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text_.size());
    const int line = 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(at), '\n'));
    std::string what = e.what();
    const std::size_t colon = what.find(": ", what.find("parse error"));
    throw FileError(name_ + ":" + std::to_string(line) + ": invalid JSON: " +
                    (colon == std::string::npos ? what : what.substr(colon + 2)));
  } catch (const json::out_of_range&) {
    // A number too large for a double, e.g. 1e400 (found by fuzzing).
    throw FileError(name_ + ": invalid JSON: a number is out of range");
  }
}

void JsonFields::fail(const std::string& field, const std::string& problem) const {
  throw FileError(name_ + ":" + std::to_string(line_of(field)) + ": " +
                  (field.empty() ? problem : "field '" + field + "': " + problem));
}

namespace {

std::string json_key(const std::string& key) {
  std::string q;
  q.reserve(key.size() + 2);
  q += '"';
  q += key;
  q += '"';
  return q;
}

}  // namespace

int JsonFields::line_of(const std::string& field) const {
  if (field.empty()) return 1;
  const std::string key = json_key(field.substr(field.rfind('.') + 1));
  std::size_t at = text_.find(key);
  if (field.find('.') != std::string::npos) {  // nested: after the parent's key
    std::string parent = field.substr(0, field.find('.'));
    // An element of an array, "parent[k].key": the (k + 1)-th such key after the parent's.
    int element = 0;
    if (const std::size_t open = parent.find('['); open != std::string::npos) {
      element = std::atoi(parent.c_str() + open + 1);
      parent = parent.substr(0, open);
    }
    const std::size_t from = text_.find(json_key(parent));
    if (from != std::string::npos) {
      at = text_.find(key, from);
      for (int k = 0; k < element && at != std::string::npos; ++k)
        at = text_.find(key, at + key.size());
    }
  }
  if (at == std::string::npos) return 1;
  return 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(at), '\n'));
}

double JsonFields::number(const json& object, const std::string& key, const std::string& path,
                          double lo, double hi) const {
  if (!object.contains(key))
    fail(path, "missing (a number from " + show(lo) + " to " + show(hi) + ")");
  const json& v = object.at(key);
  if (!v.is_number()) fail(path, "must be a number, got " + std::string(v.type_name()));
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi)
    fail(path, "must be from " + show(lo) + " to " + show(hi) + ", got " + show(x));
  return x;
}

Color JsonFields::color(const json& object, const std::string& key, const std::string& path,
                        double hi, std::optional<Color> fallback) const {
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

std::string JsonFields::string(const json& object, const std::string& key,
                               const std::string& path) const {
  if (!object.contains(key)) fail(path, "missing (a string)");
  if (!object.at(key).is_string())
    fail(path, "must be a string, got " + std::string(object.at(key).type_name()));
  return object.at(key).get<std::string>();
}

void JsonFields::only(const json& object, const std::set<std::string>& allowed,
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

std::string JsonFields::show(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

}  // namespace basis
