// Acclaim ASF / AMC, read line by line: every number checked, every count
// bounded by the file, every error naming the file, the line and the field.
//
// Geometry (the Acclaim convention, as the CMU viewer reads it): a bone's
// `direction` and `axis` are given in the world frame of the rest pose; its
// dof rotation M acts in the frame `axis` defines (C), so its rotation
// relative to the rest is C M C^-1. A joint per bone sits where the bone
// starts (its parent's end: the parent's length along its direction).
// Rotation orders name the order of application: "XYZ" is Rz Ry Rx.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "gatcore/character/io/asf.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

enum class Dof { rx, ry, rz, tx, ty, tz, l };

struct Bone {
  std::string name;
  int line = 0;
  Vec3 direction{0.0f, 0.0f, 0.0f};
  double length = 0.0;
  double axis[3] = {0.0, 0.0, 0.0};
  std::string axis_order = "XYZ";
  std::vector<Dof> dofs;
  int parent = -1;  // index into bones; -1: the root
  bool placed = false;
};

struct Asf {
  double length_scale = 1.0;
  bool degrees = true;
  std::vector<Dof> root_order;
  std::string root_axis = "XYZ";
  double root_position[3] = {0, 0, 0}, root_orientation[3] = {0, 0, 0};
  std::vector<Bone> bones;
  std::vector<int> order;  // bones in hierarchy order (parents first)
};

// The lines of a file, split into words (comments, CR, tabs dropped).
struct Lines {
  Lines(std::string_view t, const std::string& p) : text(t), path(p) {}
  std::string_view text;
  const std::string& path;
  std::size_t pos = 0;
  int line = 0;
  std::vector<std::string_view> words;

  [[noreturn]] void fail(const std::string& what) const {
    throw InvalidArgument(detail::cat(path, ": line ", line, ": ", what));
  }
  // The next non-empty line; false at the end.
  bool next() {
    while (pos < text.size()) {
      ++line;
      const std::size_t e = std::min(text.find('\n', pos), text.size());
      std::string_view l = text.substr(pos, e - pos);
      pos = e + 1;
      if (const std::size_t c = l.find('#'); c != std::string_view::npos) l = l.substr(0, c);
      words.clear();
      std::size_t i = 0;
      while (i < l.size()) {
        while (i < l.size() && std::isspace(static_cast<unsigned char>(l[i]))) ++i;
        const std::size_t b = i;
        while (i < l.size() && !std::isspace(static_cast<unsigned char>(l[i]))) ++i;
        if (i > b) words.push_back(l.substr(b, i - b));
      }
      if (!words.empty()) return true;
    }
    words.clear();
    return false;
  }
  // Puts the current line back (read again by the next next()).
  void unread() {
    // Re-scan from the start of the current line: find it by counting back.
    std::size_t p = pos > 0 ? pos - 1 : 0;
    if (p > text.size()) p = text.size();
    std::size_t b = p;
    while (b > 0 && text[b - 1] != '\n') --b;
    pos = b;
    --line;
  }
  double number(std::string_view w, const std::string& what) const {
    char buf[64];
    if (w.size() >= sizeof buf) fail(detail::cat(what, ": '", w.substr(0, 32), "...' is not a number"));
    w.copy(buf, w.size());
    buf[w.size()] = '\0';
    char* end = nullptr;
    const double v = std::strtod(buf, &end);
    if (end == buf || *end != '\0') fail(detail::cat(what, ": '", w, "' is not a number"));
    if (!std::isfinite(v) || std::abs(v) > 1e30) fail(detail::cat(what, ": '", w, "' is not a finite number"));
    return v;
  }
  void need(std::size_t n, const std::string& what) const {
    if (words.size() != n + 1)
      fail(detail::cat(what, ": expected ", n, n == 1 ? " value" : " values", ", found ", words.size() - 1));
  }
};

