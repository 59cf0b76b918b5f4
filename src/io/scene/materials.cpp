// Builder: the `materials` section: named bond materials.
#include "io/scene/builder.hpp"

#include <cmath>
#include <optional>

namespace qbond::scene_detail {

void Builder::materials(const json& j, json& res) {
  if (!j.is_object()) bad("materials", "expected an object (material name -> parameters), got " + type_name(j));
  for (const auto& [name, mj] : j.items()) {
    const std::string path = "materials." + name;
    if (annotation(name, mj, path)) continue;  // the section's own description or notes
    if (!mj.is_object()) bad(path, "expected an object, got " + type_name(mj));
    Material m;
    BondSpec& b = m.bond;
    if (mj.contains("law")) {
      std::vector<std::string> names;
      for (const LawInfo& l : all_laws()) names.emplace_back(l.name);
      const std::string s = string(mj["law"], path + ".law");
      const std::optional<Law> law = parse_law(s);
      if (!law) bad(path + ".law", "unknown value '" + s + "' (accepted: " + join(names) + ")");
      b.law = *law;
    }
    const LawInfo& info = law_info(b.law);
    const std::string law_name(info.name);
    const std::vector<std::string> keys = material_keys(info);
    // A key of another law: say whose it is.
    for (const auto& [key, v] : mj.items()) {
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) continue;
      std::vector<std::string> owners;
      for (const LawInfo& l : all_laws()) {
        bool has = l.strength.key == key || (key == "youngs_modulus" && l.calibrated_by_modulus);
        for (const LawParam& p : l.shape) has |= p.key == key;
        if (has) owners.emplace_back(l.name);
      }
      if (!owners.empty())
        bad(path + "." + key, "not a parameter of the " + law_name + " law (its keys: " + join(keys) +
                                  "; '" + key + "' belongs to: " + join(owners) + ")");
    }
    Obj o(mj, path, keys_of("material." + law_name));
    const std::string strength(info.strength.key);
    if (info.calibrated_by_modulus)
      o.one_of(strength.c_str(), "youngs_modulus");
    else
      o.required(strength.c_str());
    if (o.has(strength.c_str())) b.stiffness = positive(o[strength.c_str()], o.at(strength));
    if (o.has("youngs_modulus")) m.youngs_modulus = positive(o["youngs_modulus"], o.at("youngs_modulus"));
    for (std::size_t k = 0; k < info.shape.size(); ++k) {
      const std::string key(info.shape[k].key);
      if (o.has(key.c_str()))
        b.shape[k] = positive(o[key.c_str()], o.at(key));
      else if (info.shape[k].fallback.empty())
        bad(o.at(key), "required key missing (the " + law_name + " law's " + std::string(info.shape[k].doc) + ")");
    }
    if (const std::string_view why = info.invalid(b.shape); !why.empty()) bad(path, std::string(why));
    if (o.has("density")) m.density = positive(o["density"], o.at("density"));
    b.damping = o.has("damping") ? non_negative(o["damping"], o.at("damping")) : 0.0;
    b.damping_model = o.has("damping_model")
                          ? choice<DampingModel>(o["damping_model"], o.at("damping_model"),
                                                 {{"axial", DampingModel::axial}, {"isotropic", DampingModel::isotropic}})
                          : DampingModel::axial;
    materials_[name] = m;
    json& r = res[name];
    r["law"] = law_name;
    for (std::size_t k = 0; k < info.shape.size(); ++k)
      if (b.shape[k] != 0) r[std::string(info.shape[k].key)] = b.shape[k];
    r["damping"] = b.damping;
    r["damping_model"] = to_string(b.damping_model);
  }
}

BondSpec Builder::bond_material(const json& j, const std::string& path) {
  const Material& m = material(j, path);
  if (m.youngs_modulus > 0)
    bad(path, "material '" + j.get<std::string>() +
                  "' is given by youngs_modulus, which calibrates lattices and chains; a single bond needs 'stiffness'");
  return m.bond;
}

const Material& Builder::material(const json& j, const std::string& path) {
  const std::string name = string(j, path);
  if (auto it = materials_.find(name); it != materials_.end()) return it->second;
  std::vector<std::string> names;
  for (const auto& [k, v] : materials_) names.push_back(k);
  bad(path, "unknown material '" + name + "' (defined: " + (names.empty() ? "none" : join(names)) + ")");
}

}  // namespace qbond::scene_detail
