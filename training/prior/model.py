"""Realism prior (contract v1, docs/prior-features.md): map encoder + query decoder
with L=3 layers of temporal / agent-agent / agent-map multi-head (differential) attention.

`MapEncoder` is pose-free (map_tokens [N, 7 or 10] -> [N, D]) so a scenario's map is
encoded once; `Decoder` answers one query agent: x0 = MLP(scaled history +
agent_self), then per layer a temporal attention over the 6 history points
(+ learned time embedding, masked by `valid`), an agent-agent attention over
the 16 neighbours (+ relative pose d_ij) and an agent-map attention over the
48 map tokens (+ pose + signal), each with one learned always-valid null key,
and an FFN, all pre-LayerNorm residual; Linear(D -> 3969) logits.
`attention="differential"` is multi-head differential attention (Ye et al.
2024), `"plain"` the same-size ablation (parameter counts within 0.05 %).

Written for ONNX opset 17 and what tract runs of it: physical inputs are
scaled inside the graph by fixed constants; masks use `masked_fill` with a
finite scalar (no -inf, no `torch.where` with full tensors); the softmax over
the short key axes is exp(x - max) * mask / sum.clamp_min, so padding and
empty rows never give NaN.
"""
import math
import torch
import torch.nn as nn
import torch.nn.functional as F

VOCAB = 3969
NEG = -1e4


def mlp(i, h, o):
    """Two-layer GELU MLP i -> h -> o."""
    return nn.Sequential(nn.Linear(i, h), nn.GELU(), nn.Linear(h, o))


class Scales(nn.Module):
    """Physical units -> O(1) inputs; constants live in the graph."""

    def __init__(self, scales):
        super().__init__()
        self.register_buffer("s", torch.tensor(scales, dtype=torch.float32))

    def forward(self, x):
        return x / self.s


HIST_SCALE = [20.0, 20.0, 1.0, 1.0, 10.0, 5.0, 1.5, 1.0]
SELF_SCALE = [5.0, 5.0, 1.0, 1.0, 1.0, 1.0]
NB_SCALE = [10.0, 10.0, 10.0, 5.0, 5.0, 1.0, 1.0, 1.0, 1.0, 5.0, 5.0, 1.0]
POSE_SCALE = [20.0, 20.0, 50.0, 1.0, 1.0]
# Map token values: kind one-hot (4), length_m, in_intersection, speed_limit_mps, then (feature contract 2)
# the lane's turn ahead: rightmost_rad, leftmost_rad, reach_m.
MAP_SCALE = [1.0, 1.0, 1.0, 1.0, 8.0, 1.0, 30.0, 1.0, 1.0, 40.0]
# Values per map token a map encoder may read: the first 7 (contract 1) or all 10 (contract 2).
MAP_TOKEN_WIDTHS = (7, 10)


def masked_softmax(scores, mask):
    """softmax over the last axis with a 0/1 mask, tract-friendly (no -inf)."""
    scores = scores.masked_fill(mask == 0, NEG)
    m = scores.max(dim=-1, keepdim=True).values
    e = torch.exp(scores - m) * mask
    return e / e.sum(dim=-1, keepdim=True).clamp_min(1e-6)


class DiffAttention(nn.Module):
    """Multi-head differential attention (Ye et al. 2024) for one query token."""

    def __init__(self, d, heads, layer_index):
        super().__init__()
        self.h = heads
        self.dh = d // heads // 2  # width of each of Q1, Q2, K1, K2
        self.q = nn.Linear(d, 2 * self.h * self.dh, bias=False)
        self.k = nn.Linear(d, 2 * self.h * self.dh, bias=False)
        self.v = nn.Linear(d, self.h * 2 * self.dh, bias=False)
        self.o = nn.Linear(self.h * 2 * self.dh, d, bias=False)
        self.lambda_init = 0.8 - 0.6 * math.exp(-0.3 * (layer_index - 1))
        self.lq1 = nn.Parameter(torch.randn(self.dh) * 0.1)
        self.lk1 = nn.Parameter(torch.randn(self.dh) * 0.1)
        self.lq2 = nn.Parameter(torch.randn(self.dh) * 0.1)
        self.lk2 = nn.Parameter(torch.randn(self.dh) * 0.1)
        self.norm_w = nn.Parameter(torch.ones(2 * self.dh))

    def forward(self, x, kv, mask):
        # x [B, d], kv [B, N, d], mask [B, N]
        B, N, _ = kv.shape
        q = self.q(x).view(B, self.h, 2, self.dh)
        k = self.k(kv).view(B, N, self.h, 2, self.dh)
        v = self.v(kv).view(B, N, self.h, 2 * self.dh)
        s = torch.einsum("bhcd,bnhcd->bhcn", q, k) / math.sqrt(self.dh)  # [B,h,2,N]
        m = mask[:, None, None, :]
        a = masked_softmax(s, m)
        lam = (torch.exp((self.lq1 * self.lk1).sum()) - torch.exp((self.lq2 * self.lk2).sum()) + self.lambda_init)
        att = a[:, :, 0, :] - lam * a[:, :, 1, :]  # [B,h,N]
        out = torch.einsum("bhn,bnhe->bhe", att, v)  # [B,h,2dh]
        # headwise RMS norm, then (1 - lambda_init)
        out = out * torch.rsqrt((out * out).mean(dim=-1, keepdim=True) + 1e-5) * self.norm_w
        out = out * (1.0 - self.lambda_init)
        return self.o(out.reshape(B, -1))


