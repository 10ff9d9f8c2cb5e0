// Checkpoints: bit-exact round trip, resume = uninterrupted training, and
// every kind of bad file rejected with a message naming file and problem.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>

#include "checkpoint_v1.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "model_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

std::string tmp_path(const std::string& name) { return "test_checkpoint_" + name + ".gcm"; }

std::string slurp(const std::string& p) {
  std::ifstream is(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
}
void spit(const std::string& p, const std::string& s) {
  std::ofstream os(p, std::ios::binary | std::ios::trunc);
  os.write(s.data(), std::streamsize(s.size()));
}

ModelConfig small_config(const std::string& name) {
  ModelConfig c = ModelConfig::defaults(name, 9, name == "neuroskinning" ? 5 : 3);
  c.modules = 2;
  c.blocks = 2;
  c.heads = 2;
  c.head_dim = 4;
  c.transform = {8};
  c.head = {16};
  c.stage1 = {16};
  c.gc_heads = {2, 1, 1};
  c.gc_dims = {8, 8, 8};
  c.gc_pool = {4, 6, 8};
  c.global_mlp = {16};
  c.classifier = {16};
  return c;
}

std::vector<Sample> data_for(const ModelConfig& c) {
  const bool w = c.task == Task::weights;
  return {fixtures::wave_sample(7, 6, 0.f, w), fixtures::wave_sample(7, 6, 0.9f, w), fixtures::wave_sample(6, 6, 0.4f, w)};
}

}  // namespace

TEST_CASE("checkpoint round trip is bit-exact, including BatchNorm running stats and normalisation") {
  for (const std::string name : {"densegats", "neuroskinning"}) {
    INFO("model " << name);
    ModelConfig cfg = small_config(name);
    auto m = make_model(cfg, 11);
    auto data = data_for(cfg);
    Normaliser norm = Normaliser::fit(data, cfg.task == Task::displacement);
    TrainOptions o = TrainOptions::defaults_for(cfg);
    o.sampling = Sampling::full;
    o.batch_size = 2;
    Trainer t(*m, o, norm);
    t.run_epoch(data);
    t.run_epoch(data);
    const std::string path = tmp_path(name);
    save_checkpoint(path, *m, norm, &t, {{"skeleton", "hips,spine,arm"}});
    LoadedModel l = load_checkpoint(path);
    CHECK(l.model->config() == cfg);
    CHECK(l.file.metadata.at("skeleton") == "hips,spine,arm");
    for (const auto& p : m->registry().params)
      CHECK(l.model->registry().find_param(p.name)->value().to_vector() == p.var.value().to_vector());
    for (const auto& b : m->registry().buffers)
      CHECK(l.model->registry().find_buffer(b.name)->to_vector() == b.tensor.to_vector());
    CHECK(l.norm.mean.to_vector() == norm.mean.to_vector());
    CHECK(l.norm.inv_std.to_vector() == norm.inv_std.to_vector());
    CHECK(l.norm.target_scale == norm.target_scale);
    // Identical outputs on a full mesh.
    Tensor a = predict(*m, data[0], norm), b = predict(*l.model, data[0], l.norm);
    CHECK(a.to_vector() == b.to_vector());
    std::remove(path.c_str());
  }
}

TEST_CASE("resuming from a checkpoint gives the same next epoch as uninterrupted training") {
  ModelConfig cfg = small_config("densegats");
  auto data = data_for(cfg);
  Normaliser norm = Normaliser::fit(data, true);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.sample_vertices = 20;  // consecutive sampling: exercises the RNG
  o.batch_size = 2;
  o.seed = 3;
  auto m = make_model(cfg, 5);
  Trainer t(*m, o, norm);
  t.run_epoch(data, {data[2]});
  t.run_epoch(data, {data[2]});
  const std::string path = tmp_path("resume");
  save_checkpoint(path, *m, norm, &t);
  const EpochStats uninterrupted = t.run_epoch(data, {data[2]});

  LoadedModel l = load_checkpoint(path);
  Trainer t2(*l.model, o, l.norm);
  restore_training_state(l.file, t2, path);
  CHECK(t2.epoch() == 2);
  const EpochStats resumed = t2.run_epoch(data, {data[2]});
  CHECK(resumed.epoch == 3);
  CHECK(resumed.train_loss == uninterrupted.train_loss);
  CHECK(resumed.val_loss == uninterrupted.val_loss);
  CHECK(resumed.lr == uninterrupted.lr);
  for (const auto& p : m->registry().params)
    CHECK(l.model->registry().find_param(p.name)->value().to_vector() == p.var.value().to_vector());
  std::remove(path.c_str());
}

