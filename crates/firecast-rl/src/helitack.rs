//! The helitack environment as a [`VecEnvironment`]: fire pools drawn from a [`FireSet`]
//! (procedural landscapes, wind, fuel moisture, ignition cells), observations of 4 stacked
//! frames plus a helicopter channel (image) and `[x, y, on_fire]` (vector).

use firecast_landscape::{Landscape, procedural};
use firecast_ppo::PpoError;
use firecast_ppo::env::{ObsBatch, ObsSpace, VecEnvironment};
use firecast_sim::automaton::KernelConfig;
use firecast_sim::env::{CODE_MAX, EnvCore, FRAME_STACK};
use firecast_sim::{Action, EnvConfig, FuelMoisture, RewardWeights, VecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::RlError;

/// Image channels: the frame stack, then the helicopter cell.
pub const CHANNELS: usize = FRAME_STACK + 1;

/// A distribution of fires and the draws from it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FireSet {
    /// Seeds of the procedural landscapes fires burn on.
    pub landscape_seeds: Vec<u64>,
    #[serde(default = "default_width")]
    pub width: usize,
    #[serde(default = "default_height")]
    pub height: usize,
    /// How many fires to draw.
    pub fires: usize,
    /// Seed of the draws (landscape, wind, moisture and ignition of each fire).
    pub seed: u64,
    /// Midflame wind speed, uniform in [lo, hi] mi/h.
    pub wind_speed_mph: [f64; 2],
    /// Direction the wind blows from, uniform in [lo, hi] degrees.
    #[serde(default = "full_circle")]
    pub wind_from_deg: [f64; 2],
    /// Dead 1-h fuel moisture (fraction), uniform in [lo, hi]; the 10-h and 100-h classes
    /// are drier-lagged at +0.01 and +0.02.
    pub dead_1h_frac: [f64; 2],
    #[serde(default = "default_live_herb")]
    pub live_herb_frac: f64,
    #[serde(default = "default_live_woody")]
    pub live_woody_frac: f64,
    /// Ignitions are drawn on burnable cells at least this far from every edge.
    #[serde(default = "default_margin")]
    pub ignition_margin_cells: usize,
    /// Environment settings shared by every fire (reward, max_steps, helicopter…); wind,
    /// moisture and ignition are replaced per fire.
    #[serde(default)]
    pub env: EnvConfig,
}

fn default_width() -> usize {
    240
}
fn default_height() -> usize {
    160
}
fn full_circle() -> [f64; 2] {
    [0.0, 360.0]
}
fn default_live_herb() -> f64 {
    0.6
}
fn default_live_woody() -> f64 {
    0.9
}
fn default_margin() -> usize {
    40
}

/// One drawn fire.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FireDraw {
    pub index: usize,
    pub landscape_seed: u64,
    pub wind_speed_mph: f64,
    pub wind_from_deg: f64,
    pub dead_1h_frac: f64,
    pub ignition: [usize; 2],
}

impl FireSet {
    pub fn validate(&self, key: &str) -> Result<(), RlError> {
        let bad = |k: &str, m: String| Err(RlError::config(format!("{key}.{k}"), m));
        if self.landscape_seeds.is_empty() {
            return bad("landscape_seeds", "needs at least one seed".into());
        }
        if self.fires == 0 {
            return bad("fires", "must be at least 1".into());
        }
        if !self.width.is_multiple_of(8)
            || !self.height.is_multiple_of(8)
            || self.width < 16
            || self.height < 16
        {
            return bad(
                "width",
                format!(
                    "{}×{}: width and height must be multiples of 8, at least 16",
                    self.width, self.height
                ),
            );
        }
        for (k, [lo, hi]) in [
            ("wind_speed_mph", self.wind_speed_mph),
            ("wind_from_deg", self.wind_from_deg),
            ("dead_1h_frac", self.dead_1h_frac),
        ] {
            if lo.is_nan() || hi.is_nan() || lo > hi || lo < 0.0 {
                return bad(k, format!("[{lo}, {hi}] is not a range of non-negative values"));
            }
        }
        if 2 * self.ignition_margin_cells >= self.width.min(self.height) {
            return bad(
                "ignition_margin_cells",
                format!("{} leaves no room on the grid", self.ignition_margin_cells),
            );
        }
        let (w, h) = (self.width, self.height);
        let outside = |[x, y]: [usize; 2]| {
            (x >= w || y >= h)
                .then(|| format!("cell ({x}, {y}) is outside the {w} × {h} map (x in 0..{w}, y in 0..{h})"))
        };
        if let Some(cell) = self.env.ignition {
            // Each fire draws its own spark cell; a fixed one here would be silently replaced.
            let why = outside(cell).map_or_else(String::new, |m| format!("{m}; "));
            return bad(
                "env.ignition",
                format!(
                    "{why}ignitions are drawn per fire (burnable cells `ignition_margin_cells` from \
                     the edges): leave `env.ignition` out"
                ),
            );
        }
        if let Some(message) = self.env.helicopter_start.and_then(outside) {
            return bad("env.helicopter_start", message);
        }
        Ok(())
    }

