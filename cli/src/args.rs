//! Value parsers for options several commands share, so each refuses a bad value the same
//! way: as a usage error (exit status 2) naming the option and the accepted range, never by
//! silently changing it.

/// `--threads N`: CPU worker threads, 1 to [`optik::max_cpu_threads`].
pub fn threads(s: &str) -> Result<usize, String> {
    let max = optik::max_cpu_threads();
    match s.parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected a thread count from 1 to {max} (this machine has {} cores)",
            optik::available_cores()
        )),
    }
}

/// `--repeat N`: launches per measurement, at least 1.
pub fn repeat(s: &str) -> Result<usize, String> {
    at_least_one(s)
}

/// `--rounds R`: interleaved rounds of a comparison, at least 1.
pub fn rounds(s: &str) -> Result<usize, String> {
    at_least_one(s)
}

fn at_least_one(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err("expected a count of at least 1".to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds() {
        assert_eq!(threads("4"), Ok(4));
        assert!(threads("0").is_err());
        assert!(threads(&(optik::max_cpu_threads() + 1).to_string()).is_err());
        assert!(threads("-1").is_err());
        assert_eq!(repeat("1"), Ok(1));
        assert!(repeat("0").unwrap_err().contains("at least 1"));
        assert_eq!(rounds("5"), Ok(5));
        assert!(rounds("0").unwrap_err().contains("at least 1"));
        assert!(rounds("two").is_err());
    }
}
