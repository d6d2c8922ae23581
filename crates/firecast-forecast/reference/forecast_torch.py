"""PyTorch eager references of FireCast's forecasting networks (independent re-statements of
the architectures in crates/firecast-forecast/src/neural.rs, written from the spec, not
generated from the Rust code).

    python forecast_torch.py count  WIDTH DAYS          -> JSON {kind: parameter count}
    python forecast_torch.py count-spec JSON            -> JSON {name: parameter count}
    python forecast_torch.py bench  KIND WIDTH DAYS N BATCH STEPS THREADS
                                    [WARMUP HIDDEN LAYERS DROPOUT LR WEIGHT_DECAY]
                                                        -> JSON {samples_per_s, ...}

`count` lets a test check that the tch nets (default sizes) have exactly PyTorch's parameter
counts; `count-spec` does it for a list of {"name", "kind", "width", "days", "hidden",
"layers", "dropout"} (sizes as an experiment sets them). `bench` times training steps
(forward, BCE, backward, AdamW step) for `firecast bench forecast`; the warm-up steps run
first and are not timed.
"""

import json
import math
import sys
import time
import warnings

import torch
from torch import nn

# A one-layer recurrent net with a dropout setting is legal (FireCast accepts it too); the
# warning would only clutter the bench's output.
warnings.filterwarnings("ignore", message="dropout option adds dropout")


class CnnBiLstmR(nn.Module):
    """Variant R: the authors' train.py."""

    def __init__(self, f, hidden=128, layers=3, dropout=0.25):
        super().__init__()
        self.conv1 = nn.Conv1d(f, 64, 3, padding=1)
        self.bn1 = nn.BatchNorm1d(64)
        self.conv2 = nn.Conv1d(64, 128, 3, padding=1)
        self.bn2 = nn.BatchNorm1d(128)
        self.pool = nn.MaxPool1d(2)
        self.lstm = nn.LSTM(128, hidden, layers, batch_first=True, bidirectional=True, dropout=dropout)
        self.fc = nn.Linear(2 * hidden, 1)

    def forward(self, x):
        z = x.permute(0, 2, 1)
        z = self.pool(self.bn1(torch.relu(self.conv1(z))))
        z = self.pool(self.bn2(torch.relu(self.conv2(z))))
        _, (h, _) = self.lstm(z.permute(0, 2, 1))
        return self.fc(torch.cat([h[-2], h[-1]], dim=1)).squeeze(1)


class AttnNet(nn.Module):
    """Variant D (conv 64-64, BiLSTM 150x3, attention, 300-150-1 head) and FireCast's net
    (conv 32-32 dilated, BiGRU, attention) share this shape."""

    def __init__(self, f, kind, hidden, layers, dropout):
        super().__init__()
        if kind == "cnn_bilstm_attn":
            self.conv1 = nn.Conv1d(f, 64, 3, padding=1)
            self.conv2 = nn.Conv1d(64, 64, 3, padding=1)
            c = 64
            self.rnn = nn.LSTM(c, hidden, layers, batch_first=True, bidirectional=True, dropout=dropout)
        else:
            self.conv1 = nn.Conv1d(f, 32, 5, padding=2)
            self.conv2 = nn.Conv1d(32, 32, 5, padding=4, dilation=2)
            c = 32
            self.rnn = nn.GRU(c, hidden, layers, batch_first=True, bidirectional=True,
                              dropout=dropout if layers > 1 else 0.0)
        self.bn1 = nn.BatchNorm1d(c)
        self.bn2 = nn.BatchNorm1d(c)
        self.attn = nn.Linear(2 * hidden, 1)
        self.fc1 = nn.Linear(2 * hidden, hidden)
        self.fc2 = nn.Linear(hidden, 1)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x):
        z = x.permute(0, 2, 1)
        z = self.dropout(torch.relu(self.bn1(self.conv1(z))))
        z = self.dropout(torch.relu(self.bn2(self.conv2(z))))
        out, _ = self.rnn(z.permute(0, 2, 1))
        w = torch.softmax(self.attn(out), dim=1)
        pooled = (out * w).sum(dim=1)
        return self.fc2(self.dropout(torch.relu(self.fc1(pooled)))).squeeze(1)


class Lstm2(nn.Module):
    def __init__(self, f, hidden=64, layers=2, dropout=0.2):
        super().__init__()
        self.lstm = nn.LSTM(f, hidden, layers, batch_first=True, dropout=dropout)
        self.fc = nn.Linear(hidden, 1)

    def forward(self, x):
        _, (h, _) = self.lstm(x)
        return self.fc(h[-1]).squeeze(1)


