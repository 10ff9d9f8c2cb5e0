// Deploy-time inference (deploy.hpp): the forward passes of densegats.cpp /
// origat.cpp / nn::GatBlock / nn::DenseLayer replayed with the backend's
// forward kernels into buffers allocated once per plan. The order of kernel
// calls and their arguments follow those files exactly: that is what makes
// the results bitwise equal to models::predict (test_deploy checks it), so a
// change to a model's forward must be mirrored here.
#include "gatcore/models/deploy.hpp"

#include <algorithm>
#include <cmath>

#include "gatcore/backend.hpp"
#include "gatcore/vulkan.hpp"
#include "src/backends/cpu/inference.hpp"

namespace gatcore::models {

namespace {

// BatchNorm1d's eps: every model builds its BatchNorms with the default
// (nn::BatchNorm1d), which the registry does not record.
constexpr float kBatchNormEps = 1e-5f;

struct DenseStep {  // y = act(x W + b) (act identity: no activation call)
  Tensor W, b;
  cpu::PrepackedB Wp;  // CPU: W packed once for the product
  Activation act = Activation::identity;
  float slope = 0.f;
};

struct GatStep {  // nn::GatBlock in eval mode
  Tensor W, att_dst, att_src, self_W, self_b;
  int heads = 0, head_dim = 0;
  std::int64_t self_width = 0;
  float slope = 0.2f;
  bool bn = false;
  Tensor bn_mean, bn_scale, bn_shift;     // CPU: batchnorm_affine_forward
  Tensor bn_gamma, bn_beta, bn_rm, bn_rv;  // other devices: batchnorm_eval_forward
  // CPU: [W | self_W] packed once, one product for both streams (the 8-wide
  // self stream alone leaves most of each vector idle; each output column's
  // arithmetic is the same whichever panel computes it, so fp32 stays bitwise).
  cpu::PrepackedB Wp;
  std::int64_t kf() const { return std::int64_t(heads) * head_dim; }
  std::int64_t width() const { return kf() + self_width; }
};

struct OriLayer {
  Tensor W, att_dst, att_src, b;
  cpu::PrepackedB Wp;  // CPU
  int heads = 1;
  bool act = true;
};

}  // namespace

struct DeployModel {
  ModelConfig cfg;
  Device device = Device::cpu;
  Precision precision = Precision::fp32;  // of the CPU products
  Normaliser norm;  // host
  std::int64_t params = 0;
  bool origat = false;
  // densegats family
  std::vector<DenseStep> transform, head;
  std::vector<std::vector<GatStep>> modules;
  std::vector<GatStep> transitions;
  std::vector<std::int64_t> module_in;
  bool dense = true;
  // origat
  std::vector<OriLayer> layers;
  // config.linear_skip (either family): x W + b on the normalised input, added
  // to the network's output. Always fp32: it carries most of the correction
  // (the least-squares part) and costs a [n x in] x [in x 3] product.
  bool has_skip = false;
  DenseStep skip;
};

namespace {

class Loader {
 public:
  Loader(const Model& m, Device d, std::int64_t& count) : reg_(m.registry()), name_(m.config().name), dev_(d), count_(count) {}
  Tensor param(const std::string& name) {
    const Var* p = reg_.find_param(name);
    GATCORE_CHECK(p, "deploy: model '", name_, "' has no parameter '", name, "'");
    return place(p->value());
  }
  Tensor buffer(const std::string& name) {
    const Tensor* t = reg_.find_buffer(name);
    GATCORE_CHECK(t, "deploy: model '", name_, "' has no buffer '", name, "'");
    return place(*t);
  }
  Tensor host(const Tensor& t) const { return to(t, Device::cpu).clone(); }
  Tensor place(const Tensor& t) {
    count_ += t.numel();
    Tensor h = host(t);  // a copy: the deploy model does not share the Model's storage
    return dev_ == Device::cpu ? h : to(h, dev_);
  }
  Tensor buffer_host(const std::string& name) const {
    const Tensor* t = reg_.find_buffer(name);
    GATCORE_CHECK(t, "deploy: model '", name_, "' has no buffer '", name, "'");
    return host(*t);
  }
  Tensor param_host(const std::string& name) const {
    const Var* p = reg_.find_param(name);
    GATCORE_CHECK(p, "deploy: model '", name_, "' has no parameter '", name, "'");
    return host(p->value());
  }

