"""The decoder's inference graph: the trained `Decoder`'s arithmetic rewritten
for tract, with the same weights and the same outputs (to float rounding).

Training keeps the readable formulation of model.py (per-head einsums over
8 heads of width 4). tract runs each of those einsums as many tiny batched
matrix products and repacks their operands on every call: at batch 32 they
were two thirds of the decoder's time (`safer bench-models --profile`). For
one query token, every per-head operation can be written as a product with a
constant 0/1 block matrix instead, which tract packs once at load:

- scores:  s[b,n,j] = sum_{c in head j} q[b,c] k[b,n,c] / sqrt(dh)
           = ((k * q[:, None, :]) @ S)[b,n,j], S the [D, J] head indicator
           with 1/sqrt(dh) folded in (J = 2H sub-heads for differential
           attention, H for plain);
- the differential combination a1 - lambda a2 and the broadcast of each
  head's weight to its value columns: a @ (L E), one constant [J, D] matrix
  (lambda is a constant of the trained weights: folded here);
- the weighted sum over keys: sum_n (a @ LE) * v, a reduction over n;
- the headwise RMS norm: mean of squares per head as (out * out) @ G and its
  broadcast back as @ E; `norm_w` and (1 - lambda_init) folded into the
  output projection;
- the division of the neighbour and pose inputs by their fixed scales folded
  into the first layer of each MLP that reads them (tract ran it as a
  broadcast multiply on every call);
- K and V projections of each context fused into one [D, 2D] product, the
  softmax keeps the graph's masking (masked keys at -1e4, exp(x - max) * mask
  / sum.clamp_min(1e-6)), with the reductions over the key axis.

`InferenceDecoder(decoder)` takes a trained `model.Decoder` (differential or
plain) and answers the same contract tensors; export.py exports it, and
`reexport.py` rebuilds it from a shipped ONNX file's weights.
"""
import math

import torch
import torch.nn as nn
import torch.nn.functional as F

from model import NEG, DiffAttention


