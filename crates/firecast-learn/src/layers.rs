//! Layers tch lacks in PyTorch's exact form.

use tch::{Tensor, nn};

/// Recurrent cell type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cell {
    Lstm,
    Gru,
}

/// A (possibly bidirectional, multi-layer) LSTM or GRU over batch-first input, with
/// PyTorch's parameter names and initialisation, and dropout between layers only when
/// training.
#[derive(Debug)]
pub struct Recurrent {
    cell: Cell,
    params: Vec<Tensor>,
    hidden: i64,
    layers: i64,
    bidirectional: bool,
    dropout: f64,
}

impl Recurrent {
    pub fn new(
        p: nn::Path<'_>,
        cell: Cell,
        input: i64,
        hidden: i64,
        layers: i64,
        bidirectional: bool,
        dropout: f64,
    ) -> Self {
        let gates = match cell {
            Cell::Lstm => 4,
            Cell::Gru => 3,
        };
        let dirs = if bidirectional { 2 } else { 1 };
        let b = 1.0 / (hidden as f64).sqrt();
        let init = nn::Init::Uniform { lo: -b, up: b };
        let mut params = Vec::new();
        for layer in 0..layers {
            let in_size = if layer == 0 { input } else { hidden * dirs };
            for dir in 0..dirs {
                let suffix = if dir == 1 { "_reverse" } else { "" };
                params.push(p.var(
                    &format!("weight_ih_l{layer}{suffix}"),
                    &[gates * hidden, in_size],
                    init,
                ));
                params.push(p.var(
                    &format!("weight_hh_l{layer}{suffix}"),
                    &[gates * hidden, hidden],
                    init,
                ));
                params.push(p.var(&format!("bias_ih_l{layer}{suffix}"), &[gates * hidden], init));
                params.push(p.var(&format!("bias_hh_l{layer}{suffix}"), &[gates * hidden], init));
            }
        }
        flatten_parameters(&mut params);
        Self {
            cell,
            params,
            hidden,
            layers,
            bidirectional,
            dropout,
        }
    }

    /// `x`: [batch, time, input] → (output [batch, time, dirs·hidden], h_n [layers·dirs, batch, hidden]).
    /// Stacked layers.
    pub fn layers(&self) -> i64 {
        self.layers
    }

    /// The parameters in PyTorch's order (per layer and direction: `weight_ih`, `weight_hh`,
    /// `bias_ih`, `bias_hh`), views of one contiguous buffer in cuDNN's packing (all weights,
    /// then all biases).
    pub fn parameters(&self) -> &[Tensor] {
        &self.params
    }

    /// One step of a one-layer, one-direction LSTM: `x` `[n, input]` from `(h, c)`
    /// (`[n, hidden]` each) to the next `(h, c)`. For policies that carry their state between
    /// calls and reset it per environment.
    ///
    /// # Panics
    /// On a GRU or a stacked or bidirectional layer (a programming error).
    pub fn step(&self, x: &Tensor, h: &Tensor, c: &Tensor) -> (Tensor, Tensor) {
        assert!(
            self.cell == Cell::Lstm && self.layers == 1 && !self.bidirectional,
            "Recurrent::step takes a one-layer, one-direction LSTM"
        );
        let p = &self.params;
        x.lstm_cell(&[h, c], &p[0], &p[1], Some(&p[2]), Some(&p[3]))
    }

    pub fn forward(&self, x: &Tensor, train: bool) -> (Tensor, Tensor) {
        let dirs = if self.bidirectional { 2 } else { 1 };
        let batch = x.size()[0];
        let h0 = Tensor::zeros([self.layers * dirs, batch, self.hidden], (x.kind(), x.device()));
        match self.cell {
            Cell::Lstm => {
                let c0 = h0.zeros_like();
                let (out, h, _c) = x.lstm(
                    &[&h0, &c0],
                    &self.params.iter().collect::<Vec<_>>(),
                    true,
                    self.layers,
                    self.dropout,
                    train,
                    self.bidirectional,
                    true,
                );
                (out, h)
            }
            Cell::Gru => x.gru(
                &h0,
                &self.params,
                true,
                self.layers,
                self.dropout,
                train,
                self.bidirectional,
                true,
            ),
        }
    }
}

/// PyTorch's `flatten_parameters`: the weights become views of one contiguous buffer laid
/// out as cuDNN packs them — every layer's and direction's `weight_ih`, `weight_hh`, then
/// every `bias_ih`, `bias_hh` (read off `nn.LSTM` on an H200, cuDNN 9) — so on CUDA libtorch
/// hands the buffer to cuDNN as it is instead of copying every weight at each call (and
/// warning each time). `params` keep PyTorch's order (per layer: weights, then biases), which
/// is what `lstm`/`gru` take. The variables stay the same variables for autograd, the VarStore
/// and the optimisers; values are unchanged, so the CPU computes the same numbers.
fn flatten_parameters(params: &mut [Tensor]) {
    let Some(first) = params.first() else {
        return;
    };
    let total: i64 = params.iter().map(|p| p.numel() as i64).sum();
    let flat = Tensor::zeros([total], (first.kind(), first.device()));
    // PyTorch's order is [w_ih, w_hh, b_ih, b_hh] per layer and direction: weights first.
    let packed = (0..params.len())
        .filter(|k| k % 4 < 2)
        .chain((0..params.len()).filter(|k| k % 4 >= 2));
    let mut offset = 0;
    tch::no_grad(|| {
        for k in packed {
            let p = &mut params[k];
            let n = p.numel() as i64;
            let mut view = flat.narrow(0, offset, n).view(p.size().as_slice());
            view.copy_(p);
            p.set_data(&view);
            offset += n;
        }
    });
}
