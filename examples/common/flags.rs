//! Command-line flags of the examples (`--name=value`).

/// The value of the flag `name` (`--name=`) among `all`, parsed, or `default` without it.
pub fn flag<T: std::str::FromStr>(all: &[String], name: &str, default: T) -> Result<T, T::Err> {
    let value = all.iter().find_map(|a| a.strip_prefix(name));
    Ok(value.map(str::parse).transpose()?.unwrap_or(default))
}
