//! Instants (epoch milliseconds, UTC) and GRIDMET days (days since 1900-01-01).

use firecast_data::gridmet::{day_to_ymd, ymd_to_day};
use serde::{Deserialize, Serialize};

use crate::geo::DAY_MS;

/// Days from 1900-01-01 to 1970-01-01.
const DAYS_1900_TO_1970: i64 = 25_567;

/// Which calendar day an instant belongs to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DayBoundary {
    /// GRIDMET's day: midnight to midnight Mountain Standard Time (07:00 UTC), so a fire
    /// discovered at 03:00 UTC gets the weather of the day it was still evening in the US.
    #[default]
    Mst,
    /// Truncate the UTC timestamp, as the authors' builder did.
    Utc,
}

/// The GRIDMET day (days since 1900-01-01) an instant falls in.
pub fn gridmet_day(time_ms: i64, boundary: DayBoundary) -> i32 {
    let shifted = match boundary {
        DayBoundary::Mst => time_ms - 7 * 3_600_000,
        DayBoundary::Utc => time_ms,
    };
    (shifted.div_euclid(DAY_MS) + DAYS_1900_TO_1970) as i32
}

/// Epoch milliseconds of 00:00 UTC on a GRIDMET day.
pub fn day_start_ms(day: i32) -> i64 {
    (i64::from(day) - DAYS_1900_TO_1970) * DAY_MS
}

/// Days since 1970-01-01 (Arrow's `Date32`) of a GRIDMET day.
pub fn date32(day: i32) -> i32 {
    (i64::from(day) - DAYS_1900_TO_1970) as i32
}

/// GRIDMET day of an Arrow `Date32` value.
pub fn from_date32(date32: i32) -> i32 {
    (i64::from(date32) + DAYS_1900_TO_1970) as i32
}

/// Parses `YYYY-MM-DD` into a GRIDMET day.
pub fn parse_date(s: &str) -> Option<i32> {
    let mut parts = s.trim().splitn(3, '-');
    let y = parts.next()?.parse().ok()?;
    let m = parts.next()?.parse().ok()?;
    let d = parts.next()?.parse().ok()?;
    ymd_to_day(y, m, d)
}

/// Formats a GRIDMET day as `YYYY-MM-DD`.
pub fn format_date(day: i32) -> String {
    let (y, m, d) = day_to_ymd(day);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Formats an instant as ISO 8601 UTC with a `Z`.
pub fn format_instant(time_ms: i64) -> String {
    let day = gridmet_day(time_ms, DayBoundary::Utc);
    let ms = time_ms - day_start_ms(day);
    let s = ms / 1000;
    format!(
        "{}T{:02}:{:02}:{:02}Z",
        format_date(day),
        s / 3600,
        (s / 60) % 60,
        s % 60
    )
}

/// The calendar year of a GRIDMET day.
pub fn year_of(day: i32) -> i32 {
    day_to_ymd(day).0
}

/// The month (1–12) of a GRIDMET day.
pub fn month_of(day: i32) -> u32 {
    day_to_ymd(day).1
}
