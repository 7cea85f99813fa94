//! ROS `map_server` metadata: the YAML file's fields ([`parse_map_yaml`]), loading the map it
//! describes ([`load_map_server_with`]) and writing one ([`save_yaml`]).
//!
//! The YAML is deserialized into [`MapServerYaml`], a derived struct, and then validated. Type
//! errors are serde-saphyr's (naming the line and column); a serde-derived struct does not say
//! which field failed, so the field is found from where the error is ([`field_of`]).

use super::pgm::{decode_pgm, encode_pgm};
use super::raster::{decode_image, raster_to_grid};
use super::{
    check_options, check_savable, extension, field_err, format_err, io_err, LoadOptions,
    SAVE_FREE_THRESH, SAVE_OCCUPIED_THRESH,
};
use crate::{MapError, OccGrid};
use serde::de::IgnoredAny;
use serde::Deserialize;
use serde_saphyr::Spanned;
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::Path;

/// How pixel values are interpreted (ROS `map_server` `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum MapMode {
    Trinary,
    Scale,
    Raw,
}

/// The fields of a ROS `map_server` YAML file.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct MapMeta {
    pub image: String,
    pub resolution: f64,
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: MapMode,
}

impl MapMeta {
    /// The assumptions for a bare image: 1 m/pixel, map saver thresholds, trinary.
    pub(super) fn bare() -> Self {
        MapMeta {
            image: String::new(),
            resolution: 1.0,
            origin: [0.0; 3],
            negate: false,
            occupied_thresh: SAVE_OCCUPIED_THRESH,
            free_thresh: SAVE_FREE_THRESH,
            mode: MapMode::Trinary,
        }
    }
}

/// A ROS `map_server` YAML file as written, before validation ([`MapServerYaml::validate`]).
/// Unknown keys are ignored (as ROS does) and a null value counts as missing.
#[derive(Deserialize)]
struct MapServerYaml {
    image: Option<String>,
    resolution: Option<f64>,
    /// `[x, y, yaw]`; a list, not an array, so that a wrong length is checked (and reported)
    /// by [`MapServerYaml::validate`] rather than located at the key by serde-saphyr.
    origin: Option<Vec<f64>>,
    negate: Option<Negate>,
    occupied_thresh: Option<f64>,
    free_thresh: Option<f64>,
    /// `trinary`, `scale` or `raw`, any case (a derived enum would be case-sensitive).
    mode: Option<String>,
}

/// What each field of [`MapServerYaml`] must hold, for errors.
const EXPECTED: [(&str, &str); 7] = [
    ("image", "a file name"),
    ("resolution", "a number of metres per pixel"),
    ("origin", "[x, y, yaw], three numbers"),
    ("negate", "0, 1, true or false"),
    ("occupied_thresh", "a number in [0, 1]"),
    ("free_thresh", "a number in [0, 1]"),
    ("mode", "trinary, scale or raw"),
];

/// `negate` as ROS writes it (`0`/`1`) or as a YAML boolean.
#[derive(Deserialize)]
#[serde(untagged, expecting = "not an integer or a boolean")]
enum Negate {
    Bool(bool),
    Int(i64),
}

/// Parses and validates ROS `map_server` YAML text. Unknown keys are ignored (as ROS does).
pub(super) fn parse_map_yaml(text: &str, yaml_path: &Path) -> Result<MapMeta, MapError> {
    let not_a_mapping = |e: serde_saphyr::Error| {
        let message = one_line(&e);
        match top_level_key(text, &e) {
            Some(key) => field_err(yaml_path, &key, message),
            None => format_err(
                yaml_path,
                format!("not a valid map_server YAML mapping: {message}"),
            ),
        }
    };
    // First the document as a whole: malformed YAML, a root that is not a mapping, a duplicate
    // key or a non-finite float anywhere is a format error, not one of a field. Where each
    // value starts tells `field_of` which field an error below belongs to.
    let values: BTreeMap<String, Spanned<IgnoredAny>> =
        serde_saphyr::from_str(text).map_err(not_a_mapping)?;
    let yaml: MapServerYaml =
        serde_saphyr::from_str(text).map_err(|e| match field_of(&e, &values) {
            Some((field, expected)) => field_err(
                yaml_path,
                field,
                format!("expected {expected} ({})", e.without_snippet()),
            ),
            None => not_a_mapping(e),
        })?;
    yaml.validate(yaml_path)
}