class LightTs(nn.Module):
    def __init__(self, f, days, hidden=32, dropout=0.1):
        super().__init__()
        self.chunk = max(1, round(math.sqrt(days)))
        self.chunks = -(-days // self.chunk)
        self.cont_in = nn.Linear(self.chunk, hidden)
        self.cont_out = nn.Linear(self.chunks, 1)
        self.int_in = nn.Linear(self.chunks, hidden)
        self.int_out = nn.Linear(self.chunk, 1)
        self.head = nn.Linear(f * 2 * hidden, 2 * hidden)
        self.out = nn.Linear(2 * hidden, 1)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x):
        b, t, f = x.shape
        pad = self.chunk * self.chunks - t
        if pad:
            x = torch.cat([x.new_zeros(b, pad, f), x], dim=1)
        xf = x.permute(0, 2, 1).reshape(b, f, self.chunks, self.chunk)
        cont = self.cont_out(torch.relu(self.cont_in(xf)).transpose(2, 3)).squeeze(3)
        inter = self.int_out(torch.relu(self.int_in(xf.transpose(2, 3))).transpose(2, 3)).squeeze(3)
        z = torch.cat([cont, inter], dim=2).flatten(1)
        return self.out(self.dropout(torch.relu(self.head(z)))).squeeze(1)


class Mlp(nn.Module):
    def __init__(self, f, days, hidden=100):
        super().__init__()
        self.hidden = nn.Linear(f * days, hidden)
        self.out = nn.Linear(hidden, 1)

    def forward(self, x):
        return self.out(torch.relu(self.hidden(x.flatten(1)))).squeeze(1)


# FireCast's defaults per kind: (hidden, layers, dropout).
DEFAULTS = {
    "cnn_bilstm": (128, 3, 0.25),
    "cnn_bilstm_attn": (150, 3, 0.1),
    "firecast": (32, 1, 0.2),
    "lstm2": (64, 2, 0.2),
    "lightts": (32, 1, 0.1),
    "mlp": (100, 1, 0.0),
}


def build(kind, width, days, hidden=None, layers=None, dropout=None):
    # `width` counts every input channel (variables, plus month sin/cos where a model adds them).
    if kind not in DEFAULTS:
        raise SystemExit(f"unknown kind {kind}")
    d_hidden, d_layers, d_dropout = DEFAULTS[kind]
    h = d_hidden if hidden is None else int(hidden)
    n = d_layers if layers is None else int(layers)
    p = d_dropout if dropout is None else float(dropout)
    if kind == "cnn_bilstm":
        return CnnBiLstmR(width, h, n, p)
    if kind in ("cnn_bilstm_attn", "firecast"):
        return AttnNet(width, kind, h, n, p)
    if kind == "lstm2":
        return Lstm2(width, h, n, p)
    if kind == "lightts":
        return LightTs(width, days, h, p)
    return Mlp(width, days, h)


KINDS = ["cnn_bilstm", "cnn_bilstm_attn", "firecast", "lstm2", "lightts", "mlp"]


def count(width, days):
    return {k: n_params(build(k, width, days)) for k in KINDS}


def n_params(net):
    return sum(p.numel() for p in net.parameters() if p.requires_grad)


def count_spec(entries):
    return {
        e["name"]: n_params(build(e["kind"], int(e["width"]), int(e["days"]), e.get("hidden"),
                                  e.get("layers"), e.get("dropout")))
        for e in entries
    }


def bench(kind, width, days, n, batch, steps, threads, warmup=3, hidden=None, layers=None,
          dropout=None, lr=1e-4, weight_decay=0.01):
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    net = build(kind, width, days, hidden, layers, dropout)
    x = torch.randn(n, days, width)
    y = (torch.rand(n) < 0.4).float()
    opt = torch.optim.AdamW(net.parameters(), lr=lr, weight_decay=weight_decay)
    loss_fn = nn.BCEWithLogitsLoss()
    net.train()

    def step(i):
        idx = torch.randint(0, n, (batch,))
        opt.zero_grad()
        loss = loss_fn(net(x[idx]), y[idx])
        loss.backward()
        opt.step()

    for i in range(warmup):
        step(i)
    t0 = time.perf_counter()
    for i in range(steps):
        step(i)
    dt = time.perf_counter() - t0
    return {"kind": kind, "steps": steps, "warmup_steps": warmup, "batch": batch,
            "threads": torch.get_num_threads(), "seconds": dt, "samples_per_s": steps * batch / dt,
            "parameters": n_params(net), "torch": torch.__version__}


if __name__ == "__main__":
    mode = sys.argv[1]
    if mode == "count":
        print(json.dumps(count(int(sys.argv[2]), int(sys.argv[3]))))
    elif mode == "count-spec":
        print(json.dumps(count_spec(json.loads(sys.argv[2]))))
    elif mode == "bench":
        kind, width, days, n, batch, steps, threads = sys.argv[2:9]
        extra = {}
        for key, conv, value in zip(["warmup", "hidden", "layers", "dropout", "lr", "weight_decay"],
                                    [int, int, int, float, float, float], sys.argv[9:15]):
            extra[key] = conv(value)
        print(json.dumps(bench(kind, int(width), int(days), int(n), int(batch), int(steps), int(threads),
                               **extra)))
    else:
        raise SystemExit(__doc__)
