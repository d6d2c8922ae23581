//! The daily synthetic weather and fire-danger model.
//!
//! Per land cell and day (equations in [`super::model_card`]):
//!
//! 1. **Anomalies.** Smooth Gaussian fields from lattices of independent AR(1) processes
//!    (spacing 2°, 1°, 0.5°, 0.25° or 4°; lag-1 autocorrelation 0.1–0.993), upsampled with
//!    smoothstep-bilinear weights, plus white fine-scale noise per cell: temperature
//!    `aT = 0.8·T₂° + 0.6·T₀.₅°`, moisture/precipitation `aP = 0.8·P₂° + 0.6·P₀.₅°`,
//!    convection `aC` (0.25°), wind `aU`, `aV` (2°), gustiness `aW` (1°), drought regime `aD`
//!    (4°, φ = 0.993).
//! 2. **Precipitation.** A latent `z = (0.8·aP + 0.35·ε + c·aC)/‖·‖` is thresholded at
//!    `θ = Φ⁻¹(1 − f_w) + 0.12·aD` (f_w the climatological wet-day fraction for the cell and
//!    season); the amount on a wet day is `α(1 − 0.06·aD)·(−ln q)^1.25/Γ(2.25)` with
//!    `q = Q(z)/Q(θ)` — a Weibull(0.8) with the climatological mean wet-day amount α.
//! 3. **Temperature, humidity, radiation, wind, reference ET** from the climatology plus the
//!    anomalies, with cloudiness from the precipitation latent; `vpd = (es(Tx)+es(Tn))/2 − ea`.
//! 4. **Fuel moisture (NFDRS 1978).** Simard EMC from (Tmax, RHmin) and (Tmin, RHmax),
//!    day-length weighted; 100-h and 1000-h moistures relax toward boundary values that include
//!    precipitation duration, with the NFDRS 24-h response factors.
//! 5. **ERC/BI (fuel model G) surrogates** from the dead-fuel moistures, greenness and wind.
//!
//! All of a cell's randomness comes from counter-based hashes of `(seed, stream, day, cell)`
//! and from the lattices (advanced serially, cheap), so rows run in parallel with rayon and the
//! result does not depend on scheduling.

use rayon::prelude::*;

use super::climate::{Cell, Settlements, YEAR_DAYS, cell_info};
use super::grid::{GRID_N_LON, GridWindow, grid_lat, land_mask};
use super::noise::{
    ArLattice, Axis, Stream, hash_with, interp_col, key, normal_q, normal_quantile, triangular_pair, unit,
};

/// Index of each output in `GridmetVariable::ALL` order, then the extra outputs.
pub(crate) mod idx {
    pub const PR: usize = 0;
    pub const RMAX: usize = 1;
    pub const RMIN: usize = 2;
    pub const SPH: usize = 3;
    pub const VPD: usize = 4;
    pub const VS: usize = 5;
    pub const TMMX: usize = 6;
    pub const TMMN: usize = 7;
    pub const SRAD: usize = 8;
    pub const BI: usize = 9;
    pub const ERC: usize = 10;
    pub const FM100: usize = 11;
    pub const FM1000: usize = 12;
    pub const PET: usize = 13;
    pub const ETR: usize = 14;
    pub const TH: usize = 15;
    /// Not a GRIDMET variable: the probability of at least one ignition, `1 − exp(−λ)`.
    pub const TRUTH: usize = 16;
    /// Number of outputs.
    pub const N: usize = 17;
}

/// NFDRS 1978 24-hour response factor of the 100-h fuel: `1 − 0.87·exp(−24/100)`.
pub(crate) const K100: f32 = 0.315_633_8;
/// Daily smoothing of the 1000-h boundary value (a 7-day running mean, `1 − exp(−1/7)`).
pub(crate) const K_BDY: f32 = 0.133_122_1;
/// Daily response of the 1000-h fuel: the NFDRS weekly factor `1 − 0.82·exp(−168/1000)`
/// spread over 7 days, `1 − (0.82·exp(−0.168))^(1/7)`.
pub(crate) const K1000: f32 = 0.051_003_5;
/// Daily persistence of the drought index (Palmer's monthly 0.897, per day).
pub(crate) const PDSI_RHO: f32 = 0.996_431;

/// Ignition base rates (per land cell-day, before the multipliers; see `ignitions`).
pub(crate) const BASE_HUMAN: f32 = 3.2e-4;
pub(crate) const BASE_LIGHTNING: f32 = 2.3e-4;
pub(crate) const BASE_RX: f32 = 4.0e-5;

/// Slowly varying state of one land cell.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FuelState {
    pub fm100: f32,
    pub fm1000: f32,
    /// Running mean of the 1000-h boundary moisture.
    pub bdy: f32,
    /// Palmer-like drought index (diagnostic; not a GRIDMET file variable here).
    pub pdsi: f32,
}

impl Default for FuelState {
    fn default() -> Self {
        Self {
            fm100: 18.0,
            fm1000: 22.0,
            bdy: 22.0,
            pdsi: 0.0,
        }
    }
}