/// serde-saphyr's message on one line: no source snippet, no notes, no advice meant for the
/// programmer (`set DuplicateKeyPolicy in Options`).
fn one_line(e: &serde_saphyr::Error) -> String {
    let text = e.without_snippet().to_string();
    let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    first
        .trim()
        .trim_start_matches("error: ")
        .replace(", set DuplicateKeyPolicy in Options if acceptable", "")
        .replace(" rejected by the configured policy", " is not allowed")
        .replace(
            "budget breached:",
            "the document expands beyond the reader's budget (anchors and aliases):",
        )
}

/// The top-level key on the line serde-saphyr's error `e` points at (`resolution: .nan`), if
/// that line starts one.
fn top_level_key(text: &str, e: &serde_saphyr::Error) -> Option<String> {
    let line = e.location()?.line();
    let line = text
        .lines()
        .nth(usize::try_from(line).ok()?.checked_sub(1)?)?;
    if line.starts_with([' ', '\t', '-', '#', '[', '{']) {
        return None;
    }
    let (key, _) = line.split_once(':')?;
    let key = key.trim().trim_matches(['"', '\'']);
    (!key.is_empty() && key.len() <= 64).then(|| key.to_string())
}

/// The field of [`MapServerYaml`] (with what it must hold, from [`EXPECTED`]) whose value
/// serde-saphyr's error `e` is in: that of the top-level key whose value (in `values`) starts
/// last at or before the error. `None` when `e` has no location or is not in a known field.
fn field_of(
    e: &serde_saphyr::Error,
    values: &BTreeMap<String, Spanned<IgnoredAny>>,
) -> Option<(&'static str, &'static str)> {
    let at = e.location()?.span().offset();
    let (key, _) = values
        .iter()
        .map(|(key, value)| (key, value.referenced.span().offset()))
        .filter(|&(_, start)| start <= at)
        .max_by_key(|&(_, start)| start)?;
    EXPECTED.iter().copied().find(|(field, _)| field == key)
}

impl MapServerYaml {
    /// Checks the values (required fields present, numbers finite, `resolution > 0`, thresholds
    /// in [0, 1] with `free_thresh < occupied_thresh`, …) and fills in the defaults. (A
    /// non-finite number is already rejected by `parse_map_yaml`'s first pass; checked again
    /// here so that this holds whatever the parser's policy.)
    fn validate(self, yaml_path: &Path) -> Result<MapMeta, MapError> {
        let missing = |name: &str| field_err(yaml_path, name, "missing required field");
        let number = |name: &str, value: Option<f64>| -> Result<f64, MapError> {
            let x = value.ok_or_else(|| missing(name))?;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(field_err(
                    yaml_path,
                    name,
                    format!("must be finite, got {x}"),
                ))
            }
        };

        let image = self.image.ok_or_else(|| missing("image"))?;
        let image = image.trim();
        if image.is_empty() {
            return Err(field_err(yaml_path, "image", "must not be empty"));
        }

        let resolution = number("resolution", self.resolution)?;
        if resolution <= 0.0 {
            return Err(field_err(
                yaml_path,
                "resolution",
                format!("must be positive (metres per pixel), got {resolution}"),
            ));
        }

