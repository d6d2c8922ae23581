//! Spread verification against Rothermel's ellipse, in the manner of ELMFIRE's V&V suite:
//! constant-condition cases (uniform fuel, constant wind, optional slope, one point ignition at
//! a cell centre) run by both engines — the FireCastRL automaton as it is, and the MTT engine —
//! and the fire read off each engine's arrival-time field after 1, 2 and 4 hours.
//!
//! The reading (the same for both engines): the arrival time is interpolated bilinearly
//! between cell centres; along 360 rays from the ignition the front is where it first exceeds
//! t. Head, flank and back rates are the front's distance along the head direction, across it
//! (the mean of both sides) and against it, over t; length and breadth are the front's extent
//! along and across the head direction; the area is the front polygon's. The burnt cells'
//! area (cells reached by t × cell area) is printed beside it. The exact values are the
//! kernel's ellipse with the ignition at its rear focus (docs/spec/fire-model.md §B7, §B10.1).

use std::f64::consts::PI;

use firecast_landscape::{GeoReference, LandCoverScheme, Landscape};
use firecast_sim::{
    Automaton, FireState, FuelModel, FuelMoisture, KernelConfig, SimConfig, SpreadInputs, SurfaceFuelBed,
    Wind,
};

use crate::mtt::{DEFAULT_STENCIL_RADIUS, MttConfig, MttGrid};

const M_PER_FT: f64 = 0.3048;
/// Reading times, hours.
pub const TIMES_H: [f64; 3] = [1.0, 2.0, 4.0];
/// Both engines run this long, so the 4-hour front has arrival times on both sides of it.
const RUN_H: f64 = 5.0;
/// The MTT engine runs until every reachable cell has its time.
const UNBOUNDED_H: f64 = 1.0e6;
/// Pass bounds: rates and L/B within 5 %, area within 10 % (issue 28).
pub const RATE_TOL: f64 = 0.05;
pub const AREA_TOL: f64 = 0.10;
/// A row is judged only when the fire's shortest radius (back, flank or head) spans this many
/// cells; a smaller fire lies within the cells around the ignition.
pub const RESOLVED_CELLS: f64 = 2.0;

/// A spread engine under test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Engine {
    /// The FireCastRL/Concord automaton with the Rothermel kernel (12-minute steps, radius 2.5).
    Automaton,
    /// Minimum travel time, stencil radius as configured.
    Mtt,
}

impl Engine {
    pub fn name(self) -> &'static str {
        match self {
            Self::Automaton => "automaton",
            Self::Mtt => "mtt",
        }
    }
}

/// One constant-condition case.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Case {
    pub name: String,
    /// Fuel-model number (Anderson 1–13, Scott & Burgan 101–204, 91–99 non-burnable).
    pub fuel: u16,
    pub moisture: FuelMoisture,
    /// Midflame wind, mi/h.
    pub wind_mph: f64,
    /// Angle of the wind's heading from the grid's +x axis, counter-clockwise, degrees.
    pub wind_angle_deg: f64,
    /// Slope, percent, rising toward +y (north).
    pub slope_pct: f64,
    pub cell_m: f64,
}

impl Case {
    /// A case in the standard moisture (6/7/8/60/90 %), named after its fuel and wind.
    pub fn new(fuel: u16, wind_mph: f64, wind_angle_deg: f64, slope_pct: f64, cell_m: f64) -> Self {
        let code = FuelModel::by_number(fuel).map_or("NB", |m| m.code);
        let name = if wind_mph > 0.0 {
            format!("{code} {wind_mph} mi/h {wind_angle_deg}°")
        } else if slope_pct > 0.0 {
            format!("{code} slope {slope_pct} %")
        } else {
            format!("{code} calm")
        };
        Self {
            name,
            fuel,
            moisture: FuelMoisture::from_percent(6.0, 7.0, 8.0, 60.0, 90.0),
            wind_mph,
            wind_angle_deg,
            slope_pct,
            cell_m,
        }
    }

    /// Azimuth (clockwise from north = +y) the wind blows toward.
    fn wind_toward_deg(&self) -> f64 {
        90.0 - self.wind_angle_deg
    }
}

/// Every case: two fuels × two winds × three angles × three cell sizes, slope alone, calm,
/// and the no-spread cases.
pub fn all_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for fuel in [102, 145] {
        for wind in [4.0, 15.0] {
            for angle in [0.0, 22.5, 45.0] {
                for cell in [30.0, 60.0, 150.0] {
                    cases.push(Case::new(fuel, wind, angle, 0.0, cell));
                }
            }
        }
    }
    for cell in [30.0, 60.0, 150.0] {
        cases.push(Case::new(102, 0.0, 0.0, 30.0, cell));
    }
    for cell in [30.0, 60.0, 150.0] {
        cases.push(Case::new(102, 0.0, 0.0, 0.0, cell));
    }
    cases.extend(no_spread_cases());
    cases
}

