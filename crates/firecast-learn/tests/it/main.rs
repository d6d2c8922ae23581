//! libtorch works from Rust: a tensor computation and a backward pass, on CUDA when present.
#![allow(clippy::unwrap_used)]

use tch::{Kind, Tensor};

#[test]
fn tensor_math_and_backward_pass() {
    let device = firecast_learn::default_device();
    // f(x) = sum(x^3 + 2x); df/dx = 3x^2 + 2
    let x = Tensor::from_slice(&[1.0f32, -2.0, 0.5])
        .to_device(device)
        .set_requires_grad(true);
    let y = (&x * &x * &x + &x * 2.0).sum(Kind::Float);
    y.backward();
    let grad: Vec<f32> = Vec::try_from(x.grad().to_device(tch::Device::Cpu)).unwrap();
    assert_eq!(grad, vec![5.0, 14.0, 2.75]);
    let value = f32::try_from(y.to_device(tch::Device::Cpu)).unwrap();
    assert!((value - (3.0 - 12.0 + 1.125)).abs() < 1e-6, "f(x) = {value}");
}

#[test]
fn cuda_is_used_when_present() {
    let info = firecast_learn::torch_info();
    if info.cuda_available {
        assert!(info.device.contains("Cuda"), "{info:?}");
        assert!(info.cuda_device_count >= 1);
    } else {
        assert_eq!(info.device, "Cpu");
    }
}

#[test]
fn cuda_backend_from_the_torch_wheel_loads() {
    // The PyPI wheel ships libtorch_cuda.so; it must be loadable through the RUNPATH even
    // on a machine without a GPU (where CUDA is then simply unavailable).
    let lib = std::path::Path::new(env!("LIBTORCH")).join("lib/libtorch_cuda.so");
    assert!(lib.exists(), "{} missing", lib.display());
    assert!(
        firecast_learn::load_cuda_backend(),
        "dlopen(libtorch_cuda.so) failed"
    );
}

#[test]
fn recurrent_weights_are_one_buffer_in_cudnn_order() {
    use firecast_learn::layers::{Cell, Recurrent};
    let vs = tch::nn::VarStore::new(tch::Device::Cpu);
    let lstm = Recurrent::new(&vs.root() / "lstm", Cell::Lstm, 5, 3, 2, true, 0.0);
    let params = lstm.parameters();
    assert_eq!(params.len(), 2 * 2 * 4);
    // One contiguous chunk as cuDNN packs it: every weight (by layer, direction, ih/hh),
    // then every bias in the same order.
    let packed: Vec<&Tensor> = (0..params.len())
        .filter(|k| k % 4 < 2)
        .chain((0..params.len()).filter(|k| k % 4 >= 2))
        .map(|k| &params[k])
        .collect();
    for pair in packed.windows(2) {
        assert_eq!(
            pair[1].data_ptr() as usize,
            pair[0].data_ptr() as usize + pair[0].numel() * 4
        );
    }
    // They are still the VarStore's variables, with PyTorch's names.
    let vars = vs.variables();
    let order = ["weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0"];
    for (k, leaf) in order.iter().enumerate() {
        assert_eq!(
            vars[&format!("lstm.{leaf}")].data_ptr(),
            params[k].data_ptr(),
            "{leaf}"
        );
    }
    assert_eq!(vars["lstm.weight_ih_l0_reverse"].data_ptr(), params[4].data_ptr());
    // And the layer trains through them.
    let x = Tensor::randn([2, 4, 5], (Kind::Float, tch::Device::Cpu));
    let (out, _) = lstm.forward(&x, true);
    out.sum(Kind::Float).backward();
    assert!(vars["lstm.weight_hh_l1"].grad().defined());
}