/// Lattices of the anomaly fields, in this order.
const LATTICES: [(Stream, usize, f64); 9] = [
    (Stream::TempSyn, 48, 0.75),
    (Stream::TempReg, 12, 0.6),
    (Stream::PrecSyn, 48, 0.55),
    (Stream::PrecReg, 12, 0.35),
    (Stream::Convective, 6, 0.1),
    (Stream::WindU, 48, 0.55),
    (Stream::WindV, 48, 0.55),
    (Stream::WindSpeed, 24, 0.45),
    (Stream::Drought, 96, 0.993),
];

/// The distinct lattice spacings, and which one each lattice of [`LATTICES`] uses (lattices
/// with the same spacing share their interpolation coordinates).
const STEPS: [usize; 5] = [48, 12, 6, 24, 96];
const STEP_OF: [usize; 9] = [0, 1, 0, 1, 2, 0, 0, 3, 4];

/// Day-level inputs shared by every cell.
#[derive(Debug, Clone)]
pub(crate) struct DayCtx {
    /// Days since 1900-01-01.
    pub day: i32,
    /// Day of year (1-based).
    pub doy: u32,
    /// `cos x, sin x, cos 2x, sin 2x`, `x = 2π(doy − 0.5)/365.25`.
    pub harm: [f32; 4],
    /// Whether ignitions are sampled (inside the requested years).
    pub sample_ignitions: bool,
    /// Global ignition rate multiplier.
    pub rate_scale: f32,
    /// Day-level multiplier of human ignitions (spring, Independence Day, weekends).
    pub human_mult: f32,
    /// Day-level multiplier of prescribed burning (late winter/spring, autumn).
    pub rx_mult: f32,
}

/// A land cell-day where the Poisson draw gave at least one ignition.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub gid: u32,
    pub day: i32,
    pub count: u32,
    pub lam_human: f32,
    pub lam_lightning: f32,
    pub lam_rx: f32,
    pub erc: f32,
    pub vs: f32,
    pub fm100: f32,
}

/// Saturation vapour pressure (kPa) over water at `t` °C (Tetens/FAO-56).
#[inline]
pub(crate) fn es(t: f32) -> f32 {
    0.6108 * exp_fast(17.27 * t / (t + 237.3))
}

/// Simard (1968) equilibrium moisture content (%), `h` relative humidity (%), `t` in °F.
#[inline]
pub(crate) fn emc_simard(h: f32, t: f32) -> f32 {
    // All three branches are cheap: compute them and select (no data-dependent jumps).
    let e1 = 0.03229 + 0.281_073 * h - 0.000_578 * h * t;
    let e2 = 2.22749 + 0.160_107 * h - 0.014_784 * t;
    let e3 = 21.0606 + 0.005_565 * h * h - 0.000_35 * h * t - 0.483_199 * h;
    let e = if h < 10.0 {
        e1
    } else if h < 50.0 {
        e2
    } else {
        e3
    };
    fmax(e, 0.2)
}

/// Rothermel's moisture damping coefficient, `r` = moisture / moisture of extinction.
#[inline]
pub(crate) fn eta_m(r: f32) -> f32 {
    if r >= 1.0 {
        0.0
    } else {
        let r = r.max(0.0);
        1.0 - 2.59 * r + 5.11 * r * r - 3.52 * r * r * r
    }
}

/// FAO-56 extraterrestrial radiation (MJ m⁻² d⁻¹) and day length (h).
pub(crate) fn ra_daylength(lat_deg: f64, doy: u32) -> (f32, f32) {
    let j = f64::from(doy);
    let phi = lat_deg.to_radians();
    let dr = 1.0 + 0.033 * (std::f64::consts::TAU * j / 365.0).cos();
    let delta = 0.409 * (std::f64::consts::TAU * j / 365.0 - 1.39).sin();
    let ws = (-phi.tan() * delta.tan()).clamp(-1.0, 1.0).acos();
    let ra = 24.0 * 60.0 / std::f64::consts::PI
        * 0.0820
        * dr
        * (ws * phi.sin() * delta.sin() + phi.cos() * delta.cos() * ws.sin());
    (ra.max(0.0) as f32, (24.0 / std::f64::consts::PI * ws) as f32)
}

#[inline]
fn seas(h: &[f32; 3], c: f32, s: f32) -> f32 {
    h[0] + h[1] * c + h[2] * s
}

/// A cheap logistic-like squashing function onto (0, 1): `½ + ½·x/(1 + |x|)`.
#[inline]
fn squash(x: f32) -> f32 {
    0.5 + 0.5 * x / (1.0 + x.abs())
}

/// `atan2(y, x)` in degrees, polynomial approximation (max error ≈ 0.25°).
#[inline]
pub(crate) fn atan2_deg(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let mx = ax.max(ay);
    if mx == 0.0 {
        return 0.0;
    }
    let a = ax.min(ay) / mx;
    let mut r = a * (FRAC_PI_4 + 0.273 * (1.0 - a));
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        r = -r;
    }
    r.to_degrees()
}

