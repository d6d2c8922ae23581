//! The HTTP API and the page: routes, the guards every request passes (token, same origin,
//! body size), and the handlers. Work that blocks (files, DuckDB, models, landscapes) runs
//! on tokio's blocking pool so the sockets keep flowing.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use axum::body::Body;
use axum::extract::ws::WebSocketUpgrade;
use axum::extract::{FromRequestParts, Path, Request, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Deserialize;
use serde::de::DeserializeOwned;

use crate::ServeConfig;
use crate::coverage::Coverage;
use crate::error::{ApiError, Code};
use crate::fire::{Environment, FireSettings, LiveAgent};
use crate::forecast::{ForecasterInfo, ProbabilityMap};
use crate::jobs::{JobSettings, Jobs};
use crate::overview::Overview;
use crate::runs::{Runs, RunsQuery};

const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_JS: &str = include_str!("../web/app.js");
const APP_CSS: &str = include_str!("../web/app.css");
const OPENAPI: &str = include_str!("openapi.json");

/// Request bodies larger than this are refused (the API takes its inputs in the query).
pub const MAX_BODY_BYTES: u64 = 64 * 1024;
/// Environments kept in memory (each holds a 240 × 160 landscape and its spread cache).
const ENVIRONMENTS_KEPT: usize = 32;
const MAPS_KEPT: usize = 32;

/// What every handler shares.
pub struct AppState {
    pub cfg: ServeConfig,
    coverage: Result<Arc<Coverage>, String>,
    overview: tokio::sync::OnceCell<Result<Arc<Overview>, String>>,
    fire: Result<FireSettings, String>,
    environments: Mutex<VecDeque<Arc<Environment>>>,
    maps: Mutex<HashMap<String, Arc<ProbabilityMap>>>,
    pub fires: crate::session::FireSlots,
    runs: Arc<Runs>,
    jobs: Jobs,
    rerun: crate::rerun_viewer::RerunViewer,
}

pub type Shared = Arc<AppState>;

impl AppState {
    pub fn new(cfg: ServeConfig) -> Shared {
        let coverage = Coverage::scan(&cfg.root.join(&cfg.gridmet)).map(Arc::new);
        let fire = FireSettings::from_threat_pipeline(&cfg.root.join(&cfg.threat_pipeline));
        let runs = Arc::new(Runs::new(cfg.registry.clone()));
        let jobs = Jobs::start(
            JobSettings {
                root: cfg.root.clone(),
                firecast_bin: cfg.firecast_bin.clone(),
                pipeline: cfg.threat_pipeline.clone(),
                global_args: cfg.job_args.clone(),
                max_queued: cfg.max_queued_jobs,
            },
            runs.clone(),
        );
        let rerun = crate::rerun_viewer::RerunViewer::new(&cfg.root, cfg.rerun_cli.clone());
        Arc::new(Self {
            rerun,
            coverage,
            overview: tokio::sync::OnceCell::new(),
            fire,
            environments: Mutex::new(VecDeque::new()),
            maps: Mutex::new(HashMap::new()),
            fires: crate::session::FireSlots::new(cfg.max_fires),
            runs,
            jobs,
            cfg,
        })
    }

    fn coverage(&self) -> Result<Arc<Coverage>, ApiError> {
        self.coverage.clone().map_err(|e| {
            ApiError::new(
                Code::NoWeather,
                format!(
                    "no GRIDMET data: {e} (run `cargo xtask demo`, or start the server with --gridmet DIR)"
                ),
            )
        })
    }

    /// The forecaster answering now: the first candidate with saved models (else the first).
    fn forecaster(&self) -> ForecasterInfo {
        let dirs: Vec<PathBuf> = self
            .cfg
            .forecasters
            .iter()
            .map(|d| self.cfg.root.join(d))
            .collect();
        let experiment = dirs
            .iter()
            .find(|d| d.join("models").is_dir())
            .or(dirs.first())
            .cloned()
            .unwrap_or_else(|| self.cfg.root.join("build/demo/table3"));
        ForecasterInfo {
            experiment,
            model: self.cfg.model.clone(),
        }
    }

    /// The PPO agent playing now: the first candidate holding a trained run.
    pub fn agent_run(&self) -> Option<PathBuf> {
        self.cfg
            .agent_runs
            .iter()
            .map(|d| self.cfg.root.join(d))
            .find(|d| d.join("summary.json").is_file())
    }

    fn fire_settings(&self) -> Result<FireSettings, ApiError> {
        self.fire.clone().map_err(ApiError::internal)
    }

    fn environment(&self, id: &str) -> Result<Arc<Environment>, ApiError> {
        let envs = self.environments.lock().unwrap_or_else(|e| e.into_inner());
        envs.iter()
            .find(|e| e.id == id)
            .cloned()
            .ok_or_else(|| ApiError::not_found(format!("no environment `{}`: create it first", short(id))))
    }

    fn keep_environment(&self, env: Arc<Environment>) {
        let mut envs = self.environments.lock().unwrap_or_else(|e| e.into_inner());
        envs.retain(|e| e.id != env.id);
        envs.push_back(env);
        while envs.len() > ENVIRONMENTS_KEPT {
            envs.pop_front();
        }
    }

    fn agents(&self) -> serde_json::Value {
        let ppo = match self.agent_run() {
            Some(run) => (true, agent_note(&run, &self.cfg.root)),
            None => (
                false,
                format!(
                    "no trained agent in {}: run `cargo xtask demo` or name one with --agent-run",
                    self.cfg
                        .agent_runs
                        .iter()
                        .map(|d| d.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
        };
        serde_json::json!([
            {"id": "ppo", "label": "Trained PPO agent", "available": ppo.0, "reason": ppo.1},
            {"id": "rule", "label": "Rule-based plan (circle)", "available": true, "reason": "FireCastRL's baseline: drops on a 30-cell circle around the ignition"},
            {"id": "rule-concentric", "label": "Rule-based plan (concentric circles)", "available": true, "reason": "drops on circles of 45, 40 and 35 cells"},
            {"id": "chaser", "label": "Chaser (flies to the flames)", "available": true, "reason": "a helicopter that flies to the nearest flames and drops on them"},
            {"id": "none", "label": "No suppression", "available": true, "reason": "the fire burns freely"},
        ])
    }
}

/// What the page says about the PPO agent: its run, and whether it sees a window around the
/// helicopter (any map size) or the whole map scaled (lost on maps larger than its fires).
fn agent_note(run: &std::path::Path, root: &std::path::Path) -> String {
    let shown = run.strip_prefix(root).unwrap_or(run).display();
    let summary: Option<serde_json::Value> = std::fs::read_to_string(run.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let windowed = summary.as_ref().is_some_and(|s| !s["policy"]["window"].is_null());
    if windowed {
        format!(
            "trained PPO agent ({shown}): sees a window around the helicopter, so it plays this 240 × 160 map at the scale it learned"
        )
    } else {
        format!(
            "trained PPO agent ({shown}): sees its whole map scaled; trained on smaller fires, it may not find this 240 × 160 fire. A threat report trains one with a window around the helicopter for this map, which then plays here"
        )
    }
}

fn short(s: &str) -> String {
    s.chars().take(40).collect()
}

/// Runs blocking work on tokio's blocking pool.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| ApiError::internal(format!("the request's work failed: {e}")))?
}

/// Query parameters whose rejection is a JSON `bad_request`.
pub struct Q<T>(pub T);

impl<S: Send + Sync, T: DeserializeOwned> FromRequestParts<S> for Q<T> {
    type Rejection = ApiError;
    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Self::Rejection> {
        axum::extract::Query::<T>::from_request_parts(parts, state)
            .await
            .map(|q| Q(q.0))
            .map_err(|e| ApiError::bad(e.body_text()))
    }
}

/// A place and a day as FireCastRL's endpoints take them.
#[derive(Debug, Deserialize)]
pub struct PlaceQuery {
    lat: Option<String>,
    lon: Option<String>,
    date: Option<String>,
}

impl PlaceQuery {
    /// Checked against the data: `(lat, lon, YYYY-MM-DD)`.
    fn resolve(&self, coverage: &Coverage) -> Result<(f64, f64, String), ApiError> {
        let num = |name: &str, v: &Option<String>| -> Result<f64, ApiError> {
            let text = v
                .as_deref()
                .filter(|s| !s.trim().is_empty())
                .ok_or_else(|| ApiError::bad(format!("`{name}` is missing")))?;
            text.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| ApiError::bad(format!("`{name}` = `{}` is not a number", short(text))))
        };
        let lat = num("lat", &self.lat)?;
        let lon = num("lon", &self.lon)?;
        let date_text = self
            .date
            .as_deref()
            .ok_or_else(|| ApiError::bad("`date` is missing (YYYY-MM-DD)"))?;
        let date = crate::coverage::parse_date(date_text).ok_or_else(|| {
            ApiError::bad(format!(
                "`{}` is not a calendar date YYYY-MM-DD",
                short(date_text)
            ))
        })?;
        coverage.check(lat, lon, &date)?;
        Ok((lat, lon, date))
    }
}

/// The routes.
pub fn router(state: Shared) -> Router {
    Router::new()
        .route("/", get(index))
        .route(
            "/app.js",
            get(|| async { asset(APP_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/app.css",
            get(|| async { asset(APP_CSS, "text/css; charset=utf-8") }),
        )
        .route("/api/health", get(health))
        .route(
            "/api/openapi.json",
            get(|| async { asset(OPENAPI, "application/json") }),
        )
        .route("/api/coverage", get(coverage))
        .route("/api/basemap.png", get(basemap))
        .route("/api/predictWildfire", post(predict))
        .route("/api/probabilityMap", get(probability_map))
        .route("/api/createEnvironment", post(create_environment))
        .route("/api/environments/{id}/landscape.png", get(landscape_png))
        .route("/api/environments/{id}/simulate", get(simulate))
        .route("/api/jobs/threat", post(submit_threat))
        .route("/api/jobs/{id}", get(job))
        .route("/api/jobs/{id}/files/{name}", get(job_file))
        .route("/api/runs", get(runs_page))
        .route("/api/runs.csv", get(runs_csv))
        .route("/api/runs/{id}", get(run_details))
        .route("/api/runs/{id}/metrics/{*key}", get(run_series))
        .route("/api/runs/{id}/log", get(run_log))
        .route("/api/runs/{id}/artifacts/{name}", get(artifact_root))
        .route("/api/runs/{id}/artifacts/{name}/{*path}", get(artifact_file))
        .route("/api/compare", get(compare))
        .route("/api/runs/{id}/outputs/{name}/{*path}", get(output_file))
        .route("/api/tables/forecast", get(forecast_table))
        .route("/api/tables/rl", get(rl_table))
        .route("/api/datasets", get(datasets))
        .route("/api/datasets/{name}", get(dataset))
        .route("/api/datasets/{name}/files/{file}", get(dataset_file))
        .route("/rerun/", get(rerun_index))
        .route("/rerun/{file}", get(rerun_file))
        .fallback(|| async { ApiError::not_found("no such page or endpoint") })
        .layer(axum::middleware::from_fn_with_state(state.clone(), guard))
        .with_state(state)
}

/// Every request: body size, token, same origin for anything that changes state.
async fn guard(State(state): State<Shared>, request: Request, next: Next) -> Response {
    let headers = request.headers();
    let length = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if length.is_some_and(|n| n > MAX_BODY_BYTES)
        || (length.is_none() && headers.contains_key(header::TRANSFER_ENCODING))
    {
        return ApiError::new(
            Code::TooLarge,
            format!("request bodies are limited to {} KiB", MAX_BODY_BYTES / 1024),
        )
        .into_response();
    }
    let mut set_cookie = None;
    if let Some(token) = &state.cfg.token {
        match presented_token(&request) {
            Some((given, from_query)) if constant_eq(given.as_bytes(), token.as_bytes()) => {
                if from_query {
                    set_cookie = Some(format!(
                        "firecast_token={token}; Path=/; HttpOnly; SameSite=Strict"
                    ));
                }
            }
            _ => {
                return ApiError::new(
                    Code::Unauthorized,
                    "this server needs its token: open the address `firecast serve` printed (…/?token=…)",
                )
                .into_response();
            }
        }
    }
    let is_ws = headers
        .get(header::UPGRADE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.eq_ignore_ascii_case("websocket"));
    let changes_state = !matches!(*request.method(), Method::GET | Method::HEAD | Method::OPTIONS);
    if (changes_state || is_ws) && !same_origin(headers) {
        return ApiError::new(
            Code::CrossOrigin,
            "requests that start work must come from this server's own page",
        )
        .into_response();
    }
    let mut response = next.run(request).await;
    if let Some(cookie) = set_cookie
        && let Ok(v) = HeaderValue::from_str(&cookie)
    {
        response.headers_mut().insert(header::SET_COOKIE, v);
    }
    response
        .headers_mut()
        .insert("x-content-type-options", HeaderValue::from_static("nosniff"));
    response
}

/// The token from `Authorization: Bearer`, the cookie, or `?token=` (then `true`).
fn presented_token(request: &Request) -> Option<(String, bool)> {
    let headers = request.headers();
    if let Some(v) = headers.get(header::AUTHORIZATION).and_then(|v| v.to_str().ok())
        && let Some(t) = v.strip_prefix("Bearer ")
    {
        return Some((t.trim().to_string(), false));
    }
    for cookie in headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
    {
        for part in cookie.split(';') {
            if let Some(t) = part.trim().strip_prefix("firecast_token=") {
                return Some((t.to_string(), false));
            }
        }
    }
    let query = request.uri().query()?;
    query
        .split('&')
        .find_map(|kv| kv.strip_prefix("token="))
        .map(|t| (t.to_string(), true))
}

fn constant_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A browser names the page's origin: it must be this server. Clients that send no `Origin`
/// (curl, scripts) are not browsers carrying someone else's page.
fn same_origin(headers: &HeaderMap) -> bool {
    if let Some(site) = headers.get("sec-fetch-site").and_then(|v| v.to_str().ok())
        && !matches!(site, "same-origin" | "none")
    {
        return false;
    }
    let Some(origin) = headers.get(header::ORIGIN).and_then(|v| v.to_str().ok()) else {
        return true;
    };
    let host = headers
        .get(header::HOST)
        .and_then(|v| v.to_str().ok())
        .unwrap_or_default();
    origin == format!("http://{host}") || origin == format!("https://{host}")
}

fn asset(body: &'static str, content_type: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

async fn index() -> Response {
    asset(INDEX_HTML, "text/html; charset=utf-8")
}

async fn health(State(state): State<Shared>) -> Json<serde_json::Value> {
    Json(serde_json::json!({
        "status": "ok",
        "version": env!("CARGO_PKG_VERSION"),
        "live_fires": state.fires.running(),
    }))
}

async fn overview(state: &Shared) -> Result<Arc<Overview>, ApiError> {
    let coverage = state.coverage()?;
    let seed = state.fire.as_ref().map_or(1, |f| f.landscape_seed);
    state
        .overview
        .get_or_init(|| async move {
            tokio::task::spawn_blocking(move || crate::overview::render(&coverage, seed).map(Arc::new))
                .await
                .unwrap_or_else(|e| Err(e.to_string()))
        })
        .await
        .clone()
        .map_err(ApiError::internal)
}

async fn coverage(State(state): State<Shared>) -> Result<Json<serde_json::Value>, ApiError> {
    let coverage = state.coverage()?;
    let overview = overview(&state).await?;
    let f = state.forecaster();
    let forecaster = match f.check() {
        Ok(()) => {
            serde_json::json!({"experiment": f.experiment, "model": f.model, "available": true, "reason": null})
        }
        Err(e) => {
            serde_json::json!({"experiment": f.experiment, "model": f.model, "available": false, "reason": e.message})
        }
    };
    let mut value = serde_json::to_value(&*coverage).map_err(|e| ApiError::internal(e.to_string()))?;
    if let Some(obj) = value.as_object_mut() {
        obj.insert(
            "basemap".into(),
            serde_json::to_value(&overview.info).unwrap_or_default(),
        );
        obj.insert("forecaster".into(), forecaster);
        obj.insert("agents".into(), state.agents());
        obj.insert(
            "fire".into(),
            serde_json::json!({"settings": state.fire.as_ref().map(|f| f.source.clone()).map_err(Clone::clone)}),
        );
        obj.insert(
            "report".into(),
            serde_json::json!({"available": state.jobs.available(), "pipeline": state.cfg.threat_pipeline}),
        );
    }
    Ok(Json(value))
}

async fn basemap(State(state): State<Shared>) -> Result<Response, ApiError> {
    let overview = overview(&state).await?;
    Ok(([(header::CONTENT_TYPE, "image/png")], overview.png.clone()).into_response())
}

async fn predict(
    State(state): State<Shared>,
    Q(q): Q<PlaceQuery>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let coverage = state.coverage()?;
    let (lat, lon, date) = q.resolve(&coverage)?;
    let forecaster = state.forecaster();
    let forecast = blocking(move || forecaster.point(&coverage, lat, lon, &date)).await?;
    let mut value = serde_json::to_value(&forecast).map_err(|e| ApiError::internal(e.to_string()))?;
    if let Some(obj) = value.as_object_mut() {
        // FireCastRL's shape: {lat, lon, date, prediction}.
        obj.insert("prediction".into(), serde_json::json!(forecast.probability));
    }
    Ok(Json(value))
}

#[derive(Debug, Deserialize)]
struct DateQuery {
    date: Option<String>,
}

async fn probability_map(
    State(state): State<Shared>,
    Q(q): Q<DateQuery>,
) -> Result<Json<Arc<ProbabilityMap>>, ApiError> {
    let coverage = state.coverage()?;
    let text = q
        .date
        .as_deref()
        .ok_or_else(|| ApiError::bad("`date` is missing (YYYY-MM-DD)"))?;
    let date = crate::coverage::parse_date(text)
        .ok_or_else(|| ApiError::bad(format!("`{}` is not a calendar date YYYY-MM-DD", short(text))))?;
    let centre_lat = (coverage.lat_min + coverage.lat_max) / 2.0;
    let centre_lon = (coverage.lon_min + coverage.lon_max) / 2.0;
    coverage.check(centre_lat, centre_lon, &date)?;
    let forecaster = state.forecaster();
    // Keyed by the forecaster too: a report job may train a better one meanwhile.
    let key = format!("{}|{}", forecaster.experiment.display(), date);
    if let Some(m) = state.maps.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(Json(m.clone()));
    }
    let map = Arc::new(blocking(move || forecaster.map(&coverage, &date)).await?);
    let mut maps = state.maps.lock().unwrap_or_else(|e| e.into_inner());
    if maps.len() >= MAPS_KEPT {
        maps.clear();
    }
    maps.insert(key, map.clone());
    Ok(Json(map))
}

async fn create_environment(
    State(state): State<Shared>,
    Q(q): Q<PlaceQuery>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let coverage = state.coverage()?;
    let (lat, lon, date) = q.resolve(&coverage)?;
    let settings = state.fire_settings()?;
    let id = crate::fire::environment_id(lat, lon, &date, settings.landscape_seed);
    let env = match state.environment(&id) {
        Ok(env) => env,
        Err(_) => {
            let root = state.cfg.root.clone();
            let gridmet = coverage.gridmet.clone();
            let env = Arc::new(
                blocking(move || Environment::create(&root, &gridmet, &settings, lat, lon, &date)).await?,
            );
            state.keep_environment(env.clone());
            env
        }
    };
    serde_json::to_value(env.info())
        .map(Json)
        .map_err(|e| ApiError::internal(e.to_string()))
}

async fn landscape_png(State(state): State<Shared>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let env = state.environment(&id)?;
    Ok(([(header::CONTENT_TYPE, "image/png")], env.landscape_png.clone()).into_response())
}

#[derive(Debug, Deserialize)]
struct SimulateQuery {
    agent: Option<String>,
    seed: Option<String>,
}

async fn simulate(
    State(state): State<Shared>,
    Path(id): Path<String>,
    Q(q): Q<SimulateQuery>,
    ws: WebSocketUpgrade,
) -> Result<Response, ApiError> {
    let env = state.environment(&id)?;
    let agent = LiveAgent::parse(q.agent.as_deref().unwrap_or("rule"))?;
    let seed =
        match q.seed.as_deref() {
            None | Some("") => 0,
            Some(s) => s.parse::<u64>().ok().filter(|&s| s < 1_000_000).ok_or_else(|| {
                ApiError::bad(format!("seed `{}`: a whole number below 1,000,000", short(s)))
            })?,
        };
    let slot = state.fires.take()?;
    let agent_run = state.agent_run();
    Ok(ws
        .max_message_size(4096)
        .on_upgrade(move |socket| crate::session::run(socket, env, agent, seed, agent_run, slot)))
}

async fn submit_threat(State(state): State<Shared>, Q(q): Q<PlaceQuery>) -> Result<Response, ApiError> {
    let coverage = state.coverage()?;
    let (lat, lon, date) = q.resolve(&coverage)?;
    let job = state.jobs.submit(lat, lon, &date)?;
    Ok((StatusCode::ACCEPTED, Json(job)).into_response())
}

async fn job(
    State(state): State<Shared>,
    Path(id): Path<String>,
) -> Result<Json<crate::jobs::Job>, ApiError> {
    state.jobs.get(&id).map(Json)
}

async fn job_file(
    State(state): State<Shared>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let path = state.jobs.file(&id, &name)?;
    let bytes = blocking(move || std::fs::read(&path).map_err(|e| ApiError::internal(e.to_string()))).await?;
    Ok(untrusted(content_type(&name), bytes))
}

async fn runs_page(
    State(state): State<Shared>,
    uri: axum::http::Uri,
    Q(q): Q<RunsQuery>,
) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    let key = uri.query().unwrap_or_default().to_string();
    let bytes = blocking(move || runs.page_json(&q, &key)).await?;
    Ok(([(header::CONTENT_TYPE, "application/json")], Body::from(bytes)).into_response())
}

async fn runs_csv(State(state): State<Shared>, Q(mut q): Q<RunsQuery>) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    q.limit = Some(q.limit.unwrap_or(10_000));
    let page = blocking(move || runs.page(&q)).await?;
    Ok((
        [
            (header::CONTENT_TYPE, "text/csv; charset=utf-8"),
            (
                header::CONTENT_DISPOSITION,
                "attachment; filename=\"firecast-runs.csv\"",
            ),
        ],
        crate::runs::to_csv(&page.runs),
    )
        .into_response())
}

async fn run_details(
    State(state): State<Shared>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    blocking(move || {
        let details = runs.details(&id)?;
        let has_log = crate::runs::log_path(&root, &details.run.run_id)?.is_file();
        let mut value = serde_json::to_value(&details).map_err(|e| ApiError::internal(e.to_string()))?;
        if let Some(obj) = value.as_object_mut() {
            obj.insert("log".into(), serde_json::json!(has_log));
        }
        Ok(Json(value))
    })
    .await
}

async fn run_series(
    State(state): State<Shared>,
    Path((id, key)): Path<(String, String)>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    blocking(move || {
        let series = runs.series(&id, &key)?;
        Ok(Json(serde_json::json!({
            "key": key,
            "steps": series.iter().map(|s| s.0).collect::<Vec<_>>(),
            "values": series.iter().map(|s| s.1).collect::<Vec<_>>(),
        })))
    })
    .await
}

async fn run_log(State(state): State<Shared>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    let text = blocking(move || {
        let details = runs.details(&id)?;
        let path = crate::runs::log_path(&root, &details.run.run_id)?;
        std::fs::read_to_string(&path)
            .map_err(|_| ApiError::not_found(format!("run {} has no log", details.run.run_id)))
    })
    .await?;
    Ok(([(header::CONTENT_TYPE, "text/plain; charset=utf-8")], text).into_response())
}

async fn artifact_root(
    State(state): State<Shared>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    artifact(state, id, name, String::new()).await
}

async fn artifact_file(
    State(state): State<Shared>,
    Path((id, name, path)): Path<(String, String, String)>,
) -> Result<Response, ApiError> {
    artifact(state, id, name, path).await
}

/// A file of a run's artifact, read through the artifact store (never a path of the
/// request's making: the key starts with the artifact's registered key).
async fn artifact(state: Shared, id: String, name: String, rest: String) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    let location = state.cfg.store.clone();
    let (bytes, file_name) = blocking(move || {
        let details = runs.details(&id)?;
        let row = details.artifacts.iter().find(|a| a.name == name).ok_or_else(|| {
            ApiError::not_found(format!(
                "run {} has no artifact `{}`",
                details.run.run_id,
                short(&name)
            ))
        })?;
        let store = firecast_store::ArtifactStore::open(&location, &root)
            .map_err(|e| ApiError::internal(e.to_string()))?;
        let base = store.key_of(&row.uri);
        // An artifact that is one file also answers to its own name (`…/ppo-best.rrd`):
        // viewers such as Rerun's tell the format from the URL's end.
        let key = if !rest.is_empty() && base.rsplit('/').next() == Some(rest.as_str()) {
            base
        } else {
            crate::runs::artifact_key(&base, &rest)?
        };
        let bytes = store.get_bytes(&key).map_err(|e| match e {
            firecast_store::StoreError::NotFound(uri) => ApiError::not_found(format!("no file {uri}")),
            other => ApiError::internal(other.to_string()),
        })?;
        let file_name = key.rsplit('/').next().unwrap_or_default().to_string();
        Ok((bytes, file_name))
    })
    .await?;
    Ok(untrusted(content_type(&file_name), bytes))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CompareQuery {
    ids: Option<String>,
    group: Option<String>,
}

async fn compare(
    State(state): State<Shared>,
    Q(q): Q<CompareQuery>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let ids: Vec<String> = q
        .ids
        .unwrap_or_default()
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .collect();
    let runs = state.runs.clone();
    blocking(move || runs.compare(&ids, q.group.as_deref()).map(Json)).await
}

/// A file a run wrote (one of its lineage outputs), read only inside the project.
async fn output_file(
    State(state): State<Shared>,
    Path((id, name, path)): Path<(String, String, String)>,
) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    let (bytes, file) = blocking(move || {
        let details = runs.details(&id)?;
        let file = crate::results::output_path(&root, &details, &name, &path)?;
        if !file.is_file() {
            return Err(ApiError::not_found(format!("{} is not a file", file.display())));
        }
        let bytes =
            std::fs::read(&file).map_err(|e| ApiError::internal(format!("{}: {e}", file.display())))?;
        Ok((
            bytes,
            file.file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
        ))
    })
    .await?;
    Ok(untrusted(content_type(&file), bytes))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TableQuery {
    run: Option<String>,
}

async fn forecast_table(
    State(state): State<Shared>,
    Q(q): Q<TableQuery>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    blocking(move || {
        let id = crate::results::run_param(q.run.as_deref())?;
        crate::results::forecast_table(&runs, &root, id).map(Json)
    })
    .await
}

async fn rl_table(
    State(state): State<Shared>,
    Q(q): Q<TableQuery>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    blocking(move || {
        let id = crate::results::run_param(q.run.as_deref())?;
        crate::results::rl_table(&runs, &root, id).map(Json)
    })
    .await
}

async fn datasets(State(state): State<Shared>) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    blocking(move || crate::results::datasets(&runs, &root).map(Json)).await
}

async fn dataset(
    State(state): State<Shared>,
    Path(name): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    blocking(move || crate::results::dataset(&runs, &root, &name).map(Json)).await
}

async fn dataset_file(
    State(state): State<Shared>,
    Path((name, file)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let runs = state.runs.clone();
    let root = state.cfg.root.clone();
    let (bytes, file) = blocking(move || {
        let path = crate::results::dataset_file(&runs, &root, &name, &file)?;
        let bytes =
            std::fs::read(&path).map_err(|e| ApiError::internal(format!("{}: {e}", path.display())))?;
        Ok((bytes, file))
    })
    .await?;
    Ok(untrusted(content_type(&file), bytes))
}

async fn rerun_index(State(state): State<Shared>) -> Result<Response, ApiError> {
    rerun_asset(state, "index.html".to_string()).await
}

async fn rerun_file(State(state): State<Shared>, Path(file): Path<String>) -> Result<Response, ApiError> {
    rerun_asset(state, file).await
}

/// A file of Rerun's web viewer (only the files it is made of).
async fn rerun_asset(state: Shared, file: String) -> Result<Response, ApiError> {
    let Some(name) = crate::rerun_viewer::FILES.iter().find(|f| **f == file) else {
        return Err(ApiError::not_found(format!(
            "Rerun's viewer has no file `{}`",
            short(&file)
        )));
    };
    let path = state.rerun.dir().await?.join(name);
    let bytes = tokio::fs::read(&path)
        .await
        .map_err(|e| ApiError::internal(format!("{}: {e}", path.display())))?;
    Ok((
        [
            (header::CONTENT_TYPE, crate::rerun_viewer::content_type(name)),
            (header::CACHE_CONTROL, "max-age=3600"),
        ],
        Body::from(bytes),
    )
        .into_response())
}

/// A file written by a pipeline: shown, never run as this server's page (no scripts, its
/// own origin).
fn untrusted(content_type: &'static str, bytes: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CONTENT_SECURITY_POLICY, "sandbox"),
        ],
        Body::from(bytes),
    )
        .into_response()
}

/// Content types by file extension (unknown files are served as bytes to download).
fn content_type(name: &str) -> &'static str {
    let ext = name.rsplit('.').next().unwrap_or_default().to_ascii_lowercase();
    match ext.as_str() {
        "html" => "text/html; charset=utf-8",
        "json" | "geojson" => "application/json",
        "csv" => "text/csv; charset=utf-8",
        "md" | "txt" | "log" | "yaml" | "yml" => "text/plain; charset=utf-8",
        "png" => "image/png",
        "gif" => "image/gif",
        "jpg" | "jpeg" => "image/jpeg",
        "svg" => "image/svg+xml",
        "pdf" => "application/pdf",
        _ => "application/octet-stream",
    }
}

/// The address the page is served at, for the CLI to print.
pub fn page_url(addr: SocketAddr, token: Option<&str>) -> String {
    match token {
        Some(t) => format!("http://{addr}/?token={t}"),
        None => format!("http://{addr}/"),
    }
}
