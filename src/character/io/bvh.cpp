// BVH motion capture, read by gatcore's own strict parser.
//
// Why not assimp (which read BVH before): its BVH importer has a
// heap-use-after-free on a 48-byte file, undefined float->unsigned casts and
// a per-file leak, and users hand gatcore their own files. The
// format is small -- a joint hierarchy with offsets and channel lists, then
// a table of numbers -- so it is parsed here, with every count bounded by
// the file and every number checked.
//
// Semantics kept from the assimp import (same joint transforms): joints are
// ROOT and JOINT entries in preorder (End Sites are not joints); a joint's
// rest local transform is a translation by its OFFSET; its rotation per frame
// is the product of the rotation channels in the order listed (intrinsic,
// degrees); a joint with all three position channels takes them as its local
// translation, otherwise it keeps its OFFSET; fps = 1 / Frame Time.
//
// Lenient where the intent is clear (other readers accept these files too):
// any rotation channel order, position channels on any joint (each replaces
// that component of the OFFSET), leaf joints without an End Site, CRLF line
// ends, tabs and trailing blanks, and a Frames: count that disagrees with the
// rows of numbers that follow: the whole frames present are read and a
// warning names both counts. A partial last frame is still an error.
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "gatcore/character/io/bvh.hpp"
#include "gatcore/error.hpp"
#include "gatcore/progress.hpp"

namespace gatcore::character {

namespace {

enum class Channel { xpos, ypos, zpos, xrot, yrot, zrot };

struct JointDef {
  std::string name;
  int parent = -1;
  Vec3 offset{};
  std::vector<Channel> channels;
  int first_value = 0;  // index of its first channel in a frame's values
};

struct Lexer {
  std::string_view text;
  const std::string& path;
  std::size_t pos = 0;
  int line = 1;

  [[noreturn]] void fail(const std::string& what) const {
    throw InvalidArgument(detail::cat(path, ": line ", line, ": ", what));
  }
  bool at_end() {
    skip();
    return pos >= text.size();
  }
  void skip() {
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) {
      if (text[pos] == '\n') ++line;
      ++pos;
    }
  }
  std::string_view next(const char* expecting) {
    skip();
    if (pos >= text.size()) fail(detail::cat("the file ends where ", expecting, " was expected"));
    const std::size_t b = pos;
    // Braces are tokens of their own, with or without spaces around them.
    if (text[pos] == '{' || text[pos] == '}') return text.substr(pos++, 1);
    while (pos < text.size() && !std::isspace(static_cast<unsigned char>(text[pos])) && text[pos] != '{' &&
           text[pos] != '}')
      ++pos;
    return text.substr(b, pos - b);
  }
  // A joint's name: the rest of its line up to a brace, inner spaces kept
  // (3ds Max's Biped writes "JOINT Bip01 L Thigh").
  std::string rest_of_line(const char* expecting) {
    while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t')) ++pos;
    const std::size_t b = pos;
    while (pos < text.size() && text[pos] != '\n' && text[pos] != '\r' && text[pos] != '{' && text[pos] != '}') ++pos;
    std::size_t e = pos;
    while (e > b && std::isspace(static_cast<unsigned char>(text[e - 1]))) --e;
    if (e == b) fail(detail::cat("expected ", expecting, " on the same line"));
    return std::string(text.substr(b, e - b));
  }
  void expect(std::string_view word) {
    const std::string_view w = next(std::string(word).c_str());
    if (w != word) fail(detail::cat("expected '", word, "', found '", w, "'"));
  }
  // `what()` names the number in an error; only called on failure.
  template <class What>
  double number(What what) {
    const std::string_view t = next("a number");
    char buf[64];
    if (t.size() >= sizeof buf) fail(detail::cat(what(), ": '", t.substr(0, 32), "...' is not a number"));
    t.copy(buf, t.size());
    buf[t.size()] = '\0';
    char* end = nullptr;
    const double v = std::strtod(buf, &end);
    if (end == buf || *end != '\0') fail(detail::cat(what(), ": '", t, "' is not a number"));
    // Values are stored as float: beyond its range is as bad as infinite.
    if (!std::isfinite(v) || std::abs(v) > 1e30) fail(detail::cat(what(), ": '", t, "' is not a finite number"));
    return v;
  }
  double number(const char* what) {
    return number([what] { return std::string(what); });
  }
  std::int64_t count(const char* what, std::int64_t max) {
    const std::string w(next(what));
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(w.c_str(), &end, 10);
    if (end == w.c_str() || *end != '\0' || errno == ERANGE || v < 0 || v > max)
      fail(detail::cat(what, ": '", w, "' is not a whole number in [0, ", max, "]"));
    return v;
  }
};

Channel channel_of(Lexer& lx, std::string_view w) {
  if (w == "Xposition") return Channel::xpos;
  if (w == "Yposition") return Channel::ypos;
  if (w == "Zposition") return Channel::zpos;
  if (w == "Xrotation") return Channel::xrot;
  if (w == "Yrotation") return Channel::yrot;
  if (w == "Zrotation") return Channel::zrot;
  lx.fail(detail::cat("unknown channel '", w, "' (expected X/Y/Z position or rotation)"));
}

const char* channel_name(Channel c) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
  return names[static_cast<int>(c)];
}

