// Builder: the `materials` section: named bond materials.
#include "io/scene/builder.hpp"

namespace qbond::scene_detail {

void Builder::materials(const json& j, json& res) {
  if (!j.is_object()) bad("materials", "expected an object (material name -> parameters), got " + type_name(j));
  for (const auto& [name, mj] : j.items()) {
    Obj o(mj, "materials." + name,
          {"law", "stiffness", "youngs_modulus", "density", "damping", "damping_model", "eps"});
    Material m;
    BondSpec& b = m.bond;
    b.law = o.has("law") ? choice<Law>(o["law"], o.at("law"), {{"linear", Law::linear}, {"inverse", Law::inverse}})
                         : Law::linear;
    if (o.has("stiffness") == o.has("youngs_modulus"))
      bad("materials." + name, o.has("stiffness") ? "give either 'stiffness' or 'youngs_modulus', not both"
                                                  : "one of 'stiffness' or 'youngs_modulus' is required");
    if (o.has("stiffness")) b.stiffness = positive(o["stiffness"], o.at("stiffness"));
    if (o.has("youngs_modulus")) {
      if (b.law != Law::linear) bad(o.at("youngs_modulus"), "calibrates linear bonds only (law is " + std::string(to_string(b.law)) + ")");
      m.youngs_modulus = positive(o["youngs_modulus"], o.at("youngs_modulus"));
    }
    if (o.has("density")) m.density = positive(o["density"], o.at("density"));
    b.damping = o.has("damping") ? non_negative(o["damping"], o.at("damping")) : 0.0;
    b.damping_model = o.has("damping_model")
                          ? choice<DampingModel>(o["damping_model"], o.at("damping_model"),
                                                 {{"axial", DampingModel::axial}, {"isotropic", DampingModel::isotropic}})
                          : DampingModel::axial;
    if (o.has("eps")) {
      if (b.law != Law::inverse) bad(o.at("eps"), "only the inverse law has a regularisation length");
      b.eps = positive(o["eps"], o.at("eps"));
    }
    materials_[name] = m;
    json& r = res[name];
    r["law"] = to_string(b.law);
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
