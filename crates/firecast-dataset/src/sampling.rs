//! Positives and three-tier negatives (docs/spec/data.md §4).
//!
//! Two variants, chosen by a param:
//! - `paper`: the FireCastRL paper's description — near negatives shifted 90–150 days, tier
//!   counts 5,000 / 35,000 / 36,000 (or scaled to keep its 50,720 : 76,080 ratio), and the
//!   "no fire recorded" conditions checked at each negative's own time and place.
//! - `code`: what the authors' scripts do (docs/spec/data.md §4.2–4.5): one near attempt per positive with
//!   a ±90–120 day offset, yearly negatives at every whole 365-day step back to the period
//!   start, far negatives until the count is reached. Their quirks are kept, except two
//!   that are switches: the near check against the *origin* positive itself (which rejects
//!   almost every candidate, `exclude_origin`) and the 32 racing threads (FireCast draws
//!   sequentially from one seeded generator, so the same seed gives the same samples).
//!
//! Every tier draws from its own stream of a ChaCha generator derived from the seed, so
//! changing one tier's count never changes another tier's samples.

use std::collections::{BTreeMap, HashSet};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::geo::{DAY_MS, GeoBox, PointIndex, geodesic_destination, haversine_km};
use crate::land::LandMask;
use crate::{DatasetError, Tier, time};

/// One incident report reduced to what de-duplication needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IncidentPoint {
    /// Data-row number in the source file (for the reject report).
    pub row: u64,
    pub time_ms: i64,
    pub lat: f64,
    pub lon: f64,
}

/// A sample: a place and an instant with a tier (positive or a negative tier).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub lat: f64,
    pub lon: f64,
    pub time_ms: i64,
    pub tier: Tier,
    /// Source row of a positive; for near/yearly negatives, the row of the positive they
    /// were derived from.
    pub source_row: Option<u64>,
}

/// The authors' sequential de-duplication rule and the region filters.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct IgnitionRules {
    /// Keep a report only if it is at least this far from the last kept one …
    #[serde(default = "default_min_distance_km")]
    pub min_distance_km: f64,
    /// … and at least this many hours after it.
    #[serde(default = "default_min_gap_hours")]
    pub min_gap_hours: f64,
    /// Reports outside this box (inclusive) are dropped. Default: the authors' CONUS box.
    #[serde(default)]
    pub region: GeoBox,
    /// Drop reports whose GRIDMET cell has no data (ocean, Canada, Mexico).
    #[serde(default = "yes")]
    pub land_mask: bool,
}

fn default_min_distance_km() -> f64 {
    5.0
}
fn default_min_gap_hours() -> f64 {
    2.0
}
fn yes() -> bool {
    true
}

impl Default for IgnitionRules {
    fn default() -> Self {
        Self {
            min_distance_km: default_min_distance_km(),
            min_gap_hours: default_min_gap_hours(),
            region: GeoBox::default(),
            land_mask: true,
        }
    }
}

/// Counts per rule: every report is counted exactly once.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct IgnitionCounts {
    pub reports: u64,
    pub outside_region: u64,
    pub off_land: u64,
    /// Less than `min_gap_hours` after the last kept report.
    pub within_gap_hours: u64,
    /// Far enough in time but closer than `min_distance_km` to the last kept report.
    pub within_distance_km: u64,
    pub kept: u64,
}

