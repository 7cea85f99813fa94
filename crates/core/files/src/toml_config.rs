//! Reading TOML configs: every config file of madenet (scenario, study, scalability study,
//! training runs, model descriptions) is parsed here, so every bad one gets the same kind of
//! error — the file, the field (`table.key`) and the line.

use serde::de::DeserializeOwned;
use std::path::Path;

/// A config that cannot be read or parsed: `path: message`, the message naming the field and
/// line where the TOML parser knows them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigFileError {
    /// The file, as given to [`read_toml`].
    pub path: String,
    /// What is wrong, e.g. ``field `scenario.sensing_range`: invalid type … (line 4)``.
    pub message: String,
}

impl std::fmt::Display for ConfigFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.path, self.message)
    }
}

impl std::error::Error for ConfigFileError {}

/// Parses TOML `text` into `T`. The error names the field it is about (`table.key`, read off
/// the line the parser points at) and the line number.
///
/// ```
/// #[derive(serde::Deserialize, Debug)]
/// #[serde(deny_unknown_fields)]
/// struct Cfg { seeds: u64 }
/// let e = madenet_files::parse_toml::<Cfg>("seeds = \"five\"\n").unwrap_err();
/// assert!(e.starts_with("field `seeds`:") && e.ends_with("(line 1)"), "{e}");
/// ```
pub fn parse_toml<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    toml::from_str(text).map_err(|e| describe(text, &e))
}

/// Reads the TOML file `path` into `T` ([`parse_toml`]'s errors, prefixed with the path).
pub fn read_toml<T: DeserializeOwned>(path: &Path) -> Result<T, ConfigFileError> {
    let fail = |message: String| ConfigFileError {
        path: path.display().to_string(),
        message,
    };
    let text =
        crate::read_text_capped(path, crate::InputKind::Config).map_err(|e| fail(e.to_string()))?;
    parse_toml(&text).map_err(fail)
}

fn describe(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim().to_string();
    let Some(span) = e.span() else { return message };
    let start = span.start.min(text.len());
    let line_no = text[..start].matches('\n').count() + 1;
    let line = text.lines().nth(line_no - 1).unwrap_or("");
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim().trim_matches('"').to_string())
        .filter(|k| !k.is_empty() && !k.starts_with('['));
    let table = text
        .lines()
        .take(line_no - 1)
        .filter_map(|l| l.trim().strip_prefix('[').and_then(|l| l.strip_suffix(']')))
        .last()
        .map(|t| t.trim().to_string());
    match (table, key) {
        (Some(t), Some(k)) => format!("field `{t}.{k}`: {message} (line {line_no})"),
        (None, Some(k)) => format!("field `{k}`: {message} (line {line_no})"),
        _ => format!("{message} (line {line_no})"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Deserialize, Debug, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Inner {
        range: i32,
    }
    #[derive(Deserialize, Debug, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Outer {
        name: String,
        inner: Inner,
    }

    #[test]
    fn errors_name_table_key_and_line() {
        let e = parse_toml::<Outer>("name = \"a\"\n[inner]\nrange = \"far\"\n").unwrap_err();
        assert!(
            e.starts_with("field `inner.range`:") && e.ends_with("(line 3)"),
            "{e}"
        );
        let e = parse_toml::<Outer>("name = 1\n").unwrap_err();
        assert!(
            e.starts_with("field `name`:") && e.ends_with("(line 1)"),
            "{e}"
        );
        let e = parse_toml::<Outer>("name = \"a\"\nbogus = 2\n").unwrap_err();
        assert!(e.contains("bogus") && e.contains("(line 2)"), "{e}");
        let ok = parse_toml::<Outer>("name = \"a\"\n[inner]\nrange = 4\n").unwrap();
        assert_eq!(ok.inner.range, 4);
    }

    #[test]
    fn files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.toml");
        let e = read_toml::<Outer>(&p).unwrap_err();
        assert_eq!(e.path, p.display().to_string());
        std::fs::write(&p, "name = 3\n").unwrap();
        let e = read_toml::<Outer>(&p).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: field `name`:", p.display())),
            "{e}"
        );
    }
}
