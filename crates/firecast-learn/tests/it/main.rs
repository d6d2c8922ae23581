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
