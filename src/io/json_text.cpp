#include "qbond/io/json_text.hpp"

#include <optional>
#include <unordered_set>
#include <vector>

namespace qbond {
namespace {

using json = nlohmann::json;

// The streaming check: tracks where it is (for the message) and stops at the first error.
class Checker : public nlohmann::json_sax<json> {
 public:
  explicit Checker(std::size_t max_depth) : max_depth_(max_depth) {}

  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return open(false); }
  bool start_array(std::size_t) override { return open(true); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    Level& l = stack_.back();
    l.key = k;
    l.has_key = true;
    if (!l.keys.insert(k).second) return fail("duplicate key (JSON would silently keep only the last one)");
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
    // "[json.exception.parse_error.101] parse error at line 1, column 4: ..." without the tag.
    std::string what = e.what();
    if (const auto end = what.find("] "); what.starts_with("[json.exception.") && end != std::string::npos)
      what.erase(0, end + 2);
    return fail("invalid JSON: " + what);
  }

  const std::optional<JsonTextError>& error() const { return error_; }

 private:
  struct Level {
    explicit Level(bool a) : array(a) {}
    bool array;
    std::size_t index = 0;
    bool has_key = false;
    std::string key;
    std::unordered_set<std::string> keys;
  };

  std::string path() const {
    std::string p;
    for (const Level& l : stack_) {
      if (l.array) {
        p.push_back('[');
        p.append(std::to_string(l.index));
        p.push_back(']');
      } else if (l.has_key) {
        if (!p.empty()) p.push_back('.');
        p.append(l.key);
      }
    }
    return p;
  }
  bool fail(std::string rule) {
    if (!error_) error_.emplace(path(), std::move(rule));
    return false;
  }
  bool value() {
    if (!stack_.empty() && stack_.back().array) ++stack_.back().index;
    return true;
  }
  bool open(bool array) {
    if (stack_.size() >= max_depth_)
      return fail("invalid JSON: nested deeper than " + std::to_string(max_depth_) + " arrays and objects");
    stack_.emplace_back(array);
    return true;
  }
  bool close() {
    stack_.pop_back();
    return value();
  }

  std::size_t max_depth_;
  std::vector<Level> stack_;
  std::optional<JsonTextError> error_;
};

}  // namespace

json parse_json_strict(std::string_view text, std::size_t max_depth, bool comments) {
  Checker checker(max_depth);
  const bool ok = json::sax_parse(text, &checker, json::input_format_t::json, /*strict=*/true, comments);
  if (checker.error()) throw *checker.error();
  if (!ok) throw JsonTextError("", "invalid JSON");
  return json::parse(text, nullptr, /*allow_exceptions=*/true, comments);
}

}  // namespace qbond