/// Result of [`dedup_ignitions`].
#[derive(Debug, Clone)]
pub struct Ignitions {
    /// Kept reports in time order.
    pub positives: Vec<Sample>,
    pub counts: IgnitionCounts,
    /// `(row, reason)` of every dropped report.
    pub dropped: Vec<(u64, &'static str)>,
}

/// The authors' rule (docs/spec/data.md §4.1): sort by time (stably, then by row), walk the reports and
/// keep one only if it is in the region, on land, and — against the *last kept* report —
/// both at least `min_distance_km` away and `min_gap_hours` later.
pub fn dedup_ignitions(
    reports: &[IncidentPoint],
    rules: &IgnitionRules,
    mask: Option<&LandMask>,
) -> Ignitions {
    let mut order: Vec<&IncidentPoint> = reports.iter().collect();
    order.sort_by_key(|r| (r.time_ms, r.row));
    let gap_ms = (rules.min_gap_hours * 3_600_000.0).round() as i64;
    let mut counts = IgnitionCounts {
        reports: reports.len() as u64,
        ..Default::default()
    };
    let mut positives = Vec::new();
    let mut dropped = Vec::new();
    let mut last: Option<&IncidentPoint> = None;
    for r in order {
        let reason = if !rules.region.contains(r.lat, r.lon) {
            counts.outside_region += 1;
            Some("outside_region")
        } else if rules.land_mask && mask.is_some_and(|m| !m.on_land(r.lat, r.lon)) {
            counts.off_land += 1;
            Some("off_land")
        } else if let Some(prev) = last {
            if r.time_ms - prev.time_ms < gap_ms {
                counts.within_gap_hours += 1;
                Some("within_gap_hours")
            } else if haversine_km(prev.lat, prev.lon, r.lat, r.lon) < rules.min_distance_km {
                counts.within_distance_km += 1;
                Some("within_distance_km")
            } else {
                None
            }
        } else {
            None
        };
        match reason {
            Some(reason) => dropped.push((r.row, reason)),
            None => {
                counts.kept += 1;
                positives.push(Sample {
                    lat: r.lat,
                    lon: r.lon,
                    time_ms: r.time_ms,
                    tier: Tier::Positive,
                    source_row: Some(r.row),
                });
                last = Some(r);
            }
        }
    }
    Ignitions {
        positives,
        counts,
        dropped,
    }
}

/// Which description of the negative sampling to follow.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// The paper's text (the default).
    #[default]
    Paper,
    /// The authors' code, docs/spec/data.md §4.
    Code,
}

/// How the paper variant sizes its tiers when no explicit count is given.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TierCounts {
    /// 5,000 far, 35,000 near, 36,000 yearly, as the paper states.
    Paper,
    /// Scaled by positives / 50,720 so the paper's 50,720 : 76,080 ratio holds.
    #[default]
    Proportional,
}

/// Negative sampling settings. Every field has the variant's default.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NegativeConfig {
    #[serde(default)]
    pub variant: Variant,
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// First day a negative may fall on (`YYYY-MM-DD`). The authors used 2014-03-01.
    #[serde(default = "default_period_start")]
    pub period_start: String,
    /// Last day (inclusive). The authors used 2025-03-31.
    #[serde(default = "default_period_end")]
    pub period_end: String,
    /// Paper variant: how tiers are sized unless counted explicitly.
    #[serde(default)]
    pub counts: TierCounts,
    pub far_count: Option<u64>,
    pub near_count: Option<u64>,
    pub yearly_count: Option<u64>,
    /// Far negatives are at least this far from every positive.
    #[serde(default = "default_100")]
    pub far_min_km: f64,
    /// Near negatives are placed 0.1 … this many km from a positive.
    #[serde(default = "default_100")]
    pub near_max_km: f64,
    /// Near-negative day offset range (inclusive). Default 90–150 (paper) or 90–120 (code).
    pub near_offset_days: Option<(u32, u32)>,
    /// Within a tier, a sample closer than this (km) …
    #[serde(default = "default_dedup_km")]
    pub dedup_km: f64,
    /// … and fewer than this many whole days apart from an accepted one is rejected.
    #[serde(default = "default_dedup_days")]
    pub dedup_days: u32,
    /// Code variant: leave the origin positive out of the near-negative fire check. The
    /// authors' code includes it, which rejects nearly every candidate (docs/spec/data.md §4.3).
    #[serde(default = "yes")]
    pub exclude_origin: bool,
    #[serde(default)]
    pub region: GeoBox,
    #[serde(default = "yes")]
    pub land_mask: bool,
    /// Give up on a tier after this many candidates per requested sample.
    #[serde(default = "default_attempts")]
    pub max_attempts_per_sample: u64,
    /// Draw every split's negatives from its own period and area (paper variant only): see
    /// [`Strata`]. Absent: the authors' sampling, where near and yearly negatives fall wherever
    /// their positive's offset puts them, so late periods get few negatives.
    #[serde(default)]
    pub strata: Option<Strata>,
}