/// `max` without NaN handling (one `maxss`; the model never produces NaN).
#[inline(always)]
fn fmax(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `min` without NaN handling (one `minss`).
#[inline(always)]
fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Branchless clamp; `lo <= hi` is the caller's business.
#[inline(always)]
fn clampf(x: f32, lo: f32, hi: f32) -> f32 {
    fmin(fmax(x, lo), hi)
}

/// `exp(x)` for f32 without a libm call: range reduction to `2^n·2^f`, `|f| ≤ ½`, and a
/// degree-6 Taylor polynomial of `2^f` (relative error < 1e-5 over the clamped range
/// [−87, 88]). Pure arithmetic, so deterministic everywhere.
#[inline(always)]
pub(crate) fn exp_fast(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0; // 1.5·2^23: adding and subtracting rounds to an integer
    let t = clampf(x, -87.0, 88.0) * std::f32::consts::LOG2_E;
    let n = (t + MAGIC) - MAGIC;
    let y = (t - n) * std::f32::consts::LN_2;
    let p = 1.0
        + y * (1.0 + y * (0.5 + y * (1.0 / 6.0 + y * (1.0 / 24.0 + y * (1.0 / 120.0 + y * (1.0 / 720.0))))));
    p * f32::from_bits(((n as i32 + 127) as u32) << 23)
}

#[inline(always)]
fn ramp(x: f32) -> f32 {
    clampf(x, 0.0, 1.0)
}

/// Everything about the window that does not change from day to day, plus the lattices.
pub(crate) struct World {
    pub seed: u64,
    pub window: GridWindow,
    /// Land cells, row-major.
    pub cells: Vec<Cell>,
    /// `cells[row_start[r]..row_start[r + 1]]` are row `r`'s land cells.
    pub row_start: Vec<usize>,
    lattices: Vec<ArLattice>,
    /// Per lattice: axis coordinates of each window row.
    row_axes: Vec<Vec<Axis>>,
    /// Per window column: axis coordinates for each spacing of [`STEPS`].
    col_axes: Vec<[Axis; 5]>,
    quantile: QuantileTable,
}

impl World {
    /// Builds the static fields of `window` and lattices initialised for day `day0`.
    pub fn new(seed: u64, window: GridWindow, day0: i32) -> Self {
        let mask = land_mask(&window);
        let settlements = Settlements::new(seed);
        let rows: Vec<Vec<Cell>> = (0..window.n_lat)
            .into_par_iter()
            .map(|r| {
                let j = window.lat_start + r;
                (0..window.n_lon)
                    .filter(|&c| mask[r * window.n_lon + c])
                    .map(|c| cell_info(seed, &settlements, j, window.lon_start + c, c as u32))
                    .collect()
            })
            .collect();
        let mut row_start = Vec::with_capacity(window.n_lat + 1);
        let mut cells = Vec::new();
        for r in rows {
            row_start.push(cells.len());
            cells.extend(r);
        }
        row_start.push(cells.len());
        let lattices: Vec<ArLattice> = LATTICES
            .iter()
            .map(|&(stream, step, phi)| ArLattice::new(seed, stream, step, phi, window.as_tuple(), day0 - 1))
            .collect();
        let row_axes = lattices
            .iter()
            .map(|l| {
                (0..window.n_lat)
                    .map(|r| l.row_axis(window.lat_start + r))
                    .collect()
            })
            .collect();
        let rep: Vec<&ArLattice> = STEPS
            .iter()
            .map(|&s| lattices.iter().find(|l| l.step == s).unwrap_or(&lattices[0]))
            .collect();
        let col_axes = (0..window.n_lon)
            .map(|c| std::array::from_fn(|g| rep[g].col_axis(window.lon_start + c)))
            .collect();
        Self {
            seed,
            window,
            cells,
            row_start,
            lattices,
            row_axes,
            col_axes,
            quantile: QuantileTable::new(),
        }
    }

    /// Number of land cells.
    pub fn land_cells(&self) -> usize {
        self.cells.len()
    }

    /// Advances the anomaly lattices to `day`.
    pub fn advance(&mut self, day: i32) {
        let seed = self.seed;
        self.lattices.par_iter_mut().for_each(|l| l.step_day(seed, day));
    }

    /// Computes one day for every land cell of every row: updates `state`, writes the
    /// requested outputs (`slots`: `(variable index, output index)`) into `outputs`
    /// (`[lat][lon]` grids), and returns the ignition candidates in row-major order. With
    /// `full` false (warm-up) only the state is advanced (the same equations, fewer outputs).
    pub fn run_day(
        &self,
        ctx: &DayCtx,
        full: bool,
        state: &mut [FuelState],
        outputs: &mut [Vec<f32>],
        slots: &[(usize, usize)],
    ) -> Vec<Candidate> {
        let need = Needs::for_slots(full, slots);
        let n_lat = self.window.n_lat;
        let n_lon = self.window.n_lon;
        let mut state_rows: Vec<&mut [FuelState]> = Vec::with_capacity(n_lat);
        let mut rest = state;
        for r in 0..n_lat {
            let (a, b) = rest.split_at_mut(self.row_start[r + 1] - self.row_start[r]);
            state_rows.push(a);
            rest = b;
        }
        let mut out_rows: Vec<Vec<&mut [f32]>> =
            (0..n_lat).map(|_| Vec::with_capacity(outputs.len())).collect();
        for buf in outputs.iter_mut() {
            for (r, chunk) in buf.chunks_mut(n_lon).enumerate() {
                out_rows[r].push(chunk);
            }
        }
        let rows: Vec<Vec<Candidate>> = state_rows
            .into_par_iter()
            .zip(out_rows.into_par_iter())
            .enumerate()
            .map(|(r, (st, mut outs))| {
                let mut cands = Vec::new();
                self.run_row(r, ctx, st, &mut outs, slots, need, &mut cands);
                cands
            })
            .collect();
        rows.into_iter().flatten().collect()
    }

    #[allow(clippy::too_many_lines, clippy::too_many_arguments)]
    fn run_row(
        &self,
        r: usize,
        ctx: &DayCtx,
        state: &mut [FuelState],
        outs: &mut [&mut [f32]],
        slots: &[(usize, usize)],
        need: Needs,
        cands: &mut Vec<Candidate>,
    ) {
        let cells = &self.cells[self.row_start[r]..self.row_start[r + 1]];
        if cells.is_empty() {
            return;
        }
        let lat = grid_lat(self.window.lat_start + r);
        let (ra, daylen) = ra_daylength(lat, ctx.doy);
        let night = 24.0 - daylen;
        let mut rows: Vec<Vec<f32>> = vec![Vec::new(); self.lattices.len()];
        for (k, l) in self.lattices.iter().enumerate() {
            if need.full || !matches!(k, 5..=7) {
                l.interp_row(self.row_axes[k][r], &mut rows[k]);
            }
        }
        let [c1, s1, c2, s2] = ctx.harm;
        let key_a = key(self.seed, Stream::CellNoiseA, i64::from(ctx.day));
        let key_b = key(self.seed, Stream::CellNoiseB, i64::from(ctx.day));
        let key_i = key(self.seed, Stream::Ignition, i64::from(ctx.day));
        let mut vals = [f32::NAN; idx::N];
        const INV24: f32 = 1.0 / 24.0;

        // Cells go through the model in chunks, one stage at a time: the stages are long chains
        // of dependent operations, and running a stage over independent cells back to back lets
        // them overlap (and lets the compiler vectorise the branch-free stages).
        const CH: usize = 16;
        for (cc, sc) in cells.chunks(CH).zip(state.chunks_mut(CH)) {
            let n = cc.len();
            let mut a_t = [0f32; CH];
            let mut a_p = [0f32; CH];
            let mut a_c = [0f32; CH];
            let mut a_d = [0f32; CH];
            let mut n2 = [0f32; CH];
            let mut n3 = [0f32; CH];
            let mut n4 = [0f32; CH];
            let mut t_clim = [0f32; CH];
            let mut fw = [0f32; CH];
            let mut theta = [0f32; CH];
            let mut z = [0f32; CH];
            let mut alpha0 = [0f32; CH];
            let mut pr = [0f32; CH];
            let mut cloud = [0f32; CH];
            let mut tmax = [0f32; CH];
            let mut tmin = [0f32; CH];
            let mut td = [0f32; CH];
            let mut ea = [0f32; CH];
            let mut esx = [0f32; CH];
            let mut esn = [0f32; CH];
            let mut rmax = [0f32; CH];
            let mut rmin = [0f32; CH];
            let mut emc_min = [0f32; CH];
            let mut dur = [0f32; CH];

            // Stage 1: anomalies, cell noise, precipitation latent and threshold.
            for k in 0..n {
                let c = &cc[k];
                let axes = &self.col_axes[c.col as usize];
                let lat_v = |l: usize| interp_col(&rows[l], axes[STEP_OF[l]]);
                a_t[k] = 0.8 * lat_v(0) + 0.6 * lat_v(1);
                a_p[k] = 0.8 * lat_v(2) + 0.6 * lat_v(3);
                a_c[k] = lat_v(4);
                a_d[k] = lat_v(8);
                let gid = u64::from(c.gid);
                let (e1, e2) = triangular_pair(hash_with(key_a, gid));
                let (e3, e4) = triangular_pair(hash_with(key_b, gid));
                (n2[k], n3[k], n4[k]) = (e2, e3, e4);
                t_clim[k] = seas(&c.t, c1, s1);
                let prel = fmax(
                    1.0 + c.p_season[0] * c1 + c.p_season[1] * s1 + c.p_season[2] * c2 + c.p_season[3] * s2,
                    0.03,
                );
                fw[k] = clampf(c.f0 * prel.sqrt(), 0.005, 0.85);
                theta[k] = self.quantile.upper(fw[k]) + 0.12 * a_d[k];
                let cw = c.convective * ramp((t_clim[k] - 12.0) * (1.0 / 12.0));
                z[k] = (0.8 * a_p[k] + 0.35 * e1 + cw * a_c[k]) / (0.7625 + cw * cw).sqrt();
                alpha0[k] = c.p_mean * prel / fw[k];
            }

            // Stage 2: amounts on wet cells.
            for k in 0..n {
                pr[k] = if z[k] > theta[k] {
                    let q =
                        (normal_q(f64::from(z[k])) / normal_q(f64::from(theta[k]))).clamp(1e-12, 1.0) as f32;
                    let alpha = alpha0[k] * clampf(1.0 - 0.06 * a_d[k], 0.7, 1.3);
                    let e = -q.ln();
                    clampf(alpha * e * e.sqrt().sqrt() * (1.0 / 1.133), 0.1, 400.0)
                } else {
                    0.0
                };
            }

            // Stage 3: cloud, temperature (°C), dew point below Tmin (so RH ≤ 100 %, vpd ≥ 0).
            for k in 0..n {
                let c = &cc[k];
                let wet = pr[k] > 0.0;
                cloud[k] = squash(1.5 * (z[k] - theta[k]) + 0.5);
                let sig_t = fmax(seas(&c.sig_t, c1, s1), 0.8);
                let tm = t_clim[k] + sig_t * a_t[k] + 0.5 * n2[k] + 0.9 * a_d[k] - 1.8 * (cloud[k] - 0.35);
                let dtr = fmax(
                    seas(&c.dtr, c1, s1) * (1.3 - 0.75 * cloud[k]) * if wet { 0.85 } else { 1.0 },
                    2.0,
                );
                tmax[k] = clampf(tm + 0.5 * dtr, 233.0 - 273.15, 327.0 - 273.15);
                tmin[k] = fmin(
                    clampf(tm - 0.5 * dtr, 225.0 - 273.15, 315.0 - 273.15),
                    tmax[k] - 0.5,
                );
                let dd = fmax(
                    seas(&[c.dd[0], c.dd[1], c.dd[2]], c1, s1) + c.dd[3] * c2 + c.dd[4] * s2 - 2.2 * a_p[k]
                        + 1.2 * a_d[k]
                        + 0.8 * n3[k],
                    0.0,
                ) * if wet { 0.15 } else { 1.0 };
                td[k] = tmin[k] - dd;
            }

            // Stage 4: vapour pressures and relative humidity.
            for k in 0..n {
                ea[k] = es(td[k]);
                esx[k] = es(tmax[k]);
                esn[k] = es(tmin[k]);
                rmax[k] = clampf(100.0 * ea[k] / esn[k], 1.0, 100.0);
                rmin[k] = clampf(100.0 * ea[k] / esx[k], 0.5, rmax[k]);
            }

            // Stage 5: NFDRS 1978 dead fuel moisture, drought index.
            for k in 0..n {
                let st = &mut sc[k];
                emc_min[k] = emc_simard(rmin[k], tmax[k] * 1.8 + 32.0);
                let emc_max = emc_simard(rmax[k], tmin[k] * 1.8 + 32.0);
                let emcbar = (daylen * emc_min[k] + night * emc_max) * INV24;
                let d = if pr[k] >= 0.25 {
                    fmin(1.0 + pr[k] * 0.25, 8.0)
                } else {
                    0.0
                };
                dur[k] = d;
                let bndryh = ((24.0 - d) * emcbar + d * (0.5 * d + 41.0)) * INV24;
                st.fm100 = clampf(st.fm100 + (bndryh - st.fm100) * K100, 0.3, 33.0);
                let bndryt = ((24.0 - d) * emcbar + d * (2.7 * d + 76.0)) * INV24;
                st.bdy += (bndryt - st.bdy) * K_BDY;
                st.fm1000 = clampf(st.fm1000 + (st.bdy - st.fm1000) * K1000, 0.4, 48.0);
                let x = pr[k] / alpha0[k] - fw[k];
                st.pdsi = clampf(PDSI_RHO * st.pdsi + 0.1203 / fw[k].sqrt() * x, -10.0, 10.0);
            }

            if !need.full {
                // Warm-up: the state is all that is kept.
                continue;
            }

            // Stage 6: wind speed, vpd, 1-h/10-h moistures and the ERC surrogate (fuel model G).
            let mut uu = [0f32; CH];
            let mut vv = [0f32; CH];
            let mut vs = [0f32; CH];
            let mut vpd = [0f32; CH];
            let mut mc1 = [0f32; CH];
            let mut mc10 = [0f32; CH];
            let mut erc = [0f32; CH];
            for k in 0..n {
                let c = &cc[k];
                let axes = &self.col_axes[c.col as usize];
                let lat_v = |l: usize| interp_col(&rows[l], axes[STEP_OF[l]]);
                // Mean flow + synoptic anomaly; speed lognormal around the climatology.
                uu[k] = seas(&c.u, c1, s1) + 2.8 * lat_v(5);
                vv[k] = seas(&c.v, c1, s1) + 2.8 * lat_v(6);
                let speed_flow = (uu[k] * uu[k] + vv[k] * vv[k]).sqrt();
                vs[k] = clampf(
                    seas(&c.vs, c1, s1) * exp_fast(0.33 * lat_v(7) + 0.1 * n3[k] - 0.06)
                        + 0.12 * fmax(speed_flow - 3.0, 0.0),
                    0.1,
                    29.0,
                );
                vpd[k] = fmax(0.5 * (esx[k] + esn[k]) - ea[k], 0.0);
                let wet = dur[k] > 0.0;
                mc1[k] = if wet { 35.0 } else { 1.03 * emc_min[k] };
                mc10[k] = if wet { 35.0 } else { 1.28 * emc_min[k] };
                let green = clampf(seas(&c.green, c1, s1), 0.0, 1.0);
                const I30: f32 = 1.0 / 30.0;
                let st = &sc[k];
                let dry = 0.15 * fmax(1.0 - mc1[k] * I30, 0.0)
                    + 0.10 * fmax(1.0 - mc10[k] * I30, 0.0)
                    + 0.25 * fmax(1.0 - st.fm100 * I30, 0.0)
                    + 0.50 * fmax(1.0 - st.fm1000 * (1.0 / 35.0), 0.0);
                let d_eff = dry * (1.0 - 0.3 * green);
                erc[k] = fmin(158.0 * d_eff * d_eff * d_eff.sqrt(), 132.0);
            }

            // Stage 7: ignition rates.
            let mut lam = [[0f32; 3]; CH];
            if ctx.sample_ignitions {
                for k in 0..n {
                    let st = &sc[k];
                    lam[k] = ignition_rates(
                        &cc[k],
                        ctx,
                        Fire {
                            fm100: st.fm100,
                            fm1000: st.fm1000,
                            erc: erc[k],
                            vs: vs[k],
                            vpd: vpd[k],
                            rmin: rmin[k],
                            pr: pr[k],
                            tmax_c: tmax[k],
                            ea: ea[k],
                            a_c: a_c[k],
                        },
                    );
                }
            }

            // Stage 8: optional outputs, writing, Poisson draws.
            for k in 0..n {
                let c = &cc[k];
                let st = &sc[k];
                let col = c.col as usize;
                if need.th {
                    let mut th = atan2_deg(-uu[k], -vv[k]) + 14.0 * n4[k];
                    if th < 0.0 {
                        th += 360.0;
                    }
                    if th < 0.0 {
                        th += 360.0;
                    }
                    // [0, 360) even after packing to 0.01°: 359.995 and up is north, 0.
                    if th >= 359.995 {
                        th = 0.0;
                    }
                    vals[idx::TH] = th;
                }
                if need.bi {
                    let u20_mph = vs[k] * (2.236_94 / 1.15);
                    let eta_fine = 0.6 * eta_m(mc1[k] * 0.04) + 0.4 * eta_m(mc10[k] * 0.04);
                    let spread = 4.0 * eta_fine * (1.0 + 0.12 * u20_mph * u20_mph.sqrt());
                    vals[idx::BI] = if spread * erc[k] > 0.0 {
                        fmin(3.01 * (spread * erc[k]).powf(0.46), 214.0)
                    } else {
                        0.0
                    };
                }
                if need.rad {
                    // Radiation (FAO-56 clear sky, reduced by cloud) and reference ET: Hargreaves
                    // (1975) radiation form + an aerodynamic term.
                    let rs = ra * (0.75 + 2e-5 * c.elev) * (1.0 - 0.65 * cloud[k]);
                    let u2 = 0.748 * vs[k];
                    let tm = 0.5 * (tmax[k] + tmin[k]);
                    let pet = fmax((0.0135 * 0.408) * (tm + 17.8) * rs, 0.0) + 0.22 * u2 * vpd[k];
                    let pet = clampf(pet, 0.0, 17.0);
                    vals[idx::SRAD] = clampf(rs * 11.574, 0.0, 456.0);
                    vals[idx::PET] = pet;
                    vals[idx::ETR] = clampf(
                        pet * (1.15 + 0.04 * fmin(u2, 6.0) + 0.03 * fmin(vpd[k], 6.0)),
                        pet,
                        27.0,
                    );
                }
                if need.sph {
                    vals[idx::SPH] = clampf(0.622 * ea[k] / (c.press - 0.378 * ea[k]), 0.0, 0.02);
                }
                vals[idx::PR] = pr[k];
                vals[idx::RMAX] = rmax[k];
                vals[idx::RMIN] = rmin[k];
                vals[idx::VPD] = vpd[k];
                vals[idx::VS] = vs[k];
                vals[idx::TMMX] = tmax[k] + 273.15;
                vals[idx::TMMN] = tmin[k] + 273.15;
                vals[idx::ERC] = erc[k];
                vals[idx::FM100] = st.fm100;
                vals[idx::FM1000] = st.fm1000;
                // The draw below gives an ignition with probability exactly 1 − exp(−λ), so this
                // is the truth the forecasting oracle scores with (computed as −expm1(−λ) so tiny
                // rates keep their precision).
                let rates = lam[k];
                let total = f64::from(ctx.rate_scale * (rates[0] + rates[1] + rates[2]));
                if need.truth {
                    vals[idx::TRUTH] = (-(-total).exp_m1()) as f32;
                }
                for &(v, o) in slots {
                    outs[o][col] = vals[v];
                }

                // Ignitions: N ~ Poisson(λ) by inverse CDF (see `ignitions` for the model).
                if ctx.sample_ignitions {
                    let u = unit(hash_with(key_i, u64::from(c.gid)));
                    // No ignition when u < exp(−λ); as exp(−λ) ≥ 1 − λ, u < 1 − λ settles the
                    // common case without an exp.
                    if total > 0.0 && u >= 1.0 - total && u >= (-total).exp() {
                        let p0 = (-total).exp();
                        let (mut count, mut p, mut cdf) = (0u32, p0, p0);
                        while u >= cdf && count < 20 {
                            count += 1;
                            p *= total / f64::from(count);
                            cdf += p;
                        }
                        cands.push(Candidate {
                            gid: c.gid,
                            day: ctx.day,
                            count: count.max(1),
                            lam_human: ctx.rate_scale * rates[0],
                            lam_lightning: ctx.rate_scale * rates[1],
                            lam_rx: ctx.rate_scale * rates[2],
                            erc: erc[k],
                            vs: vs[k],
                            fm100: st.fm100,
                        });
                    }
                }
            }
        }
    }
}

/// The weather of one cell-day that the ignition model uses.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fire {
    pub fm100: f32,
    pub fm1000: f32,
    pub erc: f32,
    pub vs: f32,
    pub vpd: f32,
    pub rmin: f32,
    pub pr: f32,
    /// Maximum temperature (°C).
    pub tmax_c: f32,
    /// Actual vapour pressure (kPa).
    pub ea: f32,
    /// Convective anomaly.
    pub a_c: f32,
}

