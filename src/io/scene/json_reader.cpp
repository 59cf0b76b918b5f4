#include "io/scene/json_reader.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace qbond::scene_detail {

[[noreturn]] void bad(const std::string& path, const std::string& rule) { throw Bad{path, rule}; }

std::string num_str(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string type_name(const json& j) {
  if (j.is_number()) return "a number";
  if (j.is_boolean()) return "a boolean";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  return "null";
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

double number(const json& j, const std::string& path) {
  if (!j.is_number()) bad(path, "expected a number, got " + type_name(j));
  const double v = j.get<double>();
  if (!std::isfinite(v)) bad(path, "must be finite");
  return v;
}

double positive(const json& j, const std::string& path) {
  const double v = number(j, path);
  if (!(v > 0)) bad(path, "must be > 0, got " + num_str(v));
  return v;
}

double non_negative(const json& j, const std::string& path) {
  const double v = number(j, path);
  if (v < 0) bad(path, "must be >= 0, got " + num_str(v));
  return v;
}

std::uint64_t integer(const json& j, const std::string& path, std::int64_t min) {
  if (!j.is_number_integer()) bad(path, "expected an integer, got " + (j.is_number() ? "a fractional number" : type_name(j)));
  if (j.is_number_unsigned()) {
    const auto v = j.get<std::uint64_t>();
    if (min > 0 && v < static_cast<std::uint64_t>(min)) bad(path, "must be >= " + std::to_string(min) + ", got " + std::to_string(v));
    return v;
  }
  const auto v = j.get<std::int64_t>();
  if (v < min) bad(path, "must be >= " + std::to_string(min) + ", got " + std::to_string(v));
  return static_cast<std::uint64_t>(v);
}

bool boolean(const json& j, const std::string& path) {
  if (!j.is_boolean()) bad(path, "expected true or false, got " + type_name(j));
  return j.get<bool>();
}

std::string string(const json& j, const std::string& path) {
  if (!j.is_string()) bad(path, "expected a string, got " + type_name(j));
  return j.get<std::string>();
}

Vec3 vec3(const json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) bad(path, "expected an array of 3 numbers, got " + (j.is_array() ? "an array of " + std::to_string(j.size()) : type_name(j)));
  return {number(j[0], path + "[0]"), number(j[1], path + "[1]"), number(j[2], path + "[2]")};
}

Vec3 direction(const json& j, const std::string& path) {
  const Vec3 v = vec3(j, path);
  if (!(v.norm() > 0)) bad(path, "must be a non-zero vector");
  return v.normalized();
}

const json& array(const json& j, const std::string& path) {
  if (!j.is_array()) bad(path, "expected an array, got " + type_name(j));
  return j;
}

bool annotation(const std::string& key, const json& value, const std::string& path) {
  if (key != "description" && key != "notes") return false;
  const bool text = value.is_string() ||
                    (value.is_array() &&
                     std::all_of(value.begin(), value.end(), [](const json& v) { return v.is_string(); }));
  if (!text) bad(path, "expected a string or an array of strings, got " + type_name(value));
  return true;
}

std::string item(const std::string& path, std::size_t k) { return path + "[" + std::to_string(k) + "]"; }

}  // namespace qbond::scene_detail