/// The periods and areas the experiments will split by. Each positive belongs to one stratum
/// (its period between consecutive `cuts`, and its block of `block_degrees` when given); its
/// near and yearly negatives must fall in the same stratum, far negatives are drawn inside each
/// stratum, and each stratum gets the tiers' counts in proportion to its positives, so every
/// split made of whole strata has the prevalence of the design. A tier that cannot fill its
/// share in a stratum (no earlier year inside a short test period, say) leaves the rest to
/// near negatives, then to far ones; the report says how many moved.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Strata {
    /// First days of later periods (`YYYY-MM-DD`, increasing), e.g. a temporal protocol's
    /// `test_from`.
    #[serde(default)]
    pub cuts: Vec<String>,
    /// Blocks of this many degrees, counted from 0° as the spatial-blocks split counts them.
    #[serde(default)]
    pub block_degrees: Option<f64>,
}

/// One stratum's positives and negatives, by tier.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StratumReport {
    /// First and last day of the stratum's period.
    pub first_day: String,
    pub last_day: String,
    /// Its block (south-west corner, degrees), when blocks are asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<(i64, i64)>,
    pub positives: u64,
    /// Negatives wanted: the tiers' totals in proportion to the stratum's positives.
    pub requested: u64,
    pub far: u64,
    pub near: u64,
    pub yearly: u64,
    /// Of those, drawn by another tier than the one they were requested of.
    pub moved_to_near: u64,
    pub moved_to_far: u64,
}

fn default_seed() -> u64 {
    42
}
fn default_period_start() -> String {
    "2014-03-01".into()
}
fn default_period_end() -> String {
    "2025-03-31".into()
}
fn default_100() -> f64 {
    100.0
}
fn default_dedup_km() -> f64 {
    5.0
}
fn default_dedup_days() -> u32 {
    120
}
fn default_attempts() -> u64 {
    200
}

impl Default for NegativeConfig {
    fn default() -> Self {
        serde_json::from_value(serde_json::json!({})).unwrap_or_else(|_| unreachable!("all fields default"))
    }
}

/// What one tier asked for and got.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TierReport {
    /// Requested count (`None` for the code variant's per-positive tiers).
    pub requested: Option<u64>,
    pub accepted: u64,
    pub candidates: u64,
    /// Rejected candidates by reason.
    pub rejected: BTreeMap<String, u64>,
    /// Exact duplicates (same place and instant) removed after sampling.
    pub duplicates_removed: u64,
}

/// Result of [`sample_negatives`].
#[derive(Debug, Clone)]
pub struct Negatives {
    /// Negatives then positives, shuffled with the seed.
    pub samples: Vec<Sample>,
    pub far: TierReport,
    pub near: TierReport,
    pub yearly: TierReport,
    /// Per stratum, when [`NegativeConfig::strata`] is given.
    pub strata: Vec<StratumReport>,
}

/// The paper's tier sizes and positive count.
pub const PAPER_COUNTS: (u64, u64, u64) = (5_000, 35_000, 36_000);
/// Positives in the paper.
pub const PAPER_POSITIVES: u64 = 50_720;

struct Ctx<'a> {
    cfg: &'a NegativeConfig,
    mask: Option<&'a LandMask>,
    /// Every positive (the fire checks look at all of them).
    positives: &'a [Sample],
    pos_index: &'a PointIndex,
    /// The positives near and yearly negatives are drawn around (a stratum's, or all).
    origins: &'a [Sample],
    start_ms: i64,
    end_ms: i64,
    /// The stratum's block, `[lat_min, lat_max) × [lon_min, lon_max)`, when blocks are asked for.
    block: Option<[f64; 4]>,
}

impl Ctx<'_> {
    fn placeable(&self, lat: f64, lon: f64) -> Option<&'static str> {
        if !self.cfg.region.contains(lat, lon) {
            Some("outside_region")
        } else if self
            .block
            .is_some_and(|[a, b, c, d]| !(a..b).contains(&lat) || !(c..d).contains(&lon))
        {
            Some("outside_stratum")
        } else if self.cfg.land_mask && self.mask.is_some_and(|m| !m.on_land(lat, lon)) {
            Some("off_land")
        } else {
            None
        }
    }

    /// Is there a positive within `km` whose time differs from `t` by fewer than `days`
    /// whole days (skipping `skip`)?
    fn fire_near(&self, lat: f64, lon: f64, km: f64, t: i64, days: u32, skip: Option<u32>) -> bool {
        self.pos_index.any_within(lat, lon, km, |id, _| {
            Some(id) != skip && whole_days(self.positives[id as usize].time_ms - t) < i64::from(days)
        })
    }
}

