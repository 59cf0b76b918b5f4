#pragma once
// What the readers of other programs' text files share (meshes, CSV tables, LAMMPS data): lines,
// whitespace-separated fields, strict numbers, and errors that name the file and line.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace qbond::text {

/// Throws std::runtime_error "NAME:LINE: rule" ("NAME: rule" for line 0: the whole file).
[[noreturn]] inline void malformed(const std::string& name, std::size_t line, const std::string& rule) {
  throw std::runtime_error(name + (line ? ":" + std::to_string(line) : "") + ": " + rule);
}

/// The extension of a file's name in lower case (".obj"), which says its format.
inline std::string lower_extension(const std::string& name) {
  std::string ext = std::filesystem::path(name).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

/// Whitespace-separated fields of one line.
inline std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_blank(line[i])) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

/// `t` without leading and trailing blanks.
inline std::string_view trim(std::string_view t) {
  while (!t.empty() && is_blank(t.front())) t.remove_prefix(1);
  while (!t.empty() && is_blank(t.back())) t.remove_suffix(1);
  return t;
}

/// A finite number written in full (no trailing characters; a leading '+' allowed).
inline bool parse_double(std::string_view t, double& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && std::isfinite(v);
}

/// An integer written in full (a leading '+' allowed).
inline bool parse_long(std::string_view t, long long& v) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

/// A field for a message: quoted, cut at 40 characters.
inline std::string quoted(std::string_view t) {
  std::string q = "'";  // appended piecewise: GCC 12 warns (-Wrestrict) falsely on "'" + string + ...
  q.append(t.substr(0, 40));
  q.append(t.size() > 40 ? "...'" : "'");
  return q;
}

/// The lines of a text, numbered from 1, '\r' of CRLF files included in the line (tokens and
/// trim drop it).
class Lines {
 public:
  explicit Lines(std::string_view text) : rest_(text) {}
  /// The next line, false at the end of the text.
  bool next(std::string_view& line) {
    if (rest_.empty()) return false;
    const std::size_t end = std::min(rest_.find('\n'), rest_.size());
    line = rest_.substr(0, end);
    rest_.remove_prefix(std::min(end + 1, rest_.size()));
    ++number_;
    return true;
  }
  /// The number of the line next() returned last.
  std::size_t number() const { return number_; }

 private:
  std::string_view rest_;
  std::size_t number_ = 0;
};

}  // namespace qbond::text