    fn landscape(&self, seed: u64) -> Result<Landscape, RlError> {
        let opts = procedural::ProceduralOptions {
            width: self.width,
            height: self.height,
            ..procedural::ProceduralOptions::with_seed(seed)
        };
        Ok(procedural::generate(&opts)?)
    }

    /// The draws and their environments (fires on one landscape with the same weather share
    /// a spread-rate cache).
    pub fn build(&self, key: &str) -> Result<(Vec<FireDraw>, Vec<EnvCore>), RlError> {
        self.validate(key)?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let landscapes: Vec<Landscape> = self
            .landscape_seeds
            .iter()
            .map(|&s| self.landscape(s))
            .collect::<Result<_, _>>()?;
        let mut draws = Vec::with_capacity(self.fires);
        let mut cores = Vec::with_capacity(self.fires);
        let m = self.ignition_margin_cells;
        for index in 0..self.fires {
            let li = rng.random_range(0..landscapes.len());
            let speed = uniform(&mut rng, self.wind_speed_mph);
            let dir = uniform(&mut rng, self.wind_from_deg);
            let d1 = uniform(&mut rng, self.dead_1h_frac);
            let cfg = self.fire_config(speed, dir, d1, None);
            let mut core = EnvCore::new(&landscapes[li], &cfg)?;
            // A burnable ignition cell away from the edges (at most 1000 tries, then any).
            let mut ignition = [self.width / 2, self.height / 2];
            for _ in 0..1000 {
                let x = rng.random_range(m..self.width - m);
                let y = rng.random_range(m..self.height - m);
                if !core.automaton().is_non_burnable(y * self.width + x) {
                    ignition = [x, y];
                    break;
                }
            }
            core.set_ignition(ignition[0], ignition[1])?;
            draws.push(FireDraw {
                index,
                landscape_seed: self.landscape_seeds[li],
                wind_speed_mph: speed,
                wind_from_deg: dir,
                dead_1h_frac: d1,
                ignition,
            });
            cores.push(core);
        }
        Ok((draws, cores))
    }
}

impl FireSet {
    /// The environment settings of a fire with this wind and moisture.
    fn fire_config(&self, speed: f64, dir: f64, d1: f64, ignition: Option<[usize; 2]>) -> EnvConfig {
        let mut cfg = self.env.clone();
        cfg.sim.wind.speed_mph = speed;
        cfg.sim.wind.from_direction_deg = dir;
        cfg.sim.kernel = KernelConfig::Rothermel {
            moisture: FuelMoisture {
                dead_1h_frac: d1,
                dead_10h_frac: d1 + 0.01,
                dead_100h_frac: d1 + 0.02,
                live_herb_frac: self.live_herb_frac,
                live_woody_frac: self.live_woody_frac,
            },
            drop_moisture_increment: match &self.env.sim.kernel {
                KernelConfig::Rothermel {
                    drop_moisture_increment,
                    ..
                } => *drop_moisture_increment,
                KernelConfig::Concord { .. } => 0.05,
            },
        };
        cfg.ignition = ignition;
        cfg
    }

    /// One drawn fire on its own: its landscape and the environment settings (ignition
    /// included) that make `WildfireEnv::new(&landscape, &cfg)` play exactly what
    /// [`FireSet::build`]'s environment of that fire plays (replays, recordings).
    pub fn fire(&self, draw: &FireDraw) -> Result<(Landscape, EnvConfig), RlError> {
        let landscape = self.landscape(draw.landscape_seed)?;
        let cfg = self.fire_config(
            draw.wind_speed_mph,
            draw.wind_from_deg,
            draw.dead_1h_frac,
            Some(draw.ignition),
        );
        Ok((landscape, cfg))
    }
}

