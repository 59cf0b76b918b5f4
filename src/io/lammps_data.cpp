// LAMMPS data files: reading atoms, masses, velocities and bonds; writing a world (lammps_data.hpp).
#include "qbond/io/lammps_data.hpp"

#include <algorithm>
#include <bit>
#include <cinttypes>
#include <cstdio>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <ostream>
#include <tuple>
#include <unordered_map>

#include "io/text_fields.hpp"
#include "qbond/laws/registry.hpp"

namespace qbond {

namespace {

using text::malformed;

/// The section keywords of the read_data format; the ones qbond does not read are skipped.
constexpr std::string_view kSections[] = {
    "Atoms", "Velocities", "Masses", "Bonds", "Angles", "Dihedrals", "Impropers", "Ellipsoids", "Lines",
    "Triangles", "Bodies", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs", "Angle Coeffs", "Dihedral Coeffs",
    "Improper Coeffs", "BondBond Coeffs", "BondAngle Coeffs", "MiddleBondTorsion Coeffs",
    "EndBondTorsion Coeffs", "AngleTorsion Coeffs", "AngleAngleTorsion Coeffs", "BondBond13 Coeffs",
    "AngleAngle Coeffs"};

/// The line without its comment ('#' to the end) and surrounding blanks.
std::string_view content(std::string_view line) { return text::trim(line.substr(0, line.find('#'))); }

/// The section a line opens, if it is a section keyword.
std::optional<std::string_view> section_of(std::string_view line) {
  const std::string_view c = content(line);
  // Keywords are single-spaced words; compare with the blanks between them normalised.
  const auto t = text::tokens(c);
  std::string joined;
  for (const auto& w : t) joined.append(joined.empty() ? "" : " ").append(w);
  for (std::string_view s : kSections)
    if (joined == s) return s;
  return std::nullopt;
}

class DataReader {
 public:
  DataReader(std::string_view text, const std::string& name, const AtomStyle* style)
      : lines_(text), name_(name), style_(style ? std::optional<AtomStyle>(*style) : std::nullopt) {}

  LammpsData read() {
    std::string_view line;
    if (!lines_.next(line)) malformed(name_, 0, "empty file: a data file starts with a title line");
    std::optional<std::string_view> section = header();
    while (section) section = read_section(*section);
    return finish();
  }

 private:
  [[noreturn]] void fail(const std::string& rule) const { malformed(name_, lines_.number(), rule); }
  long long integer(std::string_view t, const std::string& what) const {
    long long v = 0;
    if (!text::parse_long(t, v)) fail(what + " " + text::quoted(t) + " is not an integer");
    return v;
  }
  std::size_t count(std::string_view t, const std::string& what) const {
    const long long v = integer(t, what);
    if (v < 0 || v > 50'000'000) fail(what + " " + text::quoted(t) + " is not a count in [0, 5e7]");
    return static_cast<std::size_t>(v);
  }
  double number(std::string_view t, const std::string& what) const {
    double v = 0;
    if (!text::parse_double(t, v)) fail(what + " " + text::quoted(t) + " is not a finite number");
    return v;
  }

  /// The section a line opens, if any; the line is kept for its comment (`Atoms # full`).
  std::optional<std::string_view> opens(std::string_view line) {
    auto s = section_of(line);
    if (s) keyword_line_ = line;
    return s;
  }