        let origin: [f64; 3] = self
            .origin
            .ok_or_else(|| missing("origin"))?
            .try_into()
            .map_err(|items: Vec<f64>| {
                field_err(
                    yaml_path,
                    "origin",
                    format!(
                        "expected [x, y, yaw], found a list of {} items",
                        items.len()
                    ),
                )
            })?;
        if let Some(x) = origin.iter().find(|x| !x.is_finite()) {
            return Err(field_err(
                yaml_path,
                "origin",
                format!("expected three finite numbers [x, y, yaw], found {x}"),
            ));
        }

        let negate = match self.negate {
            None | Some(Negate::Int(0)) | Some(Negate::Bool(false)) => false,
            Some(Negate::Int(1)) | Some(Negate::Bool(true)) => true,
            Some(Negate::Int(i)) => {
                return Err(field_err(
                    yaml_path,
                    "negate",
                    format!("expected 0 or 1, found {i}"),
                ))
            }
        };

        let occupied_thresh = number("occupied_thresh", self.occupied_thresh)?;
        let free_thresh = number("free_thresh", self.free_thresh)?;
        for (name, v) in [
            ("occupied_thresh", occupied_thresh),
            ("free_thresh", free_thresh),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(field_err(
                    yaml_path,
                    name,
                    format!("must lie in [0, 1], got {v}"),
                ));
            }
        }
        if free_thresh >= occupied_thresh {
            return Err(field_err(
                yaml_path,
                "free_thresh",
                format!("must be below occupied_thresh ({occupied_thresh}), got {free_thresh}"),
            ));
        }

        let mode = match self.mode.as_deref().map(|m| m.trim().to_ascii_lowercase()) {
            None => MapMode::Trinary,
            Some(m) => match m.as_str() {
                "trinary" => MapMode::Trinary,
                "scale" => MapMode::Scale,
                "raw" => MapMode::Raw,
                other => {
                    return Err(field_err(
                        yaml_path,
                        "mode",
                        format!("expected trinary, scale or raw, found {other:?}"),
                    ))
                }
            },
        };

        Ok(MapMeta {
            image: image.to_string(),
            resolution,
            origin,
            negate,
            occupied_thresh,
            free_thresh,
            mode,
        })
    }
}

/// Loads a `map_server` map from YAML text; `read_image` is given the image path (resolved
/// against the YAML's folder) and returns its bytes. Shared by [`load`](super::load) and the
/// embedded paper maps.
pub(crate) fn load_map_server_with(
    yaml_text: &str,
    yaml_path: &Path,
    opts: &LoadOptions,
    read_image: impl FnOnce(&Path) -> Result<Vec<u8>, MapError>,
) -> Result<OccGrid, MapError> {
    check_options(opts)?;
    let meta = parse_map_yaml(yaml_text, yaml_path)?;
    let image_path = yaml_path
        .parent()
        .unwrap_or(Path::new(""))
        .join(&meta.image);
    let bytes = read_image(&image_path)?;
    let raster = if extension(&image_path) == "pgm" {
        decode_pgm(&bytes, &image_path)?
    } else {
        decode_image(&bytes, &image_path, None)?
    };
    raster_to_grid(&raster, &meta, yaml_path, &image_path, opts)
}

/// `s` as a YAML scalar, double-quoted when it contains anything unusual.
fn yaml_string(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-/".contains(c))
    {
        s.to_string()
    } else {
        let escaped: String = s
            .chars()
            .flat_map(|c| match c {
                '"' => vec!['\\', '"'],
                '\\' => vec!['\\', '\\'],
                c => vec![c],
            })
            .collect();
        format!("\"{escaped}\"")
    }
}

/// The PGM image [`save_yaml`] writes beside `yaml_path`: its stem with `.pgm` (none without a
/// UTF-8 file name).
pub(super) fn image_beside(yaml_path: &Path) -> Option<std::path::PathBuf> {
    let stem = (yaml_path.file_stem())
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty())?;
    Some(yaml_path.with_file_name(format!("{stem}.pgm")))
}

