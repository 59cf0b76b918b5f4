// Builder: the `heuristics` section: fracture, plasticity, obstacles, contact, formation.
#include "io/scene/builder.hpp"

#include <unordered_set>

namespace qbond::scene_detail {

std::vector<std::uint8_t> Builder::quanta_mask(const Obj& o, const World& w) {
  if (!o.has("select")) return {};
  std::vector<std::uint8_t> in(w.num_quanta(), 0);
  for (Index i : selection(o["select"], o.at("select"), w)) in[i] = 1;
  return in;
}

ContactMaterial Builder::contact_material(const Obj& o) {
  ContactMaterial c;
  if (o.has("restitution")) {
    c.restitution = non_negative(o["restitution"], o.at("restitution"));
    if (c.restitution > 1) bad(o.at("restitution"), "must be <= 1, got " + num_str(c.restitution));
  }
  if (o.has("friction")) c.friction = non_negative(o["friction"], o.at("friction"));
  if (o.has("static_friction")) {
    c.static_friction = non_negative(o["static_friction"], o.at("static_friction"));
    if (c.static_friction < c.friction)
      bad(o.at("static_friction"), "must be >= friction (" + num_str(c.friction) + "), got " + num_str(c.static_friction));
  }
  return c;
}

std::vector<HeuristicSpec> Builder::heuristics(const json& j, const World& w) {
  std::vector<HeuristicSpec> out;
  for (std::size_t k = 0; k < j.size(); ++k) {
    const std::string path = item("heuristics", k);
    if (!j[k].is_object() || !j[k].contains("type"))
      bad(path, "expected an object with a \"type\" (break, plastic, ground, plane, sphere, box, contact, form, liquid)");
    const std::string type = string(j[k]["type"], path + ".type");
    if (type == "break") {
      static const std::initializer_list<const char*> limits = {"max_strain", "max_compression", "max_tension",
                                                                "max_stress", "max_von_mises"};
      std::vector<const char*> keys(limits);
      keys.insert(keys.end(), {"type", "probability", "select"});
      Obj o(j[k], path, keys);
      BreakRule r;
      double* fields[] = {&r.max_strain, &r.max_compression, &r.max_tension, &r.max_stress, &r.max_von_mises};
      bool any = false;
      for (std::size_t f = 0; f < limits.size(); ++f) {
        const char* key = limits.begin()[f];
        if (!o.has(key)) continue;
        *fields[f] = positive(o[key], o.at(key));
        any = true;
      }
      if (!any) bad(path, "give at least one of " + join(std::vector<std::string>(limits.begin(), limits.end())));
      if ((o.has("max_stress") || o.has("max_von_mises")) &&
          std::none_of(w.model.volume.begin(), w.model.volume.end(), [](double v) { return v > 0; }))
        bad(path, "stress limits need quanta with volumes (lattice, sheet and chain bodies have them; "
                  "give 'quanta' bodies a 'volume')");
      if (o.has("probability")) {
        r.probability = positive(o["probability"], o.at("probability"));
        if (r.probability > 1) bad(o.at("probability"), "must be <= 1, got " + num_str(r.probability));
      }
      r.quanta = quanta_mask(o, w);
      out.emplace_back(std::move(r));
    } else if (type == "plastic") {
      Obj o(j[k], path, {"type", "yield_strain", "hardening", "max_plastic_strain", "select"});
      PlasticRule r;
      r.yield_strain = positive(o.required("yield_strain"), o.at("yield_strain"));
      if (o.has("hardening")) {
        r.hardening = non_negative(o["hardening"], o.at("hardening"));
        if (r.hardening >= 1) bad(o.at("hardening"), "must be < 1, got " + num_str(r.hardening));
      }
      if (o.has("max_plastic_strain")) r.max_plastic_strain = positive(o["max_plastic_strain"], o.at("max_plastic_strain"));
      r.quanta = quanta_mask(o, w);
      out.emplace_back(std::move(r));
    } else if (type == "ground" || type == "plane" || type == "sphere" || type == "box") {
      static const std::initializer_list<const char*> common = {"type", "restitution", "friction", "margin",
                                                                 "static_friction", "method", "penalty"};
      std::vector<const char*> keys(common);
      if (type == "ground") keys.push_back("height");
      if (type == "plane") keys.insert(keys.end(), {"point", "normal"});
      if (type == "sphere") keys.insert(keys.end(), {"center", "radius"});
      if (type == "box") keys.insert(keys.end(), {"center", "size", "rotation"});
      if (type == "sphere" || type == "box") keys.push_back("inside");
      Obj o(j[k], path, keys);
      Obstacle ob;
      ob.material = contact_material(o);
      if (o.has("margin")) ob.margin = non_negative(o["margin"], o.at("margin"));
      if (type == "ground") {
        ob.center = Vec3(0, 0, o.has("height") ? number(o["height"], o.at("height")) : 0.0);
      } else if (type == "plane") {
        ob.center = vec3(o.required("point"), o.at("point"));
        ob.normal = direction(o.required("normal"), o.at("normal"));
      } else if (type == "sphere") {
        ob.shape = Obstacle::Shape::sphere;
        ob.center = vec3(o.required("center"), o.at("center"));
        ob.radius = positive(o.required("radius"), o.at("radius"));
      } else {
        ob.shape = Obstacle::Shape::box;
        ob.center = vec3(o.required("center"), o.at("center"));
        const Vec3 size = vec3(o.required("size"), o.at("size"));
        if (!(size.minCoeff() > 0)) bad(o.at("size"), "every edge must be > 0");
        ob.half_extents = 0.5 * size;
        if (o.has("rotation")) {
          Obj r(o["rotation"], o.at("rotation"), {"axis", "angle"});
          ob.rotation = Eigen::AngleAxisd(number(r.required("angle"), r.at("angle")),
                                          direction(r.required("axis"), r.at("axis")))
                            .toRotationMatrix();
        }
      }
      if (o.has("inside")) {
        ob.inside = boolean(o["inside"], o.at("inside"));
        const double room = ob.shape == Obstacle::Shape::sphere ? ob.radius : ob.half_extents.minCoeff();
        if (ob.inside && !(ob.margin < room))
          bad(o.at("margin"), "must be below the container's " + std::string(ob.shape == Obstacle::Shape::sphere ? "radius" : "half size") +
                                  " " + num_str(room) + " m, or no quanta fits inside");
      }
      if (o.has("method"))
        ob.method = choice<ContactMethod>(o["method"], o.at("method"),
                                          {{"projection", ContactMethod::projection},
                                           {"implicit", ContactMethod::implicit}});
      if (o.has("penalty")) ob.penalty = positive(o["penalty"], o.at("penalty"));
      if (ob.method == ContactMethod::implicit) {
        if (integrator_.type != IntegratorType::coupled_implicit)
          bad(o.at("method"), "'implicit' contact is solved by the coupled_implicit integrator, not " +
                                  std::string(to_string(integrator_.type)) + " (use \"projection\")");
        out.emplace_back(ob);
        continue;
      }
      if (o.has("static_friction") || o.has("penalty"))
        bad(path, "static_friction and penalty are keys of \"method\": \"implicit\" obstacles");
      // Every obstacle records the impulse it gives (diagnostics' obstacle<k>_ columns).
      ob.record = static_cast<std::int32_t>(obstacles_++);
      out.emplace_back(ob);
    } else if (type == "contact") {
      Obj o(j[k], path, {"type", "radius", "restitution", "friction", "iterations", "same_body"});
      QuantaContactRule r;
      r.radius = positive(o.required("radius"), o.at("radius"));
      r.material = contact_material(o);
      if (o.has("iterations")) r.iterations = static_cast<int>(integer(o["iterations"], o.at("iterations"), 1));
      if (o.has("same_body")) r.same_body = boolean(o["same_body"], o.at("same_body"));
      check_contact_radius(r, o, w);
      out.emplace_back(r);
    } else if (type == "form") {
      Obj o(j[k], path, {"type", "capture_radius", "pairs", "max_bonds", "min_age", "rest_length", "material", "select"});
      FormRule r;
      r.capture_radius = positive(o.required("capture_radius"), o.at("capture_radius"));
      if (o.has("pairs"))
        r.pairs = choice<FormPairs>(o["pairs"], o.at("pairs"),
                                    {{"any", FormPairs::any},
                                     {"same_body", FormPairs::same_body},
                                     {"other_body", FormPairs::other_body}});
      if (o.has("max_bonds")) r.max_bonds = static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1));
      if (o.has("min_age")) r.min_age = non_negative(o["min_age"], o.at("min_age"));
      if (o.has("rest_length")) r.rest_length = positive(o["rest_length"], o.at("rest_length"));
      r.bond = bond_material(o.required("material"), o.at("material"));
      r.quanta = quanta_mask(o, w);
      out.emplace_back(std::move(r));
    } else if (type == "liquid") {
      // A preset: bonds break past max_strain and form again within the capture radius, at the
      // rest length `spacing` the liquid keeps between its quanta (its density).
      Obj o(j[k], path, {"type", "spacing", "max_strain", "capture_radius", "max_bonds", "material", "select"});
      const double a = positive(o.required("spacing"), o.at("spacing"));
      BreakRule br;
      br.max_strain = o.has("max_strain") ? positive(o["max_strain"], o.at("max_strain")) : 0.3;
      FormRule fr;
      fr.capture_radius = o.has("capture_radius") ? positive(o["capture_radius"], o.at("capture_radius")) : 1.2 * a;
      if (fr.capture_radius >= a * (1 + br.max_strain))
        bad(o.at("capture_radius"), "must be below spacing x (1 + max_strain) = " + num_str(a * (1 + br.max_strain)) +
                                        " m, or new bonds would break at once");
      fr.max_bonds = o.has("max_bonds") ? static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1)) : 12;
      fr.rest_length = a;
      fr.bond = bond_material(o.required("material"), o.at("material"));
      br.quanta = fr.quanta = quanta_mask(o, w);
      out.emplace_back(std::move(br));
      out.emplace_back(std::move(fr));
    } else {
      bad(path + ".type", "unknown heuristic '" + type +
                              "' (accepted: break, plastic, ground, plane, sphere, box, contact, form, liquid)");
    }
  }
  return out;
}

void Builder::check_contact_radius(const QuantaContactRule& r, const Obj& o, const World& w) {
  std::unordered_set<std::uint64_t> bonded;
  for (std::size_t b = 0; b < w.num_bonds(); ++b) bonded.insert(pair_key(w.state.bonds.i[b], w.state.bonds.j[b]));
  for (const auto& [a, b] : pairs_within_radius(w.state.x, 2 * r.radius)) {
    if (bonded.count(pair_key(a, b))) continue;
    if (!r.same_body && w.model.body[a] == w.model.body[b]) continue;
    if (w.model.is_kinematic(a) && w.model.is_kinematic(b)) continue;
    const double d = (w.state.x[a] - w.state.x[b]).norm();
    if (d < 2 * r.radius)
      bad(o.at("radius"), "2 x radius = " + num_str(2 * r.radius) + " m exceeds the distance " + num_str(d) +
                              " m of quanta " + std::to_string(a) + " and " + std::to_string(b) +
                              ", which share no bond: they would be pushed apart at once");
  }
}

}  // namespace qbond::scene_detail