/// Which parts of the model a day needs (`full` = false: warm-up, state only).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Needs {
    pub full: bool,
    pub th: bool,
    pub bi: bool,
    pub rad: bool,
    pub sph: bool,
    /// The ignition probability (only meaningful when ignitions are sampled).
    pub truth: bool,
}

impl Needs {
    /// What computing `slots` (and sampling ignitions, when `full`) requires.
    pub fn for_slots(full: bool, slots: &[(usize, usize)]) -> Self {
        let has = |i: usize| full && slots.iter().any(|&(v, _)| v == i);
        Self {
            full,
            th: has(idx::TH),
            bi: has(idx::BI),
            rad: has(idx::SRAD) || has(idx::PET) || has(idx::ETR),
            sph: has(idx::SPH),
            truth: has(idx::TRUTH),
        }
    }
}

/// `Φ⁻¹(1 − f)` tabulated on `f ∈ [0.005, 0.85]` (2049 points, linear interpolation;
/// |error| < 2e-4 against Acklam's approximation).
pub(crate) struct QuantileTable {
    values: Vec<f32>,
}

impl QuantileTable {
    const LO: f32 = 0.005;
    const HI: f32 = 0.85;
    const N: usize = 2048;

    pub fn new() -> Self {
        let values = (0..=Self::N)
            .map(|k| {
                let f = f64::from(Self::LO) + (f64::from(Self::HI - Self::LO)) * k as f64 / Self::N as f64;
                normal_quantile(1.0 - f) as f32
            })
            .collect();
        Self { values }
    }

