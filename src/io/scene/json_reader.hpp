#pragma once
// Strict JSON reading for scene files: each helper reads one value at a JSON path (for the
// message) and throws Bad, naming the path and the rule broken, when the value breaks the rule;
// parse_scene turns Bad into a SceneError. Obj also refuses keys it does not know.
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "qbond/core/math.hpp"

namespace qbond::scene_detail {

using json = nlohmann::json;

/// Thrown inside the parser; parse_scene adds the source name.
struct Bad {
  std::string path, rule;
};
[[noreturn]] void bad(const std::string& path, const std::string& rule);

std::string num_str(double v);

std::string type_name(const json& j);

std::string join(const std::vector<std::string>& v);

double number(const json& j, const std::string& path);
double positive(const json& j, const std::string& path);
double non_negative(const json& j, const std::string& path);
std::uint64_t integer(const json& j, const std::string& path, std::int64_t min);
bool boolean(const json& j, const std::string& path);
std::string string(const json& j, const std::string& path);
Vec3 vec3(const json& j, const std::string& path);
Vec3 direction(const json& j, const std::string& path);
const json& array(const json& j, const std::string& path);
/// One of a fixed set of names.
template <class T>
T choice(const json& j, const std::string& path, std::initializer_list<std::pair<const char*, T>> names) {
  const std::string s = string(j, path);
  std::vector<std::string> all;
  for (const auto& [n, v] : names) {
    if (s == n) return v;
    all.emplace_back(n);
  }
  bad(path, "unknown value '" + s + "' (accepted: " + join(all) + ")");
}

/// Whether `key` is one of the free annotations every object takes, `description` and `notes`
/// (a string or an array of strings, which qbond keeps but does not read); Bad when its value is
/// neither.
bool annotation(const std::string& key, const json& value, const std::string& path);

/// An object whose keys are checked against the accepted ones (and the annotations).
class Obj {
 public:
  Obj(const json& j, std::string path, std::initializer_list<const char*> keys)
      : Obj(j, std::move(path), std::vector<const char*>(keys)) {}
  Obj(const json& j, std::string path, const std::vector<const char*>& keys) : j_(j), path_(std::move(path)) {
    if (!j.is_object()) bad(path_, "expected an object, got " + type_name(j));
    for (const auto& item : j.items()) {
      const std::string& k = item.key();
      if (std::find_if(keys.begin(), keys.end(), [&](const char* a) { return k == a; }) == keys.end() &&
          annotation(k, item.value(), at(k)))
        continue;
      if (std::find_if(keys.begin(), keys.end(), [&](const char* a) { return k == a; }) == keys.end()) {
        std::vector<std::string> all(keys.begin(), keys.end());
        bad(at(k), "unknown key (accepted: " + join(all) + ")");
      }
    }
  }
  bool has(const char* k) const { return j_.contains(k); }
  const json& operator[](const char* k) const { return j_.at(k); }
  const json& required(const char* k) const {
    if (!has(k)) bad(at(k), "required key missing");
    return j_.at(k);
  }
  std::string at(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  const std::string& path() const { return path_; }
  /// Exactly one of two keys; returns whether it is the first.
  bool one_of(const char* a, const char* b) const {
    if (has(a) == has(b))
      bad(path_.empty() ? std::string(a) : path_, has(a) ? std::string("give either '") + a + "' or '" + b + "', not both"
                                                       : std::string("one of '") + a + "' or '" + b + "' is required");
    return has(a);
  }

 private:
  const json& j_;
  std::string path_;
};

std::string item(const std::string& path, std::size_t k);

}  // namespace qbond::scene_detail
