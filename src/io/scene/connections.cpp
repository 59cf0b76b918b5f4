// Builder: selections, and the `bonds`, `anchors` and `loads` sections.
#include "io/scene/builder.hpp"

#include <cmath>
#include <unordered_map>
#include <unordered_set>

#include "heuristics/spatial_hash.hpp"
#include "qbond/model/selection.hpp"

namespace qbond::scene_detail {

std::vector<Index> Builder::selection(const json& j, const std::string& path, const World& w) {
  Obj o(j, path, keys_of("selection"));
  Selection s;
  if (o.has("body")) {
    const std::string name = string(o["body"], o.at("body"));
    auto it = body_index_.find(name);
    if (it == body_index_.end()) {
      std::vector<std::string> names;
      for (const auto& [k, v] : body_index_) names.push_back(k);
      bad(o.at("body"), "unknown body '" + name + "' (defined: " + join(names) + ")");
    }
    s.body = it->second;
  }
  if (o.has("ids")) {
    std::vector<Index> ids;
    const json& a = array(o["ids"], o.at("ids"));
    for (std::size_t k = 0; k < a.size(); ++k) {
      const auto v = integer(a[k], item(o.at("ids"), k), 0);
      ids.push_back(static_cast<Index>(std::min<std::uint64_t>(v, ~Index{0})));
    }
    s.ids = ids;
  }
  if (o.has("box")) {
    const json& b = o["box"];
    if (!b.is_array() || b.size() != 2) bad(o.at("box"), "expected [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
    s.box = {vec3(b[0], o.at("box") + "[0]"), vec3(b[1], o.at("box") + "[1]")};
    if ((s.box->first.array() > s.box->second.array()).any()) bad(o.at("box"), "min must be <= max in every axis");
  }
  if (o.has("sphere")) {
    Obj sp(o["sphere"], o.at("sphere"), keys_of("sphere"));
    s.sphere = {vec3(sp.required("center"), sp.at("center")), positive(sp.required("radius"), sp.at("radius"))};
  }
  if (o.has("half_space")) {
    Obj h(o["half_space"], o.at("half_space"), keys_of("half_space"));
    s.half_space = {vec3(h.required("point"), h.at("point")), direction(h.required("normal"), h.at("normal"))};
  }
  if (o.has("all")) {
    if (!boolean(o["all"], o.at("all"))) bad(o.at("all"), "must be true when given");
    s.all = true;
  }
  if (j.empty()) bad(path, "needs at least one criterion (ids, body, box, sphere, half_space, all)");
  std::vector<Index> q;
  try {
    q = select(w, s);
  } catch (const std::out_of_range& e) {
    bad(o.at("ids"), std::string(e.what()) + (s.body ? " of the body" : ""));
  }
  if (q.empty()) bad(path, "selects no quanta");
  return q;
}

void Builder::bonds(const json& j, World& w) {
  std::unordered_set<std::uint64_t> existing;
  for (std::size_t b = 0; b < w.num_bonds(); ++b) existing.insert(pair_key(w.state.bonds.i[b], w.state.bonds.j[b]));
  for (std::size_t k = 0; k < j.size(); ++k) {
    const std::string path = item("bonds", k);
    if (!j[k].is_object()) bad(path, "expected an object, got " + type_name(j[k]));
    if (j[k].contains("between")) {
      Obj o(j[k], path, keys_of("bond.between"));
      const json& ends = o["between"];
      if (!ends.is_array() || ends.size() != 2) bad(o.at("between"), "expected two quanta ids [i, j]");
      json ids = json::object();
      ids["ids"] = ends;
      if (o.has("body")) ids["body"] = o["body"];
      // Reuse the selection rules (ranges, body-local ids) on the pair, keeping its order.
      const std::vector<Index> q = selection(ids, path, w);
      if (q.size() != 2) bad(o.at("between"), "a bond needs two different quanta");
      Index a = q[0], b = q[1];
      if (ends[0].get<std::uint64_t>() > ends[1].get<std::uint64_t>()) std::swap(a, b);
      BondSpec spec = bond_material(o.required("material"), o.at("material"));
      if (o.has("rest_length")) spec.rest_length = non_negative(o["rest_length"], o.at("rest_length"));
      if (!existing.insert(pair_key(a, b)).second)
        bad(o.at("between"), "quanta " + std::to_string(a) + " and " + std::to_string(b) + " are already bonded");
      w.add_bond(a, b, spec);
    } else {
      Obj o(j[k], path, keys_of("bond.within"));
      const std::vector<Index> from = selection(o.required("from"), o.at("from"), w);
      const std::vector<Index> to = selection(o.required("to"), o.at("to"), w);
      const double r = positive(o.required("within"), o.at("within"));
      BondSpec spec = bond_material(o.required("material"), o.at("material"));
      if (o.has("rest_length")) spec.rest_length = non_negative(o["rest_length"], o.at("rest_length"));
      std::size_t made = 0;
      pairs_within(w.state.x, from, to, r, [&](Index a, Index b) {
        if (!existing.insert(pair_key(a, b)).second) return;
        w.add_bond(a, b, spec);
        ++made;
      });
      if (made == 0) bad(o.at("within"), "no unbonded pair of quanta lies within " + num_str(r) + " m");
    }
  }
}

void Builder::check_overlaps(const World& w) {
  double shortest = INFINITY;
  for (std::size_t b = 0; b < w.num_bonds(); ++b)
    if (w.state.bonds.rest[b] > 0) shortest = std::min(shortest, w.state.bonds.rest[b]);
  const double limit = std::isfinite(shortest) ? 0.01 * shortest : 1e-9;
  for (const auto& [a, b] : pairs_within_radius(w.state.x, limit)) {
    const auto& names = w.model.body_names;
    bad("bodies", "quanta " + std::to_string(a) + " (body '" + names[w.model.body[a]] + "') and quanta " +
                      std::to_string(b) + " (body '" + names[w.model.body[b]] + "') overlap: " +
                      num_str((w.state.x[a] - w.state.x[b]).norm()) + " m apart (limit " + num_str(limit) +
                      " m, 1% of the shortest bond)");
  }
}

Motion Builder::keyframes(const json& j, const std::string& path) {
  Obj o(j, path, keys_of("motion.keyframes"));
  Motion m;
  m.type = MotionType::keyframes;
  if (o.has("interpolation"))
    m.interpolation =
        choice<Interpolation>(o["interpolation"], o.at("interpolation"),
                              {{"linear", Interpolation::linear}, {"smooth", Interpolation::smooth}});
  const json& frames = array(o.required("frames"), o.at("frames"));
  if (frames.empty()) bad(o.at("frames"), "must hold at least one keyframe");
  bool turns = false;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const std::string at = item(o.at("frames"), k);
    Obj f(frames[k], at, keys_of("keyframe"));
    Keyframe key;
    key.time = positive(f.required("time"), f.at("time"));
    if (k > 0 && !(key.time > m.keyframes.back().time))
      bad(f.at("time"), "must be after the previous keyframe's " + num_str(m.keyframes.back().time) +
                            " s, got " + num_str(key.time));
    if (f.has("offset")) key.offset = vec3(f["offset"], f.at("offset"));
    if (f.has("angle")) key.angle = number(f["angle"], f.at("angle"));
    turns |= key.angle != 0;
    m.keyframes.push_back(key);
  }
  // A turn needs its axis; without one no key is read that would make it.
  if (turns || o.has("axis") || o.has("center")) {
    m.axis = direction(o.required("axis"), o.at("axis"));
    m.center = vec3(o.required("center"), o.at("center"));
  }
  return m;
}

void Builder::anchors(const json& j, World& w) {
  std::unordered_map<Index, std::size_t> by;
  for (std::size_t k = 0; k < j.size(); ++k) {
    Obj o(j[k], item("anchors", k), keys_of("anchor"));
    const std::vector<Index> q = selection(o.required("select"), o.at("select"), w);
    for (Index i : q)
      if (auto [it, fresh] = by.emplace(i, k); !fresh)
        bad(o.at("select"), "quanta " + std::to_string(i) + " is already anchored by anchors[" +
                                std::to_string(it->second) + "]");
    Motion m;
    if (o.has("motion")) {
      const json& mj = o["motion"];
      const std::string path = o.at("motion");
      // One motion, beside which only the annotations may stand.
      std::vector<std::string> kinds;
      if (mj.is_object())
        for (const auto& [key, v] : mj.items()) {
          if (annotation(key, v, path + "." + key)) continue;
          if (key != "fixed" && key != "translate" && key != "rotate" && key != "keyframes")
            bad(path + "." + key, "unknown motion (accepted: fixed, translate, rotate, keyframes)");
          kinds.push_back(key);
        }
      if (!mj.is_object() || kinds.size() != 1)
        bad(path,
            "expected one of {\"fixed\": {}}, {\"translate\": {...}}, {\"rotate\": {...}}, "
            "{\"keyframes\": {...}}");
      const std::string kind = kinds.front();
      const std::string at = path + "." + kind;
      if (kind == "fixed") {
        Obj(mj[kind], at, keys_of("motion.fixed"));
      } else if (kind == "translate") {
        Obj t(mj[kind], at, keys_of("motion.translate"));
        m.type = MotionType::translate;
        m.velocity = vec3(t.required("velocity"), t.at("velocity"));
      } else if (kind == "rotate") {
        Obj r(mj[kind], at, keys_of("motion.rotate"));
        m.type = MotionType::rotate;
        m.axis = direction(r.required("axis"), r.at("axis"));
        m.center = vec3(r.required("center"), r.at("center"));
        m.rate = number(r.required("rate"), r.at("rate"));
      } else {
        m = keyframes(mj[kind], at);
      }
    }
    w.prescribe(q, m);
  }
}

void Builder::loads(const json& j, World& w) {
  for (std::size_t k = 0; k < j.size(); ++k) {
    Obj o(j[k], item("loads", k), keys_of("load"));
    const std::vector<Index> q = selection(o.required("select"), o.at("select"), w);
    const Vec3 f = vec3(o.required("force"), o.at("force"));
    for (Index i : q)
      if (w.model.is_kinematic(i))
        bad(o.at("select"), "selects anchored quanta " + std::to_string(i) + ": a load on it would do nothing");
    w.add_load(q, f);
  }
}

}  // namespace qbond::scene_detail