// Hamilton product in double (the frame's rotation is composed in double,
// rounded once).
std::array<double, 4> qmul(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  return {a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1], a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
          a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3], a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
}

}  // namespace

Motion parse_bvh(std::string_view text, const std::string& path, const WarningFn& warn) {
  Lexer lx{text, path};
  lx.expect("HIERARCHY");
  lx.expect("ROOT");
  std::vector<JointDef> joints;
  // The hierarchy, without recursion: `open` holds the joint of every open
  // brace (-1 for an End Site).
  std::vector<int> open;
  int values_per_frame = 0;
  auto begin_joint = [&](int parent) {
    JointDef j;
    j.name = lx.rest_of_line("a joint name");
    j.parent = parent;
    lx.expect("{");
    lx.expect("OFFSET");
    for (int a = 0; a < 3; ++a) j.offset[std::size_t(a)] = float(lx.number([&] { return "joint '" + j.name + "' OFFSET"; }));
    lx.expect("CHANNELS");
    const auto n = lx.count(detail::cat("joint '", j.name, "' CHANNELS count").c_str(), 6);
    for (std::int64_t c = 0; c < n; ++c) {
      const Channel ch = channel_of(lx, lx.next("a channel name"));
      for (Channel seen : j.channels)
        if (seen == ch) lx.fail(detail::cat("joint '", j.name, "' lists channel ", channel_name(ch), " twice"));
      j.channels.push_back(ch);
    }
    j.first_value = values_per_frame;
    values_per_frame += int(n);
    open.push_back(int(joints.size()));
    joints.push_back(std::move(j));
  };
  begin_joint(-1);
  while (!open.empty()) {
    const std::string_view w = lx.next("JOINT, End Site or '}'");
    if (w == "}") {
      open.pop_back();
    } else if (w == "JOINT") {
      if (open.back() < 0) lx.fail("a JOINT inside an End Site");
      begin_joint(open.back());
    } else if (w == "End") {
      if (open.back() < 0) lx.fail("an End Site inside an End Site");
      lx.expect("Site");
      lx.expect("{");
      lx.expect("OFFSET");
      for (int a = 0; a < 3; ++a) lx.number("End Site OFFSET");
      open.push_back(-1);
    } else {
      lx.fail(detail::cat("expected JOINT, End Site or '}', found '", w, "'"));
    }
  }
  const std::string_view after = lx.next("MOTION");
  if (after == "ROOT") lx.fail("a second ROOT hierarchy (gatcore reads BVH files with one skeleton)");
  if (after != "MOTION") lx.fail(detail::cat("expected 'MOTION', found '", after, "'"));
  lx.expect("Frames:");
  // Every frame needs at least one number per channel, each at least 2 bytes
  // ("0 "): the count is bounded by the file before anything is allocated.
  const std::int64_t max_frames = std::max<std::int64_t>(1, std::int64_t(text.size()) / 2 / std::max(1, values_per_frame));
  const std::int64_t frames = lx.count("Frames", std::min<std::int64_t>(max_frames, 10'000'000));
  lx.expect("Frame");
  lx.expect("Time:");
  const double frame_time = lx.number("Frame Time");
  if (!(frame_time > 0.0) || !std::isfinite(1.0 / frame_time))
    lx.fail(detail::cat("Frame Time ", frame_time, " must be a positive number of seconds"));

  Motion m;
  m.name = path;
  Skeleton& s = m.skeleton;
  std::vector<Mat4> global(joints.size());
  for (std::size_t j = 0; j < joints.size(); ++j) {
    const JointDef& d = joints[j];
    s.names.push_back(d.name);
    s.parents.push_back(d.parent);
    Transform t;
    t.translation = d.offset;
    s.rest_local.push_back(t);
    s.root_parent.push_back(mat4_identity());
    global[j] = d.parent < 0 ? to_matrix(t) : mul(global[std::size_t(d.parent)], to_matrix(t));
    const Vec3 at = mat4_translation(global[j]);
    GATCORE_CHECK(std::isfinite(at[0]) && std::isfinite(at[1]) && std::isfinite(at[2]), path, ": joint '", d.name,
                  "': its offsets add up past the float range");
    s.inverse_bind.push_back(inverse(global[j]));
  }
  s.validate(path.c_str());

  const std::size_t name_at = path.find_last_of('/');
  m.clip.name = name_at == std::string::npos ? path : path.substr(name_at + 1);
  m.clip.fps = float(1.0 / frame_time);
  m.clip.frames.reserve(std::size_t(frames));
  std::vector<double> v(static_cast<std::size_t>(values_per_frame));
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  const int frames_line = lx.line;
  // A skeleton without channels: the count is all there is.
  if (v.empty())
    for (std::int64_t f = 0; f < frames; ++f) m.clip.frames.push_back(Pose{s.rest_local});
  // Whole frames until the numbers end (the Frames: count is only a hint).
  for (std::int64_t f = 0; !v.empty() && !lx.at_end(); ++f) {
    if (f >= 10'000'000) lx.fail("more than 10000000 frames");
    for (std::size_t k = 0; k < v.size(); ++k) {
      if (lx.at_end()) {
        if (f >= frames)
          lx.fail(detail::cat("more numbers than ", frames, " frames of ", v.size(), " channels, and not a whole frame more (",
                              k, " of ", v.size(), " numbers)"));
        lx.fail(detail::cat("the file ends in frame ", f, " of ", frames, " (", v.size(), " numbers per frame)"));
      }
      v[k] = lx.number([&] {
        for (const JointDef& d : joints)
          if (k < std::size_t(d.first_value) + d.channels.size())
            return detail::cat("frame ", f, " joint '", d.name, "' ", channel_name(d.channels[k - std::size_t(d.first_value)]));
        return detail::cat("frame ", f, " value ", k);
      });
    }
    Pose& p = m.clip.frames.emplace_back();
    p.local = s.rest_local;
    for (std::size_t j = 0; j < joints.size(); ++j) {
      const JointDef& d = joints[j];
      std::array<double, 4> q{0, 0, 0, 1};
      Vec3 pos = d.offset;
      for (std::size_t c = 0; c < d.channels.size(); ++c) {
        const double x = v[std::size_t(d.first_value) + c];
        const Channel ch = d.channels[c];
        if (ch == Channel::xpos || ch == Channel::ypos || ch == Channel::zpos) {
          pos[std::size_t(ch)] = float(x);
          continue;
        }
        const double h = 0.5 * x * kDeg;
        std::array<double, 4> r{0, 0, 0, std::cos(h)};
        r[std::size_t(ch) - 3] = std::sin(h);
        q = qmul(q, r);
      }
      p.local[j].translation = pos;
      const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      p.local[j].rotation = {float(q[0] / n), float(q[1] / n), float(q[2] / n), float(q[3] / n)};
    }
  }
  if (v.empty() && !lx.at_end()) lx.fail("numbers after the header of a skeleton without channels");
  const auto read = static_cast<std::int64_t>(m.clip.frames.size());
  if (read == 0)
    throw InvalidArgument(frames == 0 ? detail::cat(path, ": line ", frames_line, ": Frames: 0 (the motion has no frames)")
                                      : detail::cat(path, ": line ", lx.line, ": the file ends in frame 0 of ", frames,
                                                    " (no rows of numbers follow)"));
  if (read != frames)
    report_warning(warn, detail::cat(path, ": line ", frames_line, ": Frames: says ", frames, " but ", read,
                                     " frames of ", v.size(), " numbers follow; reading the ", read, " present"));
  return m;
}

Motion load_bvh(const std::string& path, const WarningFn& warn) {
  std::ifstream is(path, std::ios::binary);
  GATCORE_CHECK(is.good(), path, ": cannot open file");
  const std::string text{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
  GATCORE_CHECK(!is.bad(), path, ": read error");
  return parse_bvh(text, path, warn);
}

}  // namespace gatcore::character