/// Accepted samples of one tier, with the 5 km / 120 day de-duplication.
struct TierSet {
    tier: Tier,
    index: PointIndex,
    times: Vec<i64>,
    samples: Vec<Sample>,
}

impl TierSet {
    fn new(tier: Tier) -> Self {
        Self {
            tier,
            index: PointIndex::new(),
            times: Vec::new(),
            samples: Vec::new(),
        }
    }

    fn clashes(&self, lat: f64, lon: f64, t: i64, cfg: &NegativeConfig) -> bool {
        self.index.any_within(lat, lon, cfg.dedup_km, |id, _| {
            whole_days(self.times[id as usize] - t) < i64::from(cfg.dedup_days)
        })
    }

    /// Accepts a sample at `time_ms`; `dedup_time` is the instant later candidates are
    /// compared with (the code variant compares near negatives by their origin's time).
    fn accept(&mut self, lat: f64, lon: f64, time_ms: i64, source_row: Option<u64>, dedup_time: i64) {
        self.index.insert(lat, lon);
        self.times.push(dedup_time);
        self.samples.push(Sample {
            lat,
            lon,
            time_ms,
            tier: self.tier,
            source_row,
        });
    }
}

fn whole_days(delta_ms: i64) -> i64 {
    delta_ms.abs() / DAY_MS
}

fn bump(map: &mut BTreeMap<String, u64>, reason: &str) {
    *map.entry(reason.to_string()).or_default() += 1;
}

/// Draws the three negative tiers around `positives` (which must be in time order, as
/// [`dedup_ignitions`] returns them) and returns them with the positives, shuffled.
pub fn sample_negatives(
    positives: &[Sample],
    cfg: &NegativeConfig,
    mask: Option<&LandMask>,
) -> Result<Negatives, DatasetError> {
    let bad = |key: &str, message: String| DatasetError::Config {
        key: key.to_string(),
        message,
    };
    let start_day = time::parse_date(&cfg.period_start).ok_or_else(|| {
        bad(
            "period_start",
            format!("`{}` is not a YYYY-MM-DD date", cfg.period_start),
        )
    })?;
    let end_day = time::parse_date(&cfg.period_end).ok_or_else(|| {
        bad(
            "period_end",
            format!("`{}` is not a YYYY-MM-DD date", cfg.period_end),
        )
    })?;
    if end_day < start_day {
        return Err(bad("period_end", "is before period_start".into()));
    }
    let offsets = cfg.near_offset_days.unwrap_or(match cfg.variant {
        Variant::Paper => (90, 150),
        Variant::Code => (90, 120),
    });
    if offsets.0 > offsets.1 {
        return Err(bad(
            "near_offset_days",
            "the first bound exceeds the second".into(),
        ));
    }
    let mut pos_index = PointIndex::new();
    for p in positives {
        pos_index.insert(p.lat, p.lon);
    }
    let ctx = Ctx {
        cfg,
        mask,
        positives,
        pos_index: &pos_index,
        origins: positives,
        start_ms: time::day_start_ms(start_day),
        end_ms: time::day_start_ms(end_day + 1) - 1,
        block: None,
    };
    let p = positives.len() as u64;
    let scaled = |paper: u64| match cfg.counts {
        TierCounts::Paper => paper,
        TierCounts::Proportional => ((paper as f64) * (p as f64) / (PAPER_POSITIVES as f64)).round() as u64,
    };
    let rng_for = |stream: u64| {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(stream);
        rng
    };

    let far_target = cfg.far_count.unwrap_or(match cfg.variant {
        Variant::Paper => scaled(PAPER_COUNTS.0),
        Variant::Code => PAPER_COUNTS.0,
    });
    let near_target = cfg.near_count.unwrap_or(scaled(PAPER_COUNTS.1));
    let yearly_target = cfg.yearly_count.unwrap_or(scaled(PAPER_COUNTS.2));
    let mut strata_reports = Vec::new();
    let (far, near, yearly, mut far_report, mut near_report, mut yearly_report) = if let Some(strata) =
        &cfg.strata
    {
        if cfg.variant != Variant::Paper {
            return Err(bad(
                "strata",
                "needs `variant: paper` (the authors' code draws per positive, without counts to share out)"
                    .into(),
            ));
        }
        let drawn = sample_stratified(
            &ctx,
            strata,
            [far_target, near_target, yearly_target],
            offsets,
            &rng_for,
        )?;
        strata_reports = drawn.strata;
        (
            drawn.sets[0].samples.clone(),
            drawn.sets[1].samples.clone(),
            drawn.sets[2].samples.clone(),
            drawn.reports[0].clone(),
            drawn.reports[1].clone(),
            drawn.reports[2].clone(),
        )
    } else {
        let mut sets = [
            TierSet::new(Tier::Far),
            TierSet::new(Tier::Near),
            TierSet::new(Tier::Yearly),
        ];
        let far_report = sample_far(&ctx, far_target, &mut rng_for(1), &mut sets[0]);
        let near_report = match cfg.variant {
            Variant::Paper => sample_near_paper(&ctx, near_target, offsets, &mut rng_for(2), &mut sets[1]),
            Variant::Code => {
                let (near, report) = sample_near_code(&ctx, offsets, &mut rng_for(2));
                sets[1].samples = near;
                report
            }
        };
        let yearly_report = match cfg.variant {
            Variant::Paper => sample_yearly_paper(&ctx, yearly_target, &mut rng_for(3), &mut sets[2]),
            Variant::Code => {
                let (yearly, report) = sample_yearly_code(&ctx);
                sets[2].samples = yearly;
                report
            }
        };
        let [f, n, y] = sets;
        (
            f.samples,
            n.samples,
            y.samples,
            far_report,
            near_report,
            yearly_report,
        )
    };

    // Exact duplicates are dropped within each tier only (docs/spec/data.md §4.5).
    let mut samples = Vec::new();
    for (tier, report) in [
        (far, &mut far_report),
        (near, &mut near_report),
        (yearly, &mut yearly_report),
    ] {
        let mut seen = HashSet::new();
        for s in tier {
            if seen.insert((s.lat.to_bits(), s.lon.to_bits(), s.time_ms)) {
                samples.push(s);
            } else {
                report.duplicates_removed += 1;
                report.accepted -= 1;
            }
        }
    }
    samples.extend_from_slice(positives);
    crate::shuffle(&mut samples, &mut rng_for(4));
    Ok(Negatives {
        samples,
        far: far_report,
        near: near_report,
        yearly: yearly_report,
        strata: strata_reports,
    })
}