  /// Reads the header up to the first section keyword, which it returns (none: the file ends).
  std::optional<std::string_view> header() {
    std::string_view line;
    while (lines_.next(line)) {
      if (auto s = opens(line)) return s;
      const auto t = text::tokens(content(line));
      if (t.empty()) continue;
      auto ends_with = [&](std::initializer_list<std::string_view> words) {
        return t.size() >= words.size() &&
               std::equal(words.begin(), words.end(), t.end() - static_cast<std::ptrdiff_t>(words.size()));
      };
      if (t.size() == 4 && ends_with({"xlo", "xhi"})) {
        data_.box[0] = number(t[0], "xlo"), data_.box[1] = number(t[1], "xhi");
      } else if (t.size() == 4 && ends_with({"ylo", "yhi"})) {
        data_.box[2] = number(t[0], "ylo"), data_.box[3] = number(t[1], "yhi");
      } else if (t.size() == 4 && ends_with({"zlo", "zhi"})) {
        data_.box[4] = number(t[0], "zlo"), data_.box[5] = number(t[1], "zhi");
      } else if (t.size() == 6 && ends_with({"xy", "xz", "yz"})) {
        for (int k = 0; k < 3; ++k) data_.tilt[static_cast<std::size_t>(k)] = number(t[static_cast<std::size_t>(k)], "tilt factor");
      } else if (t.size() == 2 && t[1] == "atoms") {
        atoms_ = count(t[0], "atom count");
      } else if (t.size() == 2 && t[1] == "bonds") {
        bonds_ = count(t[0], "bond count");
      } else if (t.size() == 3 && t[1] == "atom" && t[2] == "types") {
        atom_types_ = count(t[0], "atom type count");
      } else if (t.size() == 3 && t[1] == "bond" && t[2] == "types") {
        data_.bond_types = static_cast<int>(count(t[0], "bond type count"));
      } else if ((t.size() == 2 && (t[1] == "angles" || t[1] == "dihedrals" || t[1] == "impropers" ||
                                    t[1] == "ellipsoids" || t[1] == "lines" || t[1] == "triangles" || t[1] == "bodies")) ||
                 (t.size() == 3 && t[2] == "types") || (t.size() == 5 && t[1] == "extra" && t[3] == "per" && t[4] == "atom")) {
        count(t[0], "count");  // topology qbond does not read: checked, then skipped
      } else {
        fail("unknown header line " + text::quoted(content(line)) +
             " (read: N atoms, N bonds, N atom types, N bond types, xlo xhi, ylo yhi, zlo zhi, xy xz yz)");
      }
    }
    return std::nullopt;
  }

  /// The fields of the section's next entry line (blank lines skipped).
  std::vector<std::string_view> entry(std::string_view section) {
    std::string_view line;
    while (lines_.next(line)) {
      if (section_of(line)) fail("section " + std::string(section) + " ends before its last entry");
      auto t = text::tokens(content(line));
      if (!t.empty()) return t;
    }
    malformed(name_, lines_.number(), "the file ends inside section " + std::string(section));
  }

  /// Reads one section; returns the next section's keyword (none: the file ends).
  std::optional<std::string_view> read_section(std::string_view section) {
    if (!seen_.insert(std::string(section)).second) fail("section " + std::string(section) + " appears twice");
    if (section == "Masses") {
      data_.type_mass.assign(atom_types_, 0.0);
      for (std::size_t k = 0; k < atom_types_; ++k) {
        const auto t = entry(section);
        if (t.size() != 2) fail("a Masses line is: atom-type mass");
        const long long type = integer(t[0], "atom type");
        if (type < 1 || static_cast<std::size_t>(type) > atom_types_)
          fail("atom type " + std::to_string(type) + " is not in [1, " + std::to_string(atom_types_) + "]");
        const double m = number(t[1], "mass");
        if (!(m > 0)) fail("mass " + text::quoted(t[1]) + " must be > 0");
        data_.type_mass[static_cast<std::size_t>(type - 1)] = m;
      }
    } else if (section == "Atoms") {
      atoms_section();
    } else if (section == "Velocities") {
      for (std::size_t k = 0; k < atoms_; ++k) {
        const auto t = entry(section);
        if (t.size() != 4) fail("a Velocities line is: atom-ID vx vy vz");
        velocities_.push_back({integer(t[0], "atom ID"),
                               Vec3(number(t[1], "vx"), number(t[2], "vy"), number(t[3], "vz")), lines_.number()});
      }
    } else if (section == "Bonds") {
      for (std::size_t k = 0; k < bonds_; ++k) {
        const auto t = entry(section);
        if (t.size() != 4) fail("a Bonds line is: bond-ID bond-type atom1 atom2");
        integer(t[0], "bond ID");
        const long long type = integer(t[1], "bond type");
        if (type < 1 || type > data_.bond_types)
          fail("bond type " + std::to_string(type) + " is not in [1, " + std::to_string(data_.bond_types) + "]");
        bonds_read_.push_back({static_cast<int>(type), integer(t[2], "atom ID"), integer(t[3], "atom ID"), lines_.number()});
      }
    } else {
      data_.ignored.emplace_back(section);
      std::string_view line;
      while (lines_.next(line))
        if (auto s = opens(line)) return s;
      return std::nullopt;
    }
    std::string_view line;
    while (lines_.next(line)) {
      if (auto s = opens(line)) return s;
      if (!content(line).empty())
        fail("section " + std::string(section) + " has more entries than the header's count, or " +
             text::quoted(content(line)) + " is not a section keyword");
    }
    return std::nullopt;
  }