std::string lower(std::string_view w) {
  std::string s(w);
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Dof dof_of(const Lines& ln, std::string_view w, const std::string& what) {
  const std::string s = lower(w);
  static const std::map<std::string, Dof> names = {{"rx", Dof::rx}, {"ry", Dof::ry}, {"rz", Dof::rz}, {"tx", Dof::tx},
                                                   {"ty", Dof::ty}, {"tz", Dof::tz}, {"l", Dof::l}};
  const auto it = names.find(s);
  if (it == names.end()) ln.fail(detail::cat(what, ": unknown dof '", w, "' (expected rx ry rz tx ty tz l)"));
  return it->second;
}

std::vector<Dof> dof_list(const Lines& ln, std::size_t first, const std::string& what) {
  std::vector<Dof> d;
  for (std::size_t i = first; i < ln.words.size(); ++i) {
    const Dof x = dof_of(ln, ln.words[i], what);
    for (Dof y : d)
      if (y == x) ln.fail(detail::cat(what, ": '", ln.words[i], "' listed twice"));
    d.push_back(x);
  }
  return d;
}

std::string axis_order(const Lines& ln, std::string_view w, const std::string& what) {
  std::string s(w);
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (s.size() != 3 || s.find('X') == std::string::npos || s.find('Y') == std::string::npos ||
      s.find('Z') == std::string::npos)
    ln.fail(detail::cat(what, ": rotation order '", w, "' is not a permutation of XYZ"));
  return s;
}

// Rotations applied in `order` ("XYZ": X first), angles in radians.
Quat euler(const double a[3], const std::string& order) {
  Quat q{0.0f, 0.0f, 0.0f, 1.0f};
  for (char c : order) {
    const int k = c - 'X';
    Vec3 ax{0.0f, 0.0f, 0.0f};
    ax[std::size_t(k)] = 1.0f;
    q = quat_mul(quat_from_axis_angle(ax, float(a[k])), q);
  }
  return q;
}

Quat conj(const Quat& q) { return {-q[0], -q[1], -q[2], q[3]}; }

Asf read_asf(std::string_view text, const std::string& path) {
  Lines ln{text, path};
  Asf a;
  std::map<std::string, int> index;
  bool have_root = false, have_bones = false, have_hierarchy = false;
  std::string section;
  while (ln.next()) {
    const std::string_view w0 = ln.words[0];
    if (w0[0] == ':') {
      section = lower(w0.substr(1));
      if (section == "root") have_root = true;
      if (section == "bonedata") have_bones = true;
      if (section == "hierarchy") have_hierarchy = true;
      if (section == "version" || section == "name" || section == "documentation" || section == "units" ||
          section == "root" || section == "bonedata" || section == "hierarchy" || section == "skin")
        continue;
      ln.fail(detail::cat("unknown section '", w0, "' (expected :version :name :units :documentation :root "
                          ":bonedata :hierarchy)"));
    }
    if (section.empty()) ln.fail(detail::cat("'", w0, "' before any section (an ASF file starts with :version or :name)"));
    if (section == "documentation" || section == "version" || section == "name" || section == "skin") continue;
    const std::string key = lower(w0);
    if (section == "units") {
      ln.need(1, ":units " + key);
      if (key == "angle") {
        const std::string u = lower(ln.words[1]);
        if (u != "deg" && u != "rad" && u != "degrees" && u != "radians")
          ln.fail(detail::cat(":units angle: '", ln.words[1], "' (expected deg or rad)"));
        a.degrees = u[0] == 'd';
      } else if (key == "length") {
        a.length_scale = ln.number(ln.words[1], ":units length");
        if (!(a.length_scale > 0.0)) ln.fail(detail::cat(":units length ", a.length_scale, " must be positive"));
      } else if (key == "mass") {
        ln.number(ln.words[1], ":units mass");
      } else {
        ln.fail(detail::cat(":units: unknown unit '", w0, "' (expected mass, length, angle)"));
      }
    } else if (section == "root") {
      if (key == "order") {
        for (Dof d : dof_list(ln, 1, ":root order"))
          if (d == Dof::l) ln.fail(":root order: 'l' is not a root channel");
          else a.root_order.push_back(d);
      } else if (key == "axis") {
        ln.need(1, ":root axis");
        a.root_axis = axis_order(ln, ln.words[1], ":root axis");
      } else if (key == "position" || key == "orientation") {
        ln.need(3, ":root " + key);
        for (int i = 0; i < 3; ++i)
          (key == "position" ? a.root_position : a.root_orientation)[i] = ln.number(ln.words[std::size_t(i) + 1], ":root " + key);
      } else {
        ln.fail(detail::cat(":root: unknown field '", w0, "' (expected order, axis, position, orientation)"));
      }
    } else if (section == "bonedata") {
      if (key != "begin") ln.fail(detail::cat(":bonedata: expected 'begin', found '", w0, "'"));
      Bone b;
      b.line = ln.line;
      bool direction = false, length = false, ended = false;
      while (!ended && ln.next()) {
        const std::string k = lower(ln.words[0]);
        const std::string what = detail::cat("bone '", b.name.empty() ? "?" : b.name, "' ", k);
        if (k == "end") {
          ended = true;
        } else if (k == "id" || k == "bodymass" || k == "cofmass") {
          ln.need(1, what);
          ln.number(ln.words[1], what);
        } else if (k == "name") {
          ln.need(1, what);
          b.name = std::string(ln.words[1]);
          if (b.name == "root") ln.fail("bone name 'root' (the root is not a bone)");
        } else if (k == "direction") {
          ln.need(3, what);
          for (int i = 0; i < 3; ++i) b.direction[std::size_t(i)] = float(ln.number(ln.words[std::size_t(i) + 1], what));
          direction = true;
        } else if (k == "length") {
          ln.need(1, what);
          b.length = ln.number(ln.words[1], what);
          if (b.length < 0.0) ln.fail(detail::cat(what, " ", b.length, " is negative"));
          length = true;
        } else if (k == "axis") {
          ln.need(4, what);
          for (int i = 0; i < 3; ++i) b.axis[i] = ln.number(ln.words[std::size_t(i) + 1], what);
          b.axis_order = axis_order(ln, ln.words[4], what);
        } else if (k == "dof") {
          b.dofs = dof_list(ln, 1, what);
        } else if (k == "limits") {
          // One "(lo hi)" per dof, the first on this line, the rest on the next lines.
          std::string all;
          for (std::size_t i = 1; i < ln.words.size(); ++i) all += std::string(ln.words[i]) + " ";
          std::size_t n = 0;
          const int first_line = ln.line;
          auto take = [&](std::string s) {
            for (char& c : s)
              if (c == '(' || c == ')') c = ' ';
            std::vector<std::string_view> ws;
            std::size_t i = 0;
            while (i < s.size()) {
              while (i < s.size() && s[i] == ' ') ++i;
              const std::size_t st = i;
              while (i < s.size() && s[i] != ' ') ++i;
              if (i > st) ws.push_back(std::string_view(s).substr(st, i - st));
            }
            if (ws.size() % 2 != 0) ln.fail(detail::cat(what, ": expected '(lo hi)' pairs"));
            for (std::size_t p = 0; p < ws.size(); p += 2) {
              // "inf" / "-inf" are common in limits: unbounded.
              auto val = [&](std::string_view v) {
                const std::string lv = lower(v);
                if (lv == "inf" || lv == "+inf") return 1e30;
                if (lv == "-inf") return -1e30;
                return ln.number(v, what);
              };
              const double lo = val(ws[p]), hi = val(ws[p + 1]);
              if (lo > hi) ln.fail(detail::cat(what, ": lower limit ", lo, " above upper limit ", hi));
              ++n;
            }
          };
          take(all);
          while (n < b.dofs.size() && ln.next()) {
            if (ln.words[0].empty() || ln.words[0][0] != '(') {
              ln.unread();
              break;
            }
            std::string l;
            for (std::string_view x : ln.words) l += std::string(x) + " ";
            take(l);
          }
          if (n != b.dofs.size()) {
            ln.line = std::max(ln.line, first_line);
            ln.fail(detail::cat(what, ": ", n, " limits for ", b.dofs.size(), " dofs"));
          }
        } else {
          ln.fail(detail::cat("bone '", b.name, "': unknown field '", ln.words[0],
                              "' (expected id, name, direction, length, axis, dof, limits, end)"));
        }
      }
      if (!ended) ln.fail(detail::cat("bone '", b.name, "' (from line ", b.line, "): the file ends before 'end'"));
      if (b.name.empty()) ln.fail(detail::cat("the bone from line ", b.line, " has no name"));
      if (!direction || !length)
        ln.fail(detail::cat("bone '", b.name, "' (from line ", b.line, ") has no ", !direction ? "direction" : "length"));
      const float n = std::sqrt(b.direction[0] * b.direction[0] + b.direction[1] * b.direction[1] +
                                b.direction[2] * b.direction[2]);
      if (!(n > 0.0f) && b.length > 0.0)
        ln.fail(detail::cat("bone '", b.name, "' (from line ", b.line, "): direction 0 0 0 with length ", b.length));
      if (n > 0.0f)
        for (float& c : b.direction) c /= n;
      if (!index.emplace(b.name, int(a.bones.size())).second)
        ln.fail(detail::cat("bone '", b.name, "' defined twice"));
      if (a.bones.size() >= 100000) ln.fail("more than 100000 bones");
      a.bones.push_back(std::move(b));
    } else if (section == "hierarchy") {
      if (key == "begin" || key == "end") continue;
      int parent = -1;
      if (key != "root") {
        const auto it = index.find(std::string(w0));
        if (it == index.end()) ln.fail(detail::cat(":hierarchy: unknown bone '", w0, "'"));
        parent = it->second;
      }
      for (std::size_t i = 1; i < ln.words.size(); ++i) {
        const auto it = index.find(std::string(ln.words[i]));
        if (it == index.end()) ln.fail(detail::cat(":hierarchy: unknown bone '", ln.words[i], "'"));
        Bone& c = a.bones[std::size_t(it->second)];
        if (c.placed) ln.fail(detail::cat(":hierarchy: bone '", c.name, "' has two parents"));
        if (it->second == parent) ln.fail(detail::cat(":hierarchy: bone '", c.name, "' is its own parent"));
        c.parent = parent;
        c.placed = true;
      }
    }
  }
  ln.line = std::max(ln.line, 1);
  if (!have_root) ln.fail("no :root section");
  if (!have_bones) ln.fail("no :bonedata section");
  if (!have_hierarchy && !a.bones.empty()) ln.fail("no :hierarchy section");
  for (const Bone& b : a.bones)
    if (!b.placed) throw InvalidArgument(detail::cat(path, ": line ", b.line, ": bone '", b.name, "' is not in :hierarchy"));
  // Parents first (breadth first from the root); a bone never reached sits on a cycle.
  std::vector<std::vector<int>> kids(a.bones.size() + 1);
  for (std::size_t i = 0; i < a.bones.size(); ++i) kids[std::size_t(a.bones[i].parent + 1)].push_back(int(i));
  std::vector<int> queue = {-1};
  for (std::size_t q = 0; q < queue.size(); ++q)
    for (int c : kids[std::size_t(queue[q] + 1)]) {
      queue.push_back(c);
      a.order.push_back(c);
    }
  if (a.order.size() != a.bones.size()) {
    std::vector<char> reached(a.bones.size(), 0);
    for (int i : a.order) reached[std::size_t(i)] = 1;
    for (std::size_t i = 0; i < a.bones.size(); ++i)
      if (!reached[i])
        throw InvalidArgument(detail::cat(path, ": :hierarchy: bone '", a.bones[i].name,
                                          "' is on a cycle (never reached from the root)"));
  }
  if (a.root_order.empty())
    a.root_order = {Dof::tx, Dof::ty, Dof::tz, Dof::rx, Dof::ry, Dof::rz};
  return a;
}

struct Built {
  Skeleton skeleton;
  std::vector<int> joint_of;  // per bone: its joint
  std::vector<Quat> c;        // per joint: the axis rotation C
};

Built build(const Asf& a, const std::string& path) {
  const double to_rad = a.degrees ? 3.14159265358979323846 / 180.0 : 1.0;
  Built out;
  Skeleton& s = out.skeleton;
  out.joint_of.assign(a.bones.size(), -1);
  auto radians = [&](const double v[3], double r[3]) {
    for (int i = 0; i < 3; ++i) r[i] = v[i] * to_rad;
  };
  double r[3];
  radians(a.root_orientation, r);
  s.names.push_back("root");
  s.parents.push_back(-1);
  Transform root;
  for (int i = 0; i < 3; ++i) root.translation[std::size_t(i)] = float(a.root_position[i] / a.length_scale);
  s.rest_local.push_back(root);
  out.c.push_back(euler(r, a.root_axis));
  for (int bi : a.order) {
    const Bone& b = a.bones[std::size_t(bi)];
    const int p = b.parent < 0 ? 0 : out.joint_of[std::size_t(b.parent)];
    out.joint_of[std::size_t(bi)] = s.num_joints();
    s.names.push_back(b.name);
    s.parents.push_back(p);
    Transform t;
    if (b.parent >= 0) {
      const Bone& pb = a.bones[std::size_t(b.parent)];
      for (int i = 0; i < 3; ++i) t.translation[std::size_t(i)] = float(pb.length * pb.direction[std::size_t(i)] / a.length_scale);
    }
    s.rest_local.push_back(t);
    radians(b.axis, r);
    out.c.push_back(euler(r, b.axis_order));
  }
  std::vector<Mat4> g(s.names.size());
  for (std::size_t j = 0; j < s.names.size(); ++j) {
    const Mat4 l = to_matrix(s.rest_local[j]);
    g[j] = s.parents[j] < 0 ? l : mul(g[std::size_t(s.parents[j])], l);
    const Vec3 at = mat4_translation(g[j]);
    GATCORE_CHECK(std::isfinite(at[0]) && std::isfinite(at[1]) && std::isfinite(at[2]), path, ": bone '", s.names[j],
                  "': the lengths add up past the float range");
    s.inverse_bind.push_back(inverse(g[j]));
    s.root_parent.push_back(mat4_identity());
  }
  s.validate(path.c_str());
  return out;
}

}  // namespace