/// What [`sample_stratified`] drew: the tiers' sets and reports (far, near, yearly) and one
/// report per stratum.
struct StratifiedDraw {
    sets: [TierSet; 3],
    reports: [TierReport; 3],
    strata: Vec<StratumReport>,
}

/// Adds `from`'s counts to `into` (requested, accepted, candidates, rejections).
fn merge(into: &mut TierReport, from: &TierReport) {
    into.requested = Some(into.requested.unwrap_or(0) + from.requested.unwrap_or(0));
    into.accepted += from.accepted;
    into.candidates += from.candidates;
    for (k, v) in &from.rejected {
        *into.rejected.entry(k.clone()).or_default() += v;
    }
}

/// The tiers drawn stratum by stratum (see [`Strata`]): each stratum's share of each tier's
/// count in proportion to its positives, near and yearly negatives around its own positives
/// inside its period and block, far negatives inside them; a tier's shortfall goes to near
/// negatives, then to far ones. The tiers' de-duplication spans all strata.
fn sample_stratified(
    ctx: &Ctx<'_>,
    strata: &Strata,
    targets: [u64; 3],
    offsets: (u32, u32),
    rng_for: &dyn Fn(u64) -> ChaCha8Rng,
) -> Result<StratifiedDraw, DatasetError> {
    let mut cuts = Vec::with_capacity(strata.cuts.len());
    for (i, c) in strata.cuts.iter().enumerate() {
        let key = format!("strata.cuts[{i}]");
        let day = time::parse_date(c).ok_or_else(|| DatasetError::Config {
            key: key.clone(),
            message: format!("`{c}` is not a YYYY-MM-DD date"),
        })?;
        // GRIDMET's day starts at 07:00 UTC: the splits cut event days, so the cut falls there.
        let ms = time::day_start_ms(day) + 7 * 3_600_000;
        if ms <= ctx.start_ms || ms > ctx.end_ms || cuts.last().is_some_and(|&prev| ms <= prev) {
            return Err(DatasetError::Config {
                key,
                message: format!(
                    "`{c}` must fall after period_start, by period_end, and after the cut before it"
                ),
            });
        }
        cuts.push(ms);
    }
    if let Some(bd) = strata.block_degrees
        && !(bd > 0.0 && bd.is_finite())
    {
        return Err(DatasetError::Config {
            key: "strata.block_degrees".into(),
            message: format!("{bd} is not a positive number of degrees"),
        });
    }
    let block_of = |lat: f64, lon: f64| {
        strata
            .block_degrees
            .map(|bd| ((lat / bd).floor() as i64, (lon / bd).floor() as i64))
    };
    // A stratum: its period's index and its block (south-west corner in block units).
    type Stratum = (usize, Option<(i64, i64)>);
    let mut groups: BTreeMap<Stratum, Vec<Sample>> = BTreeMap::new();
    for p in ctx.positives {
        let period = cuts.partition_point(|&c| c <= p.time_ms);
        groups
            .entry((period, block_of(p.lat, p.lon)))
            .or_default()
            .push(*p);
    }
    let total = ctx.positives.len().max(1) as f64;
    let mut sets = [
        TierSet::new(Tier::Far),
        TierSet::new(Tier::Near),
        TierSet::new(Tier::Yearly),
    ];
    let mut reports: [TierReport; 3] = Default::default();
    let mut out = Vec::new();
    for (k, ((period, block), origins)) in groups.iter().enumerate() {
        let start_ms = if *period == 0 {
            ctx.start_ms
        } else {
            cuts[period - 1]
        };
        let end_ms = cuts.get(*period).map_or(ctx.end_ms, |&c| c - 1);
        let sub = Ctx {
            cfg: ctx.cfg,
            mask: ctx.mask,
            positives: ctx.positives,
            pos_index: ctx.pos_index,
            origins,
            start_ms,
            end_ms,
            block: block.zip(strata.block_degrees).map(|((i, j), bd)| {
                [
                    i as f64 * bd,
                    (i + 1) as f64 * bd,
                    j as f64 * bd,
                    (j + 1) as f64 * bd,
                ]
            }),
        };
        let share = origins.len() as f64 / total;
        let want = targets.map(|t| (t as f64 * share).round() as u64);
        let stream = |tier: u64| rng_for(100 + 8 * k as u64 + tier);
        let len = |sets: &[TierSet; 3], i: usize| sets[i].samples.len() as u64;
        let r = sample_far(&sub, len(&sets, 0) + want[0], &mut stream(0), &mut sets[0]);
        let mut got = [r.accepted, 0, 0];
        merge(&mut reports[0], &r);
        let r = sample_near_paper(
            &sub,
            len(&sets, 1) + want[1],
            offsets,
            &mut stream(1),
            &mut sets[1],
        );
        got[1] = r.accepted;
        merge(&mut reports[1], &r);
        let r = sample_yearly_paper(&sub, len(&sets, 2) + want[2], &mut stream(2), &mut sets[2]);
        got[2] = r.accepted;
        merge(&mut reports[2], &r);
        // What a tier could not give here, near negatives then far ones make up.
        let requested: u64 = want.iter().sum();
        let short = |got: &[u64; 3]| requested.saturating_sub(got.iter().sum());
        let mut moved = [0u64; 2];
        if short(&got) > 0 {
            let r = sample_near_paper(
                &sub,
                len(&sets, 1) + short(&got),
                offsets,
                &mut stream(3),
                &mut sets[1],
            );
            moved[0] = r.accepted;
            got[1] += r.accepted;
            merge(&mut reports[1], &r);
        }
        if short(&got) > 0 {
            let r = sample_far(&sub, len(&sets, 0) + short(&got), &mut stream(4), &mut sets[0]);
            moved[1] = r.accepted;
            got[0] += r.accepted;
            merge(&mut reports[0], &r);
        }
        let day = |ms: i64| time::format_date(time::gridmet_day(ms, time::DayBoundary::Mst));
        out.push(StratumReport {
            first_day: day(start_ms),
            last_day: day(end_ms),
            block: block
                .zip(strata.block_degrees)
                .map(|((i, j), bd)| ((i as f64 * bd) as i64, (j as f64 * bd) as i64)),
            positives: origins.len() as u64,
            requested,
            far: got[0],
            near: got[1],
            yearly: got[2],
            moved_to_near: moved[0],
            moved_to_far: moved[1],
        });
    }
    Ok(StratifiedDraw {
        sets,
        reports,
        strata: out,
    })
}