  void atoms_section() {
    AtomStyle style = AtomStyle::bond;
    if (style_) {
      style = *style_;
    } else if (const std::size_t hash = keyword_line_.find('#'); hash != std::string_view::npos) {
      const auto t = text::tokens(keyword_line_.substr(hash + 1));
      if (!t.empty()) {
        if (t[0] == "atomic") style = AtomStyle::atomic;
        else if (t[0] == "bond") style = AtomStyle::bond;
        else if (t[0] == "molecular") style = AtomStyle::molecular;
        else if (t[0] == "full") style = AtomStyle::full;
        else fail("atom style " + text::quoted(t[0]) + " is not read (accepted: atomic, bond, molecular, full)");
      }
    }
    const std::size_t at = style == AtomStyle::atomic ? 2 : style == AtomStyle::full ? 4 : 3;  // x's column
    const std::size_t type_col = style == AtomStyle::atomic ? 1 : 2;
    const char* columns = style == AtomStyle::atomic ? "atom-ID atom-type x y z"
                          : style == AtomStyle::full ? "atom-ID molecule-ID atom-type q x y z"
                                                     : "atom-ID molecule-ID atom-type x y z";
    const double lx = data_.box[1] - data_.box[0], ly = data_.box[3] - data_.box[2], lz = data_.box[5] - data_.box[4];
    for (std::size_t k = 0; k < atoms_; ++k) {
      const auto t = entry("Atoms");
      if (t.size() != at + 3 && t.size() != at + 6)
        fail(std::string("an Atoms line of this style is: ") + columns + " [ix iy iz] (" + std::to_string(t.size()) +
             " fields); give the style after the keyword (Atoms # full) or the body's atom_style");
      const long long id = integer(t[0], "atom ID");
      if (style != AtomStyle::atomic) integer(t[1], "molecule ID");
      if (style == AtomStyle::full) number(t[3], "charge");
      const long long type = integer(t[type_col], "atom type");
      if (type < 1 || static_cast<std::size_t>(type) > atom_types_)
        fail("atom type " + std::to_string(type) + " is not in [1, " + std::to_string(atom_types_) + "]");
      Vec3 x(number(t[at], "x"), number(t[at + 1], "y"), number(t[at + 2], "z"));
      if (t.size() == at + 6) {
        const long long ix = integer(t[at + 3], "image flag"), iy = integer(t[at + 4], "image flag"),
                        iz = integer(t[at + 5], "image flag");
        if (ix || iy || iz) {  // unwrap across the periodic box
          const double fx = static_cast<double>(ix), fy = static_cast<double>(iy), fz = static_cast<double>(iz);
          x += Vec3(fx * lx + fy * data_.tilt[0] + fz * data_.tilt[1], fy * ly + fz * data_.tilt[2], fz * lz);
        }
      }
      atoms_read_.push_back({id, static_cast<int>(type), x, lines_.number()});
    }
  }