/// Moisture above extinction (FM1 at 15 % dead, extinction 12 %) and a non-burnable cover.
pub fn no_spread_cases() -> Vec<Case> {
    let mut wet = Case::new(1, 15.0, 22.5, 0.0, 30.0);
    wet.moisture = FuelMoisture::from_percent(15.0, 16.0, 17.0, 60.0, 90.0);
    wet.name = "FM1 wet (15 % > Mx 12 %)".into();
    let mut nb = Case::new(91, 15.0, 22.5, 0.0, 30.0);
    nb.name = "NB1 non-burnable".into();
    vec![wet, nb]
}

/// The small subset the test suite runs.
pub fn quick_cases() -> Vec<Case> {
    let mut cases = vec![
        Case::new(102, 15.0, 22.5, 0.0, 60.0),
        Case::new(145, 4.0, 45.0, 0.0, 150.0),
        Case::new(102, 0.0, 0.0, 30.0, 60.0),
    ];
    cases.extend(no_spread_cases());
    cases
}

/// The kernel's rates for a case (ft/min) and its ellipse.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Exact {
    pub head_m_min: f64,
    pub flank_m_min: f64,
    pub back_m_min: f64,
    pub length_to_breadth: f64,
    /// Semi-minor axis growth (behave's flanking rate), m/min.
    pub semi_minor_m_min: f64,
    /// Head azimuth, degrees clockwise from +y.
    pub head_azimuth_deg: f64,
}

impl Exact {
    /// Ellipse area after `t_h` hours, hectares: π·a·b·t², a = (head + back)/2.
    pub fn area_ha(&self, t_h: f64) -> f64 {
        let t = t_h * 60.0;
        PI * 0.5 * (self.head_m_min + self.back_m_min) * t * self.semi_minor_m_min * t / 1e4
    }

    pub fn spreads(&self) -> bool {
        self.head_m_min > 0.0
    }
}

/// The kernel's ellipse for a case (the exact values of the table).
pub fn exact(case: &Case) -> Exact {
    let model = FuelModel::by_number(case.fuel);
    let Some(model) = model else {
        return Exact {
            head_m_min: 0.0,
            flank_m_min: 0.0,
            back_m_min: 0.0,
            length_to_breadth: 1.0,
            semi_minor_m_min: 0.0,
            head_azimuth_deg: 0.0,
        };
    };
    let bed = SurfaceFuelBed::new(model, &case.moisture).expect("valid case moisture");
    // Upslope is north (0°); with no slope the frame is the same.
    let b = bed.spread(&SpreadInputs {
        midflame_wind_mph: case.wind_mph,
        slope_percent: case.slope_pct,
        wind_dir_from_upslope_deg: case.wind_toward_deg(),
    });
    Exact {
        head_m_min: b.head_ros_ftmin * M_PER_FT,
        flank_m_min: b.ros_from_head_ftmin(90.0) * M_PER_FT,
        back_m_min: b.ros_from_head_ftmin(180.0) * M_PER_FT,
        length_to_breadth: b.length_to_width_ratio,
        semi_minor_m_min: b.flanking_ros_ftmin * M_PER_FT,
        head_azimuth_deg: b.dir_max_spread_from_upslope_deg,
    }
}

/// What one engine did in one case at one time.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Measured {
    pub head_m_min: f64,
    pub flank_m_min: f64,
    pub back_m_min: f64,
    pub length_to_breadth: f64,
    /// Area of the front polygon, ha.
    pub area_ha: f64,
    /// Cells reached by t × cell area, ha.
    pub cells_area_ha: f64,
    pub cells_burnt: usize,
    /// A ray reached the grid's edge before the front (the reading is then a lower bound).
    pub edge: bool,
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Row {
    pub case: String,
    pub cell_m: f64,
    pub time_h: f64,
    pub engine: Engine,
    pub exact: Exact,
    pub exact_area_ha: f64,
    pub measured: Measured,
    /// measured / exact: head, flank, back, L/B, area; `None` for a no-spread case.
    pub ratios: Option<[f64; 5]>,
    /// The shortest of the exact head, flank and back distances at t spans at least
    /// [`RESOLVED_CELLS`] cells; below that the reading cannot resolve the front.
    pub resolved: bool,
    pub pass: bool,
}