/// Adds far negatives to `set` until it holds `target` (or the attempts run out).
fn sample_far(ctx: &Ctx<'_>, target: u64, rng: &mut ChaCha8Rng, set: &mut TierSet) -> TierReport {
    let cfg = ctx.cfg;
    let mut report = TierReport {
        requested: Some(target.saturating_sub(set.samples.len() as u64)),
        ..Default::default()
    };
    let before = set.samples.len();
    let max = report
        .requested
        .unwrap_or(0)
        .saturating_mul(cfg.max_attempts_per_sample);
    // Uniform in degrees over the box (or the stratum's block in it), as the authors drew them.
    let (mut lat0, mut lat1, mut lon0, mut lon1) = (
        cfg.region.lat_min,
        cfg.region.lat_max,
        cfg.region.lon_min,
        cfg.region.lon_max,
    );
    if let Some([a, b, c, d]) = ctx.block {
        (lat0, lat1, lon0, lon1) = (lat0.max(a), lat1.min(b), lon0.max(c), lon1.min(d));
    }
    if lat0 > lat1 || lon0 > lon1 {
        return report;
    }
    while (set.samples.len() as u64) < target && report.candidates < max {
        report.candidates += 1;
        let lat = rng.random_range(lat0..=lat1);
        let lon = rng.random_range(lon0..=lon1);
        let t = rng.random_range(ctx.start_ms..=ctx.end_ms);
        if let Some(reason) = ctx.placeable(lat, lon) {
            bump(&mut report.rejected, reason);
        } else if ctx.pos_index.any_within(lat, lon, cfg.far_min_km, |_, _| true) {
            bump(&mut report.rejected, "near_a_positive");
        } else if set.clashes(lat, lon, t, cfg) {
            bump(&mut report.rejected, "duplicate_within_tier");
        } else {
            set.accept(lat, lon, t, None, t);
        }
    }
    report.accepted = (set.samples.len() - before) as u64;
    report
}

