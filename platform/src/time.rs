//! Readable UTC times for the pages, and ISO 8601 UTC times for the exports.

/// `YYYY-MM-DD HH:00 UTC` of a Unix-ms time (civil-from-days, proleptic Gregorian).
pub(crate) fn utc_hour(ms: i64) -> String {
    let (year, month, day, secs) = utc_civil(ms);
    format!("{year:04}-{month:02}-{day:02} {:02}:00 UTC", secs / 3600)
}

/// `YYYY-MM-DD HH:MM UTC` of a Unix-ms time.
pub(crate) fn utc_minute(ms: i64) -> String {
    let (year, month, day, secs) = utc_civil(ms);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        secs / 3600,
        secs % 3600 / 60
    )
}

/// `YYYY-MM-DDTHH:MM:SS.sssZ` (ISO 8601, UTC) of a Unix-ms time, for machine-readable files.
pub(crate) fn iso8601(ms: i64) -> String {
    let (year, month, day, secs) = utc_civil(ms);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        secs / 3600,
        secs % 3600 / 60,
        secs % 60,
        ms.rem_euclid(1000)
    )
}

/// (year, month, day, seconds into the day) of a Unix-ms time.
fn utc_civil(ms: i64) -> (i64, i64, i64, i64) {
    let secs = ms.div_euclid(1000);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day, rem)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_hours() {
        assert_eq!(utc_hour(0), "1970-01-01 00:00 UTC");
        // 2026-11-22 03:00:00 UTC.
        assert_eq!(utc_hour(1_795_316_400_000), "2026-11-22 03:00 UTC");
        assert_eq!(utc_hour(951_782_400_000), "2000-02-29 00:00 UTC");
        // 2026-11-22 03:07:59 UTC.
        assert_eq!(utc_minute(1_795_316_879_000), "2026-11-22 03:07 UTC");
        assert_eq!(iso8601(1_795_316_879_042), "2026-11-22T03:07:59.042Z");
        assert_eq!(iso8601(0), "1970-01-01T00:00:00.000Z");
    }
}