/// Options of a verification run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerifyOptions {
    pub stencil_radius: u32,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        Self {
            stencil_radius: DEFAULT_STENCIL_RADIUS,
        }
    }
}

/// A uniform landscape sized for the case's 5-hour ellipse, and the ignition cell.
pub fn landscape(case: &Case, ex: &Exact) -> (Landscape, (usize, usize)) {
    let t = RUN_H * 60.0;
    let (fwd, back, half) = if ex.spreads() {
        (ex.head_m_min * t, ex.back_m_min * t, ex.semi_minor_m_min * t)
    } else {
        (0.0, 0.0, 0.0)
    };
    let (s, c) = ex.head_azimuth_deg.to_radians().sin_cos();
    // Corners of the ellipse's bounding box (u along the head, v across), in metres.
    let mut xr = (0.0f64, 0.0f64);
    let mut yr = (0.0f64, 0.0f64);
    for (u, v) in [(fwd, half), (fwd, -half), (-back, half), (-back, -half)] {
        let (x, y) = (u * s + v * c, u * c - v * s);
        xr = (xr.0.min(x), xr.1.max(x));
        yr = (yr.0.min(y), yr.1.max(y));
    }
    let margin = |m: f64| (1.15 * m / case.cell_m).ceil() as usize + 8;
    let (left, right) = (margin(-xr.0), margin(xr.1));
    let (down, up) = (margin(-yr.0), margin(yr.1));
    let (w, h) = (left + right + 1, down + up + 1);
    let cell_ft = case.cell_m / M_PER_FT;
    let scheme = if case.fuel < 100 {
        LandCoverScheme::Fbfm13
    } else {
        LandCoverScheme::Fbfm40
    };
    let rise = (case.slope_pct / 100.0 * cell_ft) as f32;
    let elevation = (0..h)
        .flat_map(|y| std::iter::repeat_n(1000.0 + rise * y as f32, w))
        .collect();
    let georef = GeoReference {
        crs: "EPSG:32611".into(),
        origin_x: 500_000.0,
        origin_y: 4_000_000.0,
        cell_size_x: case.cell_m,
        cell_size_y: case.cell_m,
    };
    let land = Landscape::new(w, h, cell_ft, scheme, vec![case.fuel; w * h], elevation, georef)
        .expect("valid verification landscape");
    (land, (left, down))
}

fn wind(case: &Case) -> Wind {
    Wind {
        speed_mph: case.wind_mph,
        from_direction_deg: case.wind_toward_deg() + 180.0,
        ..Wind::default()
    }
}

/// The arrival-time field (hours) of one engine on one case's landscape.
pub fn arrival_field(
    engine: Engine,
    case: &Case,
    land: &Landscape,
    ignition: (usize, usize),
    opts: &VerifyOptions,
) -> Vec<f64> {
    match engine {
        Engine::Mtt => {
            let cfg = MttConfig {
                moisture: case.moisture,
                wind: wind(case),
                stencil_radius: opts.stencil_radius,
                max_time_h: UNBOUNDED_H,
            };
            // Unbounded, so the cells beyond a slow front still carry their (later) times.
            MttGrid::new(land, &cfg)
                .and_then(|g| g.arrival_times_h(&[ignition], cfg.stencil_radius, UNBOUNDED_H))
                .expect("valid MTT case")
        }
        Engine::Automaton => {
            let cfg = SimConfig {
                kernel: KernelConfig::Rothermel {
                    moisture: case.moisture,
                    drop_moisture_increment: 0.05,
                },
                wind: wind(case),
                ..SimConfig::default()
            };
            let mut a = Automaton::new(land, &cfg).expect("valid automaton case");
            a.ignite(ignition.0, ignition.1, 0.0).expect("ignition inside");
            let steps = (RUN_H * 60.0 / cfg.dt_min).round() as usize;
            for _ in 0..steps {
                a.step();
            }
            // Every cell ignited by t has an ignition time ≤ t; a cell still waiting has its
            // scheduled time (> 5 h), which the reading needs beyond a slow front.
            debug_assert!(
                (0..land.len())
                    .all(|i| a.fire_state(i) != FireState::Unburnt || a.ignition_times()[i] > RUN_H * 60.0)
            );
            a.ignition_times().iter().map(|&t| t / 60.0).collect()
        }
    }
}

