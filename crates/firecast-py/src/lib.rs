//! firecast-py: the extension module `firecast._firecast` behind the Python package
//! `firecast` (`python/firecast/`, built and installed into `.venv` by `cargo xtask setup`
//! with maturin).
//!
//! - [`Env`] wraps [`firecast_sim::WildfireEnv`]; the Gymnasium `firecast.HelitackEnv` is a
//!   thin Python class around it (seeding from `np_random`, spaces, rendering).
//! - [`VecEnv`] wraps [`firecast_sim::VecEnv`] (same-step autoreset, a fire pool, rayon);
//!   `firecast.HelitackVecEnv` adapts it to Stable-Baselines3's `VecEnv` interface.
//!
//! Observations cross as one freshly allocated numpy array per buffer and call (one copy of
//! the Rust buffer; no Python loop over cells). Steps and resets run with the GIL released.

mod spec;

use firecast_landscape::LandscapeError;
use firecast_sim::env::{EnvCore, FRAME_STACK};
use firecast_sim::{Action, EnvConfig, StepInfo};
use numpy::ndarray::{ArrayView1, ArrayView2, ArrayView3, ArrayView4};
use numpy::{PyArray1, PyReadonlyArray1, ToPyArray};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::spec::{BindError, LandscapeSpec};

impl From<BindError> for PyErr {
    fn from(e: BindError) -> Self {
        match &e {
            BindError::Landscape(LandscapeError::Io { source, .. })
                if source.kind() == std::io::ErrorKind::NotFound =>
            {
                PyFileNotFoundError::new_err(e.to_string())
            }
            BindError::Landscape(LandscapeError::Io { .. }) => PyOSError::new_err(e.to_string()),
            _ => PyValueError::new_err(e.to_string()),
        }
    }
}

fn action(a: i64, env: Option<usize>) -> Result<Action, BindError> {
    u8::try_from(a)
        .ok()
        .and_then(|v| Action::try_from(v).ok())
        .ok_or_else(|| {
            let key = env.map_or_else(|| "action".to_string(), |i| format!("actions[{i}]"));
            BindError::invalid(
                key,
                format!("{a} is not an action (0 north/up, 1 south/down, 2 west/left, 3 east/right, 4 drop)"),
            )
        })
}

fn shape_error(e: numpy::ndarray::ShapeError) -> PyErr {
    PyValueError::new_err(format!("observation buffer has an unexpected size: {e}"))
}

/// `StepInfo` as a dict (Gymnasium's info).
fn info_dict<'py>(py: Python<'py>, info: &StepInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("step", info.step)?;
    d.set_item("sim_time_min", info.sim_time_min)?;
    d.set_item("cells_burning", info.cells_burning)?;
    d.set_item("cells_burnt", info.cells_burnt)?;
    d.set_item("new_burnt", info.new_burnt)?;
    d.set_item("quenched_step", info.quenched_step)?;
    d.set_item("cells_quenched", info.cells_quenched)?;
    d.set_item("drops", info.drops)?;
    d.set_item("water_used_gal", info.water_used_gal)?;
    Ok(d)
}

/// One observation dict: `cells` (4, H, W) uint8, `helicopter_coord` (2,) int32, `on_fire`
/// a Python int (Discrete(2)).
fn obs_dict<'py>(
    py: Python<'py>,
    frames: &[u8],
    (w, h): (usize, usize),
    agent: [i32; 2],
    on_fire: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let cells = ArrayView3::from_shape((FRAME_STACK, h, w), frames).map_err(shape_error)?;
    let d = PyDict::new(py);
    d.set_item("cells", cells.to_pyarray(py))?;
    d.set_item("helicopter_coord", ArrayView1::from(&agent[..]).to_pyarray(py))?;
    d.set_item("on_fire", i64::from(on_fire))?;
    Ok(d)
}

fn load_landscape(py: Python<'_>, landscape: &str) -> Result<firecast_landscape::Landscape, BindError> {
    let spec = LandscapeSpec::parse(landscape)?;
    py.detach(|| spec.load())
}