  LammpsData finish() {
    if (!seen_.contains("Atoms") || atoms_ == 0) malformed(name_, 0, "no atoms (a header line 'N atoms' and an Atoms section)");
    if (!seen_.contains("Masses"))
      malformed(name_, 0, "no Masses section: qbond takes each atom's mass from its type's");
    for (std::size_t k = 0; k < atom_types_; ++k)
      if (!(data_.type_mass[k] > 0)) malformed(name_, 0, "Masses gives no mass for atom type " + std::to_string(k + 1));
    if (bonds_ > 0 && !seen_.contains("Bonds")) malformed(name_, 0, "the header says " + std::to_string(bonds_) + " bonds, but there is no Bonds section");
    std::sort(atoms_read_.begin(), atoms_read_.end(), [](const Atom& a, const Atom& b) { return a.id < b.id; });
    std::unordered_map<long long, Index> row;
    for (std::size_t k = 0; k < atoms_read_.size(); ++k) {
      const Atom& a = atoms_read_[k];
      if (!row.emplace(a.id, static_cast<Index>(k)).second)
        malformed(name_, a.line, "atom ID " + std::to_string(a.id) + " appears twice");
      data_.atom_id.push_back(a.id);
      data_.atom_type.push_back(a.type);
      data_.x.push_back(a.x);
    }
    data_.v.assign(data_.x.size(), Vec3::Zero());
    auto find = [&](long long id, std::size_t line) {
      const auto it = row.find(id);
      if (it == row.end()) malformed(name_, line, "atom ID " + std::to_string(id) + " is not in the Atoms section");
      return it->second;
    };
    for (const auto& v : velocities_) data_.v[find(v.id, v.line)] = v.v;
    for (const auto& b : bonds_read_) {
      const Index i = find(b.a, b.line), j = find(b.b, b.line);
      if (i == j) malformed(name_, b.line, "bonds atom " + std::to_string(b.a) + " to itself");
      data_.bond_type.push_back(b.type);
      data_.bond_ends.emplace_back(i, j);
    }
    return std::move(data_);
  }

  struct Atom {
    long long id;
    int type;
    Vec3 x;
    std::size_t line;
  };
  struct Velocity {
    long long id;
    Vec3 v;
    std::size_t line;
  };
  struct BondLine {
    int type;
    long long a, b;
    std::size_t line;
  };

