//! Outputs never replace inputs: the paths a command reads (its flags' files, and the files a
//! map YAML points to) and writes, compared once before any work
//! ([`madenet_files::check_outputs`], symbolic links resolved).

use anyhow::Result;
use madenet_sim::MapSource;
use std::path::{Path, PathBuf};

/// `flag`'s path, if given, as one input or output.
pub fn given<'a>(flag: &'a str, path: Option<&PathBuf>) -> Vec<(&'a str, PathBuf)> {
    path.map(|p| (flag, p.clone())).into_iter().collect()
}

/// Refuses, before any work, an output path that is an input's file or another output's
/// ([`madenet_files::check_outputs`], symbolic links resolved).
pub fn refuse_clashes(outputs: &[(&str, PathBuf)], inputs: &[(&str, PathBuf)]) -> Result<()> {
    fn refs<'a>(v: &'a [(&'a str, PathBuf)]) -> Vec<(&'a str, &'a Path)> {
        v.iter().map(|(f, p)| (*f, p.as_path())).collect()
    }
    madenet_files::check_outputs(&refs(outputs), &refs(inputs)).map_err(anyhow::Error::msg)
}

/// The files map `source` is read from (none for a built-in map), as `flag`'s inputs.
pub fn map_inputs<'a>(flag: &'a str, source: &MapSource) -> Vec<(&'a str, PathBuf)> {
    match source {
        MapSource::File(p) => madenet_map::io::files_read(p)
            .into_iter()
            .map(|f| (flag, f))
            .collect(),
        _ => Vec::new(),
    }
}

/// [`map_inputs`] of every map of a list (`--maps`; names that do not parse name no file).
pub fn map_list_inputs<'a>(flag: &'a str, maps: &[String]) -> Vec<(&'a str, PathBuf)> {
    (maps.iter())
        .filter_map(|m| m.parse::<MapSource>().ok())
        .flat_map(|m| map_inputs(flag, &m))
        .collect()
}