/// The helitack environment (one episode at a time).
#[pyclass(module = "firecast._firecast", name = "Env")]
struct Env {
    env: firecast_sim::WildfireEnv,
    size: (usize, usize),
    /// Whether `reset` ran: a step before it is an error (Gymnasium's order), not an episode
    /// from a seed nobody chose.
    started: bool,
}

#[pymethods]
impl Env {
    /// `landscape`: `procedural:SEED`, `firecastrl:LC.png,HM.png` or a JSON object;
    /// `config`: a JSON object of `EnvConfig` keys; `profile`: `p2`, `websocket_t`,
    /// `p1_improved` or `suppression`.
    #[new]
    #[pyo3(signature = (landscape, config=None, profile=None))]
    fn new(py: Python<'_>, landscape: &str, config: Option<&str>, profile: Option<&str>) -> PyResult<Self> {
        let cfg = spec::env_config(config, profile)?;
        let land = load_landscape(py, landscape)?;
        spec::check_grid(&land, &cfg, "landscape")?;
        let env = firecast_sim::WildfireEnv::new(&land, &cfg).map_err(BindError::from)?;
        Ok(Self {
            size: (land.width, land.height),
            env,
            started: false,
        })
    }

    /// Starts an episode with this Rust seed: `(obs, info)`.
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: u64,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let env = &mut self.env;
        let info = py.detach(|| env.reset(seed).1);
        self.started = true;
        Ok((self.observation(py)?, info_dict(py, &info)?))
    }

    /// `(obs, reward, terminated, truncated, info)`.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: i64,
    ) -> PyResult<(Bound<'py, PyDict>, f64, bool, bool, Bound<'py, PyDict>)> {
        if !self.started {
            return Err(PyRuntimeError::new_err(
                "step() before reset(): call reset() first to start an episode",
            ));
        }
        let a = self::action(action, None)?;
        let env = &mut self.env;
        let (reward, terminated, truncated, info) = py.detach(|| {
            let (_, r, te, tr, info) = env.step(a);
            (r, te, tr, info)
        });
        Ok((
            self.observation(py)?,
            reward,
            terminated,
            truncated,
            info_dict(py, &info)?,
        ))
    }

    /// The current observation.
    fn observation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = self.env.observation();
        obs_dict(py, o.frames, self.size, o.agent, o.on_fire)
    }

    /// The newest frame of cell codes, (H, W) uint8.
    fn current_frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (w, h) = self.size;
        let o = self.env.observation();
        let frame = ArrayView2::from_shape((h, w), o.current_frame()).map_err(shape_error)?;
        Ok(frame.to_pyarray(py).into_any())
    }

    #[getter]
    fn width(&self) -> usize {
        self.size.0
    }
    #[getter]
    fn height(&self) -> usize {
        self.size.1
    }
    #[getter]
    fn max_steps(&self) -> u32 {
        self.env.core().config().max_steps
    }
    /// Simulated minutes per step.
    #[getter]
    fn dt_min(&self) -> f64 {
        self.env.core().config().sim.dt_min
    }
    #[getter]
    fn helicopter(&self) -> (i32, i32) {
        let [x, y] = self.env.core().helicopter();
        (x, y)
    }
    #[getter]
    fn ignition(&self) -> (usize, usize) {
        self.env.core().ignition_cell()
    }
}

/// N environments over a fire pool, stepped in parallel with same-step autoreset.
#[pyclass(module = "firecast._firecast", name = "VecEnv")]
struct VecEnv {
    vec: firecast_sim::VecEnv,
    size: (usize, usize),
    actions: Vec<Action>,
}

