#include "gatcore/models/checkpoint.hpp"
#include "gatcore/backend.hpp"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace gatcore::models {
namespace {

constexpr const char* kFormat = "gatcore-checkpoint";
constexpr const char* kVersion = "1";

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw CheckpointError("checkpoint '" + path + "': " + what);
}

std::uint64_t fnv1a(const unsigned char* p, std::size_t n) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      case '\r': o += "\\r"; break;
      default:
        if (c < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          o += b;
        } else {
          o += char(c);
        }
    }
  }
  return o + "\"";
}

// A minimal JSON reader for the safetensors header: objects, arrays, strings,
// non-negative integers.
struct Json {
  enum Kind { object, array, string, number } kind = string;
  std::vector<std::pair<std::string, Json>> members;
  std::vector<Json> items;
  std::string str;
  std::uint64_t num = 0;
  const Json* get(const std::string& k) const {
    for (const auto& m : members)
      if (m.first == k) return &m.second;
    return nullptr;
  }
};

struct Parser {
  const std::string& s;
  std::size_t i = 0;
  std::string err;
  void ws() {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\n' || s[i] == '\t' || s[i] == '\r')) ++i;
  }
  bool expect(char c) {
    ws();
    if (i < s.size() && s[i] == c) {
      ++i;
      return true;
    }
    err = detail::cat("expected '", c, "' at header byte ", i);
    return false;
  }
  bool parse_string(std::string& out) {
    if (!expect('"')) return false;
    while (i < s.size() && s[i] != '"') {
      char c = s[i++];
      if (c == '\\') {
        if (i >= s.size()) break;
        char e = s[i++];
        if (e == 'n') c = '\n';
        else if (e == 't') c = '\t';
        else if (e == 'r') c = '\r';
        else if (e == 'u') {
          if (i + 4 > s.size()) break;
          c = char(std::strtol(s.substr(i, 4).c_str(), nullptr, 16));
          i += 4;
        } else c = e;
      }
      out += c;
    }
    return expect('"');
  }
  bool parse(Json& j, int depth = 0) {
    if (depth > 8) {
      err = "header nested too deeply";
      return false;
    }
    ws();
    if (i >= s.size()) {
      err = "header ends early";
      return false;
    }
    if (s[i] == '{') {
      ++i;
      j.kind = Json::object;
      ws();
      if (i < s.size() && s[i] == '}') return ++i, true;
      for (;;) {
        std::string k;
        Json v;
        if (!parse_string(k) || !expect(':') || !parse(v, depth + 1)) return false;
        j.members.emplace_back(std::move(k), std::move(v));
        ws();
        if (i < s.size() && s[i] == ',') {
          ++i;
          continue;
        }
        return expect('}');
      }
    }
    if (s[i] == '[') {
      ++i;
      j.kind = Json::array;
      ws();
      if (i < s.size() && s[i] == ']') return ++i, true;
      for (;;) {
        Json v;
        if (!parse(v, depth + 1)) return false;
        j.items.push_back(std::move(v));
        ws();
        if (i < s.size() && s[i] == ',') {
          ++i;
          continue;
        }
        return expect(']');
      }
    }
    if (s[i] == '"') {
      j.kind = Json::string;
      return parse_string(j.str);
    }
    if (s[i] >= '0' && s[i] <= '9') {
      j.kind = Json::number;
      while (i < s.size() && s[i] >= '0' && s[i] <= '9') j.num = j.num * 10 + std::uint64_t(s[i++] - '0');
      return true;
    }
    err = detail::cat("unexpected character '", s[i], "' at header byte ", i);
    return false;
  }
};

void put_u64(std::string& out, std::uint64_t v) {
  for (int k = 0; k < 8; ++k) out += char((v >> (8 * k)) & 0xff);
}

}  // namespace

const Tensor* CheckpointFile::find(const std::string& name) const {
  for (const auto& t : tensors)
    if (t.first == name) return &t.second;
  return nullptr;
}