TEST_CASE("weight averaging: the average follows its rule, validation and checkpoints use it, a resume continues it") {
  ModelConfig cfg = small_config("densegats");
  auto data = data_for(cfg);
  Normaliser norm = Normaliser::fit(data, true);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.sample_vertices = 20;
  o.batch_size = 1;  // three steps an epoch
  o.seed = 3;
  o.average_decay = 0.75f;
  auto m = make_model(cfg, 5);
  Trainer t(*m, o, norm);
  REQUIRE(t.averaging());
  const auto& params = m->registry().params;
  // Averaged: the parameters, then the buffers (BatchNorm statistics).
  std::vector<Tensor> live;
  for (const auto& p : params) live.push_back(p.var.value());
  for (const auto& b : m->registry().buffers) live.push_back(b.tensor);
  REQUIRE(m->registry().buffers.size() > 0);
  REQUIRE(t.averaged().size() == live.size());
  // The rule, in double beside the trainer: after step s (counted from 1)
  // avg = d avg + (1 - d) param, d = min(decay, (1 + s) / (10 + s)).
  std::vector<std::vector<double>> expect;
  for (const Tensor& x : live) {
    const auto v = x.to_vector();
    expect.emplace_back(v.begin(), v.end());
  }
  const auto follow = [&](int, std::int64_t, std::int64_t, double) {
    const double s = double(t.optimiser().steps());
    const double d = std::min(0.75, (1 + s) / (10 + s));
    for (std::size_t k = 0; k < live.size(); ++k) {
      const auto v = live[k].to_vector();
      for (std::size_t i = 0; i < v.size(); ++i) expect[k][i] = d * expect[k][i] + (1 - d) * double(v[i]);
    }
  };
  for (int e = 0; e < 4; ++e) t.run_epoch(data, {}, follow);
  CHECK(t.optimiser().steps() == 12);
  double gap = 0;  // the average is not the last step's weights
  for (std::size_t k = 0; k < live.size(); ++k) {
    const auto a = t.averaged()[k].to_vector(), v = live[k].to_vector();
    for (std::size_t i = 0; i < a.size(); ++i) {
      CHECK(a[i] == Approx(expect[k][i]).margin(1e-6));
      gap = std::max(gap, std::abs(double(a[i]) - double(v[i])));
    }
  }
  CHECK(gap > 1e-4);

  // Validation runs on the average and leaves the last step's weights in place.
  const auto raw_before = params[0].var.value().to_vector();
  const EpochStats st = t.run_epoch(data, {data[2]});
  const auto raw = params[0].var.value().to_vector();
  CHECK(raw != raw_before);
  double on_raw = t.validate({data[2]}).loss;
  {
    AveragedWeightsScope averaged(t);
    CHECK(params[0].var.value().to_vector() != raw);
    CHECK(t.validate({data[2]}).loss == st.val_loss);
  }
  CHECK(params[0].var.value().to_vector() == raw);
  CHECK(on_raw != st.val_loss);

  // The checkpoint's model is the average; the last step's weights ride along.
  const std::string path = tmp_path("average");
  save_checkpoint(path, *m, norm, &t);
  CHECK(params[0].var.value().to_vector() == raw);
  const auto& buffer = m->registry().buffers.front();
  const auto raw_buffer = buffer.tensor.to_vector(), averaged_buffer = t.averaged()[params.size()].to_vector();
  CHECK(raw_buffer != averaged_buffer);
  const EpochStats uninterrupted = t.run_epoch(data, {data[2]});
  LoadedModel l = load_checkpoint(path);
  CHECK(l.file.metadata.at("average_decay") == "0.75");
  CHECK(read_training_progress(l.file, path).average_decay == 0.75);
  REQUIRE(l.file.find("optim.raw." + params[0].name));
  CHECK(l.file.find("optim.raw." + params[0].name)->to_vector() == raw);
  CHECK(l.model->registry().find_param(params[0].name)->value().to_vector() != raw);
  REQUIRE(l.file.find("optim.raw." + buffer.name));
  CHECK(l.file.find("optim.raw." + buffer.name)->to_vector() == raw_buffer);
  CHECK(l.model->registry().find_buffer(buffer.name)->to_vector() == averaged_buffer);

  // Resuming continues the same run: same losses, same average, same weights.
  Trainer t2(*l.model, o, l.norm);
  restore_training_state(l.file, t2, path);
  const EpochStats resumed = t2.run_epoch(data, {data[2]});
  CHECK(resumed.train_loss == uninterrupted.train_loss);
  CHECK(resumed.val_loss == uninterrupted.val_loss);
  for (std::size_t k = 0; k < params.size(); ++k)
    CHECK(l.model->registry().params[k].var.value().to_vector() == params[k].var.value().to_vector());
  for (std::size_t k = 0; k < m->registry().buffers.size(); ++k)
    CHECK(l.model->registry().buffers[k].tensor.to_vector() == m->registry().buffers[k].tensor.to_vector());
  for (std::size_t k = 0; k < live.size(); ++k) CHECK(t2.averaged()[k].to_vector() == t.averaged()[k].to_vector());

  // A file with the last step's weights of only some parameters is refused.
  CheckpointFile partial = l.file;
  std::erase_if(partial.tensors, [&](const auto& nt) { return nt.first == "optim.raw." + params[0].name; });
  const std::string bad = tmp_path("average_partial");
  write_checkpoint_file(bad, partial);
  LoadedModel lp = load_checkpoint(bad);
  Trainer t3(*lp.model, o, lp.norm);
  CHECK_THROWS_WITH(restore_training_state(lp.file, t3, bad),
                    Catch::Contains(bad) && Catch::Contains("optim.raw") && Catch::Contains("cannot resume"));
  // Bad last-step tensors and decays are refused by name.
  CheckpointFile odd = l.file;
  odd.tensors.emplace_back("optim.raw.no_such_param", Tensor::zeros(1, 1));
  write_checkpoint_file(bad, odd);
  CHECK_THROWS_WITH(load_checkpoint(bad), Catch::Contains("unknown tensor 'optim.raw.no_such_param'"));
  CheckpointFile misshaped = l.file;
  for (auto& [name, x] : misshaped.tensors)
    if (name == "optim.raw." + params[0].name) x = Tensor::zeros(1, 1);
  write_checkpoint_file(bad, misshaped);
  LoadedModel lm = load_checkpoint(bad);
  Trainer t4(*lm.model, o, lm.norm);
  CHECK_THROWS_WITH(restore_training_state(lm.file, t4, bad),
                    Catch::Contains("shape mismatch for 'optim.raw." + params[0].name + "'"));
  CheckpointFile decay = l.file;
  decay.metadata["average_decay"] = "1.5";
  CHECK_THROWS_WITH(read_training_progress(decay, bad), Catch::Contains("average_decay"));
  // A decay of 1 would never move.
  TrainOptions one = o;
  one.average_decay = 1.f;
  CHECK_THROWS_WITH(Trainer(*m, one, norm), Catch::Contains("weight-average decay 1"));
  std::remove(path.c_str());
  std::remove(bad.c_str());
}