class InferenceAttention(nn.Module):
    """One trained attention module (differential or plain) as products with constant matrices.

    Layout: scores are [B, J, N] (J sub-heads, N keys), so every reduction
    runs over the last axis. For one query token nothing per key needs a
    projection: the query side is folded into the key weights and the value
    projection is applied after the weighted sum.
    """

    def __init__(self, att, null):
        super().__init__()
        # The context's always-valid learned key/value row (the agent and map contexts have one, the
        # temporal context none).
        self.has_null = null is not None
        null = (null if self.has_null else torch.zeros(att.q.weight.shape[1])).detach().double()
        d = att.q.weight.shape[1]
        diff = isinstance(att, DiffAttention)
        h = att.h
        dh = att.dh  # width of one sub-head's query/key (Q1, Q2, K1, K2 for differential attention)
        sub = 2 * h if diff else h
        vw = d // h  # value columns per head
        lam = (float(torch.exp((att.lq1 * att.lk1).sum()) - torch.exp((att.lq2 * att.lk2).sum()) + att.lambda_init)
               if diff else 0.0)
        wq = att.q.weight.detach().double()  # [D, D_in]
        wk = att.k.weight.detach().double()
        wv = att.v.weight.detach().double()
        # s[b, j, n] = sum_{c in sub-head j} q[b, c] k[b, n, c] / sqrt(dh), q = x Wq^T, k = kv Wk^T
        #            = sum_e (x @ QK)[b, j * D + e] kv[b, n, e],  QK[:, j * D + e] = sum_{c in j} Wq[c, :] Wk[c, e] / sqrt(dh)
        qk = torch.zeros(d, sub, d, dtype=torch.float64)
        for j in range(sub):
            c = slice(j * dh, (j + 1) * dh)
            qk[:, j, :] = wq[c, :].t() @ wk[c, :] / math.sqrt(dh)
        self.qk = nn.Parameter(qk.reshape(d, sub * d).float(), requires_grad=False)
        # The null key's score is x @ qk_null: no concatenation of the null row in front of the keys
        # (tract propagates such a concat through the whole attention as split products).
        self.qk_null = nn.Parameter((qk @ null).float(), requires_grad=False)  # [D, J]
        # Per-head weights from the sub-heads: a1 - lambda a2 (differential) or a (plain).
        lt = torch.zeros(h, sub)
        for head in range(h):
            if diff:
                lt[head, 2 * head], lt[head, 2 * head + 1] = 1.0, -lam
            else:
                lt[head, head] = 1.0
        self.register_buffer("lt", lt)
        # out[b, head * vw + e] = sum_i C[b, head, i] Wv[head * vw + e, i], C = weights @ kv: block-diagonal.
        bw = torch.zeros(h, d, d, dtype=torch.float64)
        for head in range(h):
            cols = slice(head * vw, (head + 1) * vw)
            bw[head, :, cols] = wv[cols, :].t()
        # The null row's value, per head: out += (weights of the null per head) @ nv.
        nv = torch.zeros(h, d, dtype=torch.float64)
        null_v = wv @ null
        for head in range(h):
            cols = slice(head * vw, (head + 1) * vw)
            nv[head, cols] = null_v[cols]
        wo = att.o.weight.detach().double().t()  # [D_in, D_out]
        if diff:
            G = torch.zeros(d, h)
            E = torch.zeros(h, d)
            for head in range(h):
                G[head * vw:(head + 1) * vw, head] = 1.0 / vw
                E[head, head * vw:(head + 1) * vw] = 1.0
            self.register_buffer("G", G)
            self.register_buffer("E", E)
            wo = wo * (att.norm_w.detach().double().repeat(h) * (1.0 - att.lambda_init))[:, None]
        else:
            # Without the headwise norm the value and output projections fold into one.
            bw = (bw.reshape(h * d, d) @ wo).reshape(h, d, d)
            nv = nv @ wo
            wo = None
        self.nv = nn.Parameter(nv.float(), requires_grad=False)
        self.l = nn.Parameter(lt.t().contiguous(), requires_grad=False)  # [J, H]
        self.bw = nn.Parameter(bw.reshape(h * d, d).float(), requires_grad=False)
        self.o = None if wo is None else nn.Parameter(wo.float().contiguous(), requires_grad=False)
        self.d, self.h, self.sub, self.diff = d, h, sub, diff

    def forward(self, x, kv, kv_t, mask, fill):
        # x [B, D]; kv [B, N, D] and kv_t [B, D, N] (its transpose, made once per context); mask [B, J, N]
        # (1 = key, 0 = padding) and fill = (mask - 1) * 1e4, expanded once per context: tract runs
        # same-shape element-wise ops far faster than broadcasting ones. The null key is handled apart.
        B, N = kv.shape[0], kv.shape[1]
        qk = (x @ self.qk).reshape(B, self.sub, self.d)
        s = qk @ kv_t  # [B, J, N]
        s = s * mask + fill  # = masked_fill(mask == 0, -1e4) for finite scores
        if self.has_null:
            s_null = (x @ self.qk_null)[:, :, None]  # [B, J, 1]
            m = torch.maximum(max_over_keys(s), s_null)
            e_null = torch.exp(s_null - m)
        else:
            m = max_over_keys(s)
        e = torch.exp(s - m.expand(B, self.sub, N)) * mask
        total = e.sum(dim=2, keepdim=True)
        if self.has_null:
            total = total + e_null
        total = total.clamp_min(1e-6)
        a = e / total.expand(B, self.sub, N)
        c = (self.lt @ a) @ kv  # [B, H, D]
        out = c.reshape(B, self.h * self.d) @ self.bw  # [B, D]
        if self.has_null:
            out = out + ((e_null / total)[:, :, 0] @ self.l) @ self.nv
        if self.diff:
            out = out * (torch.rsqrt((out * out) @ self.G + 1e-5) @ self.E)
            out = out @ self.o
        return out

    @property
    def sub_heads(self):
        return self.sub