impl VecEnv {
    /// One pool entry per (landscape JSON, config JSON) pair.
    fn of_fires(
        py: Python<'_>,
        num_envs: usize,
        seed: u64,
        pairs: &[(String, String)],
        profile: Option<&str>,
    ) -> PyResult<Self> {
        if pairs.is_empty() {
            return Err(BindError::invalid("fires", "needs at least one fire").into());
        }
        let mut cores = Vec::with_capacity(pairs.len());
        let mut loaded: std::collections::HashMap<String, std::sync::Arc<firecast_landscape::Landscape>> =
            std::collections::HashMap::new();
        let mut size: Option<(usize, usize)> = None;
        for (k, (land_text, cfg_text)) in pairs.iter().enumerate() {
            // Errors name `landscape…`/`config…`: put them under this fire.
            let rekey = |e: BindError| match e {
                BindError::Invalid { key, message } => {
                    BindError::invalid(format!("fires[{k}].{key}"), message)
                }
                other => other,
            };
            // Fires share few landscapes: generate each once.
            let land = match loaded.get(land_text) {
                Some(l) => std::sync::Arc::clone(l),
                None => {
                    let l = std::sync::Arc::new(load_landscape(py, land_text).map_err(rekey)?);
                    loaded.insert(land_text.clone(), std::sync::Arc::clone(&l));
                    l
                }
            };
            let cfg = spec::env_config(Some(cfg_text), profile).map_err(rekey)?;
            spec::check_same_grid(
                &land,
                &mut size,
                &format!("fires[{k}].landscape"),
                "fires[0].landscape",
            )?;
            spec::check_grid(&land, &cfg, &format!("fires[{k}].landscape"))?;
            cores.push(EnvCore::new(&land, &cfg).map_err(BindError::from)?);
        }
        let vec = py
            .detach(|| firecast_sim::VecEnv::with_fires(cores, num_envs, seed))
            .map_err(BindError::from)?;
        Ok(Self {
            vec,
            size: size.unwrap_or((0, 0)),
            actions: Vec::with_capacity(num_envs),
        })
    }

    fn observations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (w, h) = self.size;
        let n = self.vec.num_envs();
        let cells = ArrayView4::from_shape((n, FRAME_STACK, h, w), self.vec.frames()).map_err(shape_error)?;
        let coord = ArrayView2::from_shape((n, 2), self.vec.agent_positions()).map_err(shape_error)?;
        let on_fire: Vec<i64> = self.vec.on_fire().iter().map(|&f| i64::from(f)).collect();
        let d = PyDict::new(py);
        d.set_item("cells", cells.to_pyarray(py))?;
        d.set_item("helicopter_coord", coord.to_pyarray(py))?;
        d.set_item("on_fire", PyArray1::from_vec(py, on_fire))?;
        Ok(d)
    }

    fn infos<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for info in self.vec.infos() {
            list.append(info_dict(py, info)?)?;
        }
        Ok(list)
    }
}

