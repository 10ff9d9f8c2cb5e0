#!/usr/bin/env python3
"""gatcore vs PyTorch + PyTorch Geometric on the same workloads, one table.

Runs gatbench (--benchmark_format=json) for the gatcore side and its own
PyTorch implementation of the same models for the reference side, in this
one invocation, with the same thread count on both sides:

  workload                         PyTorch side
  gat_layer fwd / fwd+bwd, 10k     PyG GATConv(64, 8, heads=8, bias=False) on the mesh (self-loops in the graph)
  densegats infer 1x10k            DenseGATs, eval mode, BatchNorm folded into the Linear layers, no_grad
  densegats train 8x1000           forward + MSE + backward + Adam
  origat train 8x1000              4 GATConv layers (8x8 heads, LeakyReLU 0.01, last 1 head x 3)
  neuroskinning train 12x2048      MLP + GC units (dot-product attention, neighbour mean) + global max pool, KL loss
  peak memory of each training step, measured in a fresh process on both sides

Layer sizes are gatcore's (include/gatcore/models, shared/SPEC.md); the
meshes are gatbench's (bench/bench_util.hpp: 25x40-vertex triangulated grid
patches, self-loops), rebuilt here identically. Timings: warm-up, then the
median of repeats. Each PyTorch workload runs in two variants, eager and
torch.compile (inductor; warm-up includes the compilation), each in its own
fresh process right after gatcore's run of the same workload; the faster of
the two is the reference. The GEMM section times torch.mm (the BLAS torch was
built with: MKL in the PyPI wheel) against gatbench's gemm on the same shapes,
back to back per shape. bench/compare.sh makes the environment and runs this.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

FEATURES = 71  # [p, n, distances to 65 joints]
BONES = 65
PATCH_COLS, PATCH_ROWS = 25, 40

# ---------------------------------------------------------------------------- meshes


def mesh_edges(nodes):
    """(src, dst) of gatbench's mesh graph: both directions of every triangle edge + self-loops."""
    per = PATCH_COLS * PATCH_ROWS
    pairs = set()
    for base in range(0, nodes, per):
        count = min(per, nodes - base)
        for r in range(PATCH_ROWS - 1):
            for c in range(PATCH_COLS - 1):
                if (r + 1) * PATCH_COLS + c + 1 >= count:
                    continue
                a = base + r * PATCH_COLS + c
                b, d = a + 1, a + PATCH_COLS
                e = d + 1
                for u, v in ((a, b), (b, e), (e, a), (a, e), (e, d), (d, a)):
                    pairs.add((u, v))
                    pairs.add((v, u))
    for i in range(nodes):
        pairs.add((i, i))
    pairs = sorted(pairs, key=lambda p: (p[1], p[0]))  # CSR by destination
    return [p[0] for p in pairs], [p[1] for p in pairs]


def hop_neighbourhoods(nodes, src, dst, k):
    """Row i: the k nearest vertices of i by hops (itself first), like gatcore's hop_neighbours."""
    adj = [[] for _ in range(nodes)]
    for s, d in zip(src, dst):
        if s != d:
            adj[d].append(s)
    for a in adj:
        a.sort()
    rows = []
    for s in range(nodes):
        seen = {s}
        queue = [s]
        q = 0
        while q < len(queue) and len(queue) < k:
            for u in adj[queue[q]]:
                if u not in seen:
                    seen.add(u)
                    queue.append(u)
                    if len(queue) >= k:
                        break
            q += 1
        rows.append(queue)
    return rows


# ---------------------------------------------------------------------------- models