    #[inline]
    pub fn upper(&self, f: f32) -> f32 {
        let x = clampf(
            (f - Self::LO) * (Self::N as f32 / (Self::HI - Self::LO)),
            0.0,
            Self::N as f32 - 1e-3,
        );
        // Via i32: an f32 → usize cast needs a slower saturating sequence.
        let k = x as i32 as usize;
        let t = x - k as f32;
        match self.values.get(k..k + 2) {
            Some(&[a, b]) => a + (b - a) * t,
            _ => self.values[Self::N],
        }
    }
}

/// `[human, lightning, prescribed]` ignition rates of one cell-day (before `rate_scale`).
/// Branch-free apart from `ln(1 + pr)` on wet days.
#[inline]
pub(crate) fn ignition_rates(c: &Cell, ctx: &DayCtx, w: Fire) -> [f32; 3] {
    let Fire {
        fm100,
        fm1000,
        erc,
        vs,
        vpd,
        rmin,
        pr,
        tmax_c,
        ea,
        a_c,
    } = w;
    let x1 = (12.0 - fm100) * 0.25;
    let x2 = (15.0 - fm1000) * 0.2;
    let x3 = (erc - 40.0) * 0.04;
    let x4 = (vs - 3.5) * 0.4;
    let x5 = (vpd - 1.5) * (1.0 / 1.2);
    let x6 = (30.0 - rmin) * (1.0 / 15.0);
    let x7 = if pr > 0.0 { (1.0 + pr).ln() } else { 0.0 };
    let cold = ramp((3.0 - tmax_c) * 0.1);
    let dryness = 0.35 * x1 + 0.15 * x2 + 0.2 * x3;
    let human_act = c.human / (1.0 + c.human * (1.0 / 3.0));
    let lin_h = dryness + 0.2 * x4 + 0.1 * x5 + 0.1 * x6 - 0.8 * x7 - 2.5 * cold;
    let lam_h = BASE_HUMAN * human_act * ctx.human_mult * exp_fast(fmin(lin_h, 8.0));

    // Lightning: warm, moist, convectively active days; most efficient with little rain
    // (factor 0.45 without rain at the cell, 1 for 0.25–5 mm, exp(−(pr − 5)/4) above).
    let warm_moist = ramp((tmax_c - 22.0) * (1.0 / 12.0)) * ramp(ea * (1.0 / 1.2));
    let rain_eff = if pr < 0.25 { 0.45 } else { 1.0 };
    let lin_l = 1.2 * a_c - 0.72 + 0.5 * x1 + 0.3 * x2 + 0.3 * x3 - 2.5 * cold - fmax((pr - 5.0) * 0.25, 0.0);
    let lam_l = BASE_LIGHTNING * c.lightning * warm_moist * rain_eff * exp_fast(fmin(lin_l, 8.0));

    // Prescribed fire: moderate moisture, light wind, no rain, in the burn seasons.
    let m = (fm100 - 14.0) * 0.2;
    let dry_day = if pr < 1.0 { 1.0 } else { 0.0 };
    let lam_rx = dry_day * BASE_RX * c.rx * ctx.rx_mult * exp_fast(-m * m - 0.5 * fmax(vs - 5.0, 0.0));
    [lam_h, lam_l, lam_rx]
}