  text::Lines lines_;
  const std::string& name_;
  std::optional<AtomStyle> style_;
  std::string_view keyword_line_;  // the last section keyword's line
  std::size_t atoms_ = 0, bonds_ = 0, atom_types_ = 0;
  std::set<std::string> seen_;
  std::vector<Atom> atoms_read_;
  std::vector<Velocity> velocities_;
  std::vector<BondLine> bonds_read_;
  LammpsData data_;
};

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

LammpsData parse_lammps_data(std::string_view text, const std::string& name, const AtomStyle* style) {
  return DataReader(text, name, style).read();
}

std::pair<std::vector<int>, int> lammps_bond_types(const World& world) {
  const Bonds& b = world.state.bonds;
  using Key = std::tuple<Law, std::uint64_t, std::uint64_t, DampingModel, std::uint32_t>;
  std::map<Key, int> types;
  std::vector<int> out;
  for (std::size_t k = 0; k < b.size(); ++k) {
    if (!b.alive[k]) continue;
    const Key key{b.law[k], std::bit_cast<std::uint64_t>(b.strength[k]), std::bit_cast<std::uint64_t>(b.damping[k]),
                  b.damping_model[k], b.shape[k]};
    out.push_back(types.emplace(key, static_cast<int>(types.size()) + 1).first->second);
  }
  return {out, static_cast<int>(types.size())};
}

void write_lammps_data(std::ostream& out, const World& world, const std::string& title) {
  const Model& m = world.model;
  const State& s = world.state;
  const Bonds& b = s.bonds;
  const std::size_t n = m.num_quanta();
  // Atoms in the order of the user's ids.
  std::vector<Index> order(n);
  std::iota(order.begin(), order.end(), Index{0});
  std::sort(order.begin(), order.end(), [&](Index p, Index q) { return m.quanta_id[p] < m.quanta_id[q]; });
  std::map<std::uint64_t, int> mass_type;
  std::vector<double> type_mass;
  std::vector<int> atom_type(n);
  for (Index i : order) {
    const auto [it, fresh] = mass_type.emplace(std::bit_cast<std::uint64_t>(m.mass[i]), static_cast<int>(type_mass.size()) + 1);
    if (fresh) type_mass.push_back(m.mass[i]);
    atom_type[i] = it->second;
  }
  const auto [bond_type, bond_types] = lammps_bond_types(world);
  Vec3 lo = Vec3::Constant(0), hi = Vec3::Constant(0);
  if (n > 0) {
    lo = hi = s.x[0];
    for (const Vec3& x : s.x) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
  }
  const double margin = std::max(0.01 * (hi - lo).maxCoeff(), 1e-3);
  out << "LAMMPS data file written by qbond: " << title << " (units si, atom_style bond)\n\n";
  out << n << " atoms\n" << bond_type.size() << " bonds\n" << type_mass.size() << " atom types\n" << bond_types
      << " bond types\n";
  // One comment per bond type: the law and parameters its bonds share (LAMMPS's input script
  // gives the matching bond_coeff).
  {
    std::map<int, std::size_t> first;
    std::size_t alive = 0;
    for (std::size_t k = 0; k < b.size(); ++k)
      if (b.alive[k]) first.emplace(bond_type[alive++], k);
    for (const auto& [type, k] : first) {
      const LawInfo& info = law_info(b.law[k]);
      out << "# bond type " << type << ": " << info.name << ", " << info.strength.key << " " << g17(b.strength[k])
          << ", damping " << g17(b.damping[k]) << " (" << (b.damping_model[k] == DampingModel::axial ? "axial" : "isotropic")
          << ")";
      for (std::size_t p = 0; p < info.shape.size(); ++p) out << ", " << info.shape[p].key << " " << g17(m.shapes[b.shape[k]][p]);
      out << "\n";
    }
  }
  out << "\n";
  out << g17(lo.x() - margin) << " " << g17(hi.x() + margin) << " xlo xhi\n";
  out << g17(lo.y() - margin) << " " << g17(hi.y() + margin) << " ylo yhi\n";
  out << g17(lo.z() - margin) << " " << g17(hi.z() + margin) << " zlo zhi\n";
  out << "\nMasses\n\n";
  for (std::size_t t = 0; t < type_mass.size(); ++t) out << t + 1 << " " << g17(type_mass[t]) << "\n";
  out << "\nAtoms # bond\n\n";
  for (Index i : order)
    out << m.quanta_id[i] + 1 << " " << m.body[i] + 1 << " " << atom_type[i] << " " << g17(s.x[i].x()) << " "
        << g17(s.x[i].y()) << " " << g17(s.x[i].z()) << "\n";
  out << "\nVelocities\n\n";
  for (Index i : order)
    out << m.quanta_id[i] + 1 << " " << g17(s.v[i].x()) << " " << g17(s.v[i].y()) << " " << g17(s.v[i].z()) << "\n";
  if (!bond_type.empty()) {
    out << "\nBonds\n\n";
    std::size_t alive = 0;
    for (std::size_t k = 0; k < b.size(); ++k)
      if (b.alive[k]) {
        out << alive + 1 << " " << bond_type[alive] << " " << m.quanta_id[b.i[k]] + 1 << " " << m.quanta_id[b.j[k]] + 1
            << "\n";
        ++alive;
      }
  }
}

}  // namespace qbond
