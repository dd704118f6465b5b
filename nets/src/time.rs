//! Time: an integer count of microseconds, and durations as written in nets
//! (`30s`, `500ms`, `1.5s`, `2min`, `1h`).

/// Microseconds. The player never reads a clock: every instant is an input.
pub type Micros = u64;

/// Microseconds in one second.
pub const SECOND: Micros = 1_000_000;

/// Why a duration could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DurationError {
    #[error("malformed duration `{0}`: expected a number and a unit, as in `30s`, `500ms`, `1.5s`, `2min` or `1h`")]
    Malformed(String),
    #[error("duration `{0}` is out of range")]
    OutOfRange(String),
}

/// Parses a duration: a non-negative decimal number followed by one of the
/// units `us`, `ms`, `s`, `min`, `h` (spaces between them allowed). The result
/// is rounded to the nearest microsecond.
pub fn parse_duration(text: &str) -> Result<Micros, DurationError> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .ok_or_else(|| DurationError::Malformed(text.to_owned()))?;
    let (number, unit) = t.split_at(split);
    let unit = unit.trim_start();
    let scale: f64 = match unit {
        "us" | "µs" => 1.0,
        "ms" => 1e3,
        "s" => 1e6,
        "min" | "m" => 60e6,
        "h" => 3600e6,
        _ => return Err(DurationError::Malformed(text.to_owned())),
    };
    if number.is_empty()
        || number.starts_with('.')
        || number.ends_with('.')
        || number.matches('.').count() > 1
    {
        return Err(DurationError::Malformed(text.to_owned()));
    }
    let value: f64 = number
        .parse()
        .map_err(|_| DurationError::Malformed(text.to_owned()))?;
    let micros = (value * scale).round();
    if !micros.is_finite() || micros > 1e15 {
        return Err(DurationError::OutOfRange(text.to_owned()));
    }
    Ok(micros as Micros)
}

/// Formats microseconds as seconds with up to six decimals (`12.5`).
pub fn seconds(t: Micros) -> f64 {
    t as f64 / 1e6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations() {
        assert_eq!(parse_duration("30s"), Ok(30_000_000));
        assert_eq!(parse_duration("500ms"), Ok(500_000));
        assert_eq!(parse_duration("1.5s"), Ok(1_500_000));
        assert_eq!(parse_duration("2min"), Ok(120_000_000));
        assert_eq!(parse_duration("2 m"), Ok(120_000_000));
        assert_eq!(parse_duration("1h"), Ok(3_600_000_000));
        assert_eq!(parse_duration("250us"), Ok(250));
        assert_eq!(parse_duration("0s"), Ok(0));
        for bad in [
            "",
            "s",
            "10",
            "10 parsecs",
            "-1s",
            ".5s",
            "1.s",
            "1..2s",
            "1e3s",
            "ten s",
        ] {
            assert!(parse_duration(bad).is_err(), "{bad:?} should be rejected");
        }
        assert!(matches!(
            parse_duration("99999999999h"),
            Err(DurationError::OutOfRange(_))
        ));
    }
}
