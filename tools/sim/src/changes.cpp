// What differs between two epochs of a world, and the world's things as CSV: the ground truth that
// map updates from vehicles' change reports are judged by.
#include <algorithm>
#include <cstdio>
#include <map>

#include "pl/common/error.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

namespace {

Footprint footprint(const WorldObject& o) { return {o.centre, o.half, o.yaw}; }

bool same_shapes(const WorldObject& a, const WorldObject& b) {
  if (a.shapes.size() != b.shapes.size()) return false;
  for (std::size_t i = 0; i < a.shapes.size(); ++i) {
    const Primitive &p = a.shapes[i], &q = b.shapes[i];
    if (p.shape != q.shape || p.a != q.a || p.b != q.b || p.c != q.c || p.yaw != q.yaw) return false;
  }
  return true;
}

void append_footprint(std::string& out, bool has, const Footprint& f) {
  char buf[160];
  if (!has) {
    out += ",,,,,";
    return;
  }
  std::snprintf(buf, sizeof buf, ",%.3f,%.3f,%.3f,%.3f,%.5f", f.centre.x(), f.centre.y(), f.half.x(), f.half.y(), f.yaw);
  out += buf;
}

}  // namespace

const char* change_name(ObjectChange::Kind k) {
  switch (k) {
    case ObjectChange::Kind::Moved: return "moved";
    case ObjectChange::Kind::Removed: return "removed";
    case ObjectChange::Kind::Added: return "added";
    case ObjectChange::Kind::Grown: return "grown";
  }
  return "?";
}

std::vector<ObjectChange> changes_between(const World& before, const World& after) {
  std::map<std::uint32_t, const WorldObject*> old, now;
  for (const WorldObject& o : before.objects) old[o.id] = &o;
  for (const WorldObject& o : after.objects) now[o.id] = &o;
  std::vector<ObjectChange> out;
  for (const auto& [id, o] : old) {
    auto it = now.find(id);
    ObjectChange c;
    c.id = id;
    c.cls = o->cls;
    c.has_before = true;
    c.before = footprint(*o);
    if (it == now.end()) {
      c.kind = ObjectChange::Kind::Removed;
      out.push_back(c);
      continue;
    }
    const WorldObject& n = *it->second;
    if (n.cls != o->cls) throw Error("the worlds' thing " + std::to_string(id) + " changed class: not two epochs of one world");
    c.has_after = true;
    c.after = footprint(n);
    if (n.centre != o->centre) {
      c.kind = ObjectChange::Kind::Moved;
      out.push_back(c);
    } else if (n.half != o->half || !same_shapes(*o, n)) {
      c.kind = ObjectChange::Kind::Grown;
      out.push_back(c);
    }
  }
  for (const auto& [id, n] : now) {
    if (old.count(id)) continue;
    ObjectChange c;
    c.kind = ObjectChange::Kind::Added;
    c.id = id;
    c.cls = n->cls;
    c.has_after = true;
    c.after = footprint(*n);
    out.push_back(c);
  }
  std::sort(out.begin(), out.end(), [](const ObjectChange& a, const ObjectChange& b) { return a.id < b.id; });
  return out;
}

std::string objects_csv(const World& world, const std::vector<std::uint64_t>& returns, const std::vector<std::uint64_t>& near) {
  if (returns.size() != world.objects.size() || near.size() != returns.size())
    throw Error("objects_csv: one return count per thing is needed");
  std::string out = "id,class,x,y,half_x,half_y,yaw,base,height,returns,returns_40m\n";
  char buf[256];
  for (std::size_t i = 0; i < world.objects.size(); ++i) {
    const WorldObject& o = world.objects[i];
    std::snprintf(buf, sizeof buf, "%u,%s,%.3f,%.3f,%.3f,%.3f,%.5f,%.3f,%.3f,%llu,%llu\n", o.id, class_name(o.cls), o.centre.x(),
                  o.centre.y(), o.half.x(), o.half.y(), o.yaw, o.base, o.height, static_cast<unsigned long long>(returns[i]),
                  static_cast<unsigned long long>(near[i]));
    out += buf;
  }
  return out;
}

std::string changes_csv(const std::vector<ObjectChange>& changes, const std::vector<std::uint64_t>& rays_seeing) {
  if (rays_seeing.size() != changes.size()) throw Error("changes_csv: one ray count per change is needed");
  std::string out = "id,class,change,x0,y0,half_x0,half_y0,yaw0,x1,y1,half_x1,half_y1,yaw1,rays_seeing\n";
  for (std::size_t i = 0; i < changes.size(); ++i) {
    const ObjectChange& c = changes[i];
    out += std::to_string(c.id) + "," + class_name(c.cls) + "," + change_name(c.kind);
    append_footprint(out, c.has_before, c.before);
    append_footprint(out, c.has_after, c.after);
    out += "," + std::to_string(rays_seeing[i]) + "\n";
  }
  return out;
}

}  // namespace pl::sim
