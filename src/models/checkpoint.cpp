#include "gatcore/models/checkpoint.hpp"
#include "gatcore/backend.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "gatcore/atomic_file.hpp"

namespace gatcore::models {
namespace {

// ordered_json: tensors keep their file order, metadata is written first.
using json = nlohmann::ordered_json;

constexpr const char* kFormat = "gatcore-checkpoint";
// 2: the checksum covers the metadata and every tensor's name, shape and
// data, independently of the order and offsets in the file (version 1 covered
// the data section only, so an edited header went unnoticed).
constexpr const char* kVersion = "2";
// safetensors' own limit on the header: a bigger length is a corrupted file.
constexpr std::uint64_t kMaxHeader = 100u << 20;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw CheckpointError("checkpoint '" + path + "': " + what);
}

struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  void add_str(const std::string& s) { add(s.data(), s.size() + 1); }  // with its NUL: "ab"+"c" != "a"+"bc"
  void add_u64(std::uint64_t v) {
    unsigned char b[8];
    for (int k = 0; k < 8; ++k) b[k] = static_cast<unsigned char>(v >> (8 * k));
    add(b, 8);
  }
};

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// The largest side of a tensor without data ([r, 0] or [0, c]) a file may
// declare: far above any layer width, far below a side whose loop would hang.
constexpr std::uint64_t kMaxEmptyTensorSide = std::uint64_t(1) << 24;

// The checksum of a checkpoint: every metadata entry but "checksum" (sorted by
// key), then every tensor sorted by name: name, shape, row-major f32 bytes.
// Independent of the tensors' order in the file, so a file re-saved by
// Python's safetensors with the same metadata still verifies.
std::string checksum(const std::map<std::string, std::string>& meta,
                     const std::vector<std::pair<std::string, Tensor>>& tensors) {
  Fnv1a h;
  for (const auto& [k, v] : meta)
    if (k != "checksum") h.add_str(k), h.add_str(v);
  std::vector<const std::pair<std::string, Tensor>*> order;
  for (const auto& t : tensors) order.push_back(&t);
  std::sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->first < b->first; });
  for (const auto* t : order) {
    h.add_str(t->first);
    h.add_u64(std::uint64_t(t->second.rows()));
    h.add_u64(std::uint64_t(t->second.cols()));
    if (t->second.cols() > 0)  // (no bytes in an empty tensor's rows)
      for (std::int64_t r = 0; r < t->second.rows(); ++r)
        h.add(t->second.row(r), std::size_t(t->second.cols()) * sizeof(float));
  }
  return hex(h.h);
}

void put_u64(std::string& out, std::uint64_t v) {
  for (int k = 0; k < 8; ++k) out += char((v >> (8 * k)) & 0xff);
}

// A non-negative JSON integer, or nullopt (a float, a negative number, a string).
std::optional<std::uint64_t> unsigned_of(const json& j) {
  if (!j.is_number_unsigned()) return std::nullopt;
  return j.get<std::uint64_t>();
}

}  // namespace

const Tensor* CheckpointFile::find(const std::string& name) const {
  for (const auto& t : tensors)
    if (t.first == name) return &t.second;
  return nullptr;
}

std::string checkpoint_bytes(const CheckpointFile& f) {
  std::set<std::string> names;
  for (const auto& [name, t] : f.tensors) {
    GATCORE_CHECK(t.defined() && t.dtype() == DType::f32, "checkpoint: tensor '", name, "' is not a defined f32 tensor");
    GATCORE_CHECK(name != "__metadata__", "checkpoint: reserved tensor name");
    GATCORE_CHECK(names.insert(name).second, "checkpoint: tensor '", name, "' given twice");
  }
  std::map<std::string, std::string> meta = f.metadata;
  meta["format"] = kFormat;
  meta["format_version"] = kVersion;
  meta["checksum"] = checksum(meta, f.tensors);
  json header = json::object();
  header["__metadata__"] = json(meta);
  std::string data;
  for (const auto& [name, t] : f.tensors) {
    const std::size_t begin = data.size();
    for (std::int64_t r = 0; r < t.rows(); ++r)
      data.append(reinterpret_cast<const char*>(t.row(r)), std::size_t(t.cols()) * sizeof(float));
    header[name] = {{"dtype", "F32"}, {"shape", {t.rows(), t.cols()}}, {"data_offsets", {begin, data.size()}}};
  }
  std::string text = header.dump();
  while (text.size() % 8) text += ' ';
  std::string out;
  put_u64(out, text.size());
  out += text;
  out += data;
  return out;
}