fn random_offset_place(ctx: &Ctx<'_>, origin: &Sample, rng: &mut ChaCha8Rng) -> (f64, f64) {
    // Distance uniform in km (not in area), as the authors drew it.
    let d = rng.random_range(0.1..=ctx.cfg.near_max_km.max(0.1));
    let bearing = rng.random_range(0.0..360.0);
    geodesic_destination(origin.lat, origin.lon, bearing, d)
}

fn signed_offset_ms(offsets: (u32, u32), rng: &mut ChaCha8Rng) -> i64 {
    let days = i64::from(rng.random_range(offsets.0..=offsets.1));
    let sign = if rng.random_bool(0.5) { 1 } else { -1 };
    sign * days * DAY_MS
}

/// Adds near negatives to `set` until it holds `target` (or the attempts run out).
fn sample_near_paper(
    ctx: &Ctx<'_>,
    target: u64,
    offsets: (u32, u32),
    rng: &mut ChaCha8Rng,
    set: &mut TierSet,
) -> TierReport {
    let cfg = ctx.cfg;
    let mut report = TierReport {
        requested: Some(target.saturating_sub(set.samples.len() as u64)),
        ..Default::default()
    };
    let before = set.samples.len();
    let max = report
        .requested
        .unwrap_or(0)
        .saturating_mul(cfg.max_attempts_per_sample);
    while !ctx.origins.is_empty() && (set.samples.len() as u64) < target && report.candidates < max {
        report.candidates += 1;
        let origin = &ctx.origins[rng.random_range(0..ctx.origins.len())];
        let (lat, lon) = random_offset_place(ctx, origin, rng);
        let t = origin.time_ms + signed_offset_ms(offsets, rng);
        if let Some(reason) = ctx.placeable(lat, lon) {
            bump(&mut report.rejected, reason);
        } else if !(ctx.start_ms..=ctx.end_ms).contains(&t) {
            bump(&mut report.rejected, "outside_period");
        } else if ctx.fire_near(lat, lon, cfg.near_max_km, t, offsets.0, None) {
            // No fire recorded within the radius in the days around the negative itself.
            bump(&mut report.rejected, "fire_nearby");
        } else if set.clashes(lat, lon, t, cfg) {
            bump(&mut report.rejected, "duplicate_within_tier");
        } else {
            set.accept(lat, lon, t, origin.source_row, t);
        }
    }
    report.accepted = (set.samples.len() - before) as u64;
    report
}