/// Bilinear reading of a cell-centred field at (x, y) in cell units; unreached cells count as
/// a time far in the future.
fn bilinear(field: &[f64], w: usize, h: usize, x: f64, y: f64) -> Option<f64> {
    if x < 0.0 || y < 0.0 || x > (w - 1) as f64 || y > (h - 1) as f64 {
        return None;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let v = |xx: usize, yy: usize| field[yy * w + xx].min(1e6);
    Some(
        (1.0 - fy) * ((1.0 - fx) * v(x0, y0) + fx * v(x1, y0))
            + fy * ((1.0 - fx) * v(x0, y1) + fx * v(x1, y1)),
    )
}

/// Distance (cells) from the ignition along a unit direction to where the field first exceeds
/// `t`, and whether the grid's edge came first.
fn front_distance(
    field: &[f64],
    w: usize,
    h: usize,
    ign: (usize, usize),
    dir: (f64, f64),
    t: f64,
) -> (f64, bool) {
    const STEP: f64 = 0.25;
    let (x0, y0) = (ign.0 as f64, ign.1 as f64);
    let mut prev = (0.0, 0.0);
    let mut s = STEP;
    loop {
        let Some(v) = bilinear(field, w, h, x0 + s * dir.0, y0 + s * dir.1) else {
            return (s - STEP, true);
        };
        if v > t {
            // Linear between the two samples.
            let (ps, pv) = prev;
            return (ps + (t - pv) / (v - pv) * (s - ps), false);
        }
        prev = (s, v);
        s += STEP;
    }
}

/// Rays of the reading, one per degree.
const RAYS: usize = 360;

/// The front at `t_h` along [`RAYS`] rays from the ignition, the first along the head and
/// then turning clockwise, as (along the head, across it to the right) in metres; and whether
/// a ray met the grid's edge first.
fn front_uv(
    field: &[f64],
    w: usize,
    h: usize,
    ign: (usize, usize),
    head_azimuth_deg: f64,
    cell_m: f64,
    t_h: f64,
) -> (Vec<(f64, f64)>, bool) {
    let mut pts = Vec::with_capacity(RAYS);
    let mut edge = false;
    for k in 0..RAYS {
        // ψ from the head direction; the ray's azimuth is head + ψ.
        let psi = (k as f64) * 360.0 / RAYS as f64;
        let az = (head_azimuth_deg + psi).to_radians();
        let (d, e) = front_distance(field, w, h, ign, (az.sin(), az.cos()), t_h);
        edge |= e;
        let d = d * cell_m;
        pts.push((d * psi.to_radians().cos(), d * psi.to_radians().sin()));
    }
    (pts, edge)
}

/// The front polygon the table reads at `t_h` (the same rays), as (east, north) metres from
/// the ignition.
pub fn front_polygon(
    field: &[f64],
    land: &Landscape,
    ign: (usize, usize),
    head_azimuth_deg: f64,
    cell_m: f64,
    t_h: f64,
) -> Vec<(f64, f64)> {
    let (pts, _) = front_uv(field, land.width, land.height, ign, head_azimuth_deg, cell_m, t_h);
    let (s, c) = head_azimuth_deg.to_radians().sin_cos();
    pts.into_iter()
        .map(|(u, v)| (u * s + v * c, u * c - v * s))
        .collect()
}

/// Reads the fire at time `t_h` off an arrival-time field.
pub fn measure(
    field: &[f64],
    land: &Landscape,
    ign: (usize, usize),
    head_azimuth_deg: f64,
    cell_m: f64,
    t_h: f64,
) -> Measured {
    let (w, h) = (land.width, land.height);
    let cells_burnt = field.iter().filter(|&&a| a <= t_h).count();
    let cells_area_ha = cells_burnt as f64 * cell_m * cell_m / 1e4;
    let t_min = t_h * 60.0;
    if field[ign.1 * w + ign.0] > t_h {
        return Measured {
            head_m_min: 0.0,
            flank_m_min: 0.0,
            back_m_min: 0.0,
            length_to_breadth: 1.0,
            area_ha: 0.0,
            cells_area_ha,
            cells_burnt,
            edge: false,
        };
    }
    let (pts, edge) = front_uv(field, w, h, ign, head_azimuth_deg, cell_m, t_h);
    let at = |deg: usize| pts[deg * RAYS / 360].0.hypot(pts[deg * RAYS / 360].1);
    let (umin, umax) = pts
        .iter()
        .fold((0.0f64, 0.0f64), |a, p| (a.0.min(p.0), a.1.max(p.0)));
    let (vmin, vmax) = pts
        .iter()
        .fold((0.0f64, 0.0f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    let mut area = 0.0;
    for k in 0..RAYS {
        let (a, b) = (pts[k], pts[(k + 1) % RAYS]);
        area += a.0 * b.1 - b.0 * a.1;
    }
    let breadth = vmax - vmin;
    Measured {
        head_m_min: at(0) / t_min,
        flank_m_min: 0.5 * (at(90) + at(270)) / t_min,
        back_m_min: at(180) / t_min,
        length_to_breadth: if breadth > 0.0 {
            (umax - umin) / breadth
        } else {
            1.0
        },
        area_ha: 0.5 * area.abs() / 1e4,
        cells_area_ha,
        cells_burnt,
        edge,
    }
}

/// Runs one case with both engines (or the ones given) and reads it at 1, 2 and 4 hours.
pub fn run_case(case: &Case, engines: &[Engine], opts: &VerifyOptions) -> Vec<Row> {
    let ex = exact(case);
    let (land, ign) = landscape(case, &ex);
    let mut rows = Vec::new();
    for &engine in engines {
        let field = arrival_field(engine, case, &land, ign, opts);
        rows.extend(rows_of(case, engine, &field, &land, ign));
    }
    rows
}

/// The rows at 1, 2 and 4 hours of one engine's arrival-time field on the case's landscape
/// ([`landscape`]).
pub fn rows_of(
    case: &Case,
    engine: Engine,
    field: &[f64],
    land: &Landscape,
    ign: (usize, usize),
) -> Vec<Row> {
    let ex = exact(case);
    let mut rows = Vec::new();
    for t in TIMES_H {
        let m = measure(field, land, ign, ex.head_azimuth_deg, case.cell_m, t);
        let shortest = ex.head_m_min.min(ex.flank_m_min).min(ex.back_m_min) * t * 60.0;
        let resolved = !ex.spreads() || shortest >= RESOLVED_CELLS * case.cell_m;
        let (ratios, pass) = if ex.spreads() {
            let r = [
                m.head_m_min / ex.head_m_min,
                m.flank_m_min / ex.flank_m_min,
                m.back_m_min / ex.back_m_min,
                m.length_to_breadth / ex.length_to_breadth,
                m.area_ha / ex.area_ha(t),
            ];
            let pass = !m.edge
                && resolved
                && r[..4].iter().all(|q| (q - 1.0).abs() <= RATE_TOL)
                && (r[4] - 1.0).abs() <= AREA_TOL;
            (Some(r), pass)
        } else {
            // No spread: nothing beyond the ignition cell.
            (None, m.cells_burnt <= 1)
        };
        rows.push(Row {
            case: case.name.clone(),
            cell_m: case.cell_m,
            time_h: t,
            engine,
            exact: ex,
            exact_area_ha: ex.area_ha(t),
            measured: m,
            ratios,
            resolved,
            pass,
        });
    }
    rows
}

/// Runs every case given.
pub fn run(cases: &[Case], engines: &[Engine], opts: &VerifyOptions) -> Vec<Row> {
    cases.iter().flat_map(|c| run_case(c, engines, opts)).collect()
}

/// The table as Markdown: one row per case, cell size, time and engine; ratios are
/// measured / exact.
pub fn markdown_table(rows: &[Row]) -> String {
    let mut out = String::from(
        "| case | cell (m) | t (h) | engine | head | flank | back | L/B | area | cells' area | pass |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let cols = match r.ratios {
            Some(q) => q.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>(),
            None => vec!["—".into(); 5],
        };
        let cells = if r.exact_area_ha > 0.0 {
            format!("{:.3}", r.measured.cells_area_ha / r.exact_area_ha)
        } else {
            format!("{} cells", r.measured.cells_burnt)
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {}{} | {} |\n",
            r.case,
            r.cell_m,
            r.time_h,
            r.engine.name(),
            cols.join(" | "),
            cells,
            if r.measured.edge { " (edge)" } else { "" },
            if r.pass {
                "yes"
            } else if !r.resolved {
                "n/r"
            } else {
                "**no**"
            }
        ));
    }
    out
}

/// The kernel's values per case (the denominators of the table), as Markdown.
pub fn exact_table(cases: &[Case]) -> String {
    let mut out = String::from(
        "| case | head (m/min) | flank (m/min) | back (m/min) | L/B | area at 1 h (ha) |\n|---|---|---|---|---|---|\n",
    );
    let mut seen = Vec::new();
    for c in cases {
        if seen.contains(&c.name) {
            continue;
        }
        seen.push(c.name.clone());
        let e = exact(c);
        out.push_str(&format!(
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} |\n",
            c.name,
            e.head_m_min,
            e.flank_m_min,
            e.back_m_min,
            e.length_to_breadth,
            e.area_ha(1.0)
        ));
    }
    out
}
