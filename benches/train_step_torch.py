#!/usr/bin/env python3
"""The fine-tuning step of Avatar Studio re-implemented in plain PyTorch (CPU), to put our
training step side by side with the tool users would otherwise pick.

Same networks, sizes and loss as `avatar-studio bench --only train`: the hierarchical bone
encoder (frozen, as fine-tuning keeps it), one head per SIREN layer (Linear-LayerNorm-ReLU x2,
then a linear layer; low-rank residuals U_l C(pose) for `compact`, full residuals for `paper`),
a SIREN per pose (w0 = 30), 8 poses x (1,000 surface + 1,000 off-surface) points (the fit's
defaults; `avatar-studio bench --only train` passes its workload), the spatial
gradient by double backward (create_graph=True), the IGR loss (on-surface |f|, off-surface
exp(-100|f|), eikonal, the sign prior's hinge) plus the residual regulariser, and Adam with
burn's defaults. Random data of the same shapes: the cost of a step does not depend on it.

    python3 benches/train_step_torch.py --preset compact --threads 2 --steps 30

Prints the median step time in milliseconds and the CPU time a step (all threads). Not part
of the tests; without torch it says so and exits 0.
"""
import argparse
import statistics
import sys
import time

try:
    import torch
except ImportError:
    print("torch is not installed: skipping the PyTorch side (pip install torch)")
    sys.exit(0)

PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21]
W0 = 30.0


class BoneEncoder(torch.nn.Module):
    def __init__(self):
        super().__init__()
        self.prior = torch.nn.Linear(24 * 12, 6)
        self.l1 = torch.nn.ModuleList([torch.nn.Linear(19, 19) for _ in range(24)])
        self.l2 = torch.nn.ModuleList([torch.nn.Linear(19, 6) for _ in range(24)])

    def forward(self, x):  # [B, 24 * 13]
        bones = x.view(x.shape[0], 24, 13)
        prior = self.prior(bones[:, :, :12].reshape(x.shape[0], -1))
        feats = []
        for j in range(24):
            parent = prior if PARENTS[j] < 0 else feats[PARENTS[j]]
            h = torch.relu(self.l1[j](torch.cat([bones[:, j], parent], 1)))
            feats.append(self.l2[j](h))
        return torch.cat(feats, 1)


class Head(torch.nn.Module):
    def __init__(self, cond, hidden, out):
        super().__init__()
        self.net = torch.nn.Sequential(
            torch.nn.Linear(cond, hidden), torch.nn.LayerNorm(hidden), torch.nn.ReLU(),
            torch.nn.Linear(hidden, hidden), torch.nn.LayerNorm(hidden), torch.nn.ReLU(),
            torch.nn.Linear(hidden, out))
        torch.nn.init.zeros_(self.net[-1].weight)
        torch.nn.init.zeros_(self.net[-1].bias)

    def forward(self, c):
        return self.net(c)


class HyperNet(torch.nn.Module):
    def __init__(self, hidden, layers, head_hidden, rank):
        super().__init__()
        self.widths = [3] + [hidden] * layers + [1]
        self.rank = rank
        self.encoder = BoneEncoder()
        self.weights = torch.nn.ParameterList()
        self.biases = torch.nn.ParameterList()
        self.heads = torch.nn.ModuleList()
        self.bases = torch.nn.ParameterList()
        for k, (i, o) in enumerate(zip(self.widths[:-1], self.widths[1:])):
            bound = 1.0 / i if k == 0 else (6.0 / i) ** 0.5 / W0
            self.weights.append(torch.nn.Parameter(torch.empty(i, o).uniform_(-bound, bound)))
            self.biases.append(torch.nn.Parameter(torch.empty(o).uniform_(-bound, bound)))
            r = min(rank, i) if rank else None
            self.heads.append(Head(144, head_hidden, (r if r else i) * o + o))
            if r:
                self.bases.append(torch.nn.Parameter(torch.empty(i, r).uniform_(-i ** -0.5, i ** -0.5)))

    def forward(self, pose_inputs, x):  # x: [B, N, 3] with requires_grad
        cond = self.encoder(pose_inputs)
        b = x.shape[0]
        h = x
        residual = 0.0
        for k, (i, o) in enumerate(zip(self.widths[:-1], self.widths[1:])):
            out = self.heads[k](cond)
            width = out.shape[1] - o
            db = out[:, width:]
            if self.rank:
                r = width // o
                dw = self.bases[k].unsqueeze(0) @ out[:, :width].view(b, r, o)
            else:
                dw = out[:, :width].view(b, i, o)
            residual = residual + (dw * dw).sum() + (db * db).sum()
            z = h @ (self.weights[k].unsqueeze(0) + dw) + (self.biases[k].unsqueeze(0) + db).unsqueeze(1)
            h = torch.sin(W0 * z) if k + 1 < len(self.widths) - 1 else z
        return h, residual / b


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--preset", choices=["compact", "paper"], default="compact")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--poses", type=int, default=8)
    ap.add_argument("--surface", type=int, default=1000)
    ap.add_argument("--off", type=int, default=1000)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    if args.preset == "compact":
        net = HyperNet(128, 4, 128, 8)
    else:
        net = HyperNet(256, 6, 256, None)
    for p in net.encoder.parameters():
        p.requires_grad_(False)
    sdf_params = list(net.weights) + list(net.biases)
    head_params = list(net.heads.parameters()) + list(net.bases)
    opt = torch.optim.Adam([{"params": head_params, "lr": 1e-6}, {"params": sdf_params, "lr": 1e-4}], eps=1e-5)
    n_sdf = sum(p.numel() for p in sdf_params)
    b, s, o = args.poses, args.surface, args.off
    pose_inputs = torch.randn(b, 24 * 13)
    times = []
    for step in range(args.steps + 3):
        if step == 3:
            cpu = time.process_time()
        t = time.perf_counter()
        surf = torch.rand(b, s, 3) * 1.2 - 0.6
        off = torch.rand(b, o, 3) * 2 - 1
        signs = torch.randint(-1, 2, (b, o, 1)).float()
        x = torch.cat([surf, off], 1).requires_grad_(True)
        f, residual = net(pose_inputs, x)
        (g,) = torch.autograd.grad(f.sum(), x, create_graph=True)
        f_s, f_o = f[:, :s], f[:, s:]
        loss = (3e3 * f_s.abs().mean() + 1e2 * torch.exp(-100.0 * f_o.abs()).mean()
                + 5e1 * (g.norm(dim=2) - 1).abs().mean()
                + 1e3 * torch.clamp(-signs * f_o, min=0).mean()
                + torch.sqrt(residual + 1e-12) * (1e2 / n_sdf))
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step >= 3:
            times.append((time.perf_counter() - t) * 1e3)
    # CPU time of all threads: steadier than wall time on a shared machine (with one thread;
    # with more, the OpenMP threads' spin-waiting counts too).
    cpu_ms = (time.process_time() - cpu) * 1e3 / args.steps
    print(f"pytorch {torch.__version__} {args.preset}: {statistics.median(times):.1f} ms a step "
          f"(median of {args.steps}, {args.threads} threads, {b} poses x ({s} + {o}) points; "
          f"{cpu_ms:.1f} ms CPU a step)")


if __name__ == "__main__":
    main()