/// Day-level multipliers and harmonics for `day`.
pub(crate) fn day_ctx(day: i32, sample_ignitions: bool, rate_scale: f64) -> DayCtx {
    let (y, m, d) = firecast_data::gridmet::day_to_ymd(day);
    let doy = (day - firecast_data::gridmet::ymd_to_day(y, 1, 1).unwrap_or(day)) as u32 + 1;
    let x = std::f64::consts::TAU * (f64::from(doy) - 0.5) / YEAR_DAYS;
    let g = |t: f64, c: f64, w: f64| (-0.5 * ((t - c) / w).powi(2)).exp();
    let t = f64::from(doy);
    // 1900-01-01 was a Monday: (day mod 7) 5 and 6 are Saturday and Sunday.
    let weekend = matches!(day.rem_euclid(7), 5 | 6);
    let july4 = m == 7 && (d == 4 || d == 5);
    let human = (1.0 + 0.45 * g(t, 85.0, 28.0) + 0.15 * g(t, 300.0, 25.0))
        * if weekend { 1.15 } else { 1.0 }
        * if july4 { 2.5 } else { 1.0 };
    let rx = 0.12 + g(t, 65.0, 35.0) + 0.5 * g(t, 305.0, 25.0);
    DayCtx {
        day,
        doy,
        harm: [
            x.cos() as f32,
            x.sin() as f32,
            (2.0 * x).cos() as f32,
            (2.0 * x).sin() as f32,
        ],
        sample_ignitions,
        rate_scale: rate_scale as f32,
        human_mult: human as f32,
        rx_mult: rx as f32,
    }
}