fn uniform(rng: &mut ChaCha8Rng, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo { rng.random_range(lo..hi) } else { lo }
}

/// The reward presets by profile name.
pub fn reward_profile(name: &str) -> Result<RewardWeights, RlError> {
    RewardWeights::preset(name).ok_or_else(|| {
        RlError::config(
            "profile",
            format!("unknown profile `{name}` (use p2, websocket_t, p1_improved or suppression)"),
        )
    })
}

/// Writes one observation: image = frames then the helicopter channel (value 9 on its
/// cell), vector = [x, y, on_fire].
pub fn encode(
    frames: &[u8],
    agent: [i32; 2],
    on_fire: bool,
    w: usize,
    h: usize,
    image: &mut [u8],
    vector: &mut [f32],
) {
    let n = w * h;
    image[..FRAME_STACK * n].copy_from_slice(frames);
    let heli = &mut image[FRAME_STACK * n..];
    heli.fill(0);
    let (x, y) = (
        agent[0].clamp(0, w as i32 - 1) as usize,
        agent[1].clamp(0, h as i32 - 1) as usize,
    );
    heli[y * w + x] = CODE_MAX;
    vector[0] = agent[0] as f32;
    vector[1] = agent[1] as f32;
    vector[2] = if on_fire { 1.0 } else { 0.0 };
}

/// The observation space on a `w × h` grid.
pub fn space(w: usize, h: usize) -> ObsSpace {
    ObsSpace {
        image: Some([CHANNELS, h, w]),
        vector: 3,
    }
}

/// `n` helitack environments over a fire pool.
pub struct HelitackVec {
    vec: VecEnv,
    width: usize,
    height: usize,
    /// Actions since each environment's episode started (checkpoint replay).
    actions: Vec<Vec<u8>>,
    seed: u64,
}

#[derive(Serialize, Deserialize)]
struct Snapshot {
    seed: u64,
    episodes: Vec<u64>,
    actions: Vec<Vec<u8>>,
}

impl HelitackVec {
    pub fn new(fires: Vec<EnvCore>, n: usize, seed: u64) -> Result<Self, RlError> {
        let (width, height) = fires.first().map_or((0, 0), EnvCore::grid_size);
        let vec = VecEnv::with_fires(fires, n, seed)?;
        Ok(Self {
            vec,
            width,
            height,
            actions: vec![Vec::new(); n],
            seed,
        })
    }
    pub fn inner(&self) -> &VecEnv {
        &self.vec
    }
}

