//! `random: python_mt` against CPython itself: for many seeds (one- and two-word, and past
//! the first 624-word twist), FireCast's draws must equal `random.random()` bit for bit, or
//! parity runs against the FireCastRL Python engine would drift apart.

use std::process::Command;

use firecast_sim::PythonRandom;

#[test]
fn python_mt_draws_equal_cpython_random() {
    let mut seeds: Vec<u64> = (0..40).collect();
    seeds.extend([
        1 << 31,
        (1 << 32) - 1,
        1 << 32,
        (1 << 40) + 5,
        u64::MAX,
        0x9e37_79b9_7f4a_7c15,
    ]);
    // Draws 0..3 and 700..703 (the second block comes after a twist of the state).
    let script = format!(
        "import random\nfor s in {seeds:?}:\n    random.seed(s)\n    d = [random.random() for _ in range(703)]\n    print(' '.join(x.hex() for x in d[:3] + d[700:]))\n"
    );
    let out = Command::new("python3")
        .args(["-c", &script])
        .output()
        .expect("python3 is part of the documented setup");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), seeds.len());
    for (&seed, line) in seeds.iter().zip(lines) {
        let mut r = PythonRandom::seed(seed);
        let d: Vec<f64> = (0..703).map(|_| r.random()).collect();
        let ours: Vec<String> = d[..3].iter().chain(&d[700..]).map(|x| python_hex(*x)).collect();
        assert_eq!(ours.join(" "), line, "seed {seed}");
    }
}

/// `float.hex()` of a normal number in [0, 1): `0x1.<13 hex digits>p-<e>` (or `0x0.0p+0`).
fn python_hex(x: f64) -> String {
    if x == 0.0 {
        return "0x0.0p+0".into();
    }
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mantissa = bits & ((1 << 52) - 1);
    format!("0x1.{mantissa:013x}p{exp:+}")
}