def build_models(torch, pyg):
    nn = torch.nn
    F = torch.nn.functional
    GATConv = pyg.nn.GATConv

    class DenseLayer(nn.Module):  # Linear -> BatchNorm -> activation
        def __init__(self, i, o, act):
            super().__init__()
            self.lin, self.bn, self.act = nn.Linear(i, o), nn.BatchNorm1d(o), act

        def forward(self, x):
            return self.act(self.bn(self.lin(x)))

        def fold(self):  # BatchNorm (eval statistics) into the Linear layer, as gatcore does
            s = self.bn.weight / torch.sqrt(self.bn.running_var + self.bn.eps)
            self.lin.weight.data = self.lin.weight.data * s[:, None]
            self.lin.bias.data = (self.lin.bias.data - self.bn.running_mean) * s + self.bn.bias
            self.bn = nn.Identity()

    class GatBlock(nn.Module):  # 8x8 additive attention ++ self stream (8), tanhshrink, BatchNorm
        def __init__(self, i):
            super().__init__()
            self.gat = GATConv(i, 8, heads=8, bias=False, add_self_loops=False)
            self.self_lin = nn.Linear(i, 8)
            self.bn = nn.BatchNorm1d(72)

        def forward(self, x, ei):
            return self.bn(F.tanhshrink(torch.cat([self.gat(x, ei), self.self_lin(x)], 1)))

    class DenseGats(nn.Module):
        def __init__(self):
            super().__init__()
            self.transform = nn.ModuleList([DenseLayer(FEATURES, 32, torch.tanh), DenseLayer(32, 32, torch.tanh)])
            self.modules_ = nn.ModuleList()
            self.transitions = nn.ModuleList()
            w = 32
            for m in range(3):
                blocks = nn.ModuleList()
                for b in range(6):
                    blocks.append(GatBlock(w + 72 * b))
                self.modules_.append(blocks)
                w += 72 * 6
                if m < 2:
                    self.transitions.append(GatBlock(w))
                    w = 72
            self.head = nn.ModuleList([DenseLayer(w, 512, torch.tanh), DenseLayer(512, 128, torch.tanh)])
            self.out = nn.Linear(128, 3)

        def forward(self, x, ei):
            for l in self.transform:
                x = l(x)
            for m, blocks in enumerate(self.modules_):
                feats = [x]
                for b in blocks:  # DenseNet: each block sees input ++ all earlier outputs
                    feats.append(b(torch.cat(feats, 1) if len(feats) > 1 else feats[0], ei))
                x = torch.cat(feats, 1)
                if m < len(self.transitions):
                    x = self.transitions[m](x, ei)
            for l in self.head:
                x = l(x)
            return self.out(x)

        def fold(self):
            for l in list(self.transform) + list(self.head):
                l.fold()

    class OriGat(nn.Module):
        def __init__(self):
            super().__init__()
            self.layers = nn.ModuleList([GATConv(FEATURES, 8, heads=8, add_self_loops=False)] +
                                        [GATConv(64, 8, heads=8, add_self_loops=False) for _ in range(2)] +
                                        [GATConv(64, 3, heads=1, add_self_loops=False)])

        def forward(self, x, ei):
            for k, l in enumerate(self.layers):
                x = l(x, ei)
                if k + 1 < len(self.layers):
                    x = F.leaky_relu(x, 0.01)
            return x

    def lrelu(x):
        return F.leaky_relu(x, 0.1)

    class GcUnit(nn.Module):  # x ++ LeakyReLU(dot-product attention of C x) ++ neighbour mean of that
        def __init__(self, i, heads, dim):
            super().__init__()
            self.C = nn.Linear(i, heads * dim)
            self.heads, self.dim = heads, dim

        def forward(self, x, ei, pool):
            src, dst = ei
            h = self.C(x).view(-1, self.heads, self.dim)
            # index_select rather than h[src]: its backward is index_add_, not the slower index_put_
            h_src = h.index_select(0, src)
            logits = (h.index_select(0, dst) * h_src).sum(-1) / self.dim ** 0.5  # [E, heads]
            alpha = pyg.utils.softmax(logits, dst, num_nodes=x.shape[0])
            msg = alpha.unsqueeze(-1) * h_src
            conv = torch.zeros_like(h).index_add_(0, dst, msg).view(x.shape[0], -1)
            conv = lrelu(conv)
            return torch.cat([x, conv, torch.sparse.mm(pool, conv)], 1)

    class NeuroSkinning(nn.Module):
        def __init__(self, characters):
            super().__init__()
            self.characters = characters
            self.stage1 = nn.Sequential(DenseLayerL(FEATURES, 128), DenseLayerL(128, 64))
            self.gc = nn.ModuleList([GcUnit(64, 4, 64), GcUnit(64 + 512, 2, 64), GcUnit(64 + 512 + 256, 2, 64)])
            self.glob = nn.Sequential(DenseLayerL(64 + 512, 512), DenseLayerL(512, 1024))
            w = 64 + 512 + 256 + 256
            self.classifier = nn.Sequential(DenseLayerL(w + 1024, 1024), DenseLayerL(1024, 512), nn.Linear(512, BONES))

        def forward(self, x, ei, pools):
            y = self.stage1(x)
            y = self.gc[0](y, ei, pools[16])
            g = self.glob(y)
            n = g.shape[0]
            g = g.view(self.characters, n // self.characters, -1).max(1).values  # max pool per character
            g = g.repeat_interleave(n // self.characters, 0)
            y = self.gc[1](y, ei, pools[24])
            y = self.gc[2](y, ei, pools[64])
            return torch.softmax(self.classifier(torch.cat([y, g], 1)), 1)

    def DenseLayerL(i, o):
        return DenseLayer(i, o, lrelu)

    return DenseGats, OriGat, NeuroSkinning


# ---------------------------------------------------------------------------- timing


def median_ms(fn, warmup, repeats, min_seconds):
    for _ in range(warmup):
        fn()
    times = []
    t_end = time.perf_counter() + min_seconds
    while len(times) < repeats or time.perf_counter() < t_end:
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
        if len(times) >= 50 * repeats:
            break
    return statistics.median(times)


def batch_graph(torch, characters, vertices):
    src, dst = mesh_edges(vertices)
    s = torch.tensor(src)
    d = torch.tensor(dst)
    ss = torch.cat([s + c * vertices for c in range(characters)])
    dd = torch.cat([d + c * vertices for c in range(characters)])
    return torch.stack([ss, dd]), src, dst


def pool_matrix(torch, characters, vertices, src, dst, k):
    rows = hop_neighbourhoods(vertices, src, dst, k)
    r, c, v = [], [], []
    for ch in range(characters):
        off = ch * vertices
        for i, lst in enumerate(rows):
            for j in lst:
                r.append(i + off)
                c.append(j + off)
                v.append(1.0 / len(lst))
    n = characters * vertices
    return torch.sparse_coo_tensor(torch.tensor([r, c]), torch.tensor(v), (n, n)).coalesce()


def make_workload(name, torch, pyg, compiled=False, bf16=False):
    """Returns the step function of a workload; compiled: the model under torch.compile; bf16: the forward
    under torch.autocast("cpu", bfloat16) (PyTorch's mixed precision: products in bf16, weights, optimiser
    and loss in fp32), the reference for gatcore's bf16 rows."""
    import contextlib
    F = torch.nn.functional
    DenseGats, OriGat, NeuroSkinning = build_models(torch, pyg)
    gen = torch.Generator().manual_seed(1)

    def maybe_compile(m):
        return torch.compile(m) if compiled else m

    def amp():
        return torch.autocast("cpu", dtype=torch.bfloat16) if bf16 else contextlib.nullcontext()

    def train_step(model, x, ei, target, loss_fn, extra=()):
        opt = torch.optim.Adam(model.parameters(), lr=1e-3)
        run = maybe_compile(model)

        def step():
            opt.zero_grad(set_to_none=True)
            with amp():
                out = run(x, ei, *extra)
            loss = loss_fn(out.float(), target)
            loss.backward()
            opt.step()
        return step

    if name in ("gat_layer_fwd", "gat_layer_fwdbwd"):
        ei, _, _ = batch_graph(torch, 1, 10000)
        x = torch.rand(10000, 64, generator=gen) * 2 - 1
        target = torch.rand(10000, 64, generator=gen)
        conv = pyg.nn.GATConv(64, 8, heads=8, bias=False, add_self_loops=False)
        run = maybe_compile(conv)
        if name == "gat_layer_fwd":
            def fwd():
                with torch.no_grad():
                    run(x, ei)
            return fwd

        def fwdbwd():
            conv.zero_grad(set_to_none=True)
            F.mse_loss(run(x, ei), target).backward()
        return fwdbwd
    if name == "densegats_infer":
        ei, _, _ = batch_graph(torch, 1, 10000)
        x = torch.rand(10000, FEATURES, generator=gen) * 2 - 1
        model = DenseGats().eval()
        model.fold()
        run = maybe_compile(model)

        def infer():
            with torch.no_grad(), amp():
                run(x, ei)
        return infer
    if name in ("densegats_train", "origat_train"):
        ei, _, _ = batch_graph(torch, 8, 1000)
        x = torch.rand(8000, FEATURES, generator=gen) * 2 - 1
        target = torch.rand(8000, 3, generator=gen) * 0.2 - 0.1
        model = (DenseGats() if name == "densegats_train" else OriGat()).train()
        return train_step(model, x, ei, target, F.mse_loss)
    if name == "neuroskinning_train":
        chars, verts = 12, 2048
        ei, src, dst = batch_graph(torch, chars, verts)
        pools = {k: pool_matrix(torch, chars, verts, src, dst, k) for k in (16, 24, 64)}
        x = torch.rand(chars * verts, FEATURES, generator=gen) * 2 - 1
        target = torch.rand(chars * verts, BONES, generator=gen)
        target = target / target.sum(1, keepdim=True)
        model = NeuroSkinning(chars).train()

        def kl(pred, t):  # KL(target || pred), mean over rows, like gatcore's kl_div_loss
            return (t * (torch.log(t + 1e-8) - torch.log(pred + 1e-8))).sum(1).mean()
        return train_step(model, x, ei, target, kl, (pools,))
    raise SystemExit(f"unknown workload {name}")


WORKLOADS = [
    # (name, gatbench benchmark name, label)
    ("gat_layer_fwd", "gat_layer_fwd/nodes:10000/real_time", "GAT layer 64->8x8, 10k nodes, fwd"),
    ("gat_layer_fwdbwd", "gat_layer_fwdbwd/nodes:10000/real_time", "GAT layer 64->8x8, 10k nodes, fwd+bwd"),
    # gatcore's inference is the deploy path (what gat deform and the runtime
    # run; fp32, predict's numbers bitwise); the generic tape-free forward and
    # bf16 products are shown beside it (EXTRA), against the same torch runs.
    ("densegats_infer", "model_infer_deploy/densegats/nodes:10000/real_time", "DenseGATs inference 1x10k"),
    ("densegats_train", "model_train/densegats/real_time", "DenseGATs train step 8x1000"),
    ("origat_train", "model_train/origat/real_time", "Ori.GAT train step 8x1000"),
    ("neuroskinning_train", "model_train/neuroskinning/real_time", "NeuroSkinning train step 12x2048"),
]
EXTRA = {  # workload -> more gatcore rows timed right after it: (gatbench benchmark name, label, torch
    # variants: None = compared with the workload's own torch runs; a list = run these for the row)
    "densegats_infer": [("model_infer_densegats/nodes:10000/real_time", "  (generic forward, no deploy plan)", None),
                        ("model_infer_deploy/densegats_bf16/nodes:10000/real_time", "  (bf16 products)",
                         ["eager_bf16", "compiled_bf16"])],
    # gat train --precision bf16 (products in bf16, everything else fp32) against torch under autocast
    "densegats_train": [("model_train/densegats_bf16/real_time", "  (bf16 products)", ["eager_bf16", "compiled_bf16"])],
    "origat_train": [("model_train/origat_bf16/real_time", "  (bf16 products)", ["eager_bf16", "compiled_bf16"])],
    "neuroskinning_train": [("model_train/neuroskinning_bf16/real_time", "  (bf16 products)",
                             ["eager_bf16", "compiled_bf16"])],
}
PEAK = [("densegats_train", "model_peak_rss/densegats"), ("origat_train", "model_peak_rss/origat"),
        ("neuroskinning_train", "model_peak_rss/neuroskinning")]


GEMMS = [  # (M, K, N, gatbench op, label): the model's shapes and the large squares
    (8000, 504, 512, 0, "8000x504x512 C=AB"), (8000, 504, 512, 1, "8000x504x512 dA=dC B^T"),
    (8000, 504, 512, 2, "8000x504x512 dB=A^T dC"), (24576, 1088, 1024, 0, "24576x1088x1024 C=AB"),
    (24576, 1088, 1024, 1, "24576x1088x1024 dA=dC B^T"), (24576, 1088, 1024, 2, "24576x1088x1024 dB=A^T dC"),
    (2048, 2048, 2048, 0, "2048^3"), (4096, 4096, 4096, 0, "4096^3"),
]


def torch_gemm_gflops(torch, m, k, n, op, args, cpu_time=False):
    """torch.mm on gatbench's product `op` (0: A B, 1: dC B^T, 2: A^T dC), accumulating like gatbench.
    cpu_time: GFLOP per CPU-second of this process (1 thread: what a core does when it runs, which a
    loaded machine's time-sharing does not change much) instead of per wall-clock second."""
    a, b = torch.rand(m, k) * 2 - 1, torch.rand(k, n) * 2 - 1
    dc = torch.rand(m, n) * 2 - 1
    if op == 0:
        out = torch.empty(m, n)
        fn = lambda: torch.mm(a, b, out=out)
    elif op == 1:
        da = torch.zeros(m, k)
        fn = lambda: da.addmm_(dc, b.t())
    else:
        db = torch.zeros(k, n)
        fn = lambda: db.addmm_(a.t(), dc)
    if cpu_time:
        for _ in range(args.warmup):
            fn()
        best = 0.0
        for _ in range(max(args.repeats, 1)):
            t0 = time.process_time()
            fn()
            best = max(best, 2.0 * m * k * n / max(time.process_time() - t0, 1e-9) / 1e9)
        return best
    ms = median_ms(fn, args.warmup, args.repeats, args.min_time)
    return 2.0 * m * k * n / (ms * 1e-3) / 1e9


def child(name, mode, args):
    """Runs in a fresh process: time one workload, or measure its peak RSS."""
    import torch
    torch.set_num_threads(args.threads)
    if mode in ("gemm", "gemm_cpu"):
        m, k, n, op = (int(v) for v in name.split(","))
        print(json.dumps({"gflops": torch_gemm_gflops(torch, m, k, n, op, args, mode == "gemm_cpu")}))
        return
    if mode == "versions":
        import torch_geometric as pyg
        print(json.dumps({"torch": torch.__version__, "torch_geometric": pyg.__version__,
                          "config": torch.__config__.show(), "parallel": torch.__config__.parallel_info()}))
        return
    import torch_geometric as pyg
    fn = make_workload(name, torch, pyg, compiled=args.child_variant.startswith("compiled"),
                       bf16=args.child_variant.endswith("_bf16"))
    if mode == "time":
        print(json.dumps({"ms": median_ms(fn, args.warmup, args.repeats, args.min_time)}))
    else:
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        ms = []
        for _ in range(3):
            t0 = time.perf_counter()
            fn()
            ms.append((time.perf_counter() - t0) * 1e3)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        print(json.dumps({"base_kib": base, "peak_kib": peak, "step_ms": statistics.median(ms)}))


def run_child(name, mode, args, variant="eager"):
    """One fresh child; a variant that fails (e.g. torch.compile on an op it cannot trace) gives NaN."""
    cmd = [sys.executable, os.path.abspath(__file__), "--child", name, "--child-mode", mode,
           "--child-variant", variant, "--threads", str(args.threads), "--warmup", str(args.warmup),
           "--repeats", str(args.repeats), "--min-time", str(args.min_time)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        print(f"compare_pyg: {name} ({mode}, {variant}) failed:\n{r.stderr[-2000:]}", file=sys.stderr)
        return None
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gatbench", default="build/bench/gatbench")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--min-time", type=float, default=2.0, help="seconds of timed repeats at least, per workload")
    ap.add_argument("--only", default="", help="comma-separated workload names (default: all)")
    ap.add_argument("--json", default="", help="also write the results here")
    ap.add_argument("--skip-memory", action="store_true", help="timings only (no peak-memory children)")
    ap.add_argument("--child", default="")
    ap.add_argument("--child-mode", default="time")
    ap.add_argument("--child-variant", default="eager")
    ap.add_argument("--variants", default="eager,compiled",
                    help="PyTorch variants to time (eager, compiled; eager_bf16 / compiled_bf16: under autocast)")
    ap.add_argument("--skip-gemm", action="store_true", help="no GEMM section")
    args = ap.parse_args()
    if args.child:
        return child(args.child, args.child_mode, args)

    os.environ["OMP_NUM_THREADS"] = str(args.threads)
    only = set(filter(None, args.only.split(",")))
    work = [w for w in WORKLOADS if not only or w[0] in only]
    peaks = [p for p in PEAK if not only or p[0] in only]

    # gatcore: gatbench over exactly these benchmarks: the peak-memory
    # children (one run each), then each timing (median of repetitions) right
    # before the PyTorch side of the same workload.
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads))

    def gatbench(names, extra, threads=None):
        filt = "^(" + "|".join(names) + ")(/|$)"
        e = env if threads is None else dict(env, OMP_NUM_THREADS=str(threads))
        out = subprocess.run([args.gatbench, "--benchmark_filter=" + filt, "--benchmark_format=json"] + extra,
                             check=True, capture_output=True, text=True, env=e).stdout
        return json.loads(out)

    bench = {}
    context = {}

    def gatbench_time(bname):
        nonlocal context
        j = gatbench([bname.split("/real_time")[0]],
                     [f"--benchmark_min_time={args.min_time / args.repeats}",
                      f"--benchmark_repetitions={args.repeats}", "--benchmark_report_aggregates_only=true"])
        context = j["context"]
        for b in j["benchmarks"]:
            # the median of the repetitions; with --repeats 1 there are no aggregates, only the run
            if b.get("aggregate_name") == "median" or (b.get("run_type") == "iteration" and b["run_name"] not in bench):
                bench[b["run_name"]] = b

    if peaks and not args.skip_memory:
        j = gatbench([p[1] for p in peaks], [])
        context = j["context"]
        for b in j["benchmarks"]:
            bench[b["run_name"].split("/iterations")[0]] = b

    def gatcore_ms(bname):
        b = bench.get(bname)
        if b is None:
            return float("nan")
        t = b["real_time"]
        return {"ms": t, "us": t / 1e3, "ns": t / 1e6, "s": t * 1e3}[b["time_unit"]]

    variants = [v for v in args.variants.split(",") if v]
    nan = float("nan")

    def load1():
        return float(open("/proc/loadavg").read().split()[0])

    versions = run_child("-", "versions", args) or {}
    names = set(subprocess.run([args.gatbench, "--benchmark_list_tests"], check=True, capture_output=True,
                               text=True, env=env).stdout.split())
    rows = []

    def torch_times(name, vs):
        """Each variant's median ms (NaN where it failed) and the fastest variant (None if all failed)."""
        py = {}
        for v in vs:
            r = run_child(name, "time", args, v)
            py[v] = r["ms"] if r else nan
        ok = {v: t for v, t in py.items() if t == t}
        return py, (min(ok, key=ok.get) if ok else None)

    def add_row(label, py, best, gc):
        rows.append({"workload": label, "pytorch_ms": py, "best_variant": best,
                     "best_pytorch_ms": py[best] if best else nan, "gatcore_ms": gc,
                     "speedup": (py[best] / gc) if best else nan, "load1": load1()})
        print(f"[progress] {json.dumps(rows[-1])}", file=sys.stderr, flush=True)

    for name, bname, label in work:
        # gatcore, then each PyTorch variant, back to back per workload: on a
        # shared machine the load drifts, and adjacent runs see about the same load.
        gatbench_time(bname)
        gc = gatcore_ms(bname)
        py, best = torch_times(name, variants)
        add_row(label, py, best, gc)
        for xname, xlabel, xvariants in EXTRA.get(name, []):
            if xname not in names and xname.split("/real_time")[0] not in names:
                continue  # gatbench has no such benchmark (e.g. a bf16 one on a CPU without AVX512_BF16)
            gatbench_time(xname)
            gx = gatcore_ms(xname)
            xpy, xbest = py, best
            if xvariants:  # torch's own bf16 (autocast) runs, for a like-for-like row
                xpy, xbest = torch_times(name, xvariants)
                if xbest is None:  # torch's autocast failed on this model: the fp32 runs are the reference
                    xlabel += " vs torch fp32 (autocast failed)"
                    xpy, xbest = py, best
            add_row(xlabel, xpy, xbest, gx)
    mem = []
    for name, bname in ([] if args.skip_memory else peaks):
        b = bench.get(bname, {})
        py = {v: run_child(name, "rss", args, v) for v in variants}
        ok = {v: r for v, r in py.items() if r}
        best = min(ok, key=lambda v: ok[v]["peak_kib"]) if ok else None
        mem.append({"workload": name, "pytorch_peak_MiB": {v: r["peak_kib"] / 1024 for v, r in ok.items()},
                    "pytorch_step_MiB": {v: (r["peak_kib"] - r["base_kib"]) / 1024 for v, r in ok.items()},
                    "best_variant": best, "best_pytorch_peak_MiB": ok[best]["peak_kib"] / 1024 if best else nan,
                    "gatcore_peak_MiB": b.get("peak_MiB", nan), "gatcore_step_MiB": b.get("step_MiB", nan)})
        print(f"[progress] {json.dumps(mem[-1])}", file=sys.stderr, flush=True)
    gemms = []
    if not args.skip_gemm and not only:
        for m, k, n, op, label in GEMMS:
            j = gatbench([f"gemm/M:{m}/K:{k}/N:{n}/op:{op}"],
                         [f"--benchmark_min_time={args.min_time / args.repeats}",
                          f"--benchmark_repetitions={args.repeats}", "--benchmark_report_aggregates_only=true"])
            med = [b for b in j["benchmarks"] if b.get("aggregate_name") == "median"] or j["benchmarks"]
            gc = med[0].get("flops", nan) / 1e9
            r = run_child(f"{m},{k},{n},{op}", "gemm", args)
            # One thread, GFLOP per CPU-second, best repetition, both sides.
            one = argparse.Namespace(**dict(vars(args), threads=1))
            j1 = gatbench([f"gemm/M:{m}/K:{k}/N:{n}/op:{op}"],
                          [f"--benchmark_repetitions={max(args.repeats, 1)}", "--benchmark_min_time=0"], threads=1)
            gc1 = max(b.get("flops", 0) * b["real_time"] / b["cpu_time"] for b in j1["benchmarks"]
                      if b.get("run_type") == "iteration") / 1e9
            r1 = run_child(f"{m},{k},{n},{op}", "gemm_cpu", one)
            gemms.append({"shape": label, "torch_gflops": r["gflops"] if r else nan, "gatcore_gflops": gc,
                          "fraction": gc / r["gflops"] if r else nan,
                          "torch_gflops_per_cpu_s": r1["gflops"] if r1 else nan, "gatcore_gflops_per_cpu_s": gc1,
                          "fraction_per_cpu_s": gc1 / r1["gflops"] if r1 else nan, "load1": load1()})
            print(f"[progress] {json.dumps(gemms[-1])}", file=sys.stderr, flush=True)

    load = open("/proc/loadavg").read().split()[:3]
    print(f"threads {args.threads} both sides; torch {versions.get('torch', '?')}, "
          f"torch_geometric {versions.get('torch_geometric', '?')}; load average at the end: {' '.join(load)}")
    head = "".join(f" {('torch ' + v + ' ms'):>19s}" for v in variants)
    print(f"{'workload':40s}{head} {'gatcore ms':>11s} {'best/gatcore':>12s}  load (1 min, after the set)")
    for r in rows:
        # a row with its own torch variants (bf16 rows: autocast) names them
        own = list(r["pytorch_ms"]) != variants
        if own:  # the best of its own variants in the first column, each variant in the note
            cols = f" {r['best_pytorch_ms']:19.2f}" + " " * 20 * (len(variants) - 1)
            note = "  torch " + ", ".join(f"{v} {t:.2f}" for v, t in r["pytorch_ms"].items()) + " ms (best shown)"
        else:
            cols = "".join(f" {r['pytorch_ms'][v]:19.2f}" for v in variants)
            note = ""
        print(f"{r['workload']:40s}{cols} {r['gatcore_ms']:11.2f} {r['speedup']:11.1f}x  {r['load1']:.1f}{note}")
    if mem:
        print()
        head = "".join(f" {('torch ' + v):>16s}" for v in variants)
        print(f"{'peak memory of a training step (MiB)':40s}{head} {'gatcore':>11s} {'best/gatcore':>12s}"
              "   (added by the steps: torch per variant / gatcore)")
        for m in mem:
            cols = "".join(f" {m['pytorch_peak_MiB'].get(v, nan):16.1f}" for v in variants)
            steps = " / ".join(f"{m['pytorch_step_MiB'].get(v, nan):.1f}" for v in variants)
            print(f"{m['workload']:40s}{cols} {m['gatcore_peak_MiB']:11.1f} "
                  f"{m['best_pytorch_peak_MiB'] / m['gatcore_peak_MiB']:11.1f}x   {steps} / {m['gatcore_step_MiB']:.1f}")
    if gemms:
        print()
        print(f"{'GEMM, GFLOP/s':28s} {'2 threads, wall clock (median)':>36s} {'1 thread, per CPU-second (best)':>36s}")
        print(f"{'':28s} {'torch.mm':>11s} {'gatcore':>11s} {'fraction':>12s} {'torch.mm':>11s} {'gatcore':>11s}"
              f" {'fraction':>12s}  load")
        for g in gemms:
            print(f"{g['shape']:28s} {g['torch_gflops']:11.1f} {g['gatcore_gflops']:11.1f} "
                  f"{100 * g['fraction']:11.1f}% {g['torch_gflops_per_cpu_s']:11.1f} "
                  f"{g['gatcore_gflops_per_cpu_s']:11.1f} {100 * g['fraction_per_cpu_s']:11.1f}%  {g['load1']:.1f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"load": load, "threads": args.threads, "versions": versions, "time": rows, "memory": mem,
                       "gemm": gemms, "gatbench_context": context}, f, indent=1)

if __name__ == "__main__":
    sys.exit(main())