 private:
  const nn::Registry& reg_;
  std::string name_;
  Device dev_;
  std::int64_t& count_;
};

// Weights packed for gemm_prepacked (CPU only; other devices run Backend::gemm).
cpu::PrepackedB pack(const Tensor& W, Device dev, Precision p) {
  return dev == Device::cpu ? cpu::prepack_b(W, p) : cpu::PrepackedB{};
}

DenseStep dense_step(Loader& L, const std::string& prefix, Activation act, float slope, Device dev, Precision p) {
  DenseStep s{L.param(prefix + "W"), L.param(prefix + "b"), {}, act, slope};
  s.Wp = pack(s.W, dev, p);
  return s;
}

GatStep gat_step(Loader& L, const std::string& p, const ModelConfig& c, Device dev, Precision prec) {
  GatStep s;
  s.heads = c.heads;
  s.head_dim = c.head_dim;
  s.self_width = std::int64_t(std::lround(double(c.beta) * double(s.kf())));  // as nn::GatBlock
  s.W = L.param(p + "W");
  s.att_dst = L.param(p + "att_dst");
  s.att_src = L.param(p + "att_src");
  if (s.self_width > 0) {
    s.self_W = L.param(p + "self.W");
    s.self_b = L.param(p + "self.b");
  }
  if (dev == Device::cpu) {
    Tensor both = Tensor::empty(s.W.rows(), s.width());
    both.cols_slice(0, s.kf()).copy_from_(s.W);
    if (s.self_width > 0) both.cols_slice(s.kf(), s.width()).copy_from_(s.self_W);
    s.Wp = cpu::prepack_b(both, prec);
  }
  s.bn = c.batch_norm;
  if (s.bn) {
    if (dev == Device::cpu) {
      const Tensor gamma = L.param_host(p + "bn.gamma"), rv = L.buffer_host(p + "bn.running_var");
      s.bn_scale = Tensor::empty(1, s.width());
      cpu::batchnorm_eval_scale(gamma, rv, kBatchNormEps, s.bn_scale);
      s.bn_mean = L.buffer(p + "bn.running_mean");
      s.bn_shift = L.param(p + "bn.beta");
    } else {
      s.bn_gamma = L.param(p + "bn.gamma");
      s.bn_beta = L.param(p + "bn.beta");
      s.bn_rm = L.buffer(p + "bn.running_mean");
      s.bn_rv = L.buffer(p + "bn.running_var");
    }
  }
  return s;
}

}  // namespace

bool deployable(const ModelConfig& c) {
  return c.task == Task::displacement && deployable(c.kind());
}

std::shared_ptr<const DeployModel> make_deploy_model(Model& model, const Normaliser& norm, Device device,
                                                     Precision precision) {
  const ModelConfig& c = model.config();
  GATCORE_CHECK(deployable(c), "deploy: model '", c.name, "' (", task_name(c.task),
                ") has no deploy path; the runtime deforms with displacement models (densegats, densegats-noself, "
                "densegats-nodense, origat)");
  GATCORE_CHECK(device == Device::cpu || has_backend(device), "deploy: no ", device_name(device), " backend");
  GATCORE_CHECK(precision == Precision::fp32 || device == Device::cpu, "deploy: precision bf16 runs on the CPU only (the ",
                device_name(device), " device computes in fp32); use fp32 there");
  GATCORE_CHECK(precision == Precision::fp32 || bf16_supported(),
                "deploy: precision bf16 needs a CPU with AVX512_BF16 (this one has none, or GATCORE_SIMD forces a lower "
                "level); use fp32");
  auto d = std::make_shared<DeployModel>();
  d->cfg = c;
  d->device = device;
  d->precision = precision;
  d->norm.target_scale = norm.target_scale;
  if (norm.defined()) {
    check_shape(norm.mean, 1, c.in_dim, "deploy: normaliser mean");
    check_shape(norm.inv_std, 1, c.in_dim, "deploy: normaliser inv_std");
    d->norm.mean = to(norm.mean, Device::cpu).clone();
    d->norm.inv_std = to(norm.inv_std, Device::cpu).clone();
  }
  model.fold_batch_norm();
  Loader L(model, device, d->params);
  if (c.linear_skip) {
    d->has_skip = true;
    d->skip = dense_step(L, "skip.", Activation::identity, 0.f, device, Precision::fp32);
  }
  if (c.kind() == ModelKind::origat) {
    d->origat = true;
    for (int l = 0; l < c.gat_layers; ++l) {
      const std::string p = "layers." + std::to_string(l) + ".";
      OriLayer o;
      o.W = L.param(p + "W");
      o.att_dst = L.param(p + "att_dst");
      o.att_src = L.param(p + "att_src");
      o.b = L.param(p + "b");
      o.Wp = pack(o.W, device, precision);
      o.heads = int(o.att_dst.rows());
      o.act = l + 1 < c.gat_layers;
      d->layers.push_back(std::move(o));
    }
    return d;
  }
  // DenseGATs: DenseLayers with tanh (densegats.cpp's DenseLayerOptions; the
  // slope is unused by tanh but passed as there).
  for (std::size_t k = 0; k < c.transform.size(); ++k)
    d->transform.push_back(dense_step(L, "transform." + std::to_string(k) + ".lin.", Activation::tanh, 0.f, device, precision));
  d->dense = c.dense;
  std::int64_t w = c.transform.back();
  for (int m = 0; m < c.modules; ++m) {
    d->module_in.push_back(w);
    std::vector<GatStep> blocks;
    for (int b = 0; b < c.blocks; ++b)
      blocks.push_back(gat_step(L, "modules." + std::to_string(m) + ".blocks." + std::to_string(b) + ".", c, device, precision));
    const std::int64_t bw = blocks.front().width();
    w = c.dense ? w + std::int64_t(c.blocks) * bw : bw;
    d->modules.push_back(std::move(blocks));
    if (m + 1 < c.modules) {
      d->transitions.push_back(gat_step(L, "transitions." + std::to_string(m) + ".", c, device, precision));
      w = d->transitions.back().width();
    }
  }
  for (std::size_t k = 0; k < c.head.size(); ++k)
    d->head.push_back(dense_step(L, "head." + std::to_string(k) + ".lin.", Activation::tanh, 0.f, device, precision));
  d->head.push_back(dense_step(L, "head." + std::to_string(c.head.size()) + ".", Activation::identity, 0.f, device, precision));
  GATCORE_CHECK(d->head.back().W.rows() == (d->head.size() > 1 ? c.head.back() : w), "deploy: model '", c.name,
                "': head input width does not match the configuration");
  return d;
}

const ModelConfig& deploy_config(const DeployModel& m) { return m.cfg; }
Precision deploy_precision(const DeployModel& m) { return m.precision; }
Device deploy_device(const DeployModel& m) { return m.device; }
std::int64_t deploy_parameter_count(const DeployModel& m) { return m.params; }

namespace {
// CPU bf16: a bf16 copy of a DenseNet buffer, kept in step as its columns are
// written, so each product reads its prefix as bf16 (half the bytes) instead
// of every later block re-converting the whole prefix.
// The unfused GAT block's scratch for `n` rows of step `s` (every block has
// its width): the attention's and the self stream's output, and with
// BatchNorm tanhshrink's before the affine. Allocated once, then kept.
void unfused_scratch(Backend& be, std::int64_t n, const GatStep& s, Tensor& both, Tensor& tsh) {
  if (!both.defined()) both = be.empty(n, s.width());
  if (s.bn && !tsh.defined()) tsh = be.empty(n, s.width());
}

struct Shadow {
  std::vector<std::uint32_t, cpu::Aligned64<std::uint32_t>> words;
  std::int64_t ld = 0;  // words per row
};
Shadow shadow_for(std::int64_t n, std::int64_t cols) {
  Shadow s;
  s.ld = ((cols + 1) / 2 + 15) / 16 * 16;  // 64-byte aligned rows
  s.words.assign(std::size_t((n + 24) * s.ld), 0u);  // 24 rows more (gemm_prepacked on Bf16Rows)
  return s;
}
}  // namespace

struct DeployPlan::Buffers {
  Tensor x;  // the model input on the device (CPU: x_host_ itself)
  std::vector<Tensor> t_lin, t_act, h_lin, h_act;
  std::vector<Tensor> mod;
  Tensor z, both, tsh, el, er, alpha;  // GAT block scratch, reused by every block
  Tensor zs;  // CPU: [z | self] from the one product of a GAT block
  std::vector<Shadow> mod_bf16;  // CPU bf16: one per B.mod (empty when not used)
  std::vector<Shadow> head_bf16;  // CPU bf16: each hidden head layer's output, only as bf16 (with mod_bf16)
  std::vector<Tensor> o_z, o_y, o_act, o_el, o_er, o_alpha;  // origat, per layer
  Tensor skip_lin, skip_out;  // config.linear_skip: x W + b, and the network's output plus it
};

DeployPlan::DeployPlan(std::shared_ptr<const DeployModel> model, GraphPtr graph)
    : model_(std::move(model)), graph_(std::move(graph)) {
  GATCORE_CHECK(model_ && graph_, "DeployPlan: needs a model and a graph");
  const DeployModel& M = *model_;
  n_ = graph_->num_nodes;
  GATCORE_CHECK(n_ > 0, "DeployPlan: the graph has no nodes");
  Backend& be = backend(M.device);
  buf_ = std::make_unique<Buffers>();
  Buffers& B = *buf_;
  x_host_ = Tensor::empty(n_, M.cfg.in_dim);
  B.x = M.device == Device::cpu ? x_host_ : be.empty(n_, M.cfg.in_dim);
  const std::int64_t E = graph_->num_edges();
  if (M.origat) {
    for (const OriLayer& L : M.layers) {
      B.o_z.push_back(be.empty(n_, L.W.cols()));
      B.o_y.push_back(be.empty(n_, L.W.cols()));
      B.o_act.push_back(L.act ? be.empty(n_, L.W.cols()) : Tensor{});
      B.o_el.push_back(be.empty(n_, L.heads));
      B.o_er.push_back(be.empty(n_, L.heads));
      B.o_alpha.push_back(be.empty(E, L.heads));
    }
  } else {
    // CPU: a tanh layer's output overwrites its pre-activation (tanh's
    // kernels are elementwise and run in place, and nothing reads the
    // pre-activation again): the paper's head 512-128 saves 25.6 MB at 10k
    // vertices. Other backends keep two buffers (a shader does not bind one
    // buffer as both input and output).
    const auto act_buffer = [&](const DenseStep& s, const Tensor& lin) {
      if (s.act == Activation::identity) return Tensor{};
      return M.device == Device::cpu && s.act == Activation::tanh ? lin : be.empty(n_, s.W.cols());
    };
    for (std::size_t k = 0; k < M.transform.size(); ++k) {
      B.t_lin.push_back(be.empty(n_, M.transform[k].W.cols()));
      B.t_act.push_back(k + 1 < M.transform.size() ? act_buffer(M.transform[k], B.t_lin.back()) : Tensor{});
    }
    const GatStep& g = M.modules.front().front();
    // Shadows need every column range they hold to start at an even column
    // (pairs): the module inputs and the block widths even (the paper's 32 and 72).
    bool even = g.width() % 2 == 0;
    for (std::int64_t w : M.module_in) even = even && w % 2 == 0;
    const bool shadows = M.device == Device::cpu && M.precision == Precision::bf16 && even && !M.head.empty();
    for (std::size_t m = 0; m < M.modules.size(); ++m) {
      const std::int64_t cols = M.module_in[m] + std::int64_t(M.modules[m].size()) * M.modules[m].front().width();
      if (shadows) B.mod_bf16.push_back(shadow_for(n_, cols));
      // With shadows every GAT block writes and reads only the bf16 words:
      // the floats are the input transform's output alone, which is then
      // shadowed (the modules' float columns would be 60 MB at 10k vertices
      // on the paper's sizes, never touched).
      B.mod.push_back(!shadows ? be.empty(n_, cols) : m == 0 ? be.empty(n_, M.module_in[0]) : Tensor{});
    }
    if (M.device == Device::cpu) {
      B.zs = be.empty(n_, g.width());
      B.z = B.zs.cols_slice(0, g.kf());
    } else {
      B.z = be.empty(n_, g.kf());
    }
    // both / tsh only serve the unfused GAT block: the fused CPU path (the
    // AVX-512 level, or bf16 shadows) never touches them, and at 10k
    // vertices they are 5.8 MB. Allocated here when this plan will take the
    // unfused path, so that run() allocates nothing; gat_block allocates
    // them itself if the SIMD level is lowered after the plan was built.
    if (M.device != Device::cpu || !(shadows || cpu::gat_epilogue_supported()))
      unfused_scratch(be, n_, g, B.both, B.tsh);
    B.el = be.empty(n_, g.heads);
    B.er = be.empty(n_, g.heads);
    B.alpha = be.empty(E, g.heads);
    for (std::size_t k = 0; k < M.head.size(); ++k) {
      B.h_lin.push_back(be.empty(n_, M.head[k].W.cols()));
      B.h_act.push_back(act_buffer(M.head[k], B.h_lin.back()));
      if (!B.mod_bf16.empty() && k + 1 < M.head.size()) B.head_bf16.push_back(shadow_for(n_, M.head[k].W.cols()));
    }
  }
  if (M.has_skip) {
    B.skip_lin = be.empty(n_, M.cfg.out_dim);
    B.skip_out = be.empty(n_, M.cfg.out_dim);
  }
  y_host_ = Tensor::empty(n_, M.cfg.out_dim);
}

DeployPlan::~DeployPlan() {
  if (model_ && model_->device == Device::vulkan) vulkan::forget_graph(graph_.get());
}

std::int64_t DeployPlan::scratch_bytes() const {
  const Buffers& B = *buf_;
  std::vector<const Storage*> seen;  // views (z of zs, x of x_host_) count once
  std::int64_t bytes = 0;
  const auto add = [&](const Tensor& t) {
    if (!t.defined() || std::find(seen.begin(), seen.end(), t.storage().get()) != seen.end()) return;
    seen.push_back(t.storage().get());
    bytes += std::int64_t(t.storage()->bytes);
  };
  for (const Tensor* t : {&x_host_, &y_host_, &B.x, &B.z, &B.zs, &B.both, &B.tsh, &B.el, &B.er, &B.alpha, &B.skip_lin,
                          &B.skip_out})
    add(*t);
  for (const auto* v : {&B.t_lin, &B.t_act, &B.h_lin, &B.h_act, &B.mod, &B.o_z, &B.o_y, &B.o_act, &B.o_el, &B.o_er,
                        &B.o_alpha})
    for (const Tensor& t : *v) add(t);
  for (const auto* v : {&B.mod_bf16, &B.head_bf16})
    for (const Shadow& sh : *v) bytes += std::int64_t(sh.words.size() * sizeof(std::uint32_t));
  return bytes;
}

namespace {

// Columns [c0, c1) of a shadowed buffer, as the bf16 A operand of a product.
cpu::Bf16Rows shadow_rows(const Shadow& s, std::int64_t n, std::int64_t c0, std::int64_t c1) {
  return {s.words.data() + c0 / 2, n, c1 - c0, s.ld};
}
// After columns [c0, c1) of `buf` were written: the same columns of its shadow (if any).
void shadow_update(Shadow* s, const Tensor& buf, std::int64_t c0, std::int64_t c1) {
  if (s) cpu::bf16_pairs(buf.cols_slice(c0, c1), s->words.data() + c0 / 2, s->ld);
}

// nn::GatBlock::forward (eval) of `x` into `out`.
// (CPU: z is the first kf columns of zs, whose last self_width columns get the self stream's product.)
// With shadows (CPU bf16): xw is x as bf16 rows, and the block's output goes
// only to `out_words` (its columns of the shadow, `out_ld` words per row),
// through gat_epilogue_bf16; `out`'s floats are then not written (nothing
// reads them: every later product reads the shadow).
void gat_block(Backend& be, const CsrGraph& g, const GatStep& s, const Tensor& x, const Tensor& out, Tensor& z,
               const Tensor& zs, Tensor& both, Tensor& tsh, Tensor& el, Tensor& er, Tensor& alpha,
               const cpu::Bf16Rows* xw = nullptr, std::uint32_t* out_words = nullptr, std::int64_t out_ld = 0) {
  const std::int64_t kf = s.kf();
  const bool cpu = be.device() == Device::cpu;
  // CPU at the AVX-512 level: the product hands each row block of z to the
  // attention projection while it is still in cache, and the attention, the
  // self stream's bias, tanhshrink and BatchNorm's map run in one pass
  // (gat_attention_epilogue*), bitwise the composition below.
  const bool fused = cpu && (xw || cpu::gat_epilogue_supported());
  if (fused) {
    struct Proj {
      const Tensor &z, &a_dst, &a_src, &el, &er;
    } proj{z, s.att_dst, s.att_src, el, er};
    const cpu::RowBlockSink sink = [](void* c, std::int64_t i0, std::int64_t rows) {
      const Proj& p = *static_cast<const Proj*>(c);
      cpu::attention_projection_forward_rows(p.z, p.a_dst, p.a_src, p.el, p.er, i0, i0 + rows);
    };
    if (xw)
      cpu::gemm_prepacked(*xw, s.Wp, zs, sink, &proj);
    else
      cpu::gemm_prepacked(x, s.Wp, zs, sink, &proj);
    // The self stream's product is where the GEMM left it.
    const Tensor self = s.self_width > 0 ? zs.cols_slice(kf, kf + s.self_width) : Tensor{};
    const Tensor self_b = s.self_width > 0 ? s.self_b : Tensor{};
    const Tensor mean = s.bn ? s.bn_mean : Tensor{};
    if (out_words)
      cpu::gat_attention_epilogue_bf16(g, z, el, er, s.slope, alpha, self, self_b, mean, s.bn_scale, s.bn_shift,
                                       out_words, out_ld);
    else
      cpu::gat_attention_epilogue(g, z, el, er, s.slope, alpha, self, self_b, mean, s.bn_scale, s.bn_shift, out);
    return;
  }
  unfused_scratch(be, z.rows(), s, both, tsh);
  if (cpu)
    cpu::gemm_prepacked(x, s.Wp, zs);
  else
    be.gemm(x, false, s.W, false, z, 1.0f, 0.0f);
  be.attention_projection_forward(z, s.att_dst, s.att_src, el, er);
  be.gat_fused_additive_forward(g, z, el, er, s.slope, both.cols_slice(0, kf), alpha);
  if (s.self_width > 0) {
    const Tensor self = both.cols_slice(kf, kf + s.self_width);
    if (cpu)
      be.copy(zs.cols_slice(kf, kf + s.self_width), self);
    else
      be.gemm(x, false, s.self_W, false, self, 1.0f, 0.0f);
    be.add_row_bias(s.self_b, self);
  }
  if (!s.bn) {
    be.activation_forward(Activation::tanhshrink, both, out, 0.f);
    return;
  }
  be.activation_forward(Activation::tanhshrink, both, tsh, 0.f);
  if (be.device() == Device::cpu)
    cpu::batchnorm_affine_forward(tsh, s.bn_mean, s.bn_scale, s.bn_shift, out);
  else
    be.batchnorm_eval_forward(tsh, s.bn_gamma, s.bn_beta, s.bn_rm, s.bn_rv, kBatchNormEps, out);
}

// nn::DenseLayer::forward (eval, folded) / Linear::forward of `x`.
void dense_step(Backend& be, const DenseStep& s, const Tensor& x, const Tensor& lin, const Tensor& out,
                const cpu::Bf16Rows* xw = nullptr) {
  if (!xw && be.device() == Device::cpu) {
    // The bias and the activation finish each row block of the product while
    // it is in cache (bitwise the passes below, which read and wrote the
    // whole [n, width] output twice more: 2-3 % of an fp32 frame).
    struct Finish {
      const DenseStep& s;
      const Tensor& lin;
      Tensor out;  // undefined for identity: the caller reads lin
    } fin{s, lin, s.act == Activation::identity ? Tensor{} : out};
    const cpu::RowBlockSink sink = [](void* c, std::int64_t i0, std::int64_t rows) {
      const Finish& f = *static_cast<const Finish*>(c);
      cpu::bias_activation_rows(f.s.b, f.s.act, f.lin, f.out, i0, i0 + rows);
    };
    cpu::gemm_prepacked(x, s.Wp, lin, sink, &fin);
    return;
  }
  if (xw)
    cpu::gemm_prepacked(*xw, s.Wp, lin);
  else if (be.device() == Device::cpu)
    cpu::gemm_prepacked(x, s.Wp, lin);
  else
    be.gemm(x, false, s.W, false, lin, 1.0f, 0.0f);
  be.add_row_bias(s.b, lin);
  if (s.act != Activation::identity) be.activation_forward(s.act, lin, out, s.slope);
}

}  // namespace

const Tensor& DeployPlan::run() {
  const DeployModel& M = *model_;
  Backend& be = backend(M.device);
  Buffers& B = *buf_;
  const CsrGraph& g = *graph_;
  // Normaliser::apply, in place.
  if (M.norm.defined()) {
    const float* mean = M.norm.mean.data();
    const float* inv = M.norm.inv_std.data();
    const std::int64_t d = x_host_.cols();
    for (std::int64_t i = 0; i < n_; ++i) {
      float* r = x_host_.row(i);
      for (std::int64_t j = 0; j < d; ++j) r[j] = (r[j] - mean[j]) * inv[j];
    }
  }
  if (M.device != Device::cpu) B.x = be.from_host(x_host_);
  Tensor out;
  if (M.origat) {
    // origat.cpp: z = gat(x W), y = z + b (the ones-column product adds b
    // exactly as add_row_bias does), LeakyReLU(0.01) between layers.
    Tensor y = B.x;
    for (std::size_t l = 0; l < M.layers.size(); ++l) {
      const OriLayer& L = M.layers[l];
      if (M.device == Device::cpu)
        cpu::gemm_prepacked(y, L.Wp, B.o_z[l]);
      else
        be.gemm(y, false, L.W, false, B.o_z[l], 1.0f, 0.0f);
      be.attention_projection_forward(B.o_z[l], L.att_dst, L.att_src, B.o_el[l], B.o_er[l]);
      be.gat_fused_additive_forward(g, B.o_z[l], B.o_el[l], B.o_er[l], 0.2f, B.o_y[l], B.o_alpha[l]);
      be.add_row_bias(L.b, B.o_y[l]);
      y = B.o_y[l];
      if (L.act) {
        be.activation_forward(Activation::leaky_relu, y, B.o_act[l], 0.01f);
        y = B.o_act[l];
      }
    }
    out = y;
  } else {
    Tensor y = B.x;
    for (std::size_t k = 0; k < M.transform.size(); ++k) {
      const Tensor dst = k + 1 == M.transform.size() ? B.mod[0].cols_slice(0, M.module_in[0]) : B.t_act[k];
      dense_step(be, M.transform[k], y, B.t_lin[k], dst);
      y = dst;
    }
    const bool shadows = !B.mod_bf16.empty();
    auto shadow = [&](std::size_t m) { return shadows ? &B.mod_bf16[m] : nullptr; };
    shadow_update(shadow(0), B.mod[0], 0, M.module_in[0]);
    cpu::Bf16Rows yw;  // y as bf16 rows, when shadowed
    for (std::size_t m = 0; m < M.modules.size(); ++m) {
      const Tensor& buf = B.mod[m];
      const std::int64_t bw = M.modules[m].front().width();
      std::int64_t c0 = M.module_in[m], prev = 0;
      for (const GatStep& s : M.modules[m]) {
        const std::int64_t lo = M.dense ? 0 : prev;
        const cpu::Bf16Rows xw = shadows ? shadow_rows(B.mod_bf16[m], n_, lo, c0) : cpu::Bf16Rows{};
        // Shadowed: no float input or output (the words are both).
        gat_block(be, g, s, shadows ? Tensor{} : buf.cols_slice(lo, c0), shadows ? Tensor{} : buf.cols_slice(c0, c0 + bw),
                  B.z, B.zs, B.both, B.tsh, B.el, B.er, B.alpha, shadows ? &xw : nullptr,
                  shadows ? B.mod_bf16[m].words.data() + c0 / 2 : nullptr, shadows ? B.mod_bf16[m].ld : 0);
        prev = c0;
        c0 += bw;
      }
      const std::int64_t lo = M.dense ? 0 : prev;
      y = shadows ? Tensor{} : buf.cols_slice(lo, c0);
      if (shadows) yw = shadow_rows(B.mod_bf16[m], n_, lo, c0);
      if (m + 1 < M.modules.size()) {
        gat_block(be, g, M.transitions[m], y, shadows ? Tensor{} : B.mod[m + 1].cols_slice(0, M.module_in[m + 1]), B.z,
                  B.zs, B.both, B.tsh, B.el, B.er, B.alpha, shadows ? &yw : nullptr,
                  shadows ? B.mod_bf16[m + 1].words.data() : nullptr, shadows ? B.mod_bf16[m + 1].ld : 0);
      }
    }
    bool y_in_yw = shadows;  // y's bf16 rows are yw
    for (std::size_t k = 0; k < M.head.size(); ++k) {
      if (y_in_yw && k + 1 < M.head.size() && M.head[k].act == Activation::tanh) {
        // A hidden layer's output goes only to its bf16 rows (the next product's operand).
        Shadow& h = B.head_bf16[k];
        cpu::gemm_prepacked_bias_act_bf16(yw, M.head[k].Wp, M.head[k].b, Activation::tanh, B.h_lin[k],
                                          h.words.data(), h.ld);
        yw = shadow_rows(h, n_, 0, M.head[k].W.cols());
        continue;
      }
      dense_step(be, M.head[k], y, B.h_lin[k], B.h_act[k], y_in_yw ? &yw : nullptr);
      y = M.head[k].act != Activation::identity ? B.h_act[k] : B.h_lin[k];
      y_in_yw = false;
    }
    out = y;
  }
  if (M.has_skip) {  // densegats.cpp / origat.cpp: add(network, skip.forward(x)), add = axpby(1, a, 1, b)
    dense_step(be, M.skip, B.x, B.skip_lin, Tensor{});
    be.axpby(1.0f, out, 1.0f, B.skip_lin, B.skip_out);
    out = B.skip_out;
  }
  if (M.device == Device::cpu) {
    y_host_.copy_from_(out);
  } else {
    y_host_.copy_from_(be.to_host(out));
  }
  // models::predict: divided by the target scale.
  if (M.norm.target_scale != 1.f) {
    const float ts = M.norm.target_scale;
    for (std::int64_t i = 0; i < n_; ++i) {
      float* r = y_host_.row(i);
      for (std::int64_t j = 0; j < y_host_.cols(); ++j) r[j] /= ts;
    }
  }
  return y_host_;
}

}  // namespace gatcore::models