void write_checkpoint_file(const std::string& path, const CheckpointFile& f) {
  const std::string bytes = checkpoint_bytes(f);
  try {
    write_file_atomic(path, bytes);
  } catch (const Error& e) {
    throw CheckpointError(std::string("checkpoint ") + e.what());
  }
}

namespace {

// allow_version_1: also read format version 1 (checksum over the data section
// only), verified as such; the result is then written as version 2.
CheckpointFile parse_checkpoint_impl(std::string_view bytes, const std::string& path, bool allow_version_1) {
  if (bytes.size() < 8) fail(path, detail::cat("truncated: ", bytes.size(), " bytes, not even a header length"));
  std::uint64_t n = 0;
  for (int k = 0; k < 8; ++k) n |= std::uint64_t(static_cast<unsigned char>(bytes[std::size_t(k)])) << (8 * k);
  if (bytes.size() == 8 || bytes[8] != '{')
    fail(path, "not a safetensors file (no JSON header after the 8-byte length), so not a gatcore checkpoint");
  if (n > kMaxHeader) fail(path, detail::cat("corrupted: header length ", n, " bytes (at most ", kMaxHeader, ")"));
  if (n > bytes.size() - 8)
    fail(path, detail::cat("truncated: the header needs ", n, " bytes, the file has ", bytes.size() - 8, " after the length"));
  const std::string_view text = bytes.substr(8, std::size_t(n));
  const json root = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (root.is_discarded()) fail(path, "corrupted header: not valid JSON");
  if (!root.is_object()) fail(path, "corrupted header: not a JSON object");
  CheckpointFile f;
  const auto meta = root.find("__metadata__");
  if (meta == root.end() || !meta->is_object())
    fail(path, "not a gatcore checkpoint: a safetensors file without __metadata__ (expected \"format\": \"gatcore-checkpoint\")");
  for (const auto& [k, v] : meta->items()) {
    if (!v.is_string()) fail(path, "corrupted header: metadata '" + k + "' is not a string");
    f.metadata[k] = v.get<std::string>();
  }
  if (f.metadata["format"] != kFormat)
    fail(path, "not a gatcore checkpoint: metadata \"format\" is '" + f.metadata["format"] + "', expected '" + kFormat + "'");
  const bool version_1 = allow_version_1 && f.metadata["format_version"] == "1";
  if (f.metadata["format_version"] != kVersion && !version_1)
    fail(path, "unsupported format version '" + f.metadata["format_version"] + "' (this build reads version " + kVersion +
                   (f.metadata["format_version"] == "1"
                        ? "; version 1 checksums did not cover the header: `gat upgrade-checkpoint " + path +
                              " -o NEW.gcm` checks its data and writes it as version 2"
                        : "") +
                   ")");
  const std::size_t data_begin = 8 + std::size_t(n);
  const std::uint64_t data_size = bytes.size() - data_begin;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> spans;
  for (const auto& [name, v] : root.items()) {
    if (name == "__metadata__") continue;
    if (!v.is_object()) fail(path, "tensor '" + name + "': not an object");
    const auto dt = v.find("dtype");
    const auto shape = v.find("shape");
    const auto off = v.find("data_offsets");
    if (dt == v.end() || !dt->is_string() || dt->get<std::string>() != "F32")
      fail(path, "tensor '" + name + "': dtype must be F32");
    if (shape == v.end() || !shape->is_array() || shape->size() != 2 || off == v.end() || !off->is_array() ||
        off->size() != 2)
      fail(path, "tensor '" + name + "': shape must be [rows, cols] and data_offsets [begin, end]");
    const auto r = unsigned_of((*shape)[0]), c = unsigned_of((*shape)[1]);
    const auto b = unsigned_of((*off)[0]), e = unsigned_of((*off)[1]);
    if (!r || !c || !b || !e) fail(path, "tensor '" + name + "': shape and data_offsets must be non-negative integers");
    // Bounded by the file before any product is formed: no wrap-around.
    if (*e > data_size || *b > *e)
      fail(path, detail::cat("tensor '", name, "': data_offsets [", *b, ", ", *e, ") outside the ", data_size,
                             "-byte data section (truncated or corrupted)"));
    const std::uint64_t elems = (*e - *b) / sizeof(float);
    if ((*e - *b) % sizeof(float) != 0 || (*c == 0 ? elems != 0 : (*r > elems / *c || *r * *c != elems)))
      fail(path, detail::cat("tensor '", name, "': data_offsets [", *b, ", ", *e, ") do not match shape [", *r, ", ",
                             *c, "]"));
    // A tensor with data has both sides bounded by the data just checked; an
    // empty one ([r, 0] or [0, c]) is not, and a loop over its 4.6e18 rows
    // (fuzz_checkpoint, tests/fuzz/found) never ends: its sides are capped.
    if (*r > std::uint64_t(std::numeric_limits<std::int64_t>::max()) ||
        *c > std::uint64_t(std::numeric_limits<std::int64_t>::max()))
      fail(path, detail::cat("tensor '", name, "': shape [", *r, ", ", *c, "] out of range"));
    if (elems == 0 && std::max(*r, *c) > kMaxEmptyTensorSide)
      fail(path, detail::cat("tensor '", name, "': shape [", *r, ", ", *c, "] out of range (a tensor without data may ",
                             "have at most ", kMaxEmptyTensorSide, " rows or columns)"));
    spans.emplace_back(*b, *e);
    Tensor t = Tensor::empty(std::int64_t(*r), std::int64_t(*c));
    if (elems != 0) std::memcpy(t.data(), bytes.data() + data_begin + *b, *e - *b);
    f.tensors.emplace_back(name, t);
  }
  // safetensors: the tensors tile the data section, no gaps, no overlaps.
  std::sort(spans.begin(), spans.end());
  std::uint64_t at = 0;
  for (const auto& [b, e] : spans) {
    if (b != at) fail(path, detail::cat("corrupted: data bytes [", std::min(b, at), ", ", std::max(b, at), ") ",
                                        b > at ? "belong to no tensor" : "belong to two tensors"));
    at = e;
  }
  if (at != data_size) fail(path, detail::cat("corrupted: ", data_size - at, " trailing bytes after the last tensor"));
  if (version_1) {
    // Version 1: FNV-1a 64 of the data section's bytes.
    Fnv1a h;
    h.add(bytes.data() + data_begin, std::size_t(data_size));
    if (f.metadata["checksum"] != hex(h.h))
      fail(path, "corrupted: version-1 checksum mismatch (stored '" + f.metadata["checksum"] + "', data give " + hex(h.h) +
                     ")");
    return f;
  }
  const std::string sum = checksum(f.metadata, f.tensors);
  if (f.metadata["checksum"] != sum)
    fail(path, "corrupted: checksum mismatch (stored '" + f.metadata["checksum"] + "', header and data give " + sum + ")");
  return f;
}

std::string read_bytes(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::string bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  if (is.bad()) fail(path, "read error");
  return bytes;
}

}  // namespace

