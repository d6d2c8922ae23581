//! Free spread with the verified engine: an ensemble of unsuppressed fires run with the
//! minimum-travel-time engine of `firecast-spread` (docs/results/spread-verification.md: it
//! passes the ellipse cases the automaton fails) instead of the automaton, over the same
//! perturbed runs as every other strategy. No helicopter flies here: drops need the
//! automaton's step-by-step state.

use firecast_sim::KernelConfig;
use firecast_spread::mtt::{self, MttConfig};

use crate::ensemble::{DomainGrowth, Ensemble, EpisodeRecord, Setup, assemble, edge_of};
use crate::{EpisodeError, LandscapeSpec};

/// What the description of an MTT ensemble says.
pub const MTT_DESCRIPTION: &str = "no suppression, spread by the minimum-travel-time engine (radius-8 stencil, \
     Rothermel ellipses per cell; verified against the ellipse in docs/results/spread-verification.md)";

/// `runs` unsuppressed fires with seeds `seed`, `seed + 1`, … spread by the MTT engine for the
/// scenario's simulated period (`max_steps` × `dt_min`). A cell counts as burning for the
/// automaton's `min_cell_burn_time_min` after the fire reaches it (the peak and whether the
/// fire went out use it).
pub fn run_mtt(
    setup: &Setup,
    runs: usize,
    seed: u64,
    on_run: impl FnMut(usize),
) -> Result<Ensemble, EpisodeError> {
    let out = mtt_runs(setup, runs, seed, false, on_run)?.unwrap_or_default();
    assemble(setup, "none", MTT_DESCRIPTION.to_string(), out)
}

/// The same ensemble on a map that grows until no run burns a border cell: the landscape is
/// rebuilt around the same centre with its width and height doubled, at most `max_factor`
/// times the base. `setup_at(width, height)` builds the setup at a size (the base size first).
/// A round stops at the first run that reaches the border. Only landscapes that can be built
/// at any size around their centre grow (see [`resized`]).
pub fn run_mtt_growing(
    mut setup_at: impl FnMut(usize, usize) -> Result<Setup, EpisodeError>,
    base: [usize; 2],
    max_factor: u32,
    runs: usize,
    seed: u64,
    mut on_run: impl FnMut(usize),
) -> Result<Ensemble, EpisodeError> {
    let mut factor = 1u32;
    let mut rounds = 0u32;
    loop {
        rounds += 1;
        let size = [base[0] * factor as usize, base[1] * factor as usize];
        let setup = setup_at(size[0], size[1])?;
        let last = factor.saturating_mul(2) > max_factor;
        if let Some(out) = mtt_runs(&setup, runs, seed, !last, &mut on_run)? {
            let contained = out.iter().all(|(e, _)| e.edge_cells_burned == 0);
            let mut ensemble = assemble(&setup, "none", MTT_DESCRIPTION.to_string(), out)?;
            ensemble.domain = Some(DomainGrowth {
                base,
                size,
                max_factor,
                rounds,
                contained,
            });
            return Ok(ensemble);
        }
        factor *= 2;
    }
}

/// The landscape spec at another size around the same centre, for the kinds that are
/// anchored to the world (the synthetic world, GeoTIFF rasters, a LANDFIRE window around a
/// centre); None for the others (a
/// procedural map changes with its size, FireCastRL's PNGs have one).
pub fn resized(spec: &LandscapeSpec, width: usize, height: usize) -> Option<LandscapeSpec> {
    let mut spec = spec.clone();
    match &mut spec {
        LandscapeSpec::Synthetic {
            width: w, height: h, ..
        }
        | LandscapeSpec::Geotiff {
            width: w, height: h, ..
        } => {
            *w = width;
            *h = height;
            Some(spec)
        }
        // A LANDFIRE window around its centre (read again at the new size).
        LandscapeSpec::Landfire {
            center: Some(_),
            width: w,
            height: h,
            site,
            ..
        } => {
            *w = Some(width);
            *h = Some(height);
            *site = None;
            Some(spec)
        }
        _ => None,
    }
}

/// One run's record and its arrival map, hours.
type Run = (EpisodeRecord, Vec<f32>);

/// Runs and arrival maps; None when `stop_at_edge` and a run burned a border cell.
fn mtt_runs(
    setup: &Setup,
    runs: usize,
    seed: u64,
    stop_at_edge: bool,
    mut on_run: impl FnMut(usize),
) -> Result<Option<Vec<Run>>, EpisodeError> {
    let land = &setup.landscape;
    let mut out = Vec::with_capacity(runs);
    for k in 0..runs {
        let s = seed.wrapping_add(k as u64);
        let (env, conditions) = setup.run_env(s);
        let KernelConfig::Rothermel { moisture, .. } = env.sim.kernel else {
            return Err(EpisodeError::Engine(
                "the minimum-travel-time engine needs the Rothermel kernel (env.sim.kernel.rothermel)".into(),
            ));
        };
        let step_h = env.sim.dt_min / 60.0;
        let period_h = f64::from(env.max_steps) * step_h;
        let cfg = MttConfig {
            moisture,
            wind: env.sim.wind,
            stencil_radius: mtt::DEFAULT_STENCIL_RADIUS,
            max_time_h: period_h,
        };
        let [ix, iy] = setup.ignition;
        // A LANDFIRE window spreads over its own slope, aspect and canopy layers.
        let site = setup.scenario.landscape.landfire_site();
        let arrival_h = match site
            .map(|s| s.mtt_arrival_h(&cfg, (ix, iy)))
            .transpose()?
            .flatten()
        {
            Some(a) => a,
            None => mtt::arrival_times_h(land, &cfg, &[(ix, iy)])
                .map_err(|e| EpisodeError::Engine(format!("minimum travel time: {e}")))?,
        };
        let arrival: Vec<f32> = arrival_h
            .iter()
            .map(|&t| if t <= period_h { t as f32 } else { f32::INFINITY })
            .collect();
        let mut times: Vec<f64> = arrival_h.iter().copied().filter(|&t| t <= period_h).collect();
        times.sort_by(f64::total_cmp);
        let reached_by = |t: f64| times.partition_point(|&a| a <= t + 1e-9) as u32;
        let residence_h = env.sim.min_cell_burn_time_min / 60.0;
        let mut burned_per_step = Vec::with_capacity(env.max_steps as usize + 1);
        let mut peak = (0u32, 0.0);
        for step in 0..=env.max_steps {
            let t = f64::from(step) * step_h;
            let burned = reached_by(t);
            let burning = burned - reached_by(t - residence_h);
            if burning > peak.0 {
                peak = (burning, t);
            }
            burned_per_step.push(burned);
        }
        let last = times.last().copied().unwrap_or(0.0);
        let went_out = last + residence_h <= period_h;
        let (edge_cells_burned, edge_first_hour) = edge_of(&arrival, land.width, land.height);
        if stop_at_edge && edge_cells_burned > 0 {
            return Ok(None);
        }
        out.push((
            EpisodeRecord {
                seed: s,
                policy: None,
                cells_burned: times.len() as u32,
                hours: if went_out { last + residence_h } else { period_h },
                contained: went_out,
                helitacks: 0,
                water_used_gal: 0.0,
                conditions,
                peak_burning_cells: peak.0,
                peak_burning_hour: peak.1,
                burned_per_step,
                drops: Vec::new(),
                edge_cells_burned,
                edge_first_hour,
            },
            arrival,
        ));
        on_run(k);
    }
    Ok(Some(out))
}