fn sample_near_code(ctx: &Ctx<'_>, offsets: (u32, u32), rng: &mut ChaCha8Rng) -> (Vec<Sample>, TierReport) {
    let cfg = ctx.cfg;
    let mut report = TierReport::default();
    let mut set = TierSet::new(Tier::Near);
    for (k, origin) in ctx.positives.iter().enumerate() {
        report.candidates += 1;
        let (lat, lon) = random_offset_place(ctx, origin, rng);
        let skip = cfg.exclude_origin.then_some(k as u32);
        if let Some(reason) = ctx.placeable(lat, lon) {
            bump(&mut report.rejected, reason);
            continue;
        }
        // The authors compare against the origin's time ts0, not the shifted time.
        if ctx.fire_near(lat, lon, cfg.near_max_km, origin.time_ms, offsets.0, skip) {
            bump(&mut report.rejected, "fire_nearby");
            continue;
        }
        if set.clashes(lat, lon, origin.time_ms, cfg) {
            bump(&mut report.rejected, "duplicate_within_tier");
            continue;
        }
        let t = origin.time_ms + signed_offset_ms(offsets, rng);
        if !(ctx.start_ms..=ctx.end_ms).contains(&t) {
            bump(&mut report.rejected, "outside_period");
            continue;
        }
        set.accept(lat, lon, t, origin.source_row, origin.time_ms);
    }
    report.accepted = set.samples.len() as u64;
    (set.samples, report)
}

const YEAR_MS: i64 = 365 * DAY_MS;

/// Adds yearly negatives to `set` until it holds `target` (or no origin has a year left).
fn sample_yearly_paper(ctx: &Ctx<'_>, target: u64, rng: &mut ChaCha8Rng, set: &mut TierSet) -> TierReport {
    let cfg = ctx.cfg;
    let mut report = TierReport {
        requested: Some(target.saturating_sub(set.samples.len() as u64)),
        ..Default::default()
    };
    let before = set.samples.len();
    let mut order: Vec<usize> = (0..ctx.origins.len()).collect();
    crate::shuffle(&mut order, rng);
    // One year back first for every positive, then two years, and so on, until the count
    // is reached or no positive has an earlier year left in the period.
    let mut years_back = 1;
    while (set.samples.len() as u64) < target {
        let mut any_in_period = false;
        for &k in &order {
            if set.samples.len() as u64 >= target {
                break;
            }
            let origin = &ctx.origins[k];
            let t = origin.time_ms - years_back * YEAR_MS;
            if t < ctx.start_ms {
                continue;
            }
            any_in_period = true;
            report.candidates += 1;
            if ctx.fire_near(origin.lat, origin.lon, cfg.dedup_km, t, cfg.dedup_days, None) {
                bump(&mut report.rejected, "fire_recorded");
            } else if set.clashes(origin.lat, origin.lon, t, cfg) {
                bump(&mut report.rejected, "duplicate_within_tier");
            } else {
                set.accept(origin.lat, origin.lon, t, origin.source_row, t);
            }
        }
        if !any_in_period {
            break;
        }
        years_back += 1;
    }
    report.accepted = (set.samples.len() - before) as u64;
    report
}

fn sample_yearly_code(ctx: &Ctx<'_>) -> (Vec<Sample>, TierReport) {
    let cfg = ctx.cfg;
    let mut report = TierReport::default();
    let mut set = TierSet::new(Tier::Yearly);
    let triples: HashSet<(u64, u64, i64)> = ctx
        .positives
        .iter()
        .map(|p| (p.lat.to_bits(), p.lon.to_bits(), p.time_ms))
        .collect();
    for origin in ctx.positives {
        let n = (origin.time_ms - ctx.start_ms).div_euclid(DAY_MS) / 365;
        for yr in 1..=n {
            report.candidates += 1;
            let t = origin.time_ms - yr * YEAR_MS;
            if triples.contains(&(origin.lat.to_bits(), origin.lon.to_bits(), t)) {
                bump(&mut report.rejected, "exact_positive");
            } else if set.clashes(origin.lat, origin.lon, t, cfg) {
                bump(&mut report.rejected, "duplicate_within_tier");
            } else {
                set.accept(origin.lat, origin.lon, t, origin.source_row, t);
            }
        }
    }
    report.accepted = set.samples.len() as u64;
    (set.samples, report)
}