CheckpointFile parse_checkpoint(std::string_view bytes, const std::string& path) {
  return parse_checkpoint_impl(bytes, path, false);
}


CheckpointFile read_checkpoint_file(const std::string& path) { return parse_checkpoint(read_bytes(path), path); }

std::string metadata_text(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

// Metadata numbers, strictly: the whole string, finite, within [lo, hi];
// otherwise an error naming the key and the value (never std::stof's bare
// "stof", never a NaN learning rate resumed into an all-NaN model).
double metadata_number(const std::map<std::string, std::string>& meta, const std::string& key, double lo, double hi,
                       const std::string& path) {
  const auto it = meta.find(key);
  if (it == meta.end()) fail(path, "metadata '" + key + "' is missing");
  const std::string& s = it->second;
  char* end = nullptr;
  errno = 0;
  const double v = s.empty() || std::isspace(static_cast<unsigned char>(s[0])) ? NAN : std::strtod(s.c_str(), &end);
  if (!end || *end != '\0' || !std::isfinite(v) || v < lo || v > hi)
    fail(path, detail::cat("metadata '", key, "' = '", s, "' is not a finite number in [", lo, ", ", hi, "]"));
  return v;
}

std::int64_t metadata_integer(const std::map<std::string, std::string>& meta, const std::string& key, std::int64_t lo,
                              std::int64_t hi, const std::string& path) {
  const double v = metadata_number(meta, key, double(lo), double(hi), path);
  if (v != std::floor(v)) fail(path, detail::cat("metadata '", key, "' = '", meta.at(key), "' is not an integer"));
  return std::int64_t(v);
}

bool metadata_flag(const std::map<std::string, std::string>& meta, const std::string& key, const std::string& path) {
  const std::string& s = meta.at(key);
  if (s != "0" && s != "1") fail(path, "metadata '" + key + "' = '" + s + "' is not 0 or 1");
  return s == "1";
}

std::string metadata_text(nn::Rng& r) {
  std::ostringstream os;
  os << r.engine();
  return os.str();
}

CheckpointFile model_checkpoint(const Model& model, const Normaliser& norm,
                                const std::map<std::string, std::string>& extra, const std::string& path) {
  if (model.folded())
    fail(path, "the model's BatchNorms were folded for inference; save the unfolded model (load it again)");
  CheckpointFile f;
  f.metadata = extra;
  f.metadata["config"] = model.config().to_text();
  f.metadata["target_scale"] = metadata_text(norm.target_scale);
  // Downloaded first when the model lives on a device.
  for (const auto& p : model.registry().params) f.tensors.emplace_back(p.name, to(p.var.value(), Device::cpu));
  for (const auto& b : model.registry().buffers) f.tensors.emplace_back(b.name, to(b.tensor, Device::cpu));
  if (norm.defined()) {
    f.tensors.emplace_back("norm.mean", norm.mean);
    f.tensors.emplace_back("norm.inv_std", norm.inv_std);
  }
  f.metadata["model_rng"] = metadata_text(const_cast<Model&>(model).rng());
  return f;
}

void save_checkpoint(const std::string& path, const Model& model, const Normaliser& norm,
                     const std::map<std::string, std::string>& extra) {
  write_checkpoint_file(path, model_checkpoint(model, norm, extra, path));
}

namespace {

LoadedModel load_checkpoint_file(CheckpointFile file, const std::string& path) {
  LoadedModel out;
  out.file = std::move(file);
  const CheckpointFile& f = out.file;
  auto it = f.metadata.find("config");
  if (it == f.metadata.end()) fail(path, "no model configuration in the metadata");
  ModelConfig cfg;
  try {
    cfg = ModelConfig::from_text(it->second);
  } catch (const Error& e) {
    fail(path, std::string("bad model configuration: ") + e.what());
  }
  std::unique_ptr<Model> m;
  try {
    m = make_model(cfg, 0);
  } catch (const Error& e) {
    fail(path, std::string("bad model configuration: ") + e.what());
  }
  const auto& reg = m->registry();
  auto known = [&](const std::string& name) {
    return reg.find_param(name) || reg.find_buffer(name) || name == "norm.mean" || name == "norm.inv_std" ||
           (name.rfind("optim.m.", 0) == 0 && reg.find_param(name.substr(8))) ||
           (name.rfind("optim.v.", 0) == 0 && reg.find_param(name.substr(8))) ||
           (name.rfind("optim.raw.", 0) == 0 && (reg.find_param(name.substr(10)) || reg.find_buffer(name.substr(10))));
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
  if (f.metadata.count("target_scale"))
    out.norm.target_scale = float(metadata_number(f.metadata, "target_scale", 1e-30, 1e30, path));
  if (auto r = f.metadata.find("model_rng"); r != f.metadata.end()) {
    std::istringstream is(r->second);
    is >> m->rng().engine();
    if (!is) fail(path, "corrupted model_rng state");
  }
  out.model = std::move(m);
  return out;
}

}  // namespace

LoadedModel load_checkpoint(const std::string& path) { return load_checkpoint_file(read_checkpoint_file(path), path); }

CheckpointFile upgrade_checkpoint_bytes(std::string_view bytes, const std::string& path, int* version) {
  CheckpointFile f = parse_checkpoint_impl(bytes, path, true);
  if (version) *version = f.metadata.at("format_version") == "1" ? 1 : 2;
  f.metadata["format_version"] = kVersion;  // checkpoint_bytes writes the version-2 checksum
  (void)load_checkpoint_file(f, path);  // a model must load from it before anything is written
  return f;
}

int upgrade_checkpoint(const std::string& in, const std::string& out) {
  int version = 0;
  write_checkpoint_file(out, upgrade_checkpoint_bytes(read_bytes(in), in, &version));
  return version;
}

}  // namespace gatcore::models