TEST_CASE("a checkpoint says how far its trainer got") {
  ModelConfig cfg = small_config("densegats");
  auto data = data_for(cfg);
  Normaliser norm = Normaliser::fit(data, true);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.batch_size = 2;
  o.lr = 3e-3f;
  auto m = make_model(cfg, 5);
  Trainer t(*m, o, norm);
  t.run_epoch(data);
  t.run_epoch(data);
  const std::string path = tmp_path("progress");
  save_checkpoint(path, *m, norm, &t);
  const TrainingProgress p = read_training_progress(load_checkpoint(path).file, path);
  CHECK(p.epoch == 2);
  CHECK(p.lr == double(t.optimiser().lr()));
  CHECK(p.adam_steps == t.optimiser().steps());
  CHECK(p.adam_steps > 0);
  CHECK(p.resumable);
  // A model saved without its trainer: nothing to resume from.
  save_checkpoint(path, *m, norm, nullptr);
  const TrainingProgress bare = read_training_progress(load_checkpoint(path).file, path);
  CHECK(bare.epoch == 0);
  CHECK(bare.lr < 0);
  CHECK(bare.adam_steps == 0);
  CHECK_FALSE(bare.resumable);
  std::remove(path.c_str());
  CheckpointFile edited;
  edited.metadata = {{"epoch", "2"}, {"lr", "nan"}};
  CHECK_THROWS_WITH(read_training_progress(edited, "e.gcm"), Catch::Contains("e.gcm") && Catch::Contains("lr"));
}