Skeleton parse_asf(std::string_view asf, const std::string& asf_path) {
  return build(read_asf(asf, asf_path), asf_path).skeleton;
}

Motion parse_asf_amc(std::string_view asf_text, const std::string& asf_path, std::string_view amc,
                     const std::string& amc_path, float fps, const WarningFn& warn) {
  const Asf a = read_asf(asf_text, asf_path);
  Built b = build(a, asf_path);
  GATCORE_CHECK(fps == 0.0f || (std::isfinite(fps) && fps > 0.0f), amc_path, ": frame rate ", fps, " fps");
  Motion m;
  m.name = amc_path;
  const std::size_t cut = amc_path.find_last_of('/');
  m.clip.name = cut == std::string::npos ? amc_path : amc_path.substr(cut + 1);
  m.clip.fps = fps > 0.0f ? fps : 120.0f;
  std::map<std::string, int> bone_index;  // "root" -> -1
  bone_index["root"] = -1;
  for (std::size_t i = 0; i < a.bones.size(); ++i) bone_index[a.bones[i].name] = int(i);
  // Current dof values per joint (joint 0: the root), file units.
  const std::size_t J = b.skeleton.names.size();
  std::vector<std::vector<double>> values(J);
  values[0].assign(a.root_order.size(), 0.0);
  std::vector<int> bone_of(J, -1);
  for (std::size_t i = 0; i < a.bones.size(); ++i) {
    values[std::size_t(b.joint_of[i])].assign(a.bones[i].dofs.size(), 0.0);
    bone_of[std::size_t(b.joint_of[i])] = int(i);
  }
  bool degrees = a.degrees;
  Lines ln{amc, amc_path};
  bool in_frame = false;
  auto emit = [&] {
    Pose p;
    p.local = b.skeleton.rest_local;
    for (std::size_t j = 0; j < J; ++j) {
      const std::vector<Dof>& dofs = j == 0 ? a.root_order : a.bones[std::size_t(bone_of[j])].dofs;
      Quat mq{0.0f, 0.0f, 0.0f, 1.0f};
      Vec3 t{0.0f, 0.0f, 0.0f};
      bool root_t = false;
      for (std::size_t k = 0; k < dofs.size(); ++k) {
        const double v = values[j][k];
        const int d = int(dofs[k]);
        if (d <= 2) {
          Vec3 ax{0.0f, 0.0f, 0.0f};
          ax[std::size_t(d)] = 1.0f;
          mq = quat_mul(quat_from_axis_angle(ax, float(degrees ? v * 3.14159265358979323846 / 180.0 : v)), mq);
        } else if (d <= 5) {
          t[std::size_t(d - 3)] = float(v / a.length_scale);
          root_t = true;
        }
      }
      const Quat& c = b.c[j];
      p.local[j].rotation = quat_normalize(quat_mul(c, quat_mul(mq, conj(c))));
      if (j == 0) {
        if (root_t)
          for (int i = 0; i < 3; ++i)
            if (std::find(dofs.begin(), dofs.end(), Dof(3 + i)) != dofs.end()) p.local[0].translation[std::size_t(i)] = t[std::size_t(i)];
      } else if (root_t) {
        const Vec3 d = quat_rotate(c, t);
        for (int i = 0; i < 3; ++i) p.local[j].translation[std::size_t(i)] += d[std::size_t(i)];
      }
    }
    m.clip.frames.push_back(std::move(p));
  };
  std::int64_t frame_number = 0;
  while (ln.next()) {
    const std::string_view w0 = ln.words[0];
    if (w0[0] == ':') {
      const std::string k = lower(w0);
      if (k == ":degrees") degrees = true;
      else if (k == ":radians") degrees = false;
      else if (k != ":fully-specified")
        ln.fail(detail::cat("unknown keyword '", w0, "' (expected :FULLY-SPECIFIED, :DEGREES or :RADIANS)"));
      continue;
    }
    if (ln.words.size() == 1 && std::isdigit(static_cast<unsigned char>(w0[0]))) {
      char* end = nullptr;
      const std::string n(w0);
      errno = 0;
      const long long f = std::strtoll(n.c_str(), &end, 10);
      if (*end != '\0' || f < 0) ln.fail(detail::cat("frame number '", w0, "' is not a whole number"));
      if (errno == ERANGE) ln.fail(detail::cat("frame number '", w0, "' is out of range"));
      if (in_frame) emit();
      if (m.clip.frames.size() >= std::size_t(kMaxClipJointSamples) / std::max<std::size_t>(1, J))
        ln.fail(detail::cat("more than ", kMaxClipJointSamples / std::int64_t(std::max<std::size_t>(1, J)), " frames"));
      if (in_frame && f - 1 != frame_number)  // f >= 0: f - 1 cannot overflow
        report_warning(warn, detail::cat(amc_path, ": line ", ln.line, ": frame ", f, " follows frame ", frame_number,
                                         " (read in file order)"));
      frame_number = f;
      in_frame = true;
      continue;
    }
    if (!in_frame) ln.fail(detail::cat("'", w0, "' before the first frame number"));
    const auto it = bone_index.find(std::string(w0));
    if (it == bone_index.end())
      ln.fail(detail::cat("frame ", frame_number, ": unknown bone '", w0, "' (not in ", asf_path, ")"));
    const std::size_t j = it->second < 0 ? 0 : std::size_t(b.joint_of[std::size_t(it->second)]);
    std::vector<double>& v = values[j];
    if (ln.words.size() - 1 != v.size())
      ln.fail(detail::cat("frame ", frame_number, " bone '", w0, "': ", ln.words.size() - 1, " values for its ", v.size(),
                          " dofs"));
    for (std::size_t k = 0; k < v.size(); ++k)
      v[k] = ln.number(ln.words[k + 1], detail::cat("frame ", frame_number, " bone '", w0, "' value ", k + 1));
  }
  if (in_frame) emit();
  if (m.clip.frames.empty()) throw InvalidArgument(detail::cat(amc_path, ": no frames (no frame number line)"));
  m.skeleton = std::move(b.skeleton);
  return m;
}

namespace {
std::string read_all(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  GATCORE_CHECK(is.good(), path, ": cannot open file");
  std::string text{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
  GATCORE_CHECK(!is.bad(), path, ": read error");
  return text;
}
}  // namespace

Motion load_asf_amc(const std::string& asf_path, const std::string& amc_path, float fps, const WarningFn& warn) {
  return parse_asf_amc(read_all(asf_path), asf_path, read_all(amc_path), amc_path, fps, warn);
}

}  // namespace gatcore::character