impl VecEnvironment for HelitackVec {
    fn num_envs(&self) -> usize {
        self.vec.num_envs()
    }
    fn space(&self) -> ObsSpace {
        space(self.width, self.height)
    }
    fn num_actions(&self) -> usize {
        Action::ALL.len()
    }
    fn reset(&mut self, seed: u64) {
        self.seed = seed;
        self.vec.reset(seed);
        for a in &mut self.actions {
            a.clear();
        }
    }
    fn step(&mut self, actions: &[u8]) -> Result<(), PpoError> {
        let acts: Vec<Action> = actions
            .iter()
            .map(|&a| Action::try_from(a))
            .collect::<Result<_, _>>()
            .map_err(RlError::from)?;
        self.vec.step(&acts).map_err(RlError::from)?;
        for (i, &a) in actions.iter().enumerate() {
            if self.vec.terminated()[i] || self.vec.truncated()[i] {
                self.actions[i].clear();
            } else {
                self.actions[i].push(a);
            }
        }
        Ok(())
    }
    fn observe(&self, out: &mut ObsBatch) {
        let l = self.vec.obs_len();
        let frames = self.vec.frames();
        let pos = self.vec.agent_positions();
        let fire = self.vec.on_fire();
        let il = out.space.image_len();
        for i in 0..self.vec.num_envs() {
            let (img, vecs) = (
                &mut out.image[i * il..(i + 1) * il],
                &mut out.vector[i * 3..(i + 1) * 3],
            );
            encode(
                &frames[i * l..(i + 1) * l],
                [pos[2 * i], pos[2 * i + 1]],
                fire[i] != 0,
                self.width,
                self.height,
                img,
                vecs,
            );
        }
    }
    fn terminal_observation(&self, i: usize, out: &mut ObsBatch, row: usize) {
        let (frames, agent, on_fire) = self.vec.terminal_observation(i);
        let il = out.space.image_len();
        let img = &mut out.image[row * il..(row + 1) * il];
        let vecs = &mut out.vector[row * 3..(row + 1) * 3];
        encode(frames, agent, on_fire, self.width, self.height, img, vecs);
    }
    fn rewards(&self) -> &[f64] {
        self.vec.rewards()
    }
    fn terminated(&self) -> &[bool] {
        self.vec.terminated()
    }
    fn truncated(&self) -> &[bool] {
        self.vec.truncated()
    }
    fn episode_extras(&self, i: usize) -> Vec<(&'static str, f64)> {
        let info = self.vec.infos()[i];
        vec![
            ("cells_burned", f64::from(info.cells_burnt + info.cells_burning)),
            ("helitacks", f64::from(info.drops)),
            ("contained", if self.vec.terminated()[i] { 1.0 } else { 0.0 }),
        ]
    }
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
    fn snapshot(&self) -> serde_json::Value {
        let snap = Snapshot {
            seed: self.seed,
            episodes: (0..self.vec.num_envs())
                .map(|i| self.vec.episode_index(i))
                .collect(),
            actions: self.actions.clone(),
        };
        serde_json::to_value(snap).unwrap_or_default()
    }
    fn restore(&mut self, snapshot: &serde_json::Value) -> Result<(), PpoError> {
        let snap: Snapshot = serde_json::from_value(snapshot.clone())
            .map_err(|e| RlError::config("env", format!("bad helitack snapshot: {e}")))?;
        if snap.episodes.len() != self.vec.num_envs() || snap.actions.len() != self.vec.num_envs() {
            return Err(RlError::config(
                "ppo.n_envs",
                format!(
                    "the snapshot has {} environments, this run {}",
                    snap.episodes.len(),
                    self.vec.num_envs()
                ),
            )
            .into());
        }
        self.vec.reset(snap.seed);
        self.seed = snap.seed;
        for (i, (ep, acts)) in snap.episodes.iter().zip(&snap.actions).enumerate() {
            let a: Vec<Action> = acts
                .iter()
                .map(|&a| Action::try_from(a))
                .collect::<Result<_, _>>()
                .map_err(RlError::from)?;
            self.vec.restore_env(i, *ep, &a).map_err(RlError::from)?;
        }
        self.actions = snap.actions;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firecast_render::{Basemap, FireFrame, RenderOptions, render_frame};
    use firecast_sim::WildfireEnv;

    /// Centre (column, row) in pixels of the helicopter's magenta marker on the map part of
    /// a render (the legend strip below the map shows the colour too).
    fn marker(image: &firecast_render::RgbImage, map_rows: usize) -> (f64, f64) {
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
        for y in 0..map_rows {
            for x in 0..image.width {
                if image.pixel(x, y) == Some(firecast_render::palette::HELI_BODY) {
                    sx += x as f64;
                    sy += y as f64;
                    n += 1.0;
                }
            }
        }
        assert!(n > 0.0, "no helicopter marker drawn");
        (sx / n, sy / n)
    }

    /// Each action from the same cell, read three ways: the helicopter's grid cell, the
    /// observation's helicopter channel (grid rows, row 0 south) and the north-up render. The
    /// names (`Action::NAMES`) are the directions on the map, and north is up on the render.
    #[test]
    fn each_action_moves_the_helicopter_the_way_its_name_says() {
        let land = procedural::generate(&procedural::ProceduralOptions {
            width: 48,
            height: 32,
            ..procedural::ProceduralOptions::with_seed(3)
        })
        .expect("landscape");
        let cfg = EnvConfig {
            helicopter_start: Some([24, 16]),
            max_steps: 10,
            ..EnvConfig::default()
        };
        let opts = RenderOptions::default();
        let basemap = Basemap::new(&land, &opts);
        let (w, h) = (land.width, land.height);
        assert_eq!(Action::NAMES, ["north", "south", "west", "east", "drop"]);
        for action in Action::ALL {
            let mut env = WildfireEnv::new(&land, &cfg).expect("env");
            env.reset(0);
            let draw = |env: &WildfireEnv| {
                let frame = FireFrame::new(env.automaton().fire_states(), env.core().helicopter());
                marker(&render_frame(&basemap, &frame, &opts), basemap.map_height_px)
            };
            let (col0, row0) = draw(&env);
            let (obs, ..) = env.step(action);
            let [x, y] = obs.agent;
            let (mut image, mut vector) = (vec![0; CHANNELS * w * h], [0.0; 3]);
            encode(obs.frames, obs.agent, obs.on_fire, w, h, &mut image, &mut vector);
            let channel = &image[FRAME_STACK * w * h..];
            let cell = channel
                .iter()
                .position(|&v| v == CODE_MAX)
                .expect("helicopter channel");
            assert_eq!((cell % w, cell / w), (x as usize, y as usize), "{action:?}");
            let (col, row) = draw(&env);
            let s = opts.scale as f64;
            let (grid, screen) = match action.name() {
                "north" => ([24, 19], (0.0, -3.0 * s)),
                "south" => ([24, 13], (0.0, 3.0 * s)),
                "west" => ([21, 16], (-3.0 * s, 0.0)),
                "east" => ([27, 16], (3.0 * s, 0.0)),
                "drop" => ([24, 16], (0.0, 0.0)),
                other => panic!("unknown action name {other}"),
            };
            assert_eq!(
                [x, y],
                grid,
                "{} moved the helicopter to ({x}, {y})",
                action.name()
            );
            assert_eq!(
                (col - col0, row - row0),
                screen,
                "{} on the north-up render",
                action.name()
            );
        }
    }

    const FIRES: &str = "\
profile: p2
train:
  landscape_seeds: [1]
  width: 48
  height: 32
  fires: 2
  seed: 1
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
  env:
    max_steps: 40
    ignition: [100, 5]
evaluate:
  landscape_seeds: [11]
  width: 48
  height: 32
  fires: 2
  seed: 2
  wind_speed_mph: [3, 6]
  dead_1h_frac: [0.06, 0.1]
  ignition_margin_cells: 8
";

    /// An ignition off the map names its key with the file, line and column; so does a
    /// helicopter start off the map, and a fixed ignition inside it (each fire draws its own).
    #[test]
    fn an_ignition_off_the_map_names_its_key_file_and_line() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("fires.yaml");
        std::fs::write(&path, FIRES).expect("write");
        let e = crate::spec::FiresSpec::load(&path)
            .expect_err("refused")
            .to_string();
        assert_eq!(
            e,
            format!(
                "{}:13:5: train.env.ignition: cell (100, 5) is outside the 48 × 32 map (x in 0..48, y in \
                 0..32); ignitions are drawn per fire (burnable cells `ignition_margin_cells` from the \
                 edges): leave `env.ignition` out",
                path.display()
            )
        );
        std::fs::write(&path, FIRES.replace("ignition: [100, 5]", "ignition: [10, 5]")).expect("write");
        let e = crate::spec::FiresSpec::load(&path)
            .expect_err("refused")
            .to_string();
        assert!(
            e.contains(":13:5: train.env.ignition: ignitions are drawn per fire"),
            "{e}"
        );
        std::fs::write(
            &path,
            FIRES.replace("ignition: [100, 5]", "helicopter_start: [3, 32]"),
        )
        .expect("write");
        let e = crate::spec::FiresSpec::load(&path)
            .expect_err("refused")
            .to_string();
        assert!(
            e.ends_with(":13:5: train.env.helicopter_start: cell (3, 32) is outside the 48 × 32 map (x in 0..48, y in 0..32)"),
            "{e}"
        );
        std::fs::write(&path, FIRES.replace("    ignition: [100, 5]\n", "")).expect("write");
        crate::spec::FiresSpec::load(&path).expect("a fire file without a fixed ignition");
    }

    /// A grid too small for the compact network's pooling and the helicopter's moves is
    /// refused by name (the Python package refuses below 8 × 8; fire sets below 16 × 16).
    #[test]
    fn a_tiny_fire_grid_is_refused_by_name() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("fires.yaml");
        let text = FIRES
            .replace("    ignition: [100, 5]\n", "")
            .replace("width: 48", "width: 2")
            .replace("height: 32", "height: 2");
        std::fs::write(&path, text).expect("write");
        let e = crate::spec::FiresSpec::load(&path)
            .expect_err("refused")
            .to_string();
        assert!(
            e.contains(":4:3: train.width: 2×2: width and height must be multiples of 8, at least 16"),
            "{e}"
        );
    }
}