/// The global cell id's `(row, column)` on the full grid.
pub(crate) fn gid_to_ji(gid: u32) -> (usize, usize) {
    (gid as usize / GRID_N_LON, gid as usize % GRID_N_LON)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_match_their_formulas() {
        assert!((K100 - (1.0 - 0.87 * (-0.24f32).exp())).abs() < 1e-6);
        assert!((K_BDY - (1.0 - (-1.0f32 / 7.0).exp())).abs() < 1e-6);
        assert!((K1000 - (1.0 - (0.82 * (-0.168f32).exp()).powf(1.0 / 7.0))).abs() < 1e-6);
        assert!((PDSI_RHO - 0.897f32.powf(1.0 / 30.4)).abs() < 1e-5);
    }

    #[test]
    fn emc_and_es() {
        // Hot and dry: EMC a few percent; cool and humid: ~20 %.
        assert!((2.0..3.5).contains(&emc_simard(10.0, 91.0)));
        assert!((17.0..23.0).contains(&emc_simard(85.0, 18.0)));
        assert!((es(20.0) - 2.338).abs() < 0.01);
        assert!(eta_m(1.2) == 0.0 && eta_m(0.0) == 1.0);
    }

    #[test]
    fn radiation() {
        let (ra, n) = ra_daylength(40.0, 172);
        assert!((40.0..43.0).contains(&ra), "{ra}");
        assert!((14.5..15.5).contains(&n), "{n}");
        let (ra, n) = ra_daylength(40.0, 355);
        assert!((13.0..16.0).contains(&ra) && (9.0..9.7).contains(&n), "{ra} {n}");
    }

    #[test]
    fn weekday_reference() {
        // 2023-07-04 was a Tuesday; 2023-07-08 a Saturday.
        let tue = firecast_data::gridmet::ymd_to_day(2023, 7, 4).expect("date");
        assert!(!matches!(tue.rem_euclid(7), 5 | 6));
        assert_eq!((tue + 4).rem_euclid(7), 5);
    }
}

