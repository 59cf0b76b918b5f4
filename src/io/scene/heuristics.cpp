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

// The heuristic types of the `heuristics` section, one row each: its type, what it does, the
// keys it accepts (in the order error messages list them) and its reader. Adding a heuristic type
// to scenes is one row here; heuristic_types() and the docs test read this table.
std::span<const Builder::HeuristicReader> Builder::heuristic_readers() {
  using Keys = std::vector<SceneKey>;
  static const Keys obstacle_keys = {{"type", "string"},          {"restitution", "number"},
                                     {"friction", "number"},      {"margin", "number"},
                                     {"static_friction", "number"}, {"method", "enum:projection|implicit"},
                                     {"penalty", "number"}};
  auto with = [](Keys keys, std::initializer_list<SceneKey> more) {
    keys.insert(keys.end(), more);
    return keys;
  };
  static const HeuristicReader rows[] = {
      {"break", "fracture: bonds break past a strain, compression, tension or stress limit",
       {{"max_strain", "number"},
        {"max_compression", "number"},
        {"max_tension", "number"},
        {"max_stress", "number"},
        {"max_von_mises", "number"},
        {"type", "string"},
        {"probability", "number"},
        {"select", "@selection"}},
       [](Builder& b, const Obj& o, std::string_view, const World& w, std::vector<HeuristicSpec>& out) {
         static const std::initializer_list<const char*> limits = {"max_strain", "max_compression", "max_tension",
                                                                   "max_stress", "max_von_mises"};
         BreakRule r;
         double* fields[] = {&r.max_strain, &r.max_compression, &r.max_tension, &r.max_stress, &r.max_von_mises};
         bool any = false;
         for (std::size_t f = 0; f < limits.size(); ++f) {
           const char* key = limits.begin()[f];
           if (!o.has(key)) continue;
           *fields[f] = positive(o[key], o.at(key));
           any = true;
         }
         if (!any) bad(o.path(), "give at least one of " + join(std::vector<std::string>(limits.begin(), limits.end())));
         if ((o.has("max_stress") || o.has("max_von_mises")) &&
             std::none_of(w.model.volume.begin(), w.model.volume.end(), [](double v) { return v > 0; }))
           bad(o.path(), "stress limits need quanta with volumes (lattice, sheet and chain bodies have them; "
                         "give 'quanta' bodies a 'volume')");
         if (o.has("probability")) {
           r.probability = positive(o["probability"], o.at("probability"));
           if (r.probability > 1) bad(o.at("probability"), "must be <= 1, got " + num_str(r.probability));
         }
         r.quanta = b.quanta_mask(o, w);
         out.emplace_back(std::move(r));
       }},
      {"plastic", "plasticity: bilinear elastoplastic bonds with kinematic hardening",
       {{"type", "string"},
        {"yield_strain", "number"},
        {"hardening", "number"},
        {"max_plastic_strain", "number"},
        {"select", "@selection"}},
       [](Builder& b, const Obj& o, std::string_view, const World& w, std::vector<HeuristicSpec>& out) {
         PlasticRule r;
         r.yield_strain = positive(o.required("yield_strain"), o.at("yield_strain"));
         if (o.has("hardening")) {
           r.hardening = non_negative(o["hardening"], o.at("hardening"));
           if (r.hardening >= 1) bad(o.at("hardening"), "must be < 1, got " + num_str(r.hardening));
         }
         if (o.has("max_plastic_strain"))
           r.max_plastic_strain = positive(o["max_plastic_strain"], o.at("max_plastic_strain"));
         r.quanta = b.quanta_mask(o, w);
         out.emplace_back(std::move(r));
       }},
      {"ground", "an obstacle: the plane z = height", with(obstacle_keys, {{"height", "number"}}), &Builder::obstacle},
      {"plane", "an obstacle: a plane through a point", with(obstacle_keys, {{"point", "vec3"}, {"normal", "vec3"}}), &Builder::obstacle},
      {"sphere", "an obstacle, or a container with inside: true",
       with(obstacle_keys, {{"center", "vec3"}, {"radius", "number"}, {"inside", "boolean"}}), &Builder::obstacle},
      {"box", "an obstacle, or a container with inside: true",
       with(obstacle_keys, {{"center", "vec3"}, {"size", "vec3"}, {"rotation", "@rotation"}, {"inside", "boolean"}}), &Builder::obstacle},
      {"contact", "quanta-quanta collisions between quanta that share no bond",
       {{"type", "string"},
        {"radius", "number"},
        {"restitution", "number"},
        {"friction", "number"},
        {"iterations", "integer"},
        {"same_body", "boolean"},
        {"static_friction", "number"},
        {"method", "enum:projection|implicit"},
        {"penalty", "number"}},
       [](Builder& b, const Obj& o, std::string_view, const World& w, std::vector<HeuristicSpec>& out) {
         QuantaContactRule r;
         r.radius = positive(o.required("radius"), o.at("radius"));
         r.material = b.contact_material(o);
         if (o.has("iterations")) r.iterations = static_cast<int>(integer(o["iterations"], o.at("iterations"), 1));
         if (o.has("same_body")) r.same_body = boolean(o["same_body"], o.at("same_body"));
         if (o.has("method"))
           r.method = choice<ContactMethod>(o["method"], o.at("method"),
                                            {{"projection", ContactMethod::projection}, {"implicit", ContactMethod::implicit}});
         if (o.has("penalty")) r.penalty = positive(o["penalty"], o.at("penalty"));
         if (r.method == ContactMethod::implicit) {
           if (b.integrator_.type != IntegratorType::coupled_implicit)
             bad(o.at("method"), "'implicit' contact is solved by the coupled_implicit integrator, not " +
                                     std::string(to_string(b.integrator_.type)) + " (use \"projection\")");
           if (o.has("iterations")) bad(o.at("iterations"), "is a key of \"method\": \"projection\" contact");
         } else if (o.has("static_friction") || o.has("penalty")) {
           bad(o.path(), "static_friction and penalty are keys of \"method\": \"implicit\" contact");
         }
         b.check_contact_radius(r, o, w);
         out.emplace_back(r);
       }},
      {"form", "bond formation: quanta that come close bond",
       {{"type", "string"},
        {"capture_radius", "number"},
        {"pairs", "enum:any|same_body|other_body"},
        {"max_bonds", "integer"},
        {"min_age", "number"},
        {"rest_length", "number"},
        {"material", "string"},
        {"select", "@selection"}},
       [](Builder& b, const Obj& o, std::string_view, const World& w, std::vector<HeuristicSpec>& out) {
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
         r.bond = b.bond_material(o.required("material"), o.at("material"));
         r.quanta = b.quanta_mask(o, w);
         out.emplace_back(std::move(r));
       }},
      {"liquid", "a cohesive liquid: a break rule and a form rule at the liquid's spacing",
       {{"type", "string"},
        {"spacing", "number"},
        {"max_strain", "number"},
        {"capture_radius", "number"},
        {"max_bonds", "integer"},
        {"material", "string"},
        {"select", "@selection"}},
       [](Builder& b, const Obj& o, std::string_view, const World& w, std::vector<HeuristicSpec>& out) {
         // A preset: bonds break past max_strain and form again within the capture radius, at the
         // rest length `spacing` the liquid keeps between its quanta (its density).
         const double a = positive(o.required("spacing"), o.at("spacing"));
         BreakRule br;
         br.max_strain = o.has("max_strain") ? positive(o["max_strain"], o.at("max_strain")) : 0.3;
         FormRule fr;
         fr.capture_radius = o.has("capture_radius") ? positive(o["capture_radius"], o.at("capture_radius")) : 1.2 * a;
         if (fr.capture_radius >= a * (1 + br.max_strain))
           bad(o.at("capture_radius"), "must be below spacing x (1 + max_strain) = " +
                                           num_str(a * (1 + br.max_strain)) + " m, or new bonds would break at once");
         fr.max_bonds = o.has("max_bonds") ? static_cast<int>(integer(o["max_bonds"], o.at("max_bonds"), 1)) : 12;
         fr.rest_length = a;
         fr.bond = b.bond_material(o.required("material"), o.at("material"));
         br.quanta = fr.quanta = b.quanta_mask(o, w);
         out.emplace_back(std::move(br));
         out.emplace_back(std::move(fr));
       }},
  };
  return rows;
}