def max_over_keys(s):
    """max over the last axis of [B, J, N] as a 1-D max pool with the window N (exact): tract's ReduceMax
    took ~200 us for a [32, 16, 6] tensor (a third of the decoder at batch 32), a tree of element-wise
    maxima over slices 8 %, its max pool ~1 %."""
    B, J, N = s.shape
    N = int(N)  # a fixed axis; the pool's window must be a plain int when traced
    return F.max_pool1d(s.reshape(-1, 1, N), kernel_size=N).reshape(B, J, 1)


class InferenceBlock(nn.Module):
    """One decoder layer with its three attentions rewritten."""

    def __init__(self, blk, nulls):
        super().__init__()
        self.n1, self.n2, self.n3, self.n4 = blk.n1, blk.n2, blk.n3, blk.n4
        self.temporal = InferenceAttention(blk.temporal, None)
        self.agents = InferenceAttention(blk.agents, nulls[0])
        self.map = InferenceAttention(blk.map, nulls[1])
        self.ffn = blk.ffn

    def forward(self, x, hist, nb, mp):
        # each context is a (kv, kv_t, mask, fill) tuple, see InferenceAttention.forward
        x = x + self.temporal(self.n1(x), *hist)
        x = x + self.agents(self.n2(x), *nb)
        x = x + self.map(self.n3(x), *mp)
        return x + self.ffn(self.n4(x))


def scaled_mlp(mlp, scales):
    """`mlp(scales(x))` as one MLP: the division by the input scales folded
    into the first layer's weights. tract runs a division of a [B, N, 5]
    input by a [5] constant as a broadcast multiply on every call (4 % of the
    decoder at batch 32); folded, it costs nothing."""
    first = mlp[0]
    folded = nn.Linear(first.in_features, first.out_features)
    with torch.no_grad():
        folded.weight.copy_(first.weight / scales.s[None, :])
        folded.bias.copy_(first.bias)
    return nn.Sequential(folded, *list(mlp)[1:])


class InferenceDecoder(nn.Module):
    """A trained `Decoder` for export: same inputs, same logits, tract-friendly
    attention, and the neighbour and pose input scales folded into the first
    layers that read them."""

    def __init__(self, dec):
        super().__init__()
        self.dec = dec
        self.blocks = nn.ModuleList(InferenceBlock(b, dec.null) for b in dec.blocks)
        self.nb_emb = scaled_mlp(dec.nb_emb, dec.nb_scale)
        self.nb_pose = scaled_mlp(dec.nb_pose, dec.pose_scale)
        self.map_pose = scaled_mlp(dec.map_pose, dec.pose_scale)

    def forward(self, history, agent_self, neighbours, neighbour_pose, neighbour_mask,
                map_embedding, map_pose, map_signal, map_mask):
        dec = self.dec
        B = history.shape[0]
        h = dec.hist_scale(history)
        x = dec.x0(torch.cat([h.reshape(B, -1), dec.self_scale(agent_self)], dim=-1))
        hist = dec.hist_emb(h) + dec.time_emb
        hist_mask = history[:, :, 7]
        nb = self.nb_emb(neighbours) + self.nb_pose(neighbour_pose)
        nb_mask = neighbour_mask
        mp = map_embedding + self.map_pose(map_pose) + dec.map_signal(map_signal)
        mp_mask = map_mask
        j = self.blocks[0].temporal.sub_heads

        def context(kv, mask):
            full = mask[:, None, :].expand(B, j, mask.shape[1])
            return kv, kv.transpose(1, 2), full, (full - 1.0) * -NEG

        hist, nb, mp = context(hist, hist_mask), context(nb, nb_mask), context(mp, mp_mask)
        for blk in self.blocks:
            x = blk(x, hist, nb, mp)
        return dec.head(dec.out_norm(x))