class PlainAttention(nn.Module):
    """Plain multi-head attention of the same width, for the no-mda ablation."""

    def __init__(self, d, heads, layer_index):
        super().__init__()
        self.h = heads
        self.dh = d // heads
        self.q = nn.Linear(d, d, bias=False)
        self.k = nn.Linear(d, d, bias=False)
        self.v = nn.Linear(d, d, bias=False)
        self.o = nn.Linear(d, d, bias=False)

    def forward(self, x, kv, mask):
        B, N, _ = kv.shape
        q = self.q(x).view(B, self.h, self.dh)
        k = self.k(kv).view(B, N, self.h, self.dh)
        v = self.v(kv).view(B, N, self.h, self.dh)
        s = torch.einsum("bhd,bnhd->bhn", q, k) / math.sqrt(self.dh)
        a = masked_softmax(s, mask[:, None, :])
        out = torch.einsum("bhn,bnhd->bhd", a, v)
        return self.o(out.reshape(B, -1))


class Block(nn.Module):
    """One decoder layer: temporal, agent-agent and agent-map attention, then FFN (pre-LayerNorm residuals)."""

    def __init__(self, d, heads, layer_index, attention):
        super().__init__()
        Att = DiffAttention if attention == "differential" else PlainAttention
        self.n1, self.n2, self.n3, self.n4 = (nn.LayerNorm(d) for _ in range(4))
        self.temporal = Att(d, heads, layer_index)
        self.agents = Att(d, heads, layer_index)
        self.map = Att(d, heads, layer_index)
        self.ffn = mlp(d, 2 * d, d)

    def forward(self, x, hist, hist_mask, nb, nb_mask, mp, mp_mask):
        x = x + self.temporal(self.n1(x), hist, hist_mask)
        x = x + self.agents(self.n2(x), nb, nb_mask)
        x = x + self.map(self.n3(x), mp, mp_mask)
        return x + self.ffn(self.n4(x))


class MapEncoder(nn.Module):
    """Pose-free map token encoder: map_tokens [N, W] (physical units, W = 7 or 10) -> map_embedding [N, D]."""

    def __init__(self, d, width=7):
        super().__init__()
        if width not in MAP_TOKEN_WIDTHS:
            raise ValueError(f"map tokens of {width} values; a map encoder reads {MAP_TOKEN_WIDTHS}")
        self.scale = Scales(MAP_SCALE[:width])
        self.net = mlp(width, d, d)

    def forward(self, map_tokens):
        return self.net(self.scale(map_tokens))


class Decoder(nn.Module):
    """Query decoder: the contract's tensors for B query agents -> next-token logits [B, 3969]."""

    def __init__(self, d=64, heads=8, layers=3, attention="differential"):
        super().__init__()
        self.d = d
        self.hist_scale, self.self_scale = Scales(HIST_SCALE), Scales(SELF_SCALE)
        self.nb_scale, self.pose_scale = Scales(NB_SCALE), Scales(POSE_SCALE)
        self.x0 = mlp(6 * 8 + 6, 2 * d, d)
        self.hist_emb = mlp(8, d, d)
        self.time_emb = nn.Parameter(torch.randn(6, d) * 0.02)
        self.nb_emb = mlp(12, d, d)
        self.nb_pose = mlp(5, d, d)
        self.map_pose = mlp(5, d, d)
        self.map_signal = nn.Linear(4, d)
        self.null = nn.Parameter(torch.randn(2, d) * 0.02)
        self.blocks = nn.ModuleList(Block(d, heads, l + 1, attention) for l in range(layers))
        self.out_norm = nn.LayerNorm(d)
        self.head = nn.Linear(d, VOCAB)

    def forward(self, history, agent_self, neighbours, neighbour_pose, neighbour_mask,
                map_embedding, map_pose, map_signal, map_mask):
        B = history.shape[0]
        h = self.hist_scale(history)
        x = self.x0(torch.cat([h.reshape(B, -1), self.self_scale(agent_self)], dim=-1))
        hist = self.hist_emb(h) + self.time_emb
        hist_mask = history[:, :, 7]
        ones = torch.ones(B, 1, dtype=history.dtype, device=history.device)
        nb = self.nb_emb(self.nb_scale(neighbours)) + self.nb_pose(self.pose_scale(neighbour_pose))
        nb = torch.cat([self.null[0].expand(B, 1, self.d), nb], dim=1)
        nb_mask = torch.cat([ones, neighbour_mask], dim=1)
        mp = map_embedding + self.map_pose(self.pose_scale(map_pose)) + self.map_signal(map_signal)
        mp = torch.cat([self.null[1].expand(B, 1, self.d), mp], dim=1)
        mp_mask = torch.cat([ones, map_mask], dim=1)
        for blk in self.blocks:
            x = blk(x, hist, hist_mask, nb, nb_mask, mp, mp_mask)
        return self.head(self.out_norm(x))


class Prior(nn.Module):
    """Map encoder + decoder; training feeds raw map tokens."""

    def __init__(self, d=64, heads=8, layers=3, attention="differential", map_token_features=7):
        super().__init__()
        self.map_encoder = MapEncoder(d, map_token_features)
        self.decoder = Decoder(d, heads, layers, attention)

    def forward(self, batch):
        emb = self.map_encoder(batch["map_tokens"])
        return self.decoder(batch["history"], batch["agent_self"], batch["neighbours"], batch["neighbour_pose"],
                            batch["neighbour_mask"], emb, batch["map_pose"], batch["map_signal"], batch["map_mask"])