TEST_CASE("bad checkpoint files are rejected with messages naming the file and the problem") {
  ModelConfig cfg = small_config("densegats");
  auto m = make_model(cfg, 1);
  const std::string good = tmp_path("good"), bad = tmp_path("bad");
  save_checkpoint(good, *m, Normaliser{});
  const std::string bytes = slurp(good);
  auto rejects = [&](const std::string& contents, const std::string& msg) {
    spit(bad, contents);
    INFO("expecting: " << msg);
    CHECK_THROWS_WITH(load_checkpoint(bad), Catch::Contains("checkpoint '" + bad + "'") && Catch::Contains(msg));
  };
  SECTION("missing") {
    CHECK_THROWS_WITH(load_checkpoint("no_such_file.gcm"), Catch::Contains("'no_such_file.gcm': cannot open"));
  }
  SECTION("truncated") {
    rejects(bytes.substr(0, 5), "truncated");
    rejects(bytes.substr(0, 40), "truncated");
    rejects(bytes.substr(0, bytes.size() / 2), "truncated");
    rejects(bytes.substr(0, bytes.size() - 4), "truncated");
  }
  SECTION("not a gatcore checkpoint: recognised by the format metadata key") {
    rejects("PK\x03\x04 this is a zip file, not a model at all", "not a safetensors file");
    std::string other = bytes;
    other.replace(other.find("gatcore-checkpoint"), 7, "torchxx");
    rejects(other, "not a gatcore checkpoint: metadata \"format\" is 'torchxx-checkpoint'");
    const std::string plain = "{\"w\":{\"dtype\":\"F32\",\"shape\":[1,1],\"data_offsets\":[0,4]}}";
    std::string st(8, '\0');
    st[0] = char(plain.size());
    rejects(st + plain + "abcd", "not a gatcore checkpoint: a safetensors file without __metadata__");
  }
  SECTION("edited header: the checksum covers the metadata") {
    std::string c = bytes;
    const auto at = c.find("\"target_scale\":\"1\"");
    REQUIRE(at != std::string::npos);
    c[at + 16] = '2';
    rejects(c, "checksum mismatch");
  }
  SECTION("sizes from the file are checked before any product is formed") {
    // Shape [2^62, 4] with 0 bytes of data: rows * cols * 4 wraps to 0.
    CheckpointFile f;
    f.metadata["config"] = "x";
    const std::string ok = checkpoint_bytes(f);
    std::string hdr = ok.substr(8);  // no tensors: no data section
    while (hdr.back() == ' ') hdr.pop_back();
    hdr.pop_back();  // the closing brace
    hdr += ",\"norm.mean\":{\"dtype\":\"F32\",\"shape\":[4611686018427387904,4],\"data_offsets\":[0,0]}}";
    std::string len(8, '\0');
    for (int k = 0; k < 8; ++k) len[std::size_t(k)] = char((hdr.size() >> (8 * k)) & 0xff);
    spit(bad, len + hdr);
    CHECK_THROWS_WITH(read_checkpoint_file(bad), Catch::Contains("do not match shape [4611686018427387904, 4]"));
    // A tensor without data ([r, 0], [0, c]): no product to check, but a loop
    // over 2^62 empty rows never ended (fuzz_checkpoint, tests/fuzz/found).
    // Its sides are capped at 2^24; smaller empty tensors still read.
    const auto with_tensor = [&](const std::string& shape) {
      std::string h = ok.substr(8);
      while (h.back() == ' ') h.pop_back();
      h.pop_back();
      h += ",\"norm.mean\":{\"dtype\":\"F32\",\"shape\":" + shape + ",\"data_offsets\":[0,0]}}";
      std::string n(8, '\0');
      for (int k = 0; k < 8; ++k) n[std::size_t(k)] = char((h.size() >> (8 * k)) & 0xff);
      return n + h;
    };
    for (const char* shape : {"[4611686018427387903,0]", "[0,4611686018427387903]", "[16777217,0]"}) {
      INFO(shape);
      spit(bad, with_tensor(shape));
      CHECK_THROWS_WITH(read_checkpoint_file(bad), Catch::Contains("out of range (a tensor without data may have at "
                                                                   "most 16777216 rows or columns)"));
    }
    spit(bad, with_tensor("[16777216,0]"));  // read; then refused by its checksum (none in this header)
    CHECK_THROWS_WITH(read_checkpoint_file(bad), Catch::Contains("checksum mismatch"));
    std::string huge = bytes;
    huge[7] = 0x7f;  // header length ~ 2^63
    rejects(huge, "header length");
  }
  SECTION("corrupted data") {
    std::string c = bytes;
    c[c.size() - 3] ^= 0x40;
    rejects(c, "checksum mismatch");
    rejects(bytes + "junk", "trailing bytes");
  }
  SECTION("unknown tensor, missing tensor, shape mismatch, bad config") {
    CheckpointFile f = read_checkpoint_file(good);
    CheckpointFile u = f;
    u.tensors.emplace_back("modules.9.blocks.0.W", Tensor::zeros(2, 2));
    write_checkpoint_file(bad, u);
    CHECK_THROWS_WITH(load_checkpoint(bad), Catch::Contains("unknown tensor 'modules.9.blocks.0.W'"));
    CheckpointFile mi = f;
    mi.tensors.erase(mi.tensors.begin());
    write_checkpoint_file(bad, mi);
    CHECK_THROWS_WITH(load_checkpoint(bad), Catch::Contains("missing tensor 'transform.0.lin.W'"));
    CheckpointFile sh = f;
    sh.tensors[0].second = Tensor::zeros(9, 7);
    write_checkpoint_file(bad, sh);
    CHECK_THROWS_WITH(load_checkpoint(bad),
                      Catch::Contains("shape mismatch for 'transform.0.lin.W': file [9, 7], model [9, 8]"));
    CheckpointFile bc = f;
    bc.metadata["config"] = "name = densegats\nheads = lots\n";
    write_checkpoint_file(bad, bc);
    CHECK_THROWS_WITH(load_checkpoint(bad), Catch::Contains("bad model configuration"));
    CheckpointFile v = f;
    write_checkpoint_file(bad, v);
    std::string vb = slurp(bad);
    vb.replace(vb.find("\"format_version\":\"2\""), 20, "\"format_version\":\"7\"");
    rejects(vb, "unsupported format version '7'");
    // A checkpoint without training state can't resume.
    LoadedModel l = load_checkpoint(good);
    Trainer t(*l.model, TrainOptions{}, l.norm);
    CHECK_THROWS_WITH(restore_training_state(l.file, t, good), Catch::Contains("cannot resume"));
  }
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

TEST_CASE("checkpoint writes are atomic: no temp file left, an existing file is replaced whole") {
  auto m = make_model(small_config("origat"), 1);
  const std::string path = tmp_path("atomic");
  spit(path, "old contents");
  save_checkpoint(path, *m, Normaliser{});
  CHECK_FALSE(std::ifstream(path + ".tmp").good());
  CHECK_NOTHROW(load_checkpoint(path));
  CHECK_THROWS_WITH(save_checkpoint("/nonexistent_dir/x.gcm", *m, Normaliser{}),
                    Catch::Contains("/nonexistent_dir/x.gcm") && Catch::Contains("No such file"));
  // A temp file left by a process killed mid-write is cleaned by the next write.
  spit(path + ".tmp", "half a checkpoint");
  save_checkpoint(path, *m, Normaliser{});
  CHECK_FALSE(std::ifstream(path + ".tmp").good());
  CHECK_NOTHROW(load_checkpoint(path));
  auto f = make_model(small_config("fc"), 1);
  f->fold_batch_norm();
  CHECK_THROWS_WITH(save_checkpoint(path, *f, Normaliser{}), Catch::Contains("folded"));
  std::remove(path.c_str());
}

namespace {
// A resumable checkpoint of a small trained model, at `path`.
void save_trained(const std::string& path) {
  ModelConfig cfg = small_config("densegats");
  auto m = make_model(cfg, 3);
  const auto data = data_for(cfg);
  const Normaliser norm = Normaliser::fit(data, true);
  TrainOptions o = TrainOptions::defaults_for(cfg);
  o.batch_size = 2;
  Trainer t(*m, o, norm);
  t.run_epoch(data);
  save_checkpoint(path, *m, norm, &t);
}
}  // namespace

TEST_CASE("checkpoint metadata is validated: non-finite or out-of-range hyperparameters are refused by name") {
  const std::string good = tmp_path("meta_good"), bad = tmp_path("meta_bad");
  save_trained(good);
  const CheckpointFile f = read_checkpoint_file(good);
  auto resume = [&](const std::string& key, const std::string& value) {
    CheckpointFile e = f;
    e.metadata[key] = value;
    write_checkpoint_file(bad, e);  // a valid checksum over the edited value
    LoadedModel l = load_checkpoint(bad);
    Trainer t(*l.model, TrainOptions{}, l.norm);
    restore_training_state(l.file, t, bad);
  };
  for (const auto& [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"lr", "nan"}, {"lr", "inf"}, {"lr", "-0.1"}, {"lr", "0.001x"}, {"epoch", "-3"}, {"epoch", "1e20"},
           {"epoch", "2.5"}, {"adam_steps", ""}, {"plateau_best", "nan"}, {"plateau_has_best", "yes"},
           {"plateau_bad_epochs", "-1"}, {"target_scale", "abc"}, {"target_scale", "0"}}) {
    INFO(key << " = '" << value << "'");
    CHECK_THROWS_WITH(resume(key, value), Catch::Contains("checkpoint '" + bad + "'") &&
                                              Catch::Contains("metadata '" + key + "' = '" + value + "'"));
  }
  CHECK_NOTHROW(resume("lr", "0.0005"));
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

TEST_CASE("the checkpoint checksum does not depend on the order of tensors in the file") {
  const std::string a = tmp_path("order_a"), b = tmp_path("order_b");
  save_trained(a);
  CheckpointFile f = read_checkpoint_file(a);
  std::reverse(f.tensors.begin(), f.tensors.end());  // other order, other offsets
  f.metadata.erase("checksum");
  write_checkpoint_file(b, f);
  CHECK(read_checkpoint_file(b).metadata.at("checksum") == read_checkpoint_file(a).metadata.at("checksum"));
  CHECK(slurp(a) != slurp(b));
  LoadedModel l = load_checkpoint(b);
  Trainer t(*l.model, TrainOptions{}, l.norm);
  CHECK_NOTHROW(restore_training_state(l.file, t, b));
  std::remove(a.c_str());
  std::remove(b.c_str());
}

using testutil::version_1_bytes;

TEST_CASE("version-1 checkpoints: refused with the way out, upgraded after their data checksum is verified") {
  const std::string v2 = tmp_path("v2"), v1 = tmp_path("v1"), up = tmp_path("up"), bad = tmp_path("v1bad");
  save_trained(v2);
  spit(v1, version_1_bytes(slurp(v2)));
  CHECK_THROWS_WITH(load_checkpoint(v1), Catch::Contains(v1) && Catch::Contains("unsupported format version '1'") &&
                                             Catch::Contains("gat upgrade-checkpoint " + v1));
  CHECK(upgrade_checkpoint(v1, up) == 1);
  LoadedModel a = load_checkpoint(v2), b = load_checkpoint(up);
  CHECK(b.file.metadata.at("format_version") == "2");
  CHECK(b.file.metadata == a.file.metadata);  // the same contents, the version-2 checksum
  REQUIRE(b.file.tensors.size() == a.file.tensors.size());
  for (std::size_t i = 0; i < a.file.tensors.size(); ++i) {
    const Tensor* t = b.file.find(a.file.tensors[i].first);
    REQUIRE(t);
    CHECK(t->to_vector() == a.file.tensors[i].second.to_vector());
  }
  // Its data changed: the version-1 checksum catches it, nothing is written.
  std::string bytes = version_1_bytes(slurp(v2));
  bytes[bytes.size() - 3] ^= 0x10;
  spit(bad, bytes);
  std::remove(up.c_str());
  CHECK_THROWS_WITH(upgrade_checkpoint(bad, up), Catch::Contains("version-1 checksum mismatch") && Catch::Contains(bad));
  CHECK_FALSE(std::ifstream(up).good());
  // A version-2 file passes through (and may be upgraded in place).
  CHECK(upgrade_checkpoint(v2, v2) == 2);
  CHECK(load_checkpoint(v2).file.metadata == a.file.metadata);
  for (const std::string& p : {v2, v1, up, bad}) std::remove(p.c_str());
}

// Driven by tests/python/resave_checkpoint.py (ctest checkpoint_python_resave):
// writes a resumable checkpoint to $GATCORE_CKPT, or checks that the file
// Python re-saved ($GATCORE_CKPT_RESAVED) holds the same model and state.
TEST_CASE("python resave: write", "[.python-write]") {
  const char* p = std::getenv("GATCORE_CKPT");
  REQUIRE(p);
  save_trained(p);
}

TEST_CASE("python resave: read", "[.python-read]") {
  const char* p = std::getenv("GATCORE_CKPT");
  const char* q = std::getenv("GATCORE_CKPT_RESAVED");
  REQUIRE(p);
  REQUIRE(q);
  REQUIRE(slurp(p) != slurp(q));  // really a different file layout
  const CheckpointFile a = read_checkpoint_file(p), b = read_checkpoint_file(q);
  CHECK(a.metadata == b.metadata);
  REQUIRE(a.tensors.size() == b.tensors.size());
  for (const auto& [name, t] : a.tensors) {
    const Tensor* u = b.find(name);
    REQUIRE(u);
    REQUIRE(u->same_shape(t));
    for (std::int64_t r = 0; r < t.rows(); ++r)
      for (std::int64_t c = 0; c < t.cols(); ++c) CHECK(u->at(r, c) == t.at(r, c));
  }
  LoadedModel l = load_checkpoint(q);
  Trainer t(*l.model, TrainOptions{}, l.norm);
  CHECK_NOTHROW(restore_training_state(l.file, t, q));
}