#[pymethods]
impl VecEnv {
    /// The pool is every landscape × every ignition cell (`None`: the configuration's), or,
    /// with `fires`, those (landscape, configuration) pairs, each its own weather and
    /// ignition (a FireCast fire file's draws); all landscapes must share one grid size.
    #[new]
    #[pyo3(signature = (num_envs, seed, landscapes, ignitions=None, config=None, profile=None, fires=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        num_envs: usize,
        seed: u64,
        landscapes: Vec<String>,
        ignitions: Option<Vec<(usize, usize)>>,
        config: Option<&str>,
        profile: Option<&str>,
        fires: Option<Vec<(String, String)>>,
    ) -> PyResult<Self> {
        if num_envs == 0 {
            return Err(BindError::invalid("num_envs", "must be at least 1").into());
        }
        if let Some(pairs) = fires {
            if !landscapes.is_empty() || ignitions.is_some() || config.is_some() {
                return Err(BindError::invalid(
                    "fires",
                    "gives each fire its landscape and config: leave landscapes, ignitions and config out",
                )
                .into());
            }
            return Self::of_fires(py, num_envs, seed, &pairs, profile);
        }
        if landscapes.is_empty() {
            return Err(BindError::invalid("landscapes", "needs at least one landscape").into());
        }
        if ignitions.as_ref().is_some_and(Vec::is_empty) {
            return Err(
                BindError::invalid("ignitions", "is empty (leave it out for the configured cell)").into(),
            );
        }
        let cfg: EnvConfig = spec::env_config(config, profile)?;
        let mut fires = Vec::new();
        let mut size: Option<(usize, usize)> = None;
        for (k, text) in landscapes.iter().enumerate() {
            let land = load_landscape(py, text).map_err(|e| match e {
                BindError::Invalid { key, message } => {
                    BindError::invalid(key.replacen("landscape", &format!("landscapes[{k}]"), 1), message)
                }
                other => other,
            })?;
            spec::check_same_grid(&land, &mut size, &format!("landscapes[{k}]"), "landscapes[0]")?;
            spec::check_grid(&land, &cfg, &format!("landscapes[{k}]"))?;
            let core = EnvCore::new(&land, &cfg).map_err(BindError::from)?;
            match &ignitions {
                None => fires.push(core),
                Some(cells) => {
                    for (j, &(x, y)) in cells.iter().enumerate() {
                        let mut c = core.clone();
                        c.set_ignition(x, y)
                            .map_err(|e| BindError::invalid(format!("ignitions[{j}]"), e.to_string()))?;
                        fires.push(c);
                    }
                }
            }
        }
        let vec = py
            .detach(|| firecast_sim::VecEnv::with_fires(fires, num_envs, seed))
            .map_err(BindError::from)?;
        Ok(Self {
            vec,
            size: size.unwrap_or((0, 0)),
            actions: Vec::with_capacity(num_envs),
        })
    }

    /// Resets every environment from base seed `seed`: `(obs, infos)`.
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: u64,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyList>)> {
        let vec = &mut self.vec;
        py.detach(|| vec.reset(seed));
        Ok((self.observations(py)?, self.infos(py)?))
    }

    /// Steps every environment: `(obs, rewards f32, terminated, truncated, infos, terminal)`,
    /// `terminal` a list of `(i, final observation)` for the environments whose episode ended
    /// (their `obs` entry is already the next episode's first).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(
        Bound<'py, PyDict>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyList>,
        Bound<'py, PyList>,
    )> {
        let n = self.vec.num_envs();
        let raw = actions.as_array();
        if raw.len() != n {
            return Err(
                BindError::invalid("actions", format!("{} actions for {n} environments", raw.len())).into(),
            );
        }
        self.actions.clear();
        for (i, &a) in raw.iter().enumerate() {
            self.actions.push(action(a, Some(i))?);
        }
        let (vec, acts) = (&mut self.vec, &self.actions);
        py.detach(|| vec.step(acts)).map_err(BindError::from)?;

        let rewards: Vec<f32> = self.vec.rewards().iter().map(|&r| r as f32).collect();
        let terminal = PyList::empty(py);
        for i in 0..n {
            if self.vec.terminated()[i] || self.vec.truncated()[i] {
                let (frames, agent, on_fire) = self.vec.terminal_observation(i);
                terminal.append((i, obs_dict(py, frames, self.size, agent, on_fire)?))?;
            }
        }
        Ok((
            self.observations(py)?,
            PyArray1::from_vec(py, rewards).into_any(),
            PyArray1::from_slice(py, self.vec.terminated()).into_any(),
            PyArray1::from_slice(py, self.vec.truncated()).into_any(),
            self.infos(py)?,
            terminal,
        ))
    }

    /// The current observations.
    fn observation<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.observations(py)
    }

    /// Pool index of the fire environment `i` is playing.
    fn fire_index(&self, i: usize) -> PyResult<usize> {
        self.check(i)?;
        Ok(self.vec.fire_index(i))
    }

    /// Episodes environment `i` has finished since the last reset.
    fn episode_index(&self, i: usize) -> PyResult<u64> {
        self.check(i)?;
        Ok(self.vec.episode_index(i))
    }

    fn check(&self, i: usize) -> PyResult<()> {
        if i < self.vec.num_envs() {
            Ok(())
        } else {
            Err(BindError::invalid("index", format!("no environment {i} in {}", self.vec.num_envs())).into())
        }
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.vec.num_envs()
    }
    #[getter]
    fn num_fires(&self) -> usize {
        self.vec.num_fires()
    }
    #[getter]
    fn width(&self) -> usize {
        self.size.0
    }
    #[getter]
    fn height(&self) -> usize {
        self.size.1
    }
    #[getter]
    fn max_steps(&self) -> u32 {
        self.vec.envs().first().map_or(0, |e| e.config().max_steps)
    }
}

/// The extension module.
#[pymodule]
fn _firecast(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Env>()?;
    m.add_class::<VecEnv>()?;
    m.add("FRAME_STACK", FRAME_STACK)?;
    m.add("CODE_MAX", firecast_sim::env::CODE_MAX)?;
    m.add("ACTIONS", Action::NAMES.to_vec())?;
    m.add("PROFILES", spec::PROFILES.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