#[cfg(test)]
mod climatology_tests {
    use super::*;

    /// Over several years the simulated precipitation matches the climatology it is built from.
    #[test]
    fn precipitation_matches_climatology() {
        for (lat_start, lon_start) in [(300usize, 900usize), (250, 300)] {
            let window = GridWindow {
                lat_start,
                n_lat: 12,
                lon_start,
                n_lon: 12,
            };
            let mut w = World::new(5, window, 1000);
            let mut st = vec![FuelState::default(); w.land_cells()];
            let mut out = vec![vec![f32::NAN; window.cells()]];
            let (mut sim, mut clim) = (0f64, 0f64);
            for day in 1000..1000 + 6 * 365 {
                w.advance(day);
                let ctx = day_ctx(day, false, 1.0);
                w.run_day(&ctx, true, &mut st, &mut out, &[(idx::PR, 0)]);
                let [c1, s1, c2, s2] = ctx.harm;
                for r in 0..window.n_lat {
                    for c in &w.cells[w.row_start[r]..w.row_start[r + 1]] {
                        let ps = c.p_season;
                        let prel = fmax(1.0 + ps[0] * c1 + ps[1] * s1 + ps[2] * c2 + ps[3] * s2, 0.03);
                        clim += f64::from(c.p_mean * prel);
                        sim += f64::from(out[0][r * window.n_lon + c.col as usize]);
                    }
                }
            }
            let ratio = sim / clim;
            assert!(
                (0.75..1.3).contains(&ratio),
                "window ({lat_start}, {lon_start}): ratio {ratio}"
            );
        }
    }
}