/// Writes `grid` as a ROS `map_server` map: `<stem>.pgm` next to `yaml_path` (binary P5, free
/// 254, obstacle 0, unknown 205) and the YAML itself (`image` relative, `mode: trinary`,
/// the grid's `resolution` and `origin`, `negate: 0`, `occupied_thresh: 0.65`,
/// `free_thresh: 0.196`). [`load`](super::load) with `cell_size == grid.resolution` reads
/// back the same grid. Both files are written atomically, the image first.
pub fn save_yaml(grid: &OccGrid, yaml_path: &Path) -> Result<(), MapError> {
    check_savable(grid, yaml_path)?;
    if !(grid.resolution.is_finite() && grid.resolution > 0.0) {
        return Err(field_err(
            yaml_path,
            "resolution",
            format!("must be positive and finite, got {}", grid.resolution),
        ));
    }
    if grid.origin.iter().any(|x| !x.is_finite()) {
        return Err(field_err(
            yaml_path,
            "origin",
            format!("must be finite, got {:?}", grid.origin),
        ));
    }
    let image_path = image_beside(yaml_path)
        .ok_or_else(|| format_err(yaml_path, "YAML path needs a UTF-8 file name"))?;
    let image_name = image_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let [x, y, yaw] = grid.origin;
    let yaml = format!(
        "image: {}\nmode: trinary\nresolution: {:?}\norigin: [{x:?}, {y:?}, {yaw:?}]\nnegate: 0\noccupied_thresh: {SAVE_OCCUPIED_THRESH:?}\nfree_thresh: {SAVE_FREE_THRESH:?}\n",
        yaml_string(&image_name),
        grid.resolution,
    );
    // Both targets are opened (a folder or an unwritable place refused) before either is
    // written: a refused YAML never leaves a replaced image behind.
    let open = |p: &Path| madenet_files::AtomicFile::create(p).map_err(|e| io_err(p, e));
    let (mut image, mut meta) = (open(&image_path)?, open(yaml_path)?);
    for (f, p, bytes) in [
        (&mut image, image_path.as_path(), encode_pgm(grid)),
        (&mut meta, yaml_path, yaml.into_bytes()),
    ] {
        f.write_all(&bytes).map_err(|e| io_err(p, e))?;
        // Both on disk before either replaces its target: what is left to fail is a rename.
        f.sync().map_err(|e| io_err(p, e))?;
    }
    image.commit().map_err(|e| io_err(&image_path, e))?;
    meta.commit().map_err(|e| io_err(yaml_path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = "image: m.pgm\nresolution: 0.05\norigin: [1, -2.5, 0.1]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

    fn parse(text: &str) -> Result<MapMeta, MapError> {
        parse_map_yaml(text, Path::new("maps/m.yaml"))
    }

    /// The field and message of the [`MapError::Field`] that `text` gives.
    fn field_error_of(text: &str) -> (String, String) {
        match parse(text) {
            Err(MapError::Field {
                path,
                field,
                message,
            }) => {
                assert_eq!(path, Path::new("maps/m.yaml"));
                (field, message)
            }
            other => panic!("expected a field error for {text:?}, got {other:?}"),
        }
    }

    #[test]
    fn reads_the_fields_ignoring_unknown_keys() {
        let expected = MapMeta {
            image: "m.pgm".into(),
            resolution: 0.05,
            origin: [1.0, -2.5, 0.1],
            negate: false,
            occupied_thresh: 0.65,
            free_thresh: 0.196,
            mode: MapMode::Trinary,
        };
        assert_eq!(parse(OK).expect("valid"), expected);
        // Unknown keys of any kind are ignored, null counts as missing, `negate` may be a
        // boolean and `mode` is trimmed and case-insensitive.
        let text = format!(
            "{}mode: ' Scale '\nextra: {{a: [1, 2]}}\n1: 2\ny: &a n\nz: *a\n",
            OK.replace("negate: 0", "negate: true")
        );
        let meta = parse(&text).expect("valid");
        assert_eq!((meta.negate, meta.mode), (true, MapMode::Scale));
        let meta = parse(&OK.replace("negate: 0", "negate: ~")).expect("valid");
        assert!(!meta.negate);
        assert_eq!(
            field_error_of(&OK.replace("resolution: 0.05", "resolution: ~")),
            ("resolution".into(), "missing required field".into())
        );
    }

    #[test]
    fn a_value_of_the_wrong_type_names_its_field_and_line() {
        let flow = "{image: m.pgm, resolution: fine, origin: [0, 0, 0], occupied_thresh: 0.65, free_thresh: 0.196}";
        for (text, field, at) in [
            (
                OK.replace("0.05", "fine"),
                "resolution",
                "line 2, column 13",
            ),
            (flow.to_string(), "resolution", "line 1, column 28"),
            (OK.replace("-2.5", "x"), "origin", "line 3, column 13"),
            (
                OK.replace("[1, -2.5, 0.1]", "7"),
                "origin",
                "line 3, column 9",
            ),
            (
                format!("x: &a fine\n{}", OK.replace("0.05", "*a")),
                "resolution",
                "used at line 3, column 13",
            ),
            (
                OK.replace("negate: 0", "negate: 1.0"),
                "negate",
                "line 4, column 9",
            ),
            (format!("{OK}mode: [raw]\n"), "mode", "line 7, column 7"),
            (OK.replace("m.pgm", "[m.pgm]"), "image", "line 1, column 8"),
        ] {
            let (got, message) = field_error_of(&text);
            assert_eq!(got, field, "{text:?}: {message}");
            assert!(message.contains(at), "{text:?}: {message}");
        }
    }

    #[test]
    fn values_are_checked() {
        for (from, to, field, message) in [
            (
                "resolution: 0.05",
                "resolution: 0",
                "resolution",
                "must be positive",
            ),
            (
                "[1, -2.5, 0.1]",
                "[1, 2]",
                "origin",
                "found a list of 2 items",
            ),
            (
                "negate: 0",
                "negate: 2",
                "negate",
                "expected 0 or 1, found 2",
            ),
            (
                "occupied_thresh: 0.65",
                "occupied_thresh: 1.5",
                "occupied_thresh",
                "[0, 1]",
            ),
            (
                "free_thresh: 0.196",
                "free_thresh: 0.7",
                "free_thresh",
                "below occupied_thresh",
            ),
            ("image: m.pgm", "image: ' '", "image", "must not be empty"),
        ] {
            let (got, text) = field_error_of(&OK.replace(from, to));
            assert_eq!(got, field, "{to}: {text}");
            assert!(text.contains(message), "{to}: {text}");
        }
        let (got, text) = field_error_of(&format!("{OK}mode: fancy\n"));
        assert_eq!(
            (got.as_str(), text.as_str()),
            ("mode", "expected trinary, scale or raw, found \"fancy\"")
        );
    }

    #[test]
    fn a_malformed_document_is_a_format_error() {
        for text in ["image: [unclosed\n  - : :", "- a list\n"] {
            let e = parse(text).unwrap_err();
            assert!(matches!(e, MapError::Format { .. }), "{text:?}: {e}");
            assert!(e.to_string().starts_with("maps/m.yaml: "), "{e}");
            assert_eq!(e.to_string().lines().count(), 1, "{e}");
        }
    }

    /// A duplicate key or a non-finite number breaks the document as a whole, but its line
    /// names the field: the error names it too, on one line.
    #[test]
    fn a_document_error_on_a_key_line_names_the_field() {
        for (text, field) in [
            ("image: m.pgm\nimage: n.pgm\n".to_string(), "image"),
            (OK.replace("0.05", ".nan"), "resolution"),
        ] {
            let e = parse(&text).unwrap_err();
            assert!(
                matches!(&e, MapError::Field { field: f, .. } if f == field),
                "{text:?}: {e}"
            );
            assert_eq!(e.to_string().lines().count(), 1, "{e}");
            assert!(!e.to_string().contains("DuplicateKeyPolicy"), "{e}");
        }
    }
}