void Builder::obstacle(Builder& b, const Obj& o, std::string_view type, const World&, std::vector<HeuristicSpec>& out) {
  Obstacle ob;
  ob.material = b.contact_material(o);
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
      Obj r(o["rotation"], o.at("rotation"), keys_of("rotation"));
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
                                      {{"projection", ContactMethod::projection}, {"implicit", ContactMethod::implicit}});
  if (o.has("penalty")) ob.penalty = positive(o["penalty"], o.at("penalty"));
  if (ob.method == ContactMethod::implicit) {
    if (b.integrator_.type != IntegratorType::coupled_implicit)
      bad(o.at("method"), "'implicit' contact is solved by the coupled_implicit integrator, not " +
                              std::string(to_string(b.integrator_.type)) + " (use \"projection\")");
    out.emplace_back(ob);
    return;
  }
  if (o.has("static_friction") || o.has("penalty"))
    bad(o.path(), "static_friction and penalty are keys of \"method\": \"implicit\" obstacles");
  // Every obstacle records the impulse it gives (diagnostics' obstacle<k>_ columns).
  ob.record = static_cast<std::int32_t>(b.obstacles_++);
  out.emplace_back(ob);
}

std::vector<HeuristicSpec> Builder::heuristics(const json& j, const World& w) {
  std::vector<std::string> types;
  for (const HeuristicReader& r : heuristic_readers()) types.emplace_back(r.type);
  std::vector<HeuristicSpec> out;
  for (std::size_t k = 0; k < j.size(); ++k) {
    const std::string path = item("heuristics", k);
    if (!j[k].is_object() || !j[k].contains("type"))
      bad(path, "expected an object with a \"type\" (" + join(types) + ")");
    const std::string type = string(j[k]["type"], path + ".type");
    const auto rows = heuristic_readers();
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const HeuristicReader& r) { return type == r.type; });
    if (row == rows.end()) bad(path + ".type", "unknown heuristic '" + type + "' (accepted: " + join(types) + ")");
    row->read(*this, Obj(j[k], path, keys_of("heuristic." + type)), type, w, out);
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

namespace qbond {

const std::vector<SceneType>& heuristic_types() {
  static const std::vector<SceneType> types = scene_detail::Builder::scene_types(scene_detail::Builder::heuristic_readers());
  return types;
}

}  // namespace qbond
