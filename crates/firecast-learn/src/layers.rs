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