void write_checkpoint_file(const std::string& path, const CheckpointFile& f) {
  std::string data;
  std::string tensors_json;
  for (const auto& [name, t] : f.tensors) {
    GATCORE_CHECK(t.defined() && t.dtype() == DType::f32, "checkpoint: tensor '", name, "' is not a defined f32 tensor");
    GATCORE_CHECK(name != "__metadata__", "checkpoint: reserved tensor name");
    const std::size_t begin = data.size();
    for (std::int64_t r = 0; r < t.rows(); ++r)
      data.append(reinterpret_cast<const char*>(t.row(r)), std::size_t(t.cols()) * sizeof(float));
    tensors_json += "," + json_string(name) + ":{\"dtype\":\"F32\",\"shape\":[" + std::to_string(t.rows()) + "," +
                    std::to_string(t.cols()) + "],\"data_offsets\":[" + std::to_string(begin) + "," +
                    std::to_string(data.size()) + "]}";
  }
  std::map<std::string, std::string> meta = f.metadata;
  meta["format"] = kFormat;
  meta["format_version"] = kVersion;
  meta["checksum"] = hex(fnv1a(reinterpret_cast<const unsigned char*>(data.data()), data.size()));
  // "format" first, so the magic sits at a fixed place at the file start.
  std::string header = "{\"__metadata__\":{\"format\":" + json_string(kFormat);
  for (const auto& [k, v] : meta)
    if (k != "format") header += "," + json_string(k) + ":" + json_string(v);
  header += "}" + tensors_json + "}";
  while (header.size() % 8) header += ' ';
  std::string out;
  put_u64(out, header.size());
  out += header;
  out += data;

  const std::string tmp = path + ".tmp";
  {
    std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
    if (!os) fail(path, "cannot open '" + tmp + "' for writing");
    os.write(out.data(), std::streamsize(out.size()));
    os.flush();
    if (!os) {
      std::remove(tmp.c_str());
      fail(path, "write to '" + tmp + "' failed (disk full?)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    fail(path, "cannot rename '" + tmp + "' to it: " + std::strerror(errno));
  }
}

CheckpointFile read_checkpoint_file(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::string bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  if (bytes.size() < 8) fail(path, detail::cat("truncated: ", bytes.size(), " bytes, not even a header length"));
  std::uint64_t n = 0;
  for (int k = 0; k < 8; ++k) n |= std::uint64_t(static_cast<unsigned char>(bytes[std::size_t(k)])) << (8 * k);
  const std::string magic = "{\"__metadata__\":{\"format\":\"gatcore-checkpoint\"";
  if (bytes.compare(8, magic.size(), magic) != 0) {
    if (bytes.size() >= 9 && bytes[8] == '{' && n <= bytes.size() - 8)
      fail(path, "wrong magic: a safetensors file, but not a gatcore checkpoint");
    if (bytes.size() < 8 + magic.size() && magic.compare(0, bytes.size() - 8, bytes, 8, std::string::npos) == 0)
      fail(path, detail::cat("truncated: ", bytes.size(), " bytes"));
    fail(path, "wrong magic: not a gatcore checkpoint (expected a safetensors header starting with "
               "{\"__metadata__\":{\"format\":\"gatcore-checkpoint\")");
  }
  if (n > bytes.size() - 8)
    fail(path, detail::cat("truncated: the header needs ", n, " bytes, the file has ", bytes.size() - 8, " after the length"));
  const std::string header = bytes.substr(8, std::size_t(n));
  Json root;
  Parser p{header, 0, {}};
  if (!p.parse(root) || root.kind != Json::object) fail(path, "corrupted header: " + (p.err.empty() ? "not an object" : p.err));
  CheckpointFile f;
  const Json* meta = root.get("__metadata__");
  if (!meta || meta->kind != Json::object) fail(path, "corrupted header: no __metadata__ object");
  for (const auto& [k, v] : meta->members) {
    if (v.kind != Json::string) fail(path, "corrupted header: metadata '" + k + "' is not a string");
    f.metadata[k] = v.str;
  }
  if (f.metadata["format_version"] != kVersion)
    fail(path, "unsupported format version '" + f.metadata["format_version"] + "' (this build reads version " + kVersion + ")");
  const std::size_t data_begin = 8 + std::size_t(n);
  const std::size_t data_size = bytes.size() - data_begin;
  std::size_t max_end = 0;
  for (const auto& [name, v] : root.members) {
    if (name == "__metadata__") continue;
    const Json* dt = v.get("dtype");
    const Json* shape = v.get("shape");
    const Json* off = v.get("data_offsets");
    if (!dt || dt->str != "F32") fail(path, "tensor '" + name + "': dtype must be F32");
    if (!shape || shape->kind != Json::array || shape->items.size() != 2 || !off || off->kind != Json::array ||
        off->items.size() != 2)
      fail(path, "tensor '" + name + "': corrupted shape or data_offsets");
    const std::uint64_t r = shape->items[0].num, c = shape->items[1].num;
    const std::uint64_t b = off->items[0].num, e = off->items[1].num;
    if (e < b || e - b != r * c * sizeof(float))
      fail(path, detail::cat("tensor '", name, "': data_offsets [", b, ", ", e, ") do not match shape [", r, ", ", c, "]"));
    if (e > data_size)
      fail(path, detail::cat("truncated: tensor '", name, "' ends at data byte ", e, ", the file has ", data_size));
    max_end = std::max<std::size_t>(max_end, e);
    Tensor t = Tensor::empty(std::int64_t(r), std::int64_t(c));
    if (r != 0 && c != 0) std::memcpy(t.data(), bytes.data() + data_begin + b, e - b);
    f.tensors.emplace_back(name, t);
  }
  if (max_end != data_size) fail(path, detail::cat("corrupted: ", data_size - max_end, " trailing bytes after the last tensor"));
  const std::string sum = hex(fnv1a(reinterpret_cast<const unsigned char*>(bytes.data() + data_begin), data_size));
  if (f.metadata["checksum"] != sum)
    fail(path, "corrupted: checksum mismatch (stored " + f.metadata["checksum"] + ", data " + sum + ")");
  return f;
}

namespace {

std::string float_str(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

std::string rng_str(nn::Rng& r) {
  std::ostringstream os;
  os << r.engine();
  return os.str();
}

}  // namespace

void save_checkpoint(const std::string& path, const Model& model, const Normaliser& norm, const Trainer* trainer,
                     const std::map<std::string, std::string>& extra) {
  if (model.folded())
    fail(path, "the model's BatchNorms were folded for inference; save the unfolded model (load it again)");
  CheckpointFile f;
  f.metadata = extra;
  f.metadata["config"] = model.config().to_text();
  f.metadata["target_scale"] = float_str(norm.target_scale);
  // Downloaded first when the model lives on a device.
  for (const auto& p : model.registry().params) f.tensors.emplace_back(p.name, to(p.var.value(), Device::cpu));
  for (const auto& b : model.registry().buffers) f.tensors.emplace_back(b.name, to(b.tensor, Device::cpu));
  if (norm.defined()) {
    f.tensors.emplace_back("norm.mean", norm.mean);
    f.tensors.emplace_back("norm.inv_std", norm.inv_std);
  }
  f.metadata["model_rng"] = rng_str(const_cast<Model&>(model).rng());
  if (trainer) {
    auto& t = const_cast<Trainer&>(*trainer);
    const auto& params = model.registry().params;
    for (std::size_t k = 0; k < params.size(); ++k) {
      f.tensors.emplace_back("optim.m." + params[k].name, to(t.optimiser().first_moments()[k], Device::cpu));
      f.tensors.emplace_back("optim.v." + params[k].name, to(t.optimiser().second_moments()[k], Device::cpu));
    }
    f.metadata["epoch"] = std::to_string(t.epoch());
    f.metadata["lr"] = float_str(t.optimiser().lr());
    f.metadata["adam_steps"] = std::to_string(t.optimiser().steps());
    f.metadata["rng"] = rng_str(t.rng());
    f.metadata["plateau_best"] = float_str(t.plateau().best);
    f.metadata["plateau_has_best"] = t.plateau().has_best ? "1" : "0";
    f.metadata["plateau_bad_epochs"] = std::to_string(t.plateau().bad_epochs);
    f.metadata["plateau_on_validation"] = t.plateau().on_validation ? "1" : "0";
  }
  write_checkpoint_file(path, f);
}

LoadedModel load_checkpoint(const std::string& path) {
  LoadedModel out;
  out.file = read_checkpoint_file(path);
  const CheckpointFile& f = out.file;
  auto it = f.metadata.find("config");
  if (it == f.metadata.end()) fail(path, "no model configuration in the metadata");
  ModelConfig cfg;
  try {
    cfg = ModelConfig::from_text(it->second);
  } catch (const Error& e) {
    fail(path, std::string("bad model configuration: ") + e.what());
  }
  std::unique_ptr<Model> m = make_model(cfg, 0);
  const auto& reg = m->registry();
  auto known = [&](const std::string& name) {
    return reg.find_param(name) || reg.find_buffer(name) || name == "norm.mean" || name == "norm.inv_std" ||
           (name.rfind("optim.m.", 0) == 0 && reg.find_param(name.substr(8))) ||
           (name.rfind("optim.v.", 0) == 0 && reg.find_param(name.substr(8)));
  };
  for (const auto& [name, t] : f.tensors)
    if (!known(name)) fail(path, "unknown tensor '" + name + "' (not part of model '" + cfg.name + "')");
  auto load = [&](const std::string& name, const Tensor& dst) {
    const Tensor* src = f.find(name);
    if (!src) fail(path, "missing tensor '" + name + "'");
    if (!src->same_shape(dst))
      fail(path, "shape mismatch for '" + name + "': file " + src->shape_str() + ", model " + dst.shape_str());
    dst.copy_from_(*src);
  };
  for (const auto& p : reg.params) load(p.name, p.var.value());
  for (const auto& b : reg.buffers) load(b.name, b.tensor);
  if (const Tensor* mean = f.find("norm.mean")) {
    const Tensor* inv = f.find("norm.inv_std");
    if (!inv || !inv->same_shape(*mean) || mean->rows() != 1 || mean->cols() != cfg.in_dim)
      fail(path, "normalisation statistics norm.mean / norm.inv_std are missing or mis-shaped");
    out.norm.mean = *mean;
    out.norm.inv_std = *inv;
  }
  if (auto ts = f.metadata.find("target_scale"); ts != f.metadata.end()) out.norm.target_scale = std::stof(ts->second);
  if (auto r = f.metadata.find("model_rng"); r != f.metadata.end()) {
    std::istringstream is(r->second);
    is >> m->rng().engine();
    if (!is) fail(path, "corrupted model_rng state");
  }
  out.model = std::move(m);
  return out;
}

void restore_training_state(const CheckpointFile& f, Trainer& t, const std::string& path) {
  auto meta = [&](const char* k) {
    auto it = f.metadata.find(k);
    if (it == f.metadata.end()) fail(path, std::string("no training state ('") + k + "' missing): cannot resume");
    return it->second;
  };
  const auto& params = t.model().registry().params;
  for (std::size_t k = 0; k < params.size(); ++k) {
    for (int mv = 0; mv < 2; ++mv) {
      const std::string name = (mv ? "optim.v." : "optim.m.") + params[k].name;
      const Tensor* src = f.find(name);
      if (!src) fail(path, "missing optimiser tensor '" + name + "': cannot resume");
      Tensor& dst = mv ? t.optimiser().second_moments()[k] : t.optimiser().first_moments()[k];
      if (!src->same_shape(dst)) fail(path, "shape mismatch for '" + name + "'");
      if (dst.device() == Device::cpu) dst.copy_from_(*src);
      else backend(dst.device()).copy(to(*src, dst.device()), dst);  // uploaded explicitly
    }
  }
  try {
    t.set_epoch(std::stoi(meta("epoch")));
    t.optimiser().set_lr(std::stof(meta("lr")));
    t.optimiser().set_steps(std::stol(meta("adam_steps")));
    t.plateau().best = std::stof(meta("plateau_best"));
    t.plateau().has_best = meta("plateau_has_best") == "1";
    t.plateau().bad_epochs = std::stoi(meta("plateau_bad_epochs"));
    // Absent in checkpoints written before the key existed.
    t.plateau().on_validation = f.metadata.count("plateau_on_validation") && f.metadata.at("plateau_on_validation") == "1";
  } catch (const std::logic_error&) {
    fail(path, "corrupted training state in the metadata");
  }
  std::istringstream is(meta("rng"));
  is >> t.rng().engine();
  if (!is) fail(path, "corrupted rng state");
}

}  // namespace gatcore::models
